"""The uncertainty budget: every input that is not known exactly carries its uncertainty.

After the GUM (JCGM 100:2008), each input of the measurement has a standard uncertainty, and
the result says how much of its variance each input contributes. ``uncertain=`` (every
estimator, :func:`sca.precision` and ``measure``) is a dict name -> standard deviation:

* **nuisance parameters** with a Gaussian prior centred on the value given (or the water's
  constant): ``depth`` and ``distance`` (m, or a string ``"5%"`` relative to the value), any
  :data:`forward.water.COEFFICIENT_PARAMS` field (its own units, e.g. ``cdom_slope`` in nm^-1),
  ``balance`` (relative error of each camera channel's sensitivity), ``camera_shift`` (a
  wavelength shift of each channel's measured curve, nm; the same sd for every channel) and
  ``daylight`` (the surface light's colour temperature's change from the illuminant given,
  mired: :class:`forward.daylight.DaylightTilt`). They enter the one model function as parameters; the fit adds
  sum ((theta - mu) / sd)^2 to chi^2, and the profile-likelihood intervals profile them. A
  nuisance other than a length may instead be given as a *measured* prior, a dict
  ``{"centre": mu, "sd": sd, ...}`` (its own units; further keys, e.g. ``source``, are kept
  in the record): the daylight measured at the site by a reference shot
  (:func:`sca.reference.reference_prior`) enters every estimator this way (:func:`prior_of`);
* **per-patch systematic terms** (``patch``, relative): chart reflectance tolerance and
  ageing, camera-curve error and the illuminant, independent from patch to patch. They enter the
  noise: sigma_total^2 = sigma^2 + (patch x M)^2;
* **the chart's response measured in air** (``response``, :data:`MEASURED`): one factor per
  (channel, patch), (m, n), or one set per chart of a batch, (N, m, n), measured by a reference
  shot (:func:`sca.reference.patch_response`); every estimator's model multiplies the direct
  signal's rows by it (:meth:`sca.ChartModel.with_response`, :meth:`Budget.model`), not the
  data (the veiling light is additive), and the reference lowers ``patch`` to what the shot
  cannot see (decision 0079-reference-patch-response).

``uncertain={}`` is the paper's exact model (the replication figures use it); the default
(:data:`DEFAULT_UNCERTAIN`) applies wherever real data enter. A budget needs the noise
(``sigma``): without it the chi^2 scale is unknown and the budget is not applied (the result
says so: ``budget`` None and flag ``noise-unknown``).

References
----------
JCGM 100:2008, "Evaluation of measurement data - Guide to the expression of uncertainty in
measurement" (GUM), secs. 4-5 and 8.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from forward.water import Water

from .budget_defaults import BUDGET_SOURCES, DEFAULT_UNCERTAIN, REAL_WATER_UNCERTAIN
from .model import covariance
from .parameters import PARAMETERS
from forward.errors import InputError

__all__ = ["DEFAULT_UNCERTAIN", "REAL_WATER_UNCERTAIN", "BUDGET_SOURCES", "CENTRED", "NUISANCE",
           "SYSTEMATIC", "MEASURED", "Budget", "prior_arrays", "prior_centre", "prior_of",
           "resolve_budget", "response_rows", "parse_sd", "variance_shares", "limiting_source"]

# DEFAULT_UNCERTAIN (the default budget) and BUDGET_SOURCES (where each entry comes from) are
# plain data in sca.budget_defaults, re-exported here.

#: Names that are nuisance parameters with a Gaussian prior (the parameter table's rows with a
#: budget entry: the geometry, the camera, the light and every Water constant).
NUISANCE = tuple(p.prior for p in PARAMETERS.values() if p.prior)
#: Names that enter the noise of every patch (relative sd).
SYSTEMATIC = ("patch",)
#: Names of measured factors of the model (:meth:`Budget.model`).
MEASURED = ("response",)


@dataclass(frozen=True)
class Budget:
    """A resolved budget for N charts.

    Attributes
    ----------
    sd : dict
        The budget as given: name -> sd (floats, or ``"x%"`` strings for lengths).
    priors : dict
        Nuisance name -> (mean (N,), sd (N,)) in the parameter's units (relative for
        'balance': mean 0).
    patch : float
        Relative per-patch systematic sd (0: none).
    response : ndarray, (1 or N, m n), or None
        The chart's response measured in air (``uncertain['response']``): one factor per
        (channel, patch) row of the model, for every chart or one set per chart.
    """

    sd: dict
    priors: dict
    patch: float
    response: np.ndarray | None = None

    @property
    def exact(self) -> bool:
        """True for the paper's exact model (nothing uncertain)."""
        return not self.priors and self.patch == 0.0 and self.response is None

    @property
    def per_chart(self) -> bool:
        """True where the charts have their own measured responses (one per chart)."""
        return self.response is not None and len(self.response) > 1

    def model(self, mdl):
        """``mdl`` (:class:`sca.ChartModel`) with the measured response
        (:meth:`sca.ChartModel.with_response`); ``mdl`` itself without one, or where each
        chart has its own (they enter the model function as :meth:`fixed_params`)."""
        if self.response is None or self.per_chart:
            return mdl
        return mdl.with_response(self.response[0])

    def fixed_params(self) -> dict:
        """The model function's inputs the budget fixes chart by chart: 'response' (N, m n)
        where each chart has its own measured response; {} otherwise."""
        return {"response": self.response} if self.per_chart else {}

    def noise_sd(self, M, sigma):
        """sqrt(sigma^2 + (patch M)^2): the noise with the per-patch systematic term (data
        units, shape of ``M``)."""
        return np.sqrt(np.asarray(sigma, float) ** 2 + (self.patch * np.asarray(M, float)) ** 2)

    def rows(self, sl) -> "Budget":
        """The budget of the charts ``sl`` (a slice or index array)."""
        return Budget(self.sd, {k: (mu[sl], sd[sl]) for k, (mu, sd) in self.priors.items()},
                      self.patch, self.response if not self.per_chart else self.response[sl])

    def to_dict(self) -> dict:
        """The budget as plain numbers: the sd given for every name and its source (a measured
        prior's own record: its centre, sd and source)."""
        return {k: {a: np.asarray(b).tolist() if isinstance(b, np.ndarray) else b
                    for a, b in v.items()} if isinstance(v, dict) else
                {"factors": np.asarray(v).tolist(), "source": "measured by a reference shot"}
                if k in MEASURED else
                {"sd": v, "source": BUDGET_SOURCES.get(k, "given")} for k, v in self.sd.items()}


