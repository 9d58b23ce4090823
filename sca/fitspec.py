"""Which parameters a fit estimates and which it holds: ``free=``, ``fix=`` and ``gain=``, the
same for :func:`sca.estimate`, :func:`sca.estimate_least_squares`, :func:`sca.estimate_batch` and
:func:`sca.precision`."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from forward import validate
from forward.water import COEFFICIENT_PARAMS, Water

from .model import GEOMETRY, check_names
from forward.errors import InputError

__all__ = ["GAINS", "DEFAULT_FREE", "FREEABLE", "FIXABLE", "FitSpec", "fit_spec", "parse_fix"]

#: 'known': the data are in model units (exposure-normalised); 'free': M = gain G(x) + s 1^T
#: with one unknown scalar gain (a photograph's exposure, any units), estimated with the water.
GAINS = ("known", "free")
#: Estimated unless fixed: C and a_CDOM(440) (the paper's x, with w on eq 17) and s (eq 18).
DEFAULT_FREE = ("chl", "cdom")
#: Names ``free=`` may add: any coefficient of forward.Water and the geometry.
FREEABLE = DEFAULT_FREE + COEFFICIENT_PARAMS + GEOMETRY + ("gain", "backscatter")
#: Names ``fix=`` may hold: C, a_CDOM, the backscatter, or a forward.Water coefficient.
FIXABLE = ("chl", "cdom", "backscatter") + COEFFICIENT_PARAMS


@dataclass(frozen=True)
class FitSpec:
    """A fit's unknowns.

    Attributes
    ----------
    names : tuple of str
        Free nonlinear parameters in a fixed order: 'chl', 'cdom' (unless fixed), then the
        extra names of ``free=`` in the order given.
    fixed : dict
        Held values: 'chl' (mg m^-3), 'cdom' (m^-1) (scalars), 'backscatter' ((m,) array, in
        the units of the measurements). Held Water coefficients are not here but in
        ``water``.
    free_gain : bool
        The exposure gain is estimated.
    free_s : bool
        The backscatter s is estimated (eq 18: s >= 0).
    water : forward.Water
        The water with every fixed coefficient written into it.
    """

    names: tuple
    fixed: dict
    free_gain: bool
    free_s: bool
    water: Water


def parse_fix(fix, m: int) -> dict:
    """``fix`` (a dict name -> value) checked: names in :data:`FIXABLE`, values finite (C,
    a_CDOM and s >= 0; s a scalar or one value per channel, (m,)).

    Parameters
    ----------
    fix : dict or None
        Held parameters: 'chl' (mg m^-3), 'cdom' (a_CDOM(440), m^-1), 'backscatter' (scalar or
        (m,), units of the measurements) and any :data:`forward.water.COEFFICIENT_PARAMS` field
        (its own units, any sign).
    m : int
        Number of camera channels.

    Returns
    -------
    dict
        The checked values: floats, and 'backscatter' as an (m,) array; empty for None.

    Raises
    ------
    ValueError
        If ``fix`` is not a dict, names a parameter outside :data:`FIXABLE`, or a value is not
        finite, negative where it must be >= 0, or (backscatter) not broadcastable to (m,).
    """
    if fix is None:
        return {}
    if not isinstance(fix, dict):
        raise InputError("fix", "expected a dict like {'backscatter': 0, 'cdom': 0.1}, got "
                         f"{type(fix).__name__}")
    check_names("fix", tuple(fix), FIXABLE)
    out = {}
    for key, val in fix.items():
        if key == "backscatter":
            try:
                arr = np.broadcast_to(np.asarray(val, float), (m,))
            except (ValueError, TypeError):
                raise InputError("fix['backscatter']", f"expected a scalar or {m} values") from None
            out[key] = np.array(validate.array("fix['backscatter']", arr, nonnegative=True))
        elif key in ("chl", "cdom"):
            out[key] = validate.scalar(f"fix[{key!r}]", val)
        else:
            out[key] = validate.scalar(f"fix[{key!r}]", val, nonnegative=False)
    return out


def fit_spec(free, fix, gain: str, water: Water, m: int) -> FitSpec:
    """The unknowns of a fit from its ``free``, ``fix`` and ``gain`` arguments.

    Parameters
    ----------
    free : sequence of str or None
        Names estimated besides C and a_CDOM (:data:`FREEABLE`): Water coefficients, 'depth',
        'distance', 'gain' (same as ``gain='free'``); 'chl', 'cdom' and 'backscatter' are
        estimated anyway unless fixed.
    fix : dict or None
        Held values (see :func:`parse_fix`); a name may not be both free and fixed.
    gain : {'known', 'free'}
        The exposure gain (:data:`GAINS`).
    water : forward.Water
        The water model; held Water coefficients are written into a copy of it.
    m : int
        Number of camera channels.

    Returns
    -------
    FitSpec

    Raises
    ------
    ValueError
        For an unknown ``gain``, an unknown or repeated name, a name both free and fixed, or
        nothing left to estimate.
    """
    if gain not in GAINS:
        raise InputError("gain", f"must be one of {GAINS}, got {gain!r}")
    extra = check_names("free", () if free is None else free, FREEABLE)
    fixed = parse_fix(fix, m)
    both = set(extra) & set(fixed)
    if both:
        raise InputError("free", f"{sorted(both)} also fixed in fix=")
    constants = {k: fixed.pop(k) for k in list(fixed) if k in COEFFICIENT_PARAMS}
    if constants:
        water = dataclasses.replace(water, **constants)
    free_gain = gain == "free" or "gain" in extra
    free_s = "backscatter" not in fixed
    names = tuple(n for n in DEFAULT_FREE if n not in fixed) + tuple(
        n for n in extra if n not in DEFAULT_FREE + ("gain", "backscatter"))
    if not names and not free_s and not free_gain:
        raise InputError("fix", "nothing is left to estimate")
    return FitSpec(names, fixed, free_gain, free_s, water)
