"""One water, many charts: the joint fit of a dive.

N photographs of the chart in one water share C and a_CDOM(440), the uncertainty budget's shared
nuisances (the water's constants, the camera's ``balance`` and ``camera_shift``) and the
chart's per-patch systematic error (the same chart in every photo: sd sqrt(rho) x ``patch``,
rho = ``patch_correlation``; the independent remainder sqrt(1 - rho) x ``patch`` joins each
value's own noise). Each photo keeps its own exposure gain, veiling light, geometry (depth and
distance with their priors) and light field. The problem is the inference layer's dive layout
(:class:`sca.diveproblem.DiveProblem`): fitted by the one Levenberg-Marquardt (:mod:`sca.lm`;
C in u = C^e0), its 95 % profile-likelihood intervals of C and a_CDOM by :mod:`sca.intervals`
(and of the Water constants named in ``free=``: unknowns shared by the photos, without a prior;
each parameter's coordinate, cap and default from :mod:`sca.parameters`),
its covariance and Cramér-Rao bound by :func:`sca.model.covariance`, as every estimator's; path
models are compared as in :mod:`sca.pathmodels`.

Heterogeneity: are these photos one water? The likelihood-ratio statistic of "one (C, a_CDOM)"
against "one (C, a_CDOM) per photo" (the shared nuisances shared in both) is chi^2 with
2 (N - 1) degrees of freedom; below :data:`HETEROGENEITY_ALPHA` the joint estimate is flagged
``heterogeneous`` (not reliable) and each photo is tested alone against the rest (Bonferroni).

:func:`dive_precision` is the Cramér-Rao bound of the same problem: what a dive design (depths,
distances, number of photos) buys (``sca.precision(..., dive=True)``).

References
----------
Blasinski & Farrell, "A Three Parameter Underwater Image Formation Model", eqs 15-18.
S. S. Wilks, "The large-sample distribution of the likelihood ratio for testing composite
hypotheses", Ann. Math. Statist. 9 (1938) 60-62.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np
from scipy import optimize, stats

from forward.imaging import ChartSetup
from forward.water import Water, resolve_water

from .assess import BLOCKING, MISFIT_P, goodness
from .budget import DEFAULT_UNCERTAIN, NUISANCE, parse_sd, prior_arrays, prior_of, response_rows
from .budget_defaults import CHART_PATCH
from .auxiliary import auxiliary_observations, planned
from .consistency import combined, consistency_records, nuisance_pulls, objectives_alone
from .derived import derived_from_fit, is_optical_depth, quantity_sd, verdict
from .diveproblem import PATCH, DiveProblem
from .intervals import BOUND_FAILED, own_units, profile_intervals
from .lm import LM_TOL, evaluate, levenberg_marquardt
from .model import CAMERA, ChartModel, check_names, covariance_from_information
from .parameters import PARAMETERS, SHARED_FREEABLE, default, from_lm, lm_cap, to_lm
from .pathmodels import PATH_MODEL_DELTA, SPAN_FLAG, candidates, supported
from .problem import du_chain
from .quadrature import CERTIFY_SIGMA, reduction_error
from forward.errors import InputError

__all__ = [
    "HETEROGENEITY_ALPHA",
    "JOINT_MAX_ITER",
    "PATCH_CORRELATION",
    "PATH_FIT_MAX_ITER",
    "JointEstimate",
    "dive_precision",
    "estimate_joint",
]

#: Level of the heterogeneity test (one water or not) and of each photo's test against the rest
#: (Bonferroni over the photos).
HETEROGENEITY_ALPHA = 0.01
#: Default correlation of the per-patch systematic error between photos: the chart's share of
#: the default per-patch variance, (CHART_PATCH / patch)^2 = 0.49. The chart's reflectance
#: tolerance is the same in every photo; the camera curves' error and the daylight's spectrum
#: act through the light at the chart, which changes with each photo's path, and are each
#: photo's own (decision 0054-patch-correlation; 1 before issue 37).
PATCH_CORRELATION = (CHART_PATCH / DEFAULT_UNCERTAIN["patch"]) ** 2
#: Levenberg-Marquardt iterations of a joint fit (its tolerance is the package's LM_TOL).
JOINT_MAX_ITER = 300
#: Levenberg-Marquardt iterations of another path model's fit to a design's noise-free photos
#: (:func:`dive_precision`'s ``path_model``): a supported model converges in a few (about 10);
#: a rejected one may crawl along C = 0 for hundreds, its chi^2 far above
#: :data:`sca.pathmodels.PATH_MODEL_DELTA` all the way.
PATH_FIT_MAX_ITER = 60
#: The largest per-photo relative scatter the joint fit adds beyond the budget (10 %: the
#: calibration refuses a camera above PATCH_SD_MAX = 3 %; a dive's photos that scatter more
#: than this are not one measurement).
PHOTO_SCATTER_MAX = 0.10
#: Flags of a joint estimate that make it not reliable.
JOINT_BLOCKING = tuple(BLOCKING) + ("heterogeneous",)


@dataclass
class JointEstimate:
    """The joint estimate of one water from N photographs.

    Attributes
    ----------
    chl, cdom : float
        C (mg m^-3) and a_CDOM(440) (m^-1).
    chl_ci, cdom_ci : tuple of float
        95 % profile-likelihood intervals (``inf``: open), the union over supported path models.
    reliable : bool
        No blocking flag (:data:`JOINT_BLOCKING`).
    flags : tuple of str
        'misfit', 'not-converged', 'unbounded-chl', 'unbounded-cdom', 'heterogeneous',
        'reading-conflict', 'nuisance-pulled' (:mod:`sca.consistency`), 'path-model-span' and
        'unbounded-NAME' of a constant of ``free=`` (information).
    chi2, dof, chi2_p : float, int, float
        Goodness of fit of the joint model (priors' terms included in chi2).
    heterogeneity : dict
        'statistic', 'dof', 'p_value', 'one_water' (bool), 'alpha', 'disagree' (names of the
        photos that differ from the rest), 'per_photo' (name -> Bonferroni p, where tested).
    path_model : str
        The best path model; ``path_models`` name -> chi2 of every candidate.
    photos : dict
        Per photo (keyed by name): 'gain', 'backscatter', 'depth', 'distance' at the fit.
    nuisance : dict
        The shared nuisances (with a prior) at the fit; a constant of ``free=`` is in
        ``values``.
    uncertain : dict
        The budget used (name -> sd).
    notes : list of str
        Sentences for the user.
    """

    chl: float
    cdom: float
    chl_ci: tuple
    cdom_ci: tuple
    reliable: bool
    flags: tuple
    chi2: float
    dof: int
    chi2_p: float
    heterogeneity: dict
    path_model: str
    path_models: dict
    photos: dict
    nuisance: dict
    uncertain: dict
    converged: bool = True
    notes: list = field(default_factory=list)
    #: the per-photo, per-value relative scatter added beyond the budget (0: none needed;
    #: :func:`_photo_scatter`)
    photo_scatter: float = 0.0
    #: photos left out of the fit: name -> reason (:func:`measure.joint.fit_joint`)
    excluded: dict = field(default_factory=dict)
    #: what the dive measures (:mod:`sca.derived`, at the photos' median depth and distance):
    #: name -> value of every derived quantity (m^-1)
    quantities: dict = field(default_factory=dict)
    #: name -> (lo, hi) their 95 % intervals (spanning the supported path models)
    quantity_intervals: dict = field(default_factory=dict)
    #: the spectrum of the path's attenuation coefficient (m^-1) on ``wavelengths`` (nm) and its
    #: 95 % interval [[lo, hi], ...]
    beam_attenuation: list = field(default_factory=list)
    beam_attenuation_ci: list = field(default_factory=list)
    wavelengths: list = field(default_factory=list)
    #: name -> verdict of 'chl', 'cdom' and every quantity (:func:`sca.derived.verdict`)
    verdicts: dict = field(default_factory=dict)
    #: the readings and the budget's priors tested against the photos (:mod:`sca.consistency`):
    #: {'readings': {name: {'delta_chi2', 'p', 'conflict'}}, 'pulls': {nuisance: pull in its
    #: prior's sds}, 'pull_max', 'conflict_p'}
    consistency: dict = field(default_factory=dict)
    #: every estimated name ('chl', 'cdom' and the shared unknowns of ``free=``) -> its value
    #: at the fit, in its units (:data:`sca.parameters.PARAMETERS`)
    values: dict = field(default_factory=dict)
    #: name -> (lo, hi) 95 % profile-likelihood interval of each of ``values`` (``inf``: open),
    #: the union over supported path models (``intervals['chl']`` is ``chl_ci``)
    intervals: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        """joint.json's content (plain numbers; ``inf`` for open interval ends)."""
        d = dataclasses.asdict(self)
        d["chl_ci"], d["cdom_ci"] = list(self.chl_ci), list(self.cdom_ci)
        d["intervals"] = {k: list(v) for k, v in self.intervals.items()}
        d["flags"] = list(self.flags)
        d["n_photos"] = len(self.photos)
        d["units"] = {k: PARAMETERS[k].units for k in ("chl", "cdom", "depth", "distance", "gain",
                                                       "backscatter", *self.values)}
        return d


# --------------------------------------------------------------------------- the problem
@dataclass
class _Dive:
    """What every fit of one dive shares: the photos in scaled units, the models and the
    budget's priors."""

    models: list
    M: np.ndarray  # (N, m n) scaled (each photo's largest value 1)
    W2: np.ndarray  # (N, m n) weights; 0 where a value is left out
    scale: np.ndarray  # (N,)
    depth: np.ndarray
    distance: np.ndarray
    priors: dict  # shared nuisance -> (mean, sd)
    geo_sd: dict  # 'depth', 'distance' -> (N,) sd (0: held)
    patch_shared: float  # sd of the chart's per-patch error shared by the photos (relative)
    auxiliary: dict | None = None  # the user's auxiliary measurements (sca.auxiliary)
    free: tuple = ()  # Water constants estimated as shared unknowns without a prior


def _problem(d: _Dive, groups) -> DiveProblem:
    """The dive as an inference problem (:class:`sca.diveproblem.DiveProblem`) with its priors
    and auxiliary measurements."""
    N = d.M.shape[0]
    free_geo = {g: d.geo_sd[g] > 0 for g in ("depth", "distance")}
    prob = DiveProblem(d.models, d.M, d.W2, d.scale, groups, tuple(d.priors) + d.free, d.depth,
                       d.distance, free_geo["depth"], free_geo["distance"], d.patch_shared > 0,
                       None, None, auxiliary_observations(d.auxiliary, d.models[0].water))
    mean, weight = prior_arrays(d.priors, prob.names)
    for name in d.free:  # no prior (weight 0); the mean is the start (sca.parameters.default)
        mean[0, prob.layout[name]] = default(name, prob.water)
    for name in ("depth", "distance"):
        cols = prob.layout[name]
        for i in range(N):
            if cols[i] >= 0:
                mean[0, cols[i]] = getattr(d, name)[i]
                weight[0, cols[i]] = 1.0 / d.geo_sd[name][i] ** 2
    if d.patch_shared > 0:
        weight[0, prob.layout[PATCH]] = 1.0 / d.patch_shared ** 2
    prob.prior_mean, prob.prior_weight = mean, weight
    return prob


def _solve(prob: DiveProblem, theta0, hold=None, max_iter: int = JOINT_MAX_ITER):
    """The penalised least-squares optimum from ``theta0`` (p,) (``hold``: columns held);
    (theta, f, converged)."""
    f_exact = 1e-30 * np.einsum("ij,ij->", prob.W2 * prob.M, prob.M)
    theta, f, _, code = levenberg_marquardt(
        prob, np.asarray(theta0, float)[None], max_iter=max_iter, tol=LM_TOL,
        f_exact=np.array([f_exact]), hold=None if hold is None else np.asarray(hold)[None])
    return theta[0], float(f[0]), bool(code[0] <= 2)


def _certified(prob: DiveProblem, theta, M, sigma, f) -> bool:
    """The reduced quadrature's certificate at the optimum (:mod:`sca.quadrature`): every
    photo's reduced prediction within CERTIFY_SIGMA of the full grid's, in units of its noise
    (or of the residual the fit shows, where smaller). True where the models are full."""
    if prob.models[0].full is prob.models[0]:
        return True
    extras = evaluate(prob, np.zeros(1, np.int64), theta[None], False).extras
    N = prob.M.shape[0]
    shown = np.sqrt(max(f, 0.0) / max(np.count_nonzero(prob.W2), 1))  # whitened RMS
    for i in range(N):
        params = prob.photo_params(theta, i)
        params.update(gain=extras["gain"][0, i:i + 1],
                      backscatter=extras["s"][0, i:i + 1] * prob.scale[i])
        sig = np.asarray(sigma[i], float).reshape(-1)
        noise = np.where(np.isfinite(sig) & (sig > 0), sig, np.inf)
        noise = np.minimum(noise, shown * noise)  # a fit far better than its noise
        model = prob.models[i]
        if not reduction_error(model.full, model, params, noise[None])[0] <= CERTIFY_SIGMA:
            return False
    return True


def _dof(prob: DiveProblem, theta) -> int:
    """Values measured minus the photos' (C, a_CDOM), the shared unknowns without a prior
    (``free=``), gains and active veiling lights (a prior adds one term and one parameter)."""
    s = evaluate(prob, np.zeros(1, np.int64), theta[None], False).extras["s"][0]
    n_groups = int(prob.groups.max()) + 1
    n_free = len(_estimated(prob)) - 2
    return int(np.count_nonzero(prob.W2)) - 2 * n_groups - n_free - prob.M.shape[0] - int(
        np.count_nonzero(s > 0))


def _estimated(prob: DiveProblem) -> tuple:
    """The names the dive estimates: 'chl', 'cdom' and the shared unknowns without a prior."""
    return ("chl", "cdom") + tuple(k for k in prob.shared
                                   if not np.any(prob.prior_weight[0, prob.layout[k]]))


def _intervals(prob: DiveProblem, theta, f_min):
    """95 % profile-likelihood intervals of every estimated name (:func:`_estimated`: C and
    a_CDOM of group 0, the shared unknowns of ``free=``) by the one profile method
    (:func:`sca.intervals.profile_intervals`), each capped and converted by the parameter
    table (:mod:`sca.parameters`), and the flags of open or failed ends."""
    e0 = prob.models[0].e0
    names = _estimated(prob)
    cols = [int(prob.layout[k][0]) for k in names]
    H = evaluate(prob, np.zeros(1, np.int64), theta[None], True).H
    caps = np.full(len(prob.names), np.inf)
    caps[cols] = [lm_cap(k, prob.water, e0) for k in names]
    ends, codes = profile_intervals(prob, theta[None], np.array([f_min]),
                                    np.array([PATH_MODEL_DELTA]), H, caps, which=cols)
    own = own_units(ends, codes, prob.powers)
    out, flags = {}, []
    for name, j in zip(names, cols):
        lo, hi = own[0, j]
        if np.any(codes[0, j] == BOUND_FAILED):
            flags.append("not-converged")
        if not (np.isfinite(lo) and np.isfinite(hi)):
            flags.append(f"unbounded-{name}")
        out[name] = (float(lo), float(hi))
    return out, flags


# --------------------------------------------------------------------------- set-up
def _derived(prob: DiveProblem, theta, depth, distance, intervals) -> dict:
    """What the dive measures (:func:`sca.derived.derived_from_fit`) at one depth and distance
    (the photos' median), on the full grid; ``intervals`` (:func:`_intervals`) give the upper
    ends of C and a_CDOM whose profile points the quantities' intervals hold where C or a_CDOM
    sits at its bound. The optical depths (:func:`sca.derived.is_optical_depth`) are left out:
    tau is a photo's, each photo's own fit reports it."""
    H = evaluate(prob, np.zeros(1, np.int64), theta[None], True).H
    full = prob.models[0].full
    ends = {}
    for name in ("chl", "cdom"):
        hi = intervals[name][1]
        if np.isfinite(hi):
            ends[int(prob.layout[name][0])] = np.array(
                [to_lm(name, hi, prob.models[0].e0)])
    out = derived_from_fit(prob, theta[None], H, prob.water, full.wavelengths,
                           geometry={"depth": np.array([depth]),
                                     "distance": np.array([distance])}, ends=ends)
    out["quantities"] = {k: v for k, v in out["quantities"].items() if not is_optical_depth(k)}
    return out


def _budget(uncertain, water, depth, distance, depth_sd, distance_sd, patch_correlation,
            free=()):
    """(shared priors, geometry sds, shared patch sd, independent patch sd, budget dict); the
    names ``free`` get no prior (estimated), as :func:`sca.budget.resolve_budget`'s."""
    if uncertain is None:
        uncertain = DEFAULT_UNCERTAIN
    if not isinstance(uncertain, dict):
        raise InputError("uncertain", "expected a dict name -> standard deviation, or {} for the "
                         "paper's exact model")
    bad = set(uncertain) - set(NUISANCE) - {"patch", "response"}
    if bad:
        raise InputError("uncertain", f"unknown name(s) {sorted(bad)}")
    priors = {}
    for name, value in uncertain.items():
        if name in ("depth", "distance", "patch", "response"):
            continue
        centre, sd = prior_of(name, value, water)
        if np.ndim(centre) or np.ndim(sd):
            raise InputError(f"uncertain[{name!r}]", "a dive has one light: one centre and sd, "
                             "not one per chart")
        if name in free:
            continue
        if sd > 0:
            priors[name] = (centre, sd)
    geo = {}
    for name, given, ref in (("depth", depth_sd, depth), ("distance", distance_sd, distance)):
        if given is not None:
            sd = np.broadcast_to(np.asarray(given, float), ref.shape).astype(float)
            if np.any(~np.isfinite(sd)) or np.any(sd < 0):
                raise InputError(f"{name}_sd", "standard deviations must be finite and >= 0")
        elif name in uncertain:
            sd = np.broadcast_to(parse_sd(name, uncertain[name], ref), ref.shape).astype(float)
        else:
            sd = np.zeros(ref.shape)
        geo[name] = sd
    patch = float(parse_sd("patch", uncertain.get("patch", 0.0)))
    rho = float(patch_correlation)
    if not 0.0 <= rho <= 1.0:
        raise InputError("patch_correlation", f"must lie in [0, 1], got {patch_correlation!r}")
    # correlation rho between photos: a shared part of variance rho patch^2, an independent
    # part (1 - rho) patch^2
    return priors, geo, np.sqrt(rho) * patch, np.sqrt(1.0 - rho) * patch, dict(uncertain)


def _response(uncertain):
    """The dive's one chart response measured in air (``uncertain['response']``, (m, n)), or
    None: one chart and one light for the dive (:func:`sca.budget.response_rows`)."""
    rows = response_rows((uncertain or {}).get("response"), 1)
    return None if rows is None else rows[0]


def _dive(M, sigma, setups, water, depth, distance, priors, geo, patch_shared, patch_indep,
          reduce: bool = True, auxiliary=None, free=(), response=None):
    """The photos in scaled units with their weights: each value's own noise and the
    independent per-patch term in the weights (0 where a value is left out); each photo's
    model (times the chart's ``response`` measured in air, where given) on the certified
    quadrature (``reduce``) or its full grid."""
    N = M.shape[0]
    built = {}
    models = [built.setdefault(id(s), ChartModel(s, water=water).with_response(response))
              for s in setups]
    if reduce:
        models = [m.reduced() for m in models]
    Mv = M.reshape(N, -1)
    sig = sigma.reshape(N, -1)
    scale = np.nanmax(np.where(np.isfinite(Mv), Mv, 0.0), axis=1)
    if np.any(~(scale > 0)):
        raise InputError("rgb", "every chart needs a positive value")
    ok = np.isfinite(sig) & (sig > 0) & np.isfinite(Mv)
    Ms = np.where(ok, Mv, 0.0) / scale[:, None]
    total = np.sqrt((np.where(ok, sig, 1.0) / scale[:, None]) ** 2 + (patch_indep * Ms) ** 2)
    W2 = np.where(ok, 1.0 / total ** 2, 0.0)
    return _Dive(models, Ms, W2, scale, depth, distance, priors, geo, float(patch_shared),
                 auxiliary, tuple(free))


def _starts(d: _Dive, prob: DiveProblem, start) -> np.ndarray:
    """theta0 (p,) from per-photo starting values (chl, cdom): each group at its photos'
    median, every nuisance at its prior's centre."""
    theta = np.array(prob.prior_mean[0], float)
    e0 = prob.models[0].e0
    for g in range(int(prob.groups.max()) + 1):
        members = prob.groups == g
        theta[prob.layout["chl"][g]] = to_lm("chl", np.median(start["chl"][members]), e0)
        theta[prob.layout["cdom"][g]] = np.median(start["cdom"][members])
    return theta


def _single_starts(M, sigma, setups, water, depth, distance):
    """Per-photo starting values: the batch's fit of each photo alone (exact model)."""
    from .batch import estimate_batch

    out = {k: [] for k in ("chl", "cdom", "gain", "backscatter")}
    for i in range(M.shape[0]):
        sig = np.where(np.isfinite(sigma[i]), sigma[i], 1e6 * np.nanmax(M[i]))
        b = estimate_batch(M[i][None], depth=depth[i], distance=distance[i], sigma=sig,
                           setup=setups[i], water=water, gain="free", intervals=False,
                           uncertain={}, path_models=(water.path_model,))
        for k in out:
            out[k].append(np.asarray(getattr(b, k))[0])
    return {k: np.array(v, float) for k, v in out.items()}


def _check(M, sigma, depth, distance, setups):
    M = np.asarray(M, float)
    if M.ndim != 3 or M.shape[0] < 1:
        raise InputError("rgb", f"expected (N, m, n) patch values of N >= 1 photos, got shape "
                         f"{M.shape}")
    sigma = np.asarray(sigma, float)
    if sigma.shape != M.shape:
        raise InputError("sigma", f"expected the shape of rgb {M.shape}, got {sigma.shape}")
    N = M.shape[0]
    out = []
    for name, v in (("depth", depth), ("distance", distance)):
        a = np.broadcast_to(np.asarray(v, float), (N,)).astype(float)
        if np.any(~np.isfinite(a)) or np.any(a < 0):
            raise InputError(name, "expected N finite lengths >= 0 (m)")
        out.append(a)
    if isinstance(setups, ChartSetup):
        setups = [setups] * N
    setups = list(setups)
    if len(setups) != N or not all(isinstance(s, ChartSetup) for s in setups):
        raise InputError("setup", "expected one forward.ChartSetup, or one per photo")
    return M, sigma, out[0], out[1], setups


# --------------------------------------------------------------------------- the estimator
def estimate_joint(rgb, *, depth, distance, sigma, setup, water: Water | None = None,
                   uncertain=None, depth_sd=None, distance_sd=None, names=None,
                   path_models=None, patch_correlation: float = PATCH_CORRELATION,
                   start=None, auxiliary=None, free=()) -> JointEstimate:
    """Estimate one water (C, a_CDOM(440)) from N photographs of the chart.

    Parameters
    ----------
    rgb : array_like, (N, m, n)
        Patch values of each photo (any units: each photo's exposure gain is free).
    depth, distance : float or array_like, (N,)
        Each photo's chart depth and camera-to-chart distance, m (the priors' centres).
    sigma : array_like, (N, m, n)
        Standard errors of the values (same units); ``inf`` or NaN leaves a value out
        (clipped).
    setup : forward.ChartSetup or sequence of them
        The camera (its calibrated balance applied), illuminant and chart; one per photo where
        the light over the chart differs (:mod:`measure.lightfield`).
    water : forward.Water, optional
        The water model (default the paper's).
    uncertain : dict, optional
        The uncertainty budget (:mod:`sca.budget`); None: the default. The water's constants,
        'balance' and 'camera_shift' are shared by every photo; 'depth' and 'distance' are
        each photo's; 'patch' is split by ``patch_correlation``.
    depth_sd, distance_sd : array_like, (N,), optional
        Each photo's own sd (m), replacing the budget's 'depth' / 'distance'.
    names : sequence of str, optional
        Photo names for the report (default 'photo 1', ...).
    path_models : sequence of str, optional
        Path models to compare (default: every candidate where a budget applies).
    patch_correlation : float, optional
        Correlation of the per-patch systematic error between photos (default
        :data:`PATCH_CORRELATION`: the chart's part shared, the light's part each photo's own;
        1: all of it shared, the rule before issue 37).
    start : dict, optional
        Per-photo starting values 'chl', 'cdom', 'gain', 'backscatter' ((N,), (N, m); data
        units); default: each photo's own fit.
    auxiliary : dict, optional
        What was measured of this water besides the photos (:func:`sca.auxiliary.
        auxiliary_observations`: 'cdom', 'secchi', 'kd'), fused in the fit.
    free : sequence of str, optional
        Water constants (:data:`sca.parameters.SHARED_FREEABLE`, e.g. ``('nap_slope',)``)
        estimated as unknowns of the dive: one value shared by every photo, started at the
        water's constant, without the budget's prior (dropped where it has one), reported with
        its 95 % profile-likelihood interval in ``values`` and ``intervals``. Default none.

    Returns
    -------
    JointEstimate

    Raises
    ------
    ValueError
        Naming the argument for bad shapes, lengths, budgets or path models.
    """
    M, sigma, depth, distance, setups = _check(rgb, sigma, depth, distance, setup)
    free = check_names("free", free, SHARED_FREEABLE)
    N, m, n = M.shape
    water = resolve_water(water)
    names = [f"photo {i + 1}" for i in range(N)] if names is None else [str(x) for x in names]
    if len(names) != N:
        raise InputError("names", f"expected {N} names, got {len(names)}")
    priors, geo, p_shared, p_indep, budget = _budget(uncertain, water, depth, distance,
                                                     depth_sd, distance_sd, patch_correlation,
                                                     free)
    response = _response(uncertain)
    exact = not priors and not np.any(geo["depth"]) and not np.any(geo["distance"]) \
        and p_shared == 0 and p_indep == 0 and response is None
    models = candidates(path_models, water, not exact)
    if start is None:
        start = _single_starts(M, sigma, setups, water, depth, distance)
    start = {k: np.asarray(v, float) for k, v in start.items()}

    def fit(pm, indep, groups=None, theta0=None):
        w = dataclasses.replace(water, path_model=pm)
        groups = np.zeros(N, int) if groups is None else groups
        d = _dive(M, sigma, setups, w, depth, distance, priors, geo, p_shared, indep,
                  auxiliary=auxiliary, free=free, response=response)
        prob = _problem(d, groups)
        theta, f, ok = _solve(prob, _starts(d, prob, start) if theta0 is None else theta0)
        if not _certified(prob, theta, M, sigma, f):  # the full grid, from this optimum
            d = _dive(M, sigma, setups, w, depth, distance, priors, geo, p_shared, indep,
                      reduce=False, auxiliary=auxiliary, free=free, response=response)
            prob = _problem(d, groups)
            theta, f, ok = _solve(prob, theta)
        return prob, theta, f, ok

    scatter = 0.0
    if N > 1 and not exact:
        scatter = _photo_scatter(lambda indep: fit(models[0], indep, np.arange(N)), p_indep)
        p_indep = float(np.hypot(p_indep, scatter))
    fits = {pm: fit(pm, p_indep) for pm in models}
    objectives = np.array([[fits[pm][2] for pm in models]])
    best_i, ok_mask = supported(objectives)
    best = models[int(best_i[0])]
    prob, theta, f, converged = fits[best]
    flags, notes = [], []
    cis = {k: [np.inf, -np.inf] for k in ("chl", "cdom") + free}
    derived = {}
    for j, pm in enumerate(models):
        if not ok_mask[0, j]:
            continue
        ints, fl = _intervals(*fits[pm][:3])
        flags += fl
        for k in cis:
            cis[k] = [min(cis[k][0], ints[k][0]), max(cis[k][1], ints[k][1])]
        derived[pm] = _derived(fits[pm][0], fits[pm][1], np.median(depth), np.median(distance),
                               ints)
    if ok_mask.sum() > 1:
        flags.append(SPAN_FLAG)
        notes.append("the intervals span the path models the data cannot tell apart: "
                     + ", ".join(pm for j, pm in enumerate(models) if ok_mask[0, j]))
    dof = _dof(prob, theta)
    _, p = goodness(f, dof, True)
    if scatter >= PHOTO_SCATTER_MAX:
        flags.append("misfit")
        notes.append(f"the photos disagree patch by patch by more than {100 * PHOTO_SCATTER_MAX:g} "
                     "% beyond their noise: not one measurement")
    if scatter > 0:
        flags.append("photo-scatter")
        notes.append(f"the photos disagree patch by patch beyond their noise and the shared chart "
                     f"term: a per-photo term of {100 * scatter:.2g} % per value was added (its "
                     "size from the joint fit's chi^2)")
    if not converged:
        flags.append("not-converged")
    if float(p) < MISFIT_P:
        flags.append("misfit")
    consistency, table = _consistency(fits, models, best, budget)
    for k, v in consistency["readings"].items():
        if v["conflict"]:
            notes.append(f"the reading '{k}' contradicts the photos (likelihood-ratio "
                         f"Delta chi^2 = {v['delta_chi2']:.3g}, p = {v['p']:.2g}): every "
                         "number fused with it is suspect")
    for k, v in consistency["pulls"].items():
        if abs(v) > consistency["pull_max"]:
            notes.append(f"the budget's '{k}' is pulled {v:+.2g} of its prior's sds from its "
                         "centre: the fit bends a prior to agree with the photos")
    flags += [k for k, v in table.items() if v[0]]
    het = _heterogeneity(lambda groups, theta0: fit(best, p_indep, groups, theta0), prob, theta,
                         f, names)
    if not het["one_water"]:
        flags.append("heterogeneous")
        which = ", ".join(het["disagree"]) or "no single photo stands out"
        notes.append(f"these photos are not one water (likelihood-ratio p = {het['p_value']:.2g}); "
                     f"photos that disagree with the rest: {which}")
    e0 = prob.models[0].e0
    flags = tuple(dict.fromkeys(flags))
    extras = evaluate(prob, np.zeros(1, np.int64), theta[None], False).extras
    photos = {}
    for i, nm in enumerate(names):
        p_i = prob.photo_params(theta, i)
        photos[nm] = {"gain": float(extras["gain"][0, i]),
                      "backscatter": (extras["s"][0, i] * prob.scale[i]).tolist(),
                      "depth": float(p_i["depth"][0]), "distance": float(p_i["distance"][0])}
    nuisance = {k: (theta[prob.layout[k]].tolist() if k in CAMERA
                    else float(theta[prob.layout[k][0]])) for k in prob.shared if k not in free}
    values = {k: float(from_lm(k, theta[prob.layout[k][0]], e0)) for k in cis}
    best_d = derived[best]
    qi = {k: (min(d["quantities"][k][1][0, 0] for d in derived.values()),
              max(d["quantities"][k][1][0, 1] for d in derived.values()))
          for k in best_d["quantities"]}
    c_ci = np.stack([np.min([d["c_ci"][0, :, 0] for d in derived.values()], axis=0),
                     np.max([d["c_ci"][0, :, 1] for d in derived.values()], axis=0)], axis=-1)
    verdicts = {**{k: verdict(*cis[k], k) for k in ("chl", "cdom")},
                **{k: verdict(*v, k) for k, v in qi.items()}}
    return JointEstimate(
        quantities={k: float(v[0][0]) for k, v in best_d["quantities"].items()},
        quantity_intervals={k: (float(a), float(b)) for k, (a, b) in qi.items()},
        beam_attenuation=best_d["c"][0].tolist(), beam_attenuation_ci=c_ci.tolist(),
        wavelengths=best_d["wavelengths"].tolist(), verdicts=verdicts,
        chl=values["chl"], cdom=values["cdom"], values=values,
        intervals={k: tuple(float(v) for v in ci) for k, ci in cis.items()},
        chl_ci=tuple(float(v) for v in cis["chl"]), cdom_ci=tuple(float(v) for v in cis["cdom"]),
        reliable=not any(fl in JOINT_BLOCKING for fl in flags), flags=flags, chi2=float(f),
        dof=int(dof), chi2_p=float(p), heterogeneity=het, path_model=best,
        path_models={pm: float(fits[pm][2]) for pm in models}, photos=photos,
        photo_scatter=float(scatter),
        nuisance=nuisance, uncertain=budget, converged=converged, notes=notes,
        consistency=consistency)


def _consistency(fits, models, best, uncertain):
    """The readings and priors of the dive tested against its photos (:mod:`sca.consistency`)
    over the path models, and the budget's reference shots: (record, flag table)."""
    alones = [objectives_alone(fits[pm][0], fits[pm][1][None]) for pm in models]
    pulls = nuisance_pulls(fits[best][0], fits[best][1][None])
    tests, table = combined([[fits[pm][2]] for pm in models], alones, pulls, uncertain)
    return consistency_records(tests, pulls), table


def _photo_scatter(fit, base) -> float:
    """The per-photo relative scatter s (added in quadrature to the budget's independent
    per-patch term) at which the fit with one (C, a_CDOM) *per photo* has chi^2 equal to its
    degrees of freedom: the photos' own disagreement beyond their noise and the shared chart
    term, measured where a difference of water cannot be absorbed (so the heterogeneity test
    keeps its power). 0 where that fit is good without it (chi^2 p >= MISFIT_P),
    PHOTO_SCATTER_MAX where even that is not enough (the joint estimate is then flagged
    misfit). Method of moments, as the calibration's per-patch term
    (:func:`measure.camera.patch_systematic`); ``fit(indep)`` fits with that independent
    term."""
    def excess(s):
        prob, theta, f, _ = fit(float(np.hypot(base, s)))
        return f - _dof(prob, theta)

    prob, theta, f, _ = fit(base)
    if float(goodness(f, _dof(prob, theta), True)[1]) >= MISFIT_P:
        return 0.0
    if excess(PHOTO_SCATTER_MAX) > 0:
        return PHOTO_SCATTER_MAX
    lo, hi = PHOTO_SCATTER_MAX * 1e-3, PHOTO_SCATTER_MAX
    if excess(lo) <= 0:
        return lo
    return float(np.exp(optimize.brentq(lambda t: excess(np.exp(t)), np.log(lo), np.log(hi),
                                        xtol=0.05)))


def _heterogeneity(fit, prob, theta, f_joint, names) -> dict:
    """The likelihood-ratio test of one (C, a_CDOM) against one per photo; where it rejects,
    the photos that disagree, found one at a time: the photo whose own (C, a_CDOM) lowers
    chi^2 most is set apart (Bonferroni p over the photos still shared) and the rest is tested
    again, until the rest is one water (or two photos remain). ``fit(groups, theta0)`` fits
    the dive with a (C, a_CDOM) per group (theta0 None: from the photos' own starts)."""
    N = prob.M.shape[0]
    out = {"alpha": HETEROGENEITY_ALPHA, "statistic": 0.0, "dof": 2 * (N - 1), "p_value": 1.0,
           "one_water": True, "disagree": [], "per_photo": {}}
    if N < 2:
        return out

    def fit_groups(groups):
        """The fit with (C, a_CDOM) per group, from the photos' own starts and from the joint
        optimum (each group at the joint C and a_CDOM): the lower of the two."""
        sep, _, f_own, _ = fit(groups, None)
        t0 = np.empty(len(sep.names))
        G = int(np.max(groups)) + 1
        t0[sep.layout["chl"]] = theta[prob.layout["chl"][0]]
        t0[sep.layout["cdom"]] = theta[prob.layout["cdom"][0]]
        t0[2 * G:] = theta[2:]  # the same nuisances, in the same order after the groups
        f = min(f_own, fit(groups, t0)[2])
        return min(f, f_joint)  # more freedom never fits worse than the joint optimum

    f_sep = fit_groups(np.arange(N))
    stat = max(f_joint - f_sep, 0.0)
    p = float(stats.chi2.sf(stat, 2 * (N - 1)))
    out.update(statistic=float(stat), p_value=p, one_water=bool(p >= HETEROGENEITY_ALPHA))
    apart = []  # photos set apart, in order
    f_now = f_joint
    while True:
        rest = [i for i in range(N) if i not in apart]
        if len(rest) < 3:
            break
        stat_rest = max(f_now - f_sep, 0.0)
        if stats.chi2.sf(stat_rest, 2 * (len(rest) - 1)) >= HETEROGENEITY_ALPHA:
            break
        trials = {}
        for i in rest:
            groups = np.zeros(N, int)
            for k, j in enumerate(apart + [i]):
                groups[j] = k + 1
            trials[i] = fit_groups(groups)
        i = min(trials, key=trials.get)
        p_i = min(1.0, len(rest) * float(stats.chi2.sf(max(f_now - trials[i], 0.0), 2)))
        out["per_photo"][names[i]] = p_i
        if p_i >= HETEROGENEITY_ALPHA:
            break
        apart.append(i)
        f_now = trials[i]
    out["disagree"] = [names[i] for i in apart]
    return out


# --------------------------------------------------------------------------- the bound
def dive_precision(chl, cdom, *, depth, distance, sigma, setup, water: Water | None = None,
                   uncertain=None, patch_correlation: float = PATCH_CORRELATION,
                   gain=None, backscatter=None, auxiliary=None, path_model=None) -> dict:
    """The Cramér-Rao bound of C and a_CDOM(440) from N photographs of one water.

    Parameters
    ----------
    chl, cdom : float
        The water: C (mg m^-3), a_CDOM(440) (m^-1).
    depth, distance : array_like, (N,)
        The dive's photos: chart depths and camera-to-chart distances, m.
    sigma : array_like, (N, m, n)
        Each photo's noise sd at its noise-free values (the same units as the model with
        ``gain``).
    setup : forward.ChartSetup or sequence of them
        The camera, illuminant and chart.
    water, uncertain, patch_correlation :
        As :func:`estimate_joint`.
    gain : array_like, (N,), optional
        Each photo's exposure gain (default 1).
    backscatter : array_like, (N, m), optional
        Each photo's veiling light (default 0).
    auxiliary : dict, optional
        Auxiliary measurements planned (:func:`sca.auxiliary.auxiliary_observations`; their
        values do not matter, their sds do).
    path_model : str, optional
        Fit the noise-free photos (made with ``water``'s own path model) with this path model
        of :data:`forward.water.PATH_MODELS` instead: the result is then at that model's
        optimum (the values its estimate tends to) with its covariance there. Default: the
        water's own (the bound at the truth).

    Returns
    -------
    dict
        'chl_sd', 'cdom_sd' (the bound's standard deviations), 'correlation', 'n_photos';
        'chl', 'cdom' (the truth, or ``path_model``'s optimum) and 'objective' (its chi^2 on
        the noise-free photos: 0, or the noncentrality of ``path_model``'s misfit), 'converged'
        (False: that fit stopped after :data:`PATH_FIT_MAX_ITER` iterations);
        'quantities' and 'quantity_sd' (name -> value and sd of every derived quantity of
        :mod:`sca.derived` at the photos' median depth and distance, as the joint estimate
        reports them; :func:`sca.derived.quantity_sd`).

    Raises
    ------
    ValueError
        For an unknown ``path_model``.
    """
    from forward.water import COEFFICIENT_PARAMS, PATH_MODELS


    depth = np.atleast_1d(np.asarray(depth, float))
    distance = np.atleast_1d(np.asarray(distance, float))
    N = max(depth.size, distance.size)
    depth, distance = np.broadcast_to(depth, (N,)).copy(), np.broadcast_to(distance, (N,)).copy()
    water = resolve_water(water)
    setups = [setup] * N if isinstance(setup, ChartSetup) else list(setup)
    priors, geo, p_shared, p_indep, _ = _budget(uncertain, water, depth, distance, None, None,
                                                patch_correlation)
    mdl = ChartModel(setups[0], water=water)
    m, n = mdl.m, mdl.n
    gain = np.ones(N) if gain is None else np.broadcast_to(np.asarray(gain, float), (N,))
    s = np.zeros((N, m)) if backscatter is None else np.broadcast_to(
        np.asarray(backscatter, float), (N, m))
    M0 = np.stack([ChartModel(setups[i], water=water).predict(
        {"chl": chl, "cdom": cdom, "depth": depth[i], "distance": distance[i], "gain": gain[i],
         "backscatter": s[i]}, jacobian=False).values.reshape(m, n) for i in range(N)])
    sigma = np.broadcast_to(np.asarray(sigma, float), M0.shape)
    if path_model is not None and path_model not in PATH_MODELS:
        raise InputError("path_model", f"expected one of {PATH_MODELS}, got {path_model!r}")
    fitted = water if path_model in (None, water.path_model) else dataclasses.replace(
        water, path_model=path_model)
    d = _dive(M0, sigma, setups, fitted, depth, distance, priors, geo, p_shared, p_indep,
              reduce=False, response=_response(uncertain), auxiliary=planned(auxiliary, water, {"chl": np.array([chl]),
                                                                 "cdom": np.array([cdom])}))
    prob = _problem(d, np.zeros(N, int))
    theta = _starts(d, prob, {"chl": np.full(N, float(chl)), "cdom": np.full(N, float(cdom))})
    objective = 0.0
    converged = True
    if fitted is not water:  # the other model's optimum on the noise-free photos
        theta, objective, converged = _solve(prob, theta, max_iter=PATH_FIT_MAX_ITER)
    H = evaluate(prob, np.zeros(1, np.int64), theta[None], True).H[0]
    # the covariance of C itself (not u): dC/du on C's row and column
    k, c = int(prob.layout["chl"][0]), int(prob.layout["cdom"][0])
    e0 = prob.models[0].e0
    at = {"chl": float(from_lm("chl", theta[k], e0)), "cdom": float(theta[c])}
    cov = covariance_from_information(H)
    scale = np.ones(H.shape[0])
    scale[k] = float(du_chain(at["chl"], e0))
    cov = cov * scale[:, None] * scale[None, :]
    params = {n: np.atleast_1d(np.asarray(v, float))
              for n, v in prob.params(np.zeros(1, np.int64), theta[None]).items()
              if n in COEFFICIENT_PARAMS}
    params.update({"chl": np.array([at["chl"]]), "cdom": np.array([at["cdom"]]),
                   "depth": np.array([np.median(depth)]),
                   "distance": np.array([np.median(distance)])})
    held = [None if n in ("depth", "distance") else n for n in prob.names]  # at the median
    qv, qsd = quantity_sd(fitted, params, cov, held)
    out = {**at, "objective": float(objective), "converged": converged, "n_photos": N,
           "quantities": {q: float(v[0]) for q, v in qv.items() if not is_optical_depth(q)},
           "quantity_sd": {q: float(v[0]) for q, v in qsd.items() if not is_optical_depth(q)}}
    if not np.all(np.isfinite(cov[[k, c]][:, [k, c]])):  # a direction the data do not determine
        return {**out, "chl_sd": np.inf, "cdom_sd": np.inf, "correlation": np.nan}
    sd_c, sd_a = float(np.sqrt(cov[k, k])), float(np.sqrt(cov[c, c]))
    return {**out, "chl_sd": sd_c, "cdom_sd": sd_a,
            "correlation": float(cov[k, c] / (sd_c * sd_a))}