def parse_sd(name: str, value, reference=None):
    """A standard deviation from ``uncertain[name]``: a number >= 0 or ``"x%"`` of ``reference``.

    Parameters
    ----------
    name : str
        The parameter's name (used in error messages as ``uncertain['name']``).
    value : float or str
        The sd in the parameter's units, or a percentage string such as ``"5%"``.
    reference : float or array_like, optional
        The value a percentage refers to (needed for a percentage).

    Returns
    -------
    float or ndarray
        The sd (>= 0).

    Raises
    ------
    ValueError
        For a negative, non-finite or malformed value, or a percentage without a reference.
    """
    label = f"uncertain[{name!r}]"
    if isinstance(value, str):
        text = value.strip()
        if not text.endswith("%"):
            raise InputError(label, f"expected a number or a percentage like '5%', got {value!r}")
        try:
            frac = float(text[:-1]) / 100.0
        except ValueError:
            raise InputError(label, f"expected a percentage like '5%', got {value!r}") from None
        if reference is None:
            raise InputError(label, "a percentage needs a value to refer to; give an sd in "
                             "the parameter's units")
        sd = frac * np.abs(np.asarray(reference, float))
    else:
        if isinstance(value, bool):
            raise InputError(label, f"expected a number, got {value!r}")
        try:
            sd = float(value)
        except (TypeError, ValueError):
            raise InputError(label, f"expected a number, got {value!r}") from None
    if not np.all(np.isfinite(sd)) or np.any(np.asarray(sd) < 0):
        raise InputError(label, f"a standard deviation must be finite and >= 0, got {value!r}")
    return sd


