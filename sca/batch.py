"""Batched estimation: many charts at once, variable projection + Levenberg-Marquardt.

Solves the problem of :func:`sca.estimate` (eqs 15-18, one phytoplankton basis function, w on
eq 17 exactly) for N charts that share camera, illuminant, chart and grid (path lengths may
differ), for any free parameters (``free=``):

* **variable projection**: the backscatter s (and a free gain) are linear and have a closed
  form (:func:`sca.model.linear_part`), so the iteration is over the nonlinear parameters only,
  with Kaufman's exact projected Jacobian (:mod:`sca.lm`);
* C is iterated in u = C^e0 (eq 10's exponent): every C term is smooth at C = 0 in u;
* the start is the best point of a deterministic coarse grid over (C, a_CDOM), other free
  parameters at their given values;
* the 95 % profile-likelihood interval of every free parameter (:mod:`sca.intervals`).

Every prediction and Jacobian is :meth:`sca.model.ChartModel.predict`'s (for C, a_CDOM and the
path alone computed chart by chart from :meth:`forward.WaterTerms.optical_depth`'s pieces,
:func:`sca.lm.evaluate`). A chart that does not converge within ``max_iter`` is flagged
(``converged`` False, ``status`` says why).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field

import numpy as np
from scipy import special

from forward import validate
from forward.imaging import ChartSetup, resolve_setup
from forward.spectra import DEFAULT_CAMERA
from forward.water import Water, resolve_water

from .assess import (
    estimate_flag_table,
    flag_tuples,
    gain_wald,
    goodness,
    input_flag_table,
    profile_delta,
)
from .auxiliary import auxiliary_observations
from .consistency import finalize_batch, nuisance_pulls, objectives_alone
from .budget import prior_arrays, resolve_budget, variance_shares
from .fitspec import fit_spec
from .intervals import BOUND_FAILED, BOUND_FOUND, own_units, profile_intervals
from .limits import EXACT_FIT, MAX_RGB
from .charts import ChartProblem
from .lm import LM_MU_MIN, LM_TOL, STATUS, evaluate, levenberg_marquardt
from .lm import _step as lm_step
from .model import (
    CAMERA,
    CHL_DERIVATIVE_FLOOR,
    TINY,
    ChartModel,
    profiled_covariance,
)
from .parameters import default, lm_cap, to_lm
from .pathmodels import candidates, combine_batch, supported
from .projection import grid_best
from .derived import derived_from_fit, quantity_names, verdicts_of
from .quadrature import CERTIFY_SIGMA, reduction_error
from forward.errors import InputError

__all__ = [
    "CHUNK",
    "DEFAULT_ENGINE",
    "DEFAULT_QUADRATURE",
    "ENGINES",
    "QUADRATURES",
    "INIT_CDOM",
    "INIT_CHL",
    "STATUS",
    "BatchEstimate",
    "estimate_batch",
    "scale_test",
    "start_grid",
]

#: Coarse start grid of the batch (C in mg m^-3, a_CDOM in m^-1).
INIT_CHL = np.concatenate([[0.0], np.logspace(-3, 2, 8)])
INIT_CDOM = np.concatenate([[0.0], np.logspace(-3, np.log10(3.0), 6)])
#: Charts per chunk (bounds the memory of the start-grid search and of one iteration).
CHUNK = 65536
#: Values per block of the free-gain start search (charts x grid points x m n).
START_BLOCK = 2_000_000
#: The engine: the model function's columns and the compiled, physics-free variable projection
#: (:mod:`sca.projection`).
ENGINES = ("numba",)
DEFAULT_ENGINE = "numba"
#: ``quadrature=``: eq 1's integral on the certified 5 nm quadrature (:mod:`sca.quadrature`),
#: or on the grid as given.
QUADRATURES = ("reduced", "full")
DEFAULT_QUADRATURE = "reduced"


@dataclass
class BatchEstimate:
    """Arrays (length N) of the fields of :class:`sca.Estimate` (intervals (N, 2)).

    ``values`` and ``intervals`` are dicts keyed by the name of every free parameter (C and
    a_CDOM included): (N,) estimates and (N, 2) 95 % profile-likelihood intervals (Wald for the
    gain). ``len()`` is N.

    Attributes
    ----------
    chl : ndarray, (N,)
        C, mg m^-3 (the held value where fixed).
    cdom : ndarray, (N,)
        a_CDOM(440), m^-1 (the held value where fixed).
    chl_ci : ndarray, (N, 2)
        95 % profile-likelihood intervals of C, mg m^-3 (inf: open; (C, C) where fixed; NaN
        with ``intervals=False`` or where the search failed).
    cdom_ci : ndarray, (N, 2)
        The same for a_CDOM(440), m^-1.
    reliable : ndarray of bool, (N,)
        True where no flag of :data:`sca.assess.BLOCKING` is raised.
    flags : list of tuple of str
        N tuples of flag names (:mod:`sca.assess`).
    fit_rms : ndarray, (N,)
        ||M - gain G - s 1^T|| / ||M||.
    chi2_dof : ndarray, (N,)
        Reduced chi^2 (NaN where the noise is unknown).
    chi2_p : ndarray, (N,)
        Its p-value (NaN where the noise is unknown).
    dof : ndarray of int, (N,)
        m n - (free nonlinear parameters) - (active s channels) - (1 for a free gain).
    noise_known : bool
        ``sigma`` was given.
    w : ndarray, (N, 1)
        The phytoplankton weight of eq 9 on eq 17 (one basis function).
    backscatter : ndarray, (N, m)
        s, units of the measurements.
    gain : ndarray, (N,)
        The unknown exposure of M = gain G + s (gain="free"), units of the measurements per
        model unit; ones where it is known.
    gain_ci : ndarray, (N, 2)
        95 % Wald interval of the gain (its Gauss-Newton standard error), clipped at 0; the
        gain itself (both ends) where it is known.
    attenuation : ndarray, (N, q)
        k = exp(-(depth + distance) c) at the estimates.
    wavelengths : ndarray, (q,)
        The grid, nm.
    objective : ndarray, (N,)
        chi^2 (noise known) or ||M - gain G - s 1^T||^2 in data units squared.
    iterations : ndarray of int, (N,)
        Levenberg-Marquardt iterations.
    converged : ndarray of bool, (N,)
        Status codes 0-2 (:data:`sca.lm.STATUS`).
    status : ndarray of str, (N,)
        Why each chart stopped (:data:`sca.lm.STATUS`).
    status_code : ndarray of int, (N,)
        The codes of ``status``.
    elapsed_s : float
        Wall-clock time of the call, s.
    values : dict
        Every free parameter's (N,) estimates, by name, in its own units.
    intervals : dict
        Every free parameter's (N, 2) 95 % intervals, by name (profile likelihood; Wald for
        the gain; NaN with ``intervals=False``).
    """

    chl: np.ndarray
    cdom: np.ndarray
    chl_ci: np.ndarray  # (N, 2) 95 % profile-likelihood intervals, mg m^-3 (inf: open)
    cdom_ci: np.ndarray  # (N, 2) m^-1
    reliable: np.ndarray  # (N,) bool
    flags: list  # N tuples of flag names (sca.assess)
    fit_rms: np.ndarray  # ||M - G - s|| / ||M||
    chi2_dof: np.ndarray  # reduced chi^2 (NaN where the noise is unknown)
    chi2_p: np.ndarray
    dof: np.ndarray
    noise_known: bool
    w: np.ndarray  # (N, 1)
    backscatter: np.ndarray  # (N, m)
    #: (N,) the unknown exposure M = gain G + s (gain="free"); ones where it is known
    gain: np.ndarray
    #: (N, 2) 95 % Wald interval of the gain (its Gauss-Newton standard error); the gain itself
    #: where it is known
    gain_ci: np.ndarray
    attenuation: np.ndarray  # (N, q)
    wavelengths: np.ndarray
    objective: np.ndarray  # chi^2 (noise known) or ||M - G - s||^2 in data units
    iterations: np.ndarray
    converged: np.ndarray
    status: np.ndarray  # strings
    status_code: np.ndarray
    elapsed_s: float
    values: dict = field(default_factory=dict)
    intervals: dict = field(default_factory=dict)
    #: the uncertainty budget applied: name -> sd as given (:mod:`sca.budget`); {} for the
    #: paper's exact model or where it could not be applied (noise unknown)
    uncertain: dict = field(default_factory=dict)
    #: each source's share of the variance of C and a_CDOM: {'chl': {'sd': (N,), 'shares':
    #: {source: (N,)}}, 'cdom': ...} (:func:`sca.budget.variance_shares`); {} without a budget
    budget: dict = field(default_factory=dict)
    #: (N,) the path model of each chart's estimate (:mod:`sca.pathmodels`)
    path_model: np.ndarray | None = None
    #: N tuples: the path models the data support (more than one: the intervals span them)
    path_models: list = field(default_factory=list)
    #: path model -> (N,) objective of each chart under it
    path_objective: dict = field(default_factory=dict)
    #: what the photos measure (:mod:`sca.derived`): name -> (N,) value of every derived
    #: quantity (the path's attenuation coefficient c at 443, 490, 555, 670 nm and a_nw(440);
    #: m^-1)
    quantities: dict = field(default_factory=dict)
    #: name -> (N, 2) their 95 % intervals (spanning the supported path models)
    quantity_intervals: dict = field(default_factory=dict)
    #: (N, q) the attenuation coefficient of the light's path, tau / (depth + distance), on
    #: ``wavelengths``, m^-1 (the beam attenuation c = a + b for the paper's path model)
    beam_attenuation: np.ndarray | None = None
    #: (N, q, 2) its 95 % interval at every wavelength
    beam_attenuation_ci: np.ndarray | None = None
    #: name -> (N,) verdict of 'chl', 'cdom' and every quantity: 'measured', 'loosely
    #: measured', 'upper bound' or 'not constrained' (:func:`sca.derived.verdict`)
    verdicts: dict = field(default_factory=dict)
    #: the readings and priors tested against the photos (:mod:`sca.consistency`):
    #: {'readings': {name: {'delta_chi2': (N,), 'p': (N,), 'conflict': (N,)}}, 'pulls':
    #: {nuisance: (N,) pull in its prior's sds}, 'pull_max', 'conflict_p'}
    consistency: dict = field(default_factory=dict)

    def __len__(self):
        return self.chl.size


def _sigma_stack(sigma, N, m, n):
    """``sigma`` (scalar, (m, n) or (N, m, n), data units) as (N, m, n), or None; every value
    real, finite and at least 1e-100 (the charts at fault named)."""
    if sigma is None:
        return None
    arr = validate.array("sigma", sigma)
    try:
        arr = np.broadcast_to(arr, (N, m, n)) if arr.ndim in (0, 2, 3) else None
    except ValueError:
        arr = None
    if arr is None:
        raise InputError("sigma", f"expected a scalar, (m, n) = ({m}, {n}) or (N, m, n) = "
                         f"({N}, {m}, {n}) array, got shape {np.shape(sigma)}")
    if np.any(arr <= 0):
        raise InputError("sigma", f"standard deviations must be > 0 (min {arr.min():g}; "
                         f"{_charts(np.any(arr <= 0, axis=(1, 2)))})")
    if np.any(arr < 1e-100):
        raise InputError("sigma", f"standard deviations down to {arr.min():g} are too small for "
                         f"the solver (below 1e-100 their squares underflow; "
                         f"{_charts(np.any(arr < 1e-100, axis=(1, 2)))}); rescale the values "
                         "and their sds together")
    return arr


def _charts(bad) -> str:
    """'chart 3' / 'charts 3, 7, ...' (0-based indices) of a boolean (N,) mask."""
    idx = np.flatnonzero(bad)
    more = ", ..." if idx.size > 5 else ""
    return (f"chart{'s' if idx.size > 1 else ''} "
            + ", ".join(str(i) for i in idx[:5]) + more + " (0-based)")


def _per_chart(name, value, N):
    """A scalar or (N,) value (a length in m, or a level in data units) as (N,), or
    ``ValueError`` naming it (and the charts at fault)."""
    validate.real(name, value)
    try:
        raw = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(name, f"expected a number or {N} numbers, got {value!r}") from None
    if raw.ndim > 1 or (raw.ndim == 1 and raw.size not in (1, N)):
        raise InputError(name, f"expected a scalar or {N} values (one per chart), got "
                         f"{raw.size if raw.ndim == 1 else 'shape ' + str(raw.shape)}")
    arr = np.broadcast_to(raw.reshape(-1) if raw.ndim else raw, (N,)).astype(float)
    bad = ~np.isfinite(arr) | (arr < 0)
    if bad.any():
        raise InputError(name, f"must be finite and >= 0 (got {arr[bad][0]!r} at "
                         f"{_charts(bad)})")
    return arr


def estimate_batch(rgb_stack, *, depth, distance, sigma=None, saturation=None,
                   camera=DEFAULT_CAMERA, illuminant=None, reflectances=None, wavelengths=None,
                   basis=None, water: Water | None = None, path_model: str | None = None,
                   cdom_slope: float | None = None, fix=None, free=(), intervals: bool = True,
                   max_iter: int = 100, tol: float = LM_TOL, setup: ChartSetup | None = None,
                   engine: str = DEFAULT_ENGINE, gain: str = "known",
                   uncertain=None, path_models=None,
                   quadrature: str = DEFAULT_QUADRATURE, auxiliary=None) -> BatchEstimate:
    """Estimate the water of a stack of charts ``rgb_stack`` (N, m, n).

    Parameters
    ----------
    rgb_stack : array_like, (N, m, n)
        Patch values, model units (``gain='known'``) or any units (``gain='free'``).
    depth, distance : float or (N,) array, m
        The path of each chart (keyword-only).
    sigma : float, (m, n) or (N, m, n), optional
        Standard deviation of each value (data units): the fit is then weighted least squares
        and its chi^2 tested; without it no chart is ``reliable`` (flag ``noise-unknown``).
    saturation : float or (N,), optional
        The sensor's clip level in data units, for the ``saturated`` check.
    camera, illuminant, reflectances, wavelengths, basis, setup :
        As :func:`forward.simulate_chart`.
    water : forward.Water, optional
        The water model (default the paper's); ``path_model`` and ``cdom_slope`` replace those
        fields.
    fix : dict, optional
        Held values: 'chl', 'cdom', 'backscatter' (scalar or (m,)) or a forward.Water
        coefficient.
    free : sequence of str
        Parameters estimated besides C and a_CDOM: any forward.Water coefficient (e.g.
        'cdom_slope'), 'depth', 'distance', or 'gain'.
    intervals : bool
        Compute the 95 % profile-likelihood intervals (without them nothing is reliable).
    max_iter : int
        Levenberg-Marquardt iteration limit.
    tol : float
        Relative decrease at which a chart stops.
    engine : {'numba'}
        The one engine: the model function's columns projected by compiled code
        (:mod:`sca.projection`).
    gain : {'known', 'free'}
        'free': M = gain G + s with one unknown gain per chart (a photograph's exposure).
    uncertain : dict, optional
        The uncertainty budget, name -> sd (:mod:`sca.budget`): nuisance parameters with
        Gaussian priors ('depth', 'distance', Water constants, 'balance') and the per-patch
        systematic term ('patch'). Default (None): :data:`sca.budget.DEFAULT_UNCERTAIN`;
        ``{}``: the paper's exact model. Applied only with ``sigma``.
    path_models : sequence of str, optional
        The path models fitted (:mod:`sca.pathmodels`): each chart's is chosen by likelihood
        ratio, and where several fit about equally well its intervals span them (flag
        ``path-model-span``). Default: all of :data:`forward.water.PATH_MODELS` where a budget
        applies, else only the water's.
    quadrature : {'reduced', 'full'}
        'reduced' (default): eq 1's integral on the certified 5 nm quadrature
        (:mod:`sca.quadrature`) where the grid is fine, every chart's optimum checked against
        the full grid and refitted on it where they differ by more than
        :data:`sca.quadrature.CERTIFY_SIGMA` of a value's noise; 'full': the grid as given.
    auxiliary : dict, optional
        What was measured besides the photos (:func:`sca.auxiliary.auxiliary_observations`:
        'cdom' (value, sd) m^-1, 'secchi' (depth, sd) m, 'kd' {nm: (value, sd)} m^-1; values
        and sds scalars or (N,), NaN where a chart has none), fused in every fit (needs
        ``sigma``).

    Returns
    -------
    BatchEstimate

    Notes
    -----
    Safe to call from several threads (no shared mutable state).

    References
    ----------
    Blasinski & Farrell, eqs 15-18; L. Kaufman, BIT 15 (1975) 49-57 (variable projection);
    D. W. Marquardt, J. SIAM 11 (1963) 431-441 (Levenberg-Marquardt); D. J. Venzon &
    S. H. Moolgavkar, Applied Statistics 37 (1988) 87-94 (profile-likelihood intervals).

    Examples
    --------
    >>> import numpy as np, forward, sca
    >>> sims = [forward.simulate_chart(c, 0.1, depth=5, distance=1, seed=s)
    ...         for s, c in enumerate([0.5, 2.0])]
    >>> rgb = np.stack([s.rgb for s in sims])
    >>> sigma = np.stack([s.rgb_sigma for s in sims])
    >>> est = sca.estimate_batch(rgb, depth=5, distance=1, sigma=sigma)
    >>> est.chl.shape, est.verdicts["c_490"].tolist()
    ((2,), ['measured', 'measured'])
    """
    t0 = time.perf_counter()
    water = resolve_water(water, path_model=path_model, cdom_slope=cdom_slope)
    exact = resolve_budget(uncertain, depth=1.0, distance=1.0, water=water).exact
    models = candidates(path_models, water, sigma is not None and not exact)
    kw = {"depth": depth, "distance": distance, "sigma": sigma, "saturation": saturation,
          "camera": camera, "illuminant": illuminant, "reflectances": reflectances,
          "wavelengths": wavelengths, "basis": basis, "fix": fix, "free": free,
          "intervals": intervals, "max_iter": max_iter, "tol": tol, "setup": setup,
          "engine": engine, "gain": gain, "uncertain": uncertain, "quadrature": quadrature,
          "auxiliary": auxiliary}
    if auxiliary and sigma is None:
        raise InputError("auxiliary", "needs the photos' noise (sigma) to weigh against")
    if quadrature not in QUADRATURES:
        raise InputError("quadrature", f"must be one of {QUADRATURES}, got {quadrature!r}")
    if len(models) == 1:
        out = _estimate_batch(rgb_stack, water=water, **kw)
        out.consistency, table = finalize_batch([out], np.zeros(len(out), int))
    elif _no_chart(rgb_stack):  # nothing to pass twice
        results = {m: _estimate_batch(rgb_stack, water=dataclasses.replace(water, path_model=m),
                                      **kw) for m in models}
        out = combine_batch(results)
        out.consistency, table = finalize_batch(list(results.values()), np.zeros(0, int))
    else:
        out, results = _over_path_models(rgb_stack, water, models, kw)
        best = np.array([models.index(m) for m in out.path_model], int)
        out.consistency, table = finalize_batch(list(results.values()), best)
    out.flags, out.reliable = _with_flags(out.flags, out.reliable, table)
    out.elapsed_s = time.perf_counter() - t0
    return out


def _no_chart(rgb_stack) -> bool:
    """An empty stack of charts (a malformed one is left to :func:`_estimate_batch`'s
    refusal)."""
    try:
        return len(rgb_stack) == 0
    except TypeError:
        return False


def _over_path_models(rgb_stack, water, models, kw):
    """The candidates' estimates combined (:func:`sca.pathmodels.combine_batch`) in two passes:
    every chart fitted under every model; then each model's intervals, derived quantities and
    tests only on the charts where it is supported, its known gain's test only where it is the
    chosen one (an unsupported model's are never read: the same result, less work)."""
    waters = {m: dataclasses.replace(water, path_model=m) for m in models}
    first = {m: _estimate_batch(rgb_stack, water=waters[m], plan=_Plan(fit_only=True), **kw)
             for m in models}
    objective = np.column_stack([first[m]["objective"] for m in models])
    best, ok = supported(objective)
    results = {}
    for j in np.argsort(-ok.sum(axis=0), kind="stable"):  # a supported model first
        m, rows = models[j], np.flatnonzero(ok[:, j])
        if rows.size:
            plan = _Plan(False, first[m]["theta"][rows], best[rows] == j,
                         *(first[m][k][rows] for k in ("it", "code", "full", "quadrature")))
            est = _estimate_batch(rgb_stack, water=waters[m], subset=rows, plan=plan, **kw)
        else:  # supported nowhere: a blank of the layout (never read)
            est = _scatter(next(iter(results.values())), (), ok.shape[0])
            est.path_model = np.full(ok.shape[0], m)
        est.objective = first[m]["objective"]  # the support decided on the first pass's
        est.consistency["alone"] = first[m]["alone"]
        results[m] = est
    results = {m: results[m] for m in models}  # the water's own model first, as given
    return combine_batch(results), results


def _with_flags(flags, reliable, table):
    """Per-chart flags with the raised ones of ``table`` (blocking) appended, and reliable."""
    raised = np.column_stack([np.asarray(v, bool) for v in table.values()]) if table else None
    if raised is None or not raised.any():
        return flags, reliable
    names = list(table)
    out = [tuple(dict.fromkeys(tuple(f) + tuple(n for j, n in enumerate(names) if raised[i, j])))
           for i, f in enumerate(flags)]
    return out, np.asarray(reliable, bool) & ~raised.any(axis=1)


def _estimate_batch(rgb_stack, *, depth, distance, sigma, saturation, camera, illuminant,
                    reflectances, wavelengths, basis, water, fix, free, intervals, max_iter, tol,
                    setup, engine, gain, uncertain, quadrature, auxiliary, subset=None,
                    plan=None):
    """:func:`estimate_batch` under one path model (``water``'s); ``subset`` (index array):
    only those charts, the others filled in (:func:`_scatter`); ``plan``: :class:`_Plan` of
    those charts (the first pass returns {'objective', 'theta', 'alone'} only)."""
    t0 = time.perf_counter()
    setup = resolve_setup(setup, camera, illuminant, reflectances, wavelengths)
    validate.real("rgb_stack", rgb_stack)
    try:
        M = np.asarray(rgb_stack, dtype=float)
    except (TypeError, ValueError):
        raise InputError("rgb_stack", "expected a numeric (N, m, n) array") from None
    m_, n_ = setup.sensitivities.shape[1], setup.reflectances.shape[1]
    if M.ndim != 3 or M.shape[1:] != (m_, n_):
        raise InputError("rgb_stack", f"expected shape (N, {m_}, {n_}), got {M.shape}")
    N = M.shape[0]
    flat = M.reshape(N, m_ * n_)  # N = 0 too
    for bad, what in ((~np.all(np.isfinite(flat), axis=1), "NaN or infinite values"),
                      (np.any(flat < 0, axis=1), "negative values")):
        if bad.any():
            raise InputError("rgb_stack", f"{what} in {_charts(bad)}")
    scale = flat.max(axis=1) if N else np.zeros(0)
    if np.any(scale > MAX_RGB):
        raise InputError("rgb_stack", f"values up to {M.max():g} exceed {MAX_RGB:g} "
                         f"({_charts(scale > MAX_RGB)}); measurements in model units are O(1) "
                         "(a white reflector in air = 1)")
    if np.any(scale <= 0):
        raise InputError("rgb_stack", f"every value is zero in {_charts(scale <= 0)}")
    if np.any(scale < 1e-100):
        raise InputError("rgb_stack", f"values too small for the solver in "
                         f"{_charts(scale < 1e-100)} (below 1e-100 their squares underflow); "
                         "rescale them (with gain='free' any unit will do)")
    spec = fit_spec(free, fix, gain, water, m_)
    mdl = ChartModel(setup, basis=basis, water=spec.water)
    if mdl.z != 1:
        raise InputError("basis", f"the batched solver supports one basis function (z = 1), got z = {mdl.z}")
    sig = _sigma_stack(sigma, N, m_, n_)
    sat = None if saturation is None else _per_chart("saturation", saturation, N)
    geometry = {"depth": _per_chart("depth", depth, N),
                "distance": _per_chart("distance", distance, N)}
    if int(max_iter) != max_iter or max_iter < 1:
        raise InputError("max_iter", f"must be a positive integer, got {max_iter!r}")
    tol = validate.scalar("tol", tol, positive=True)
    if engine not in ENGINES:
        raise InputError("engine", f"must be one of {ENGINES}, got {engine!r}")
    budget = resolve_budget(uncertain, depth=geometry["depth"], distance=geometry["distance"],
                            water=spec.water, free=spec.names, fixed=tuple(fix or {}))
    if sig is None or budget.exact:
        budget = None  # the paper's exact model (or no noise to weigh a budget against)

    obs = [o.rows(np.arange(N)) for o in auxiliary_observations(auxiliary, spec.water)]
    for o in obs:
        o.value, o.sd = np.broadcast_to(o.value, (N,)), np.broadcast_to(o.sd, (N,))
    n_all = N
    if subset is not None:  # the second pass: the charts this path model is supported on
        subset = np.asarray(subset, np.int64)
        M, scale, N = M[subset], scale[subset], subset.size
        sig, sat = (None if a is None else a[subset] for a in (sig, sat))
        geometry = {k: v[subset] for k, v in geometry.items()}
        budget = None if budget is None else budget.rows(subset)
        obs = [o.rows(subset) for o in obs]
    step = CHUNK

    def rows(a, i):
        return None if a is None else a[i:i + step]

    def part(i):
        sub = None if budget is None else budget.rows(slice(i, i + step))
        return _solve_certified(mdl if sub is None else sub.model(mdl), spec, M[i:i + step],
                                rows(sig, i), {k: v[i:i + step] for k, v in geometry.items()},
                                scale[i:i + step], int(max_iter), tol, bool(intervals), sub,
                                quadrature == "reduced", [o.rows(slice(i, i + step)) for o in obs],
                                None if plan is None else plan.rows(slice(i, i + step)))
    parts = [part(i) for i in range(0, N, step)] or [_empty(mdl, spec)]
    if plan is not None and plan.fit_only:
        return _first_pass(parts, 1.0 if sig is not None else scale ** 2)
    out = {key: np.concatenate([p[key] for p in parts]) for key in parts[0]
           if key not in ("values", "intervals", "budget")}
    values = {k: np.concatenate([p["values"][k] for p in parts]) for k in parts[0]["values"]}
    ints = {k: np.concatenate([p["intervals"][k] for p in parts]) for k in parts[0]["intervals"]}
    shares = _concatenate_budgets([p["budget"] for p in parts])
    code = out["code"]
    converged = code <= 2
    chl = values.get("chl", np.full(N, spec.fixed.get("chl", np.nan)))
    cdom = values.get("cdom", np.full(N, spec.fixed.get("cdom", np.nan)))
    noise_known = sig is not None
    nan2 = np.full((N, 2), np.nan)
    chl_ci = ints.get("chl", np.column_stack([chl, chl]) if "chl" in spec.fixed else nan2)
    cdom_ci = ints.get("cdom", np.column_stack([cdom, cdom]) if "cdom" in spec.fixed else nan2)
    flags, reliable = flag_tuples(
        input_flag_table(M, sig, sat),
        estimate_flag_table(converged=converged, noise_known=noise_known, p_value=out["chi2_p"],
                            chl=chl, cdom=cdom, chl_ci=chl_ci, cdom_ci=cdom_ci,
                            ci_codes=out["ci_codes"] if intervals else None,
                            free_chl="chl" in spec.names, free_cdom="cdom" in spec.names,
                            scale_p=None if spec.free_gain or not noise_known
                            else out["scale_p"]))
    w = (mdl.water.phytoplankton_440(chl) / float(mdl.t440[0]))[:, None]
    objective = out["f"] * (1.0 if noise_known else scale**2)
    if spec.free_gain:
        values["gain"] = out["gain"]
        ints["gain"] = out["gain_ci"]
    quantities = {k[2:]: out[k] for k in out if k.startswith("q:")}
    quantity_intervals = {k[4:]: out[k] for k in out if k.startswith("qci:")}
    out = BatchEstimate(
        chl=chl, cdom=cdom, chl_ci=chl_ci, cdom_ci=cdom_ci, reliable=reliable,
        flags=flags, fit_rms=out["fit_rms"], chi2_dof=out["chi2_dof"], chi2_p=out["chi2_p"],
        dof=out["dof"], noise_known=noise_known, w=w,
        backscatter=out["s"] * scale[:, None], gain=out["gain"], gain_ci=out["gain_ci"],
        attenuation=out["k"], wavelengths=mdl.wavelengths,
        objective=objective, iterations=out["it"], converged=converged,
        status=np.array([STATUS[c] for c in code]), status_code=code,
        elapsed_s=time.perf_counter() - t0, values=values, intervals=ints,
        uncertain={} if budget is None else dict(budget.sd), budget=shares,
        path_model=np.full(N, water.path_model), path_models=[(water.path_model,)] * N,
        path_objective={water.path_model: objective}, quantities=quantities,
        quantity_intervals=quantity_intervals, beam_attenuation=out["c"],
        beam_attenuation_ci=out["c_ci"],
        verdicts=verdicts_of(chl_ci, cdom_ci, quantity_intervals),
        consistency={kind: {k.split(":", 1)[1]: out[k] for k in out if k.startswith(f"{key}:")}
                     for kind, key in (("alone", "alone"), ("pulls", "pull"))},
    )
    return out if subset is None else _scatter(out, subset, n_all)


@dataclass
class _Plan:
    """What one path model's pass does with a chunk of charts (:func:`estimate_batch`): the
    first pass fits every chart (``fit_only``); the second starts at the first's optimum
    (``start``, LM coordinates) on the charts the model is supported on, and runs the known
    gain's test where it is the chart's chosen model (``chosen``)."""

    fit_only: bool = False
    start: np.ndarray | None = None  # (N, p) the first pass's optimum, LM coordinates
    chosen: np.ndarray | None = None  # (N,) bool
    it: np.ndarray | None = None  # (N,) the first pass's iterations
    code: np.ndarray | None = None  # (N,) and status codes
    full: np.ndarray | None = None  # (N,) bool: the first pass fitted on the full grid
    quadrature: np.ndarray | None = None  # (N,) its largest reduction error

    def rows(self, idx) -> "_Plan":
        return _Plan(self.fit_only, *(None if a is None else a[idx] for a in (
            self.start, self.chosen, self.it, self.code, self.full, self.quadrature)))


def _first_pass(parts, unit) -> dict:
    """The first pass's result: 'objective' (N,) in data units (``unit``: 1 where the noise is
    known, else scale^2), 'theta' (N, p), 'alone' {reading: (N,)} (:mod:`sca.consistency`)."""
    out = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]
           if k in ("f", "theta", "it", "code", "full", "quadrature") or k.startswith("alone:")}
    first = {k: out[k] for k in ("theta", "it", "code", "full", "quadrature")}
    first["objective"] = out["f"] * unit
    first["alone"] = {k.split(":", 1)[1]: v for k, v in out.items() if k.startswith("alone:")}
    return first


def _filled(a, rows, n):
    """``a`` (k, ...) placed at ``rows`` of an (n, ...) array, the rest NaN (False, 0, '')."""
    a = np.asarray(a)
    fill = {"f": np.nan, "b": False, "i": 0, "u": 0}.get(a.dtype.kind, "")
    out = np.full((n,) + a.shape[1:], fill, dtype=a.dtype if a.dtype.kind != "f" else float)
    out[rows] = a
    return out


def _scatter(est: "BatchEstimate", rows, n) -> "BatchEstimate":
    """``est`` of charts ``rows`` as an estimate of all n charts (the others NaN: never read,
    :func:`sca.pathmodels.combine_batch` takes a model only where it is supported); with
    ``rows`` empty, ``est`` (of any charts) gives the layout of a blank estimate."""
    k = len(est)
    rows = np.asarray(rows, np.int64)

    def place(v):
        if isinstance(v, dict):
            return {key: place(x) for key, x in v.items()}
        if isinstance(v, np.ndarray) and v.ndim and v.shape[0] == k:
            return _filled(v[:rows.size], rows, n)
        if isinstance(v, list) and len(v) == k:
            out = [()] * n
            for i, r in enumerate(rows):
                out[r] = v[i]
            return out
        return v
    fields = {f.name: getattr(est, f.name) for f in dataclasses.fields(est)}
    return BatchEstimate(**{name: (v if name == "wavelengths" else place(v))
                            for name, v in fields.items()})

def _concatenate_budgets(parts):
    """One budget dict from the chunks' (:func:`sca.budget.variance_shares` layout)."""
    if not parts or not parts[0]:
        return {}
    out = {}
    for name in parts[0]:
        out[name] = {"sd": np.concatenate([p[name]["sd"] for p in parts]),
                     "shares": {k: np.concatenate([p[name]["shares"][k] for p in parts])
                                for k in parts[0][name]["shares"]}}
    return out


def _empty(mdl, spec):
    z = np.zeros(0)
    names = spec.names
    return {"code": np.zeros(0, int), "f": z, "s": np.zeros((0, mdl.m)),
            "k": np.zeros((0, mdl.wavelengths.size)), "it": np.zeros(0, int), "gain": z,
            "fit_rms": z, "dof": np.zeros(0, int), "chi2_dof": z, "chi2_p": z,
            "gain_ci": np.zeros((0, 2)), "ci_codes": np.zeros((0, 4), int),
            "values": {n: z for n in names}, "intervals": {n: np.zeros((0, 2)) for n in names},
            "budget": {}, "quadrature": z, "ssr": z, "scale_p": z,
            "c": np.zeros((0, mdl.full.wavelengths.size)),
            "c_ci": np.zeros((0, mdl.full.wavelengths.size, 2)),
            **{f"q:{k}": z for k in quantity_names()},
            **{f"qci:{k}": np.zeros((0, 2)) for k in quantity_names()}}


def make_problem(mdl, spec, M, sig, geometry, scale, budget=None,
                 observations=()) -> ChartProblem:
    """The scaled :class:`sca.charts.ChartProblem` of charts ``M`` (N, m, n) (data units); with a
    ``budget`` (:class:`sca.budget.Budget` of these charts) its nuisance parameters follow the
    free names, with their Gaussian priors, and ``sig`` includes the per-patch term."""
    N = M.shape[0]
    Ms = np.ascontiguousarray((M / scale[:, None, None]).reshape(N, -1))  # every chart max 1
    W2 = np.ones_like(Ms) if sig is None else np.ascontiguousarray(
        (scale[:, None] / sig.reshape(N, -1)) ** 2)
    names = tuple(spec.names)
    mean = weight = None
    if budget is not None and budget.priors:
        extra = [n for n in budget.priors for _ in range(mdl.m if n in CAMERA else 1)]
        names = names + tuple(extra)
        mean, weight = prior_arrays(budget.priors, names, N)
    fixed = dict(geometry, **({} if budget is None else budget.fixed_params()))
    for k in ("chl", "cdom"):
        if k in spec.fixed:
            fixed[k] = np.full(N, spec.fixed[k])
    fixed = {k: v for k, v in fixed.items() if k not in names}
    fs = None if spec.free_s else np.ascontiguousarray(
        spec.fixed["backscatter"][None, :] / scale[:, None])
    return ChartProblem(mdl, Ms, W2, np.ascontiguousarray(scale), names, fixed,
                        spec.free_gain, fs, mean, weight, observations)


def start_values(prob: ChartProblem, geometry) -> np.ndarray:
    """(N, p) start in LM coordinates: the start grid's (C, a_CDOM), every other free parameter
    at its given value (geometry) or the water's constant."""
    N = prob.size
    theta = np.empty((N, len(prob.names)))
    C0, A0 = start_grid(prob, geometry)
    given = {"chl": C0, "cdom": A0, **geometry}
    water, e0 = prob.model.water, prob.model.e0
    for j, name in enumerate(prob.names):  # the parameter table's defaults and coordinates
        if name not in given and prob.prior_mean is not None and np.any(prob.prior_weight[:, j] > 0):
            theta[:, j] = prob.prior_mean[:, j]  # a nuisance at its prior's centre
        else:
            theta[:, j] = to_lm(name, given[name] if name in given else default(name, water), e0)
    return theta


def start_grid(prob: ChartProblem, geometry):
    """The best (C, a_CDOM) of the coarse grid for every chart: gain and s in closed form with
    each channel's mean weight (:func:`sca.projection.grid_best`), one matrix of signals per
    distinct path length.

    The grid is :data:`INIT_CHL` x :data:`INIT_CDOM` (a held C or a_CDOM replaces its axis by
    its value); other parameters are at the water's constants.

    Parameters
    ----------
    prob : sca.charts.ChartProblem
        The charts (scaled units).
    geometry : dict
        'depth' and 'distance', (N,) each, m.

    Returns
    -------
    chl : ndarray, (N,)
        The best C of each chart, mg m^-3 (not the LM coordinate u).
    cdom : ndarray, (N,)
        The best a_CDOM(440) of each chart, m^-1.
    """
    mdl, N = prob.model, prob.size
    m, n = mdl.m, mdl.n
    chl_grid = INIT_CHL if "chl" in prob.names else prob.fixed["chl"][:1]
    cdom_grid = INIT_CDOM if "cdom" in prob.names else prob.fixed["cdom"][:1]
    C, A = (x.ravel() for x in np.meshgrid(chl_grid, cdom_grid, indexing="ij"))
    P = C.size
    L = geometry["depth"] + geometry["distance"]
    M3 = prob.M.reshape(N, m, n)
    wc = prob.W2.reshape(N, m, n).mean(axis=2)  # (N, m)
    best = np.zeros(N, dtype=int)
    uniq, inv = np.unique(L, return_inverse=True)
    block = max(1, START_BLOCK // (P * m))
    for u_idx, Lu in enumerate(uniq):
        rows = np.flatnonzero(inv == u_idx)
        G = mdl.predict({"chl": C, "cdom": A, "depth": Lu, "distance": 0.0},
                        jacobian=False).signal.reshape(P, m, n)
        own = prob.fixed.get("response")  # each chart's measured response: its own grid
        for lo in range(0, rows.size, 1 if own is not None else block):
            r = rows[lo:lo + (1 if own is not None else block)]
            best[r] = grid_best(M3[r], wc[r], prob.scale[r],
                                G if own is None else G * own[r[0]].reshape(m, n),
                                None if prob.fixed_s is None else prob.fixed_s[r],
                                prob.free_gain)
    return C[best].copy(), A[best].copy()


def _solve_certified(mdl, spec, M, sig, geometry, scale, max_iter, tol, intervals, budget,
                     reduce: bool, observations=(), plan=None):
    """:func:`_solve_chunk` on the model's certified quadrature (``reduce``, where its grid is
    reduced), each optimum checked against the full grid (:func:`sca.quadrature.reduction_error`
    in units of the sensor's noise) and the charts where they differ by more than
    :data:`sca.quadrature.CERTIFY_SIGMA` solved again on the full grid; the attenuation k of
    every chart on the full grid. Adds 'quadrature' (N,): the largest reduction error at the
    optimum (0 where the full grid was used)."""
    small = mdl.reduced() if reduce else mdl
    res = _solve_chunk(small, spec, M, sig, geometry, scale, max_iter, tol, intervals, budget,
                       observations, plan)
    N = M.shape[0]
    params = _solution_params(res, geometry, spec, scale, budget)
    res["quadrature"] = np.zeros(N)
    res["full"] = np.zeros(N, bool)
    if plan is not None and plan.full is not None:  # the second pass: the first's grids
        res["quadrature"] = plan.quadrature.copy()
        bad = np.flatnonzero(plan.full)
        if bad.size:
            redo = _solve_chunk(mdl, spec, M[bad], None if sig is None else sig[bad],
                                {k: v[bad] for k, v in geometry.items()}, scale[bad], max_iter,
                                tol, intervals, None if budget is None else budget.rows(bad),
                                [o.rows(bad) for o in observations], plan.rows(bad))
            _replace_rows(res, redo, bad)
            params = _solution_params(res, geometry, spec, scale, budget)
        res["full"] = plan.full.copy()
        res["k"] = mdl.predict(params, jacobian=False).attenuation
        return res
    if small is not mdl:
        # the sensor's noise, or the noise the residual shows where that is smaller (a fit far
        # better than its noise, or an exact one, is held to its own residual: the full grid)
        shown = (np.sqrt(res["ssr"] / M[0].size) * scale)[:, None]
        noise = shown if sig is None else np.minimum(sig.reshape(N, -1), shown)
        err = reduction_error(mdl, small, params, noise)
        res["quadrature"] = err
        bad = np.flatnonzero(~(err <= CERTIFY_SIGMA))
        if bad.size:
            redo = _solve_chunk(mdl, spec, M[bad], None if sig is None else sig[bad],
                                {k: v[bad] for k, v in geometry.items()}, scale[bad], max_iter,
                                tol, intervals, None if budget is None else budget.rows(bad),
                                [o.rows(bad) for o in observations],
                                None if plan is None else plan.rows(bad))
            _replace_rows(res, redo, bad)
            res["quadrature"][bad] = 0.0
            res["full"][bad] = True
            params = _solution_params(res, geometry, spec, scale, budget)
        if plan is None or not plan.fit_only:
            res["k"] = mdl.predict(params, jacobian=False).attenuation
    return res


def _solution_params(res, geometry, spec, scale, budget=None) -> dict:
    """The model's parameters at each chart's solution (data units; the charts' own measured
    responses from ``budget``)."""
    params = dict(geometry, **({} if budget is None else budget.fixed_params()))
    params.update({k: v for k, v in res["values"].items()})
    for k in ("chl", "cdom"):
        if k in spec.fixed:
            params[k] = np.full(scale.size, spec.fixed[k])
    params["gain"] = res["gain"]
    params["backscatter"] = res["s"] * scale[:, None]
    return params


def _replace_rows(res, redo, rows) -> None:
    """Charts ``rows`` of ``res`` replaced by ``redo``'s (in place; nested dicts too)."""
    for key, val in redo.items():
        if isinstance(val, dict):
            if key == "budget":
                for name, v in val.items():
                    res[key][name]["sd"][rows] = v["sd"]
                    for src, share in v["shares"].items():
                        res[key][name]["shares"][src][rows] = share
            else:
                for name, v in val.items():
                    res[key][name][rows] = v
        elif key != "k":
            res[key][rows] = val


def _solve_chunk(mdl, spec, M, sig, geometry, scale, max_iter, tol, intervals, budget=None,
                 observations=(), plan=None):
    """Levenberg-Marquardt (and the intervals) on one chunk of charts: a dict of results, s
    and f in the chunk's scaled units (``plan``: :class:`_Plan`, the path models' two
    passes)."""
    N = M.shape[0]
    sig_photon = sig
    if budget is not None:
        sig = budget.noise_sd(M, sig)
    prob = make_problem(mdl, spec, M, sig, geometry, scale, budget, observations)
    f_exact = EXACT_FIT * np.einsum("ij,ij->i", prob.W2 * prob.M, prob.M)
    if plan is not None and plan.start is not None:  # the first pass's optimum, as it was
        f = evaluate(prob, np.arange(N), plan.start, False).f
        return _assess_chunk(prob, spec, mdl, geometry, plan.start, f, plan.it, plan.code,
                             intervals, sig, sig_photon, budget, plan)
    theta0 = start_values(prob, geometry)
    if prob.prior_mean is not None:
        # first the paper's model (nuisances held at their priors' centres), as the loop does,
        # then every nuisance released: started at the grid point, the joint fit can settle in
        # a local minimum where the nuisances (the curves' shifts) mimic the water
        hold = np.zeros(theta0.shape, bool)
        hold[:, len(spec.names):] = True
        theta0, _, it0, _ = levenberg_marquardt(prob, theta0, max_iter=max_iter, tol=tol,
                                                f_exact=f_exact, hold=hold)
    theta, f, it, code = levenberg_marquardt(prob, theta0, max_iter=max_iter, tol=tol,
                                             f_exact=f_exact)
    if prob.prior_mean is not None:
        it = it + it0
    if plan is not None and plan.fit_only:
        ev = evaluate(prob, np.arange(N), theta, False)
        res = {"f": ev.f, "theta": theta, "code": code, "it": it, "gain": ev.extras["gain"],
               "s": ev.extras["s"], "ssr": ev.extras["ssr"],
               "values": {n: np.asarray(v, float) for n, v in
                          prob.params(np.arange(N), theta).items() if n in prob.free}}
        if prob.observations:  # what each reading adds, under every model (sca.consistency)
            alone = objectives_alone(prob, theta, (start_values(prob, geometry),))
            res.update({f"alone:{k}": v for k, v in alone.items()})
        return res
    return _assess_chunk(prob, spec, mdl, geometry, theta, f, it, code, intervals, sig,
                         sig_photon, budget, plan)


def _assess_chunk(prob, spec, mdl, geometry, theta, f, it, code, intervals, sig, sig_photon,
                  budget, plan):
    """Everything after the fit of one chunk: goodness, the known gain's test, the budget's
    shares, the intervals, the derived quantities and the consistency of the readings; with a
    ``plan`` of the second pass, the known gain's test only where this path model is the
    chosen one."""
    N = prob.size
    idx = np.arange(N)
    ev = evaluate(prob, idx, theta, True)
    f, H = ev.f, ev.H
    gain, s, ssr, k = (ev.extras[n] for n in ("gain", "s", "ssr", "k"))
    res = {"s": s, "k": k, "f": f, "it": it, "code": code, "gain": gain, "ssr": ssr}
    res["fit_rms"] = np.sqrt(ssr / np.einsum("ij,ij->i", prob.M, prob.M))
    n_s = np.zeros(N, dtype=int) if not spec.free_s else np.sum(s > 0, axis=1)
    dof = mdl.m * mdl.n - len(spec.names) - n_s - int(spec.free_gain)
    res["dof"] = dof
    noise_known = sig is not None
    res["chi2_dof"], res["chi2_p"] = goodness(f, dof, noise_known)
    res["gain_ci"] = np.column_stack([gain, gain])
    # the known gain's test (values in the units the fit was told?)
    res["scale_p"] = np.full(N, np.nan)
    chosen = np.flatnonzero(np.ones(N, bool) if plan is None else plan.chosen)
    if not spec.free_gain and sig is not None and chosen.size:
        sub = prob.subset(chosen)
        res["scale_p"][chosen], _ = scale_test(sub, theta[chosen], f[chosen],
                                               {k: v[chosen] for k, v in geometry.items()})
    res["budget"] = {} if budget is None else _budget_shares(
        prob, theta, gain, s, spec.free_s, sig, sig_photon)
    if spec.free_gain:
        var = gain_variance(prob, theta, gain, s)
        if "gain" in res["budget"]:  # with the budget: every nuisance in the gain's variance
            var = np.where(np.isfinite(res["budget"]["gain"]["sd"]),
                           res["budget"]["gain"]["sd"] ** 2, np.inf)
        res["gain_ci"] = gain_wald(gain, var, f, dof, noise_known)
    values = prob.params(idx, theta)
    if prob.observations and plan is None:  # what each reading adds (sca.consistency)
        alone = objectives_alone(prob, theta, (start_values(prob, geometry),))
        res.update({f"alone:{k}": v for k, v in alone.items()})
    res.update({f"pull:{k}": v for k, v in nuisance_pulls(prob, theta).items()})
    p = len(prob.names)
    ends = np.full((N, p, 2), np.nan)
    codes = np.full((N, p, 2), BOUND_FAILED)
    if intervals and spec.names:
        delta = profile_delta(noise_known, f, dof, np.einsum("ij,ij->i", prob.W2 * prob.M, prob.M))
        caps = np.array([lm_cap(n, mdl.water, mdl.e0) for n in prob.names])
        # the intervals of the free names; the nuisances are profiled, not bounded
        ends, codes = profile_intervals(prob, theta, f, delta, H, caps,
                                        which=range(len(spec.names)))
        # the upper ends of C and a_CDOM (LM coordinates) where found: the derived quantities'
        # intervals hold their profile points where C or a_CDOM sits at its bound
        upper = {j: np.where(codes[:, j, 1] == BOUND_FOUND, ends[:, j, 1], np.nan)
                 for j, n in enumerate(spec.names) if n in ("chl", "cdom")}
        ends = own_units(ends, codes, prob.powers)
    res["values"] = {n: np.asarray(values[n], float) for n in prob.free}
    res["intervals"] = {n: ends[:, j] for j, n in enumerate(spec.names)}
    res["ci_codes"] = _chl_cdom_codes(spec.names, codes)
    # what the photos measure: the water's optical properties with their own intervals
    sigma2 = 1.0 if noise_known else f / np.maximum(dof, 1)
    derived = derived_from_fit(prob, theta, H, mdl.water, mdl.full.wavelengths, sigma2,
                               ends=upper if intervals and spec.names else None)
    for name, (value, ci) in derived["quantities"].items():
        res[f"q:{name}"], res[f"qci:{name}"] = value, ci
    res["c"], res["c_ci"] = derived["c"], derived["c_ci"]
    return res


#: Charts per block of the budget's variance shares (bounds its memory).
BUDGET_BLOCK = 4096


def _budget_shares(prob, theta, gain, s, free_s, sig_total, sig_photon):
    """Each source's share of the variance of C and a_CDOM (:func:`sca.budget.variance_shares`)
    at the fits, in data units: every nonlinear column, the gain (if free) and the active
    backscatter channels."""
    mdl, N = prob.model, prob.size
    blocks = []
    for lo in range(0, N, BUDGET_BLOCK):
        idx = np.arange(lo, min(N, lo + BUDGET_BLOCK))
        params = prob.params(idx, theta[idx])
        params["gain"] = gain[idx]
        params["backscatter"] = s[idx] * prob.scale[idx, None]
        free = prob.free + (("gain",) if prob.free_gain else ()) + ("backscatter",)
        pred = mdl.predict(params, free, chl_floor=CHL_DERIVATIVE_FLOOR)
        names = list(pred.columns)
        k = idx.size
        active = np.ones((k, len(names)), bool)
        s_cols = [j for j, n in enumerate(names) if n == "backscatter"]
        active[:, s_cols] = (s[idx] > 0) if free_s else False
        weight = np.zeros((k, len(names)))
        if prob.prior_weight is not None:
            weight[:, :len(prob.names)] = prob.prior_weight[idx]
            # C's prior-free column is in mg m^-3 here; nuisances are in their own units
        w2t = 1.0 / sig_total[idx].reshape(k, -1) ** 2
        w2p = 1.0 / sig_photon[idx].reshape(k, -1) ** 2
        blocks.append(variance_shares(pred.jacobian, names, w2t, w2p, active, weight,
                                      of=("chl", "cdom", "gain")))
    return _concatenate_budgets(blocks)


def _chl_cdom_codes(names, codes):
    """(N, 4) BOUND_* codes of (chl low, chl high, cdom low, cdom high) for the flags; found
    where the parameter is fixed."""
    N = codes.shape[0]
    out = np.zeros((N, 4), dtype=int)
    for k, name in enumerate(("chl", "cdom")):
        if name in names:
            out[:, 2 * k:2 * k + 2] = codes[:, names.index(name)]
    return out


def gain_variance(prob: ChartProblem, theta, gain, s):
    """Gauss-Newton variance of the gain (noise variance 1 units) at the charts' optima
    (:func:`sca.model.profiled_covariance`); inf where the information is singular."""
    mdl = prob.model
    N = prob.size
    params = prob.params(np.arange(N), theta)
    pred = mdl.predict(params, prob.free, chl_floor=TINY)
    sc = prob.scale[:, None]
    J = pred.jacobian * (prob.chain(params) / sc)[:, None, :]
    shape = (N, mdl.m, mdl.n)
    active = (s > 0) if prob.fixed_s is None else np.zeros((N, mdl.m), bool)
    cov = profiled_covariance((gain[:, None, None] * J).reshape(shape + (-1,)),
                              prob.W2.reshape(shape), active,
                              gain_column=(pred.signal / sc).reshape(shape))
    var = cov[:, -1, -1]
    return np.where(np.isfinite(var) & (var > 0), var, np.inf)


#: Levenberg-Marquardt iterations of each fit of the known gain's test.
SCALE_MAX_ITER = 100
#: The known gain's test refits only charts whose second-order statistic
#: (:func:`scale_screen`) reaches this (chi^2_1 p = 0.32; the flag needs the refitted statistic
#: above 6.63, p < 0.01): over 900 charts in six worlds, 0.4-1.5 times the model's units, the
#: screened statistic was at least 0.54 of the refitted one and no flag was missed (decision
#: 0071-scale-test-screened).
SCALE_SCREEN_STAT = 1.0


def _gain_freed(prob: ChartProblem) -> ChartProblem:
    """The same charts with the gain free."""
    return ChartProblem(prob.model, prob.M, prob.W2, prob.scale, prob.names, prob.fixed, True,
                        prob.fixed_s, prob.prior_mean, prob.prior_weight, prob.observations)


def scale_screen(prob: ChartProblem, theta, f) -> np.ndarray:
    """The known gain's likelihood-ratio statistic to second order, from one evaluation: at
    the known-gain optimum ``theta`` the gain is freed (in closed form, by the variable
    projection), and the Gauss-Newton step of the other parameters adds the decrease it
    predicts (the score statistic of the gain in the profiled metric).

    Parameters
    ----------
    prob : ChartProblem
        The charts, gain known.
    theta : ndarray, (N, p)
        The known-gain optimum.
    f : ndarray, (N,)
        Its objective.

    Returns
    -------
    stat : ndarray, (N,)
        The approximate statistic f_known - f_free (>= 0).
    gain : ndarray, (N,)
        The gain the data ask for at ``theta`` (data units per model unit).
    """
    free = _gain_freed(prob)
    N = prob.size
    if N == 0:
        return np.zeros(0), np.zeros(0)
    ev = evaluate(free, np.arange(N), np.asarray(theta, float), True)
    _, pred = lm_step(ev.g, ev.H, np.full(N, LM_MU_MIN), np.asarray(theta, float), free.lower,
                      np.zeros(theta.shape, bool))
    return np.maximum(np.asarray(f, float) - ev.f + pred, 0.0), ev.extras["gain"]


def scale_test(prob: ChartProblem, theta, f, geometry):
    """The likelihood-ratio test of a gain held known: are the values in the units the fit was
    told (a white reflector in air = 1)?

    The same charts are fitted again with the gain free by the one Levenberg-Marquardt, from
    the known-gain optimum and from the start grid (the better of the two); the statistic f_known - f_free is chi^2 with one degree of freedom
    where the known gain is right. Values in other units (a chart times 0.4, read as model
    units) are otherwise fitted as another water, and can pass every other test.

    Parameters
    ----------
    prob : ChartProblem
        The charts, gain known (``free_gain`` False), noise known.
    theta : ndarray, (N, p)
        The known-gain optimum.
    f : ndarray, (N,)
        Its objective (chi^2 with the priors).
    geometry : dict
        'depth' and 'distance', (N,) each, m (for the start grid).

    Returns
    -------
    p_value : ndarray, (N,)
        P(chi^2_1 > f_known - f_free).
    gain : ndarray, (N,)
        The gain the data ask for (data units per model unit).

    References
    ----------
    S. S. Wilks, "The large-sample distribution of the likelihood ratio for testing composite
    hypotheses", Ann. Math. Statist. 9 (1938) 60-62.
    """
    stat, gain = scale_screen(prob, theta, f)
    rows = np.flatnonzero(~(stat < SCALE_SCREEN_STAT))  # the rest: no sign of another scale
    if rows.size:
        sub = _gain_freed(prob.subset(rows))
        th, f_free, _, _ = levenberg_marquardt(sub, np.asarray(theta, float)[rows],
                                               max_iter=SCALE_MAX_ITER, tol=LM_TOL,
                                               f_exact=np.zeros(rows.size))
        th2, f2, _, _ = levenberg_marquardt(sub, start_values(sub, {
            k: np.asarray(v)[rows] for k, v in geometry.items()}), max_iter=SCALE_MAX_ITER,
            tol=LM_TOL, f_exact=np.zeros(rows.size))
        better = f2 < f_free
        th[better], f_free[better] = th2[better], f2[better]
        gain[rows] = evaluate(sub, np.arange(rows.size), th, False).extras["gain"]
        stat[rows] = np.maximum(np.asarray(f, float)[rows] - f_free, 0.0)
    return special.chdtrc(1, stat), gain
