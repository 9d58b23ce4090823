"""The one table of the estimators' parameters: units, coordinate, bounds, prior and default.

Every name an estimator fits, holds or profiles has one row of :data:`PARAMETERS`
(:class:`Parameter`): its units, the coordinate the Levenberg-Marquardt iterates (C in
u = C^e0, e0 = ``Water.phyto_exponent``: eq 10's exponent; every other name in its own units),
its lower bound and the cap beyond which a profile-likelihood end is open, the name of the
uncertainty budget's entry that gives its prior (:mod:`sca.budget`), whether it has one value
per camera channel, and the value it takes when it is not given. The single chart, the batch,
the joint dive fit and the bound read these rows (:func:`lower_bound`, :func:`upper_cap`,
:func:`default`, :func:`to_lm`, :func:`from_lm`, :func:`lm_cap`) instead of spelling each
parameter themselves (decision 0077-parameter-table).

References
----------
Blasinski & Farrell, "A Three Parameter Underwater Image Formation Model", eqs 4-12, 15-18.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from forward.errors import InputError
from forward.water import COEFFICIENT_PARAMS, Water

from .problem import chl_from_u, u_from_chl

__all__ = ["BALANCE_MIN", "CDOM_MAX", "CHL_MAX", "CONSTANT_SPAN", "LENGTH_MAX", "PARAMETERS",
           "SHARED_FREEABLE", "Parameter", "default", "from_lm", "lm_cap", "lower_bound",
           "to_lm", "upper_cap"]

#: Profile upper ends beyond these are open (``inf``): C in mg m^-3, a_CDOM(440) in m^-1 (far
#: beyond natural waters: Mobley 1994 lists C up to ~100, a_CDOM(440) up to ~10), lengths in m.
CHL_MAX, CDOM_MAX, LENGTH_MAX = 1e4, 1e3, 1e4
#: A free Water constant's interval is open beyond this many times its default magnitude.
CONSTANT_SPAN = 1e3
#: Lower bound of a channel-balance error beta (the channel's sensitivity 1 + beta stays
#: positive).
BALANCE_MIN = -0.99


@dataclass(frozen=True)
class Parameter:
    """One row of the parameter table.

    Attributes
    ----------
    name : str
        The name every estimator and :meth:`sca.model.ChartModel.predict` use.
    units : str
        Its units.
    lower : float
        Its lower bound in the estimators (its own units; ``-inf``: none).
    cap : float or None
        Where a profile-likelihood end is called open (its own units); None for a Water
        constant: :data:`CONSTANT_SPAN` times its value in the water (at least 1e-3), and minus
        that for the lower end of a constant of any sign.
    power : bool
        The Levenberg-Marquardt coordinate is u = x^e0 (e0 = ``Water.phyto_exponent``); else x.
    per_channel : bool
        One value per camera channel (the same default in each).
    prior : str or None
        The uncertainty budget's entry (``uncertain=`` name) that gives its Gaussian prior;
        None: never a prior (estimated, or linear and solved in closed form).
    value : float or None
        The value it takes when not given (per channel where ``per_channel``); None for a
        Water constant (the water's own value) and for names that must be given (C, the
        geometry, the basis weights w).
    """

    name: str
    units: str
    lower: float
    cap: float | None
    power: bool = False
    per_channel: bool = False
    prior: str | None = None
    value: float | None = None

    @property
    def constant(self) -> bool:
        """A coefficient of :class:`forward.Water` (:data:`forward.water.COEFFICIENT_PARAMS`)."""
        return self.name in COEFFICIENT_PARAMS


#: The Water constants' units (:class:`forward.Water`'s docstring).
_CONSTANT_UNITS = {"cdom_slope": "nm^-1", "nap_slope": "nm^-1", "nap_scale": "m^-1",
                   "phyto_scale": "m^-1", "c_12": "mg m^-3", "s_12": "m^3 mg^-1",
                   "b_p12_star": "m^2 mg^-1", "b_p3_star": "m^2 mg^-1", "b_k": "m^-1",
                   "water_scattering": "m^-1"}


def _rows():
    inf = np.inf
    rows = [Parameter("chl", "mg m^-3", 0.0, CHL_MAX, power=True),
            Parameter("cdom", "m^-1 at 440 nm", 0.0, CDOM_MAX, value=0.0),
            Parameter("w", "1", 0.0, inf),
            Parameter("depth", "m", 0.0, LENGTH_MAX, prior="depth"),
            Parameter("distance", "m", 0.0, LENGTH_MAX, prior="distance"),
            Parameter("balance", "1 (relative)", BALANCE_MIN, inf, per_channel=True,
                      prior="balance", value=0.0),
            Parameter("camera_shift", "nm", -inf, inf, per_channel=True, prior="camera_shift",
                      value=0.0),
            Parameter("daylight", "mired", -inf, inf, prior="daylight", value=0.0)]
    rows += [Parameter(n, _CONSTANT_UNITS.get(n, "1"), -inf if n in Water._ANY_SIGN else 0.0,
                       None, prior=n) for n in COEFFICIENT_PARAMS]
    rows += [Parameter("gain", "data units per model unit", 0.0, inf, value=1.0),
             Parameter("backscatter", "data units", 0.0, inf, per_channel=True, value=0.0)]
    return {p.name: p for p in rows}


#: name -> :class:`Parameter`: every parameter the estimators know, in this order: C,
#: a_CDOM(440), w, the geometry, the camera and the light, the Water constants, the linear
#: gain and backscatter.
PARAMETERS = _rows()
#: Names a joint dive fit may estimate as one shared unknown of the dive (``free=`` of
#: :func:`sca.estimate_joint`): the Water constants.
SHARED_FREEABLE = tuple(n for n, p in PARAMETERS.items() if p.constant)


def _row(name: str) -> Parameter:
    try:
        return PARAMETERS[name]
    except KeyError:
        raise InputError("params", f"unknown parameter {name!r}; choose from "
                         f"{tuple(PARAMETERS)}") from None


def lower_bound(name: str, water: Water) -> float:
    """The lower bound of parameter ``name`` in the estimators (its own units).

    0 for C, a_CDOM, w (eq 16), s (eq 18), the gain, lengths and the nonnegative (and the
    positive) Water constants; :data:`BALANCE_MIN` for 'balance'; -inf for the constants of
    any sign (``Water._ANY_SIGN``: the slopes and spectral exponents), 'camera_shift' and
    'daylight'.

    Parameters
    ----------
    name : str
        A name of :data:`PARAMETERS`.
    water : forward.Water
        The water model (unused by the rule above; kept for a uniform signature with
        :func:`upper_cap`).

    Returns
    -------
    float
    """
    return _row(name).lower


def upper_cap(name: str, water: Water) -> float:
    """Where a profile-likelihood interval of ``name`` is called open (its upper end ``inf``).

    For constants of any sign, minus the cap is where the lower end is open.

    Parameters
    ----------
    name : str
        A name of :data:`PARAMETERS`.
    water : forward.Water
        The water model: a Water constant's cap is :data:`CONSTANT_SPAN` times its value
        there (at least 1e-3 in magnitude).

    Returns
    -------
    float
        :data:`CHL_MAX` (mg m^-3) for 'chl', :data:`CDOM_MAX` (m^-1) for 'cdom',
        :data:`LENGTH_MAX` (m) for 'depth' and 'distance', ``CONSTANT_SPAN * max(|value|, 1e-3)``
        for a :data:`forward.water.COEFFICIENT_PARAMS` field (its own units), ``inf`` otherwise
        ('w', 'gain', 'backscatter', the camera and the light).
    """
    row = _row(name)
    if row.constant:
        return CONSTANT_SPAN * max(abs(float(getattr(water, name))), 1e-3)
    return float(row.cap)


def default(name: str, water: Water) -> float:
    """The value ``name`` takes when it is not given (per channel for a per-channel name).

    Parameters
    ----------
    name : str
        A name of :data:`PARAMETERS`.
    water : forward.Water
        The water model (a Water constant's default is its value there).

    Returns
    -------
    float

    Raises
    ------
    forward.errors.InputError
        Naming ``params`` for a name with no default (C, depth, distance, w: to be given).
    """
    row = _row(name)
    if row.constant:
        return float(getattr(water, name))
    if row.value is None:
        raise InputError("params", f"'{name}' has no default; give its value")
    return float(row.value)


def to_lm(name: str, x, e0: float):
    """``x`` (its own units) in the Levenberg-Marquardt coordinate of ``name``: u = max(x,
    0)^e0 for a power row (C), else x itself.

    Parameters
    ----------
    name : str
        A name of :data:`PARAMETERS`.
    x : float or array_like
        Values in the parameter's units.
    e0 : float
        The power coordinate's exponent (``Water.phyto_exponent``).

    Returns
    -------
    ndarray
    """
    return u_from_chl(x, e0) if _row(name).power else np.asarray(x, float)


def from_lm(name: str, u, e0: float):
    """The inverse of :func:`to_lm`: x = max(u, 0)^(1 / e0) for a power row, else u; NaN (a
    profile end not found) stays NaN.

    Parameters
    ----------
    name : str
        A name of :data:`PARAMETERS`.
    u : float or array_like
        Values in the Levenberg-Marquardt coordinate (``inf`` stays ``inf``).
    e0 : float
        The power coordinate's exponent.

    Returns
    -------
    ndarray
    """
    u = np.asarray(u, float)
    return np.where(np.isnan(u), np.nan, chl_from_u(u, e0)) if _row(name).power else u


def lm_cap(name: str, water: Water, e0: float) -> float:
    """:func:`upper_cap` in the Levenberg-Marquardt coordinate (what
    :func:`sca.intervals.profile_intervals` is given).

    Parameters
    ----------
    name : str
        A name of :data:`PARAMETERS`.
    water : forward.Water
        The water model.
    e0 : float
        The power coordinate's exponent.

    Returns
    -------
    float
    """
    return float(to_lm(name, upper_cap(name, water), e0))