#: Nuisances whose prior is centred on 0: errors relative to what was given (the camera's
#: balance and curves, the daylight's colour).
CENTRED = ("balance", "camera_shift", "daylight")


def prior_centre(name: str, water: Water) -> float:
    """The centre of a nuisance's prior (not a length's: those are centred on the value
    given): 0 for :data:`CENTRED` names, else the water's constant.

    Parameters
    ----------
    name : str
        A :data:`NUISANCE` name other than 'depth' and 'distance'.
    water : forward.Water
        The water model.

    Returns
    -------
    float
    """
    return 0.0 if name in CENTRED else float(getattr(water, name))


def prior_of(name: str, value, water: Water):
    """(centre, sd) of the prior of nuisance ``name`` (not a length) from ``uncertain[name]``:
    an sd (about :func:`prior_centre`) or a measured prior ``{"centre": mu, "sd": sd, ...}``.
    The one place a prior's centre is read (every estimator through :func:`resolve_budget`,
    the joint fit through :func:`sca.joint` 's budget).

    Parameters
    ----------
    name : str
        A :data:`NUISANCE` name other than 'depth' and 'distance'.
    value : float or dict
        The sd in the parameter's units, or a dict with 'centre' and 'sd' (own units; each a
        number, or one per chart for the batch).
    water : forward.Water
        The water model (the default centre of its constants).

    Returns
    -------
    (float, float), or arrays (one per chart) where the measured prior has them

    Raises
    ------
    forward.errors.InputError
        Naming ``uncertain['name']``: a dict without a finite 'centre' or a valid 'sd'.
    """
    if not isinstance(value, dict):
        return prior_centre(name, water), float(parse_sd(name, value))
    label = f"uncertain[{name!r}]"
    if "centre" not in value or "sd" not in value:
        raise InputError(label, "a measured prior needs 'centre' and 'sd', got keys "
                         f"{sorted(value)}")
    out = []
    for key, ok in (("centre", np.isfinite), ("sd", lambda x: np.isfinite(x) & (x >= 0))):
        v = value[key]
        try:
            x = np.asarray(v, float) if not isinstance(v, (bool, str)) else np.array(np.nan)
        except (TypeError, ValueError):
            x = np.array(np.nan)
        if x.ndim > 1 or x.size == 0 or not np.all(ok(x)):
            raise InputError(label, f"'{key}' must be a finite number{' >= 0' if key == 'sd' else ''}"
                             f" (or one per chart), got {v!r}")
        out.append(float(x) if x.ndim == 0 else x)
    return out[0], out[1]


def prior_arrays(priors: dict, names, n: int = 1):
    """The priors of a problem's columns (:attr:`sca.problem.Problem.prior_mean`,
    :attr:`~sca.problem.Problem.prior_weight`): the one place a budget's priors become arrays.

    Parameters
    ----------
    priors : dict
        Name -> (mean, sd): a scalar or (n,) each, in the parameter's units (sd > 0), as
        :attr:`Budget.priors`.
    names : sequence of str, (p,)
        The problem's columns (a name of several columns, such as 'balance', gets the same
        prior on each).
    n : int, optional
        The number of units (rows). Default 1.

    Returns
    -------
    mean, weight : ndarray, (n, p)
        Each column's prior centre and information 1 / sd^2; 0 and 0 (no prior) for a name
        not in ``priors``.
    """
    mean, weight = np.zeros((n, len(names))), np.zeros((n, len(names)))
    for j, name in enumerate(names):
        if name in priors:
            mu, sd = priors[name]
            mean[:, j], weight[:, j] = mu, 1.0 / np.asarray(sd, float) ** 2
    return mean, weight


def resolve_budget(uncertain, *, depth, distance, water: Water, free=(), fixed=()) -> Budget:
    """The :class:`Budget` of ``uncertain`` for charts at ``depth`` and ``distance``.

    Parameters
    ----------
    uncertain : dict or None
        name -> sd (:data:`NUISANCE` and :data:`SYSTEMATIC` names; a nuisance other than a
        length may be a measured prior ``{"centre": mu, "sd": sd}``, :func:`prior_of`); None:
        the default budget (:data:`DEFAULT_UNCERTAIN`); ``{}``: the paper's exact model.
    depth, distance : float or (N,) array
        The given lengths, m (the priors' centres).
    water : forward.Water
        The water model (the priors' centres of its constants).
    free : sequence of str
        Names estimated freely (``free=``): they get no prior (an sd of 0 also means none).
    fixed : sequence of str
        Names held (``fix=``): they get no prior.

    Returns
    -------
    Budget

    Raises
    ------
    ValueError
        For ``uncertain`` not a dict, an unknown name or an invalid sd.
    """
    if uncertain is None:
        uncertain = DEFAULT_UNCERTAIN
    if not isinstance(uncertain, dict):
        raise InputError("uncertain", "expected a dict name -> standard deviation, e.g. "
                         f"{{'depth': 0.2}}, or {{}} for the paper's exact model; got "
                         f"{type(uncertain).__name__}")
    unknown = set(uncertain) - set(NUISANCE) - set(SYSTEMATIC) - set(MEASURED)
    if unknown:
        raise InputError("uncertain", f"unknown name(s) {sorted(unknown)}; choose from "
                         f"{tuple(NUISANCE + SYSTEMATIC + MEASURED)}")
    lengths = {"depth": np.atleast_1d(np.asarray(depth, float)),
               "distance": np.atleast_1d(np.asarray(distance, float))}
    measured = [np.size(v[k]) for v in uncertain.values() if isinstance(v, dict)
                for k in ("centre", "sd") if k in v]
    N = max(lengths["depth"].size, lengths["distance"].size, *measured)
    for name, v in uncertain.items():
        sizes = {np.size(v[k]) for k in ("centre", "sd") if k in v} if isinstance(v, dict) else ()
        if any(size not in (1, N) for size in sizes):
            raise InputError(f"uncertain[{name!r}]", f"one centre and sd, or one per chart "
                             f"({N}), got {sorted(sizes)}")
    priors = {}
    for name, value in uncertain.items():
        if name in SYSTEMATIC or name in MEASURED:
            continue
        if name in lengths:
            mean = np.broadcast_to(lengths[name], (N,)).astype(float)
            sd = np.broadcast_to(parse_sd(name, value, mean), (N,)).astype(float)
        else:
            centre, spread = prior_of(name, value, water)
            mean, sd = (np.broadcast_to(x, (N,)).astype(float) for x in (centre, spread))
        if name in free or name in fixed or not np.any(sd > 0):
            continue
        priors[name] = (mean, sd)
    patch = float(parse_sd("patch", uncertain.get("patch", 0.0)))
    return Budget(dict(uncertain), priors, patch, response_rows(uncertain.get("response"), N))


def response_rows(response, n: int):
    """``uncertain['response']`` as (1 or ``n``, m n) positive factors; None without one.

    Raises
    ------
    forward.errors.InputError
        Naming "uncertain['response']" for values not (m, n) or (``n``, m, n), or not positive.
    """
    if response is None:
        return None
    f = np.asarray(response, float)
    if f.ndim == 2:
        f = f[None]
    if f.ndim != 3 or f.shape[0] not in (1, n) or not np.all(np.isfinite(f) & (f > 0)):
        raise InputError("uncertain['response']", f"expected positive factors (m, n), or one "
                         f"set per chart ({n}, m, n), got shape {f.shape}")
    return f.reshape(f.shape[0], -1)


def variance_shares(J, names, w2_total, w2_photon, active, prior_weight, of=("chl", "cdom")):
    """Each source's share of the variance of the parameters ``of``, linearised at the fit, for
    N charts at once.

    With the whitened Jacobian Jw = sqrt(w2_total) J (every parameter, nuisances, the gain and
    the active backscatter included) and the priors' information P = diag(prior_weight), the
    covariance is S = (Jw^T Jw + P)^-1 = S Jw^T Jw S + sum_k S P_k S, and the data's part splits
    into the photon noise (fraction w2_total / w2_photon of each patch's variance) and the
    per-patch systematic term. The shares of each parameter add up to 1. (The information is
    :func:`sca.model.information`'s, through :func:`sca.model.covariance`, with the veiling
    light as indicator columns instead of :func:`sca.model.profiled_information`'s projection:
    each data row's share is read from S Jw^T row by row.)

    Parameters
    ----------
    J : ndarray, (N, m n, p)
        d M / d theta at the fits (data units per parameter unit).
    names : sequence of str, (p,)
        The name of each column ('balance' and 'backscatter' repeat, one per channel).
    w2_total, w2_photon : ndarray, (N, m n)
        1 / sigma_total^2 and 1 / sigma^2.
    active : ndarray of bool, (N, p)
        Columns taken into account (False: held, e.g. a backscatter at its bound).
    prior_weight : ndarray, (N, p)
        1 / sd^2 of each column's prior (0: none), in the parameter's units.
    of : sequence of str
        The parameters whose shares are wanted (their first column).

    Returns
    -------
    dict
        Name -> {'sd': (N,) linearised standard deviation, 'shares': {source: (N,) fraction}}
        with the sources 'noise' (photon and read noise), 'patch' and every prior's name (the
        channels of 'balance' summed); NaN where the information is singular.
    """
    with np.errstate(all="ignore"):  # a runaway fit (huge gain): its shares are NaN
        return _shares(J, names, w2_total, w2_photon, active, prior_weight, of)


def _shares(J, names, w2_total, w2_photon, active, prior_weight, of):
    J = np.asarray(J, float) * np.asarray(active, bool)[:, None, :]
    Jw = np.sqrt(w2_total)[..., None] * J
    pw = np.asarray(prior_weight, float)
    idle = ~np.asarray(active, bool)
    # the package's one covariance (Jacobi-scaled inverse of J^T J + P); a held column, all
    # zeros, is decoupled by a unit prior of its own
    S = covariance(Jw, prior_weight=pw + idle)
    S[~np.all(np.isfinite(S), axis=(1, 2))] = np.nan
    phi = np.clip(w2_total / w2_photon, 0.0, 1.0)  # photon fraction of each patch's variance
    SJ = S @ np.swapaxes(Jw, 1, 2)  # (N, p, m n)
    names = list(names)
    out = {}
    for name in of:
        if name not in names:
            continue
        i = names.index(name)
        parts = {"noise": np.sum(SJ[:, i] ** 2 * phi, axis=1),
                 "patch": np.sum(SJ[:, i] ** 2 * (1.0 - phi), axis=1)}
        for j, nj in enumerate(names):
            if np.any(pw[:, j] > 0):
                parts[nj] = parts.get(nj, 0.0) + S[:, i, j] ** 2 * pw[:, j]
        total = sum(parts.values())
        with np.errstate(all="ignore"):
            out[name] = {"sd": np.sqrt(S[:, i, i]),
                         "shares": {k: v / total for k, v in parts.items()}}
    return out


def limiting_source(shares: dict) -> str | None:
    """The source with the largest share (None for an empty budget)."""
    if not shares:
        return None
    return max(shares, key=shares.get)
