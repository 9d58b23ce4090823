"""The paper's estimator (eqs 15-18): sequential convex programming in cvxpy with Clarabel.

At iteration t the attenuation k(x) and the equality (17) are replaced by their first-order
Taylor expansions around x_t (the Jacobian of :meth:`sca.model.ChartModel.predict`), the
resulting QP (:mod:`sca.subproblem`) is solved, and its solution becomes x_{t+1}; the loop
repeats until the objective, evaluated with the true nonlinear k, no longer decreases.

Three modes (decision 0026-loop-modes):

* ``mode="paper"`` -- the literal loop: full Taylor steps, stop at the first step that does not
  decrease the objective (the previous point is returned).
* ``mode="safeguarded"`` (default) -- the same subproblem inside a trust region on the scaled
  parameters (:mod:`sca.trust_region`), shrunk when the true objective rises and grown when
  the model predicts well; iterates are put back on eq 17 (w rescaled) and s (and a free gain)
  are re-fitted in closed form; stops when the relative decrease of the objective falls below
  ``tol`` or the model predicts none.
* ``mode="lm"`` -- not the loop: the batch's variable projection and Levenberg-Marquardt
  (:mod:`sca.lm`) on the one chart, from the loop's start point (:func:`sca.verdict.fit_lm`);
  the same optimum where the loop converges, without cvxpy.

``converged`` is True only where the returned point is stationary (the subproblem predicts a
relative decrease below ``tol``) or fits the data to rounding error; every other end is
reported in ``status``. Any parameter of ``free=`` (a forward.Water coefficient, the geometry)
is one more linearised variable.

The loop's parts (methods of :class:`Estimator`): ``_linearise`` (the QP's data at the current
point), ``_set_subproblem`` / ``_solve_step`` (Clarabel, its fallbacks, the active-set polish),
``_candidate`` (the trial point and the decrease the model predicts), ``_judge`` (acceptance
and the trust-region update) and ``_result`` (:mod:`sca.verdict`).
"""

from __future__ import annotations

import dataclasses
import numbers
import time
import warnings
from dataclasses import dataclass, field

import numpy as np

from forward import validate
from forward.imaging import ChartSetup, resolve_setup
from forward.spectra import DEFAULT_CAMERA
from forward.water import Water, resolve_water

from .auxiliary import auxiliary_observations
from .budget import resolve_budget
from .consistency import tested
from .pathmodels import candidates, combine_single, supported
from .fitspec import GAINS, fit_spec
from .limits import EXACT_FIT, MAX_RGB
from .model import CHL_DERIVATIVE_FLOOR, ChartModel, linear_part, lower_bound
from .results import Estimate
from .trust_region import (
    CONVERGED_PRED_FACTOR,
    TR_COLLAPSE,
    TR_RADIUS0,
    TR_SHRINK,
    update_radius,
)
from .verdict import Settled, finish, fit_lm, settle
from forward.errors import InputError

__all__ = ["MODES", "GAINS", "Estimator", "estimate", "over_path_models", "CLARABEL_SETTINGS", "CLARABEL_FALLBACKS",
           "BOUND_CAP", "CHL_SCALE_MIN", "CDOM_SCALE_MIN", "PARAM_SCALE_MIN", "INIT_CHL",
           "INIT_CDOM", "GRADIENT_VANISHES", "GRID_BLOCK_VALUES",
           "GRID_BLOCK_MIN_POINTS"]

MODES = ("paper", "safeguarded", "lm")
#: Clarabel settings of the subproblem: its defaults (1e-8 tolerances on a subproblem that
#: is normalised to O(1) every iteration), followed by an active-set polish
#: (:func:`sca.subproblem.polish`) that makes the step exact where bounds are active.
CLARABEL_SETTINGS = dict(max_iter=200)
#: Tried in order when a solve fails (each failure is recorded; only when all fail is the loop
#: stopped and reported in ``status``).
CLARABEL_FALLBACKS = (
    CLARABEL_SETTINGS,
    dict(CLARABEL_SETTINGS, equilibrate_enable=False),
    dict(CLARABEL_SETTINGS, tol_gap_abs=1e-6, tol_gap_rel=1e-6, tol_feas=1e-6),
)

#: Inequality bounds of the (normalised) subproblem are capped at this multiple of the
#: least-squares step that satisfies the linearised eq 17 (see the loop): bounds millions of
#: step lengths away make Clarabel's interior-point start fail. Should a capped bound bind,
#: the step is still only a candidate judged by the true objective (safeguarded mode); in
#: paper mode the cap acts as a trust region of 100 such steps.
BOUND_CAP = 1e2

#: Scales (C in mg m^-3, a_CDOM in m^-1) below which parameters are not scaled further.
CHL_SCALE_MIN = 1e-3
CDOM_SCALE_MIN = 1e-3
#: ... and the same for any other free parameter (a Water coefficient, a length).
PARAM_SCALE_MIN = 1e-6
#: The loop stops as converged when ||Q^T r0|| (the part of the residual a step can remove)
#: is below this: the gradient vanishes.
GRADIENT_VANISHES = 1e-300

#: The start grid's objective is evaluated in blocks of at most about this many (point,
#: wavelength) values (~0.5 MB per temporary array), so that a block's temporaries stay in a
#: core's L2 cache: at 1 nm the 513-point grid in one piece spent ~1.3 ms more per fit moving
#: memory (decision 0025-start-point). The blocks change a point's value by
#: rounding at most (BLAS's kernel for a block's last rows) and not the best point.
GRID_BLOCK_VALUES = 60_000
#: ... and of at least this many points: :func:`forward.WaterTerms.path_coefficient` adds the
#: terms of fewer than 8 points one by one and of more by one matrix product, whose sums may
#: round differently, so a smaller block could change the last bits.
GRID_BLOCK_MIN_POINTS = 64

#: Coarse initial search grids (deterministic, independent of the data's truth).
INIT_CHL = np.concatenate([[0.0], np.logspace(-3, 2, 26)])
INIT_CDOM = np.concatenate([[0.0], np.logspace(-3, np.log10(3.0), 18)])


class Estimator:
    """Estimator for one (camera, illuminant, chart, grid, water model, basis, unknowns): build
    once, fit many.

    The cvxpy subproblem is compiled once per problem structure and per thread (see
    :func:`sca.subproblem.compiled_subproblem`); only parameter values change per iteration.
    An ``Estimator`` holds no state that a fit changes, so one may be shared between threads.

    Parameters
    ----------
    depth, distance : float
        The path of the measurement, m (keyword-only).
    camera, illuminant, reflectances, wavelengths, basis, setup :
        As :func:`forward.simulate_chart`.
    water, path_model, cdom_slope :
        The water model (:class:`forward.Water`, default the paper's).
    fix : dict, optional
        Held parameters (see :func:`sca.estimate`).
    free : sequence of str
        Parameters estimated besides C and a_CDOM (see :func:`sca.estimate`).
    gain : {'known', 'free'}
        The exposure gain of M = gain G + s: known (model units) or estimated.
    uncertain : dict, optional
        The uncertainty budget (see :func:`sca.estimate`).

    Attributes
    ----------
    depth, distance : float
        The path, m.
    setup : forward.ChartSetup
        Camera, illuminant and chart on the grid.
    spec : sca.fitspec.FitSpec
        The unknowns.
    water : forward.Water
        The water with every held coefficient written into it.
    model : sca.ChartModel
        The chart model (eq 15).
    fixed : dict
        Held 'chl' (mg m^-3), 'cdom' (m^-1), 'backscatter' ((m,), data units).
    free_gain, free_s, free_chl, free_cdom, free_w : bool
        Which of the gain, s, C, a_CDOM and w are estimated.
    extras : tuple of str
        Free names besides C and a_CDOM (not 'phyto_scale' or 'phyto_exponent', which enter
        eq 17).

    References
    ----------
    Blasinski & Farrell, "A Three Parameter Underwater Image Formation Model", eqs 15-18;
    J. Nocedal & S. J. Wright, Numerical Optimization, 2nd ed., Springer (2006),
    Algorithm 4.1 (the safeguarded loop's trust region).
    """

    def __init__(self, *, depth, distance, camera=DEFAULT_CAMERA, illuminant=None,
                 reflectances=None, wavelengths=None, basis=None, water: Water | None = None,
                 path_model: str | None = None, cdom_slope: float | None = None, fix=None,
                 free=(), setup: ChartSetup | None = None, gain: str = "known",
                 uncertain=None, quadrature: str = "reduced", auxiliary=None):
        if quadrature not in ("reduced", "full"):
            raise InputError("quadrature", f"must be 'reduced' or 'full', got {quadrature!r}")
        #: the inference layer's model: the certified quadrature or the full grid
        self.quadrature = quadrature
        self.depth = validate.scalar("depth", depth)
        self.distance = validate.scalar("distance", distance)
        self.setup = setup = resolve_setup(setup, camera, illuminant, reflectances, wavelengths)
        water = resolve_water(water, path_model=path_model, cdom_slope=cdom_slope)
        m = setup.sensitivities.shape[1]
        self.spec = spec = fit_spec(free, fix, gain, water, m)
        self.water = spec.water
        self.model = mdl = ChartModel(setup, basis=basis, water=spec.water)
        self.fixed = dict(spec.fixed)
        self.free_gain, self.free_s = spec.free_gain, spec.free_s
        self.free_chl, self.free_cdom = "chl" in spec.names, "cdom" in spec.names
        #: the uncertainty budget (:mod:`sca.budget`), applied to fits with a known noise
        self.budget = resolve_budget(uncertain, depth=self.depth, distance=self.distance,
                                     water=spec.water, free=spec.names, fixed=tuple(fix or {}))
        self.model = mdl = self.budget.model(mdl)  # a reference shot's measured response
        self.extras = tuple(n for n in spec.names if n not in ("chl", "cdom"))
        #: the user's auxiliary measurements (:mod:`sca.auxiliary`), fused from the budget's
        #: refinement on (the convex loops fit the photo alone)
        self.observations = auxiliary_observations(auxiliary, spec.water)
        tied = set(self.extras) & {"phyto_scale", "phyto_exponent"}
        if tied:
            raise InputError("free", f"{sorted(tied)} enter eq 17, which this loop linearises with "
                             "the water's constants; use sca.estimate_least_squares or "
                             "sca.estimate_batch")
        # with C fixed and one basis function, eq 17 fixes w too
        self.free_w = self.free_chl or mdl.z > 1
        # eq 16's T w >= 0: with one nonnegative basis function it is simply w >= 0, a bound
        # like those on C and a_CDOM (one row instead of q in the subproblem)
        self.w_bound = self.free_w and mdl.z == 1 and bool(np.all(mdl.T >= 0) and np.any(mdl.T > 0))
        bounded = [n for n in self.extras if np.isfinite(lower_bound(n, self.water))]
        unbounded = [n for n in self.extras if n not in bounded]
        # the QP's delta, by name: the bounded scalars, w, then the unbounded
        self.order = ((["gain"] if self.free_gain else []) + (["chl"] if self.free_chl else [])
                      + (["cdom"] if self.free_cdom else []) + bounded
                      + (["w"] if self.free_w else []) + unbounded)
        self.n_scalar_pos = len(self.order) - int(self.free_w) - len(unbounded)
        self.n_pos = self.n_scalar_pos + int(self.w_bound)
        self.n_free = len(self.order) - int(self.free_w) + (mdl.z if self.free_w else 0)
        if self.n_free == 0 and not self.free_s:
            raise InputError("fix", "nothing is left to estimate")
        self.w_slice = (self.n_scalar_pos, self.n_scalar_pos + mdl.z) if self.free_w else None

    # ----------------------------------------------------------------------------- helpers
    def _check_rgb(self, rgb):
        """``rgb`` as a finite, real, nonnegative (m, n) array whose largest value the solver
        can represent (1e-100 to ``MAX_RGB``: squares of smaller values lose their precision
        to underflow), or ``ValueError`` naming ``rgb``."""
        shape = (self.model.m, self.model.n)
        M = validate.array("rgb", rgb, shape=shape)
        if np.any(M < 0):
            raise InputError("rgb", f"contains negative values (min {M.min():g}); measurements are "
                             "exposure-normalised sensor values >= 0")
        if M.max() > MAX_RGB:
            raise InputError("rgb", f"values up to {M.max():g} exceed {MAX_RGB:g}; measurements in "
                             "model units are O(1) (a white reflector in air = 1)")
        if 0 < M.max() < 1e-100:
            raise InputError("rgb", f"values up to {M.max():g} are too small for the solver "
                             "(below 1e-100 their squares underflow); rescale them (with "
                             "gain='free' any unit will do)")
        return M

    def params(self, x) -> dict:
        """The model's parameters at the loop's point ``x`` (a dict)."""
        out = {"chl": x["chl"], "cdom": x["cdom"], "w": x["w"], "gain": x["gain"],
               "backscatter": x["s"], "depth": self.depth, "distance": self.distance}
        out.update({n: x[n] for n in self.extras})
        return out

    def signal(self, st, x) -> np.ndarray:
        """vec(G) at unit gain, in the problem's units."""
        p = self.params(x)
        p.pop("gain"), p.pop("backscatter")
        return st.mdl.predict(p, jacobian=False).signal

    def objective(self, st, x, G=None) -> float:
        """The (whitened) sum of squares of M - gain G - s at ``x`` (``G``: its unit-gain
        signal, when already computed)."""
        G = self.signal(st, x) if G is None else G
        r = st.wt * (st.Mv - x["gain"] * G - np.repeat(x["s"], st.mdl.n))
        return float(r @ r)

    def linear_part(self, st, G):
        """The closed-form (gain, s) for signals ``G`` (..., m n): s >= 0 and gain >= 0
        minimising the (whitened) residual (:func:`sca.model.linear_part`); gain = 1 where it is
        known."""
        mdl = st.mdl
        G3 = np.asarray(G, float).reshape((-1, mdl.m, mdl.n))
        fs = None if st.s_fixed is None else np.broadcast_to(st.s_fixed, (G3.shape[0], mdl.m))
        gain, s, _ = linear_part(st.Mv.reshape(1, mdl.m, mdl.n), G3,
                                 (st.wt ** 2).reshape(1, mdl.m, mdl.n), fs, self.free_gain)
        return gain.reshape(G.shape[:-1]), s.reshape(G.shape[:-1] + (mdl.m,))

    def check_sigma(self, sigma):
        """``sigma`` (None, a scalar or (m, n), data units) as a (m, n) array or None; every
        value real, finite and at least 1e-100 (smaller ones underflow when squared)."""
        if sigma is None:
            return None
        shape = (self.model.m, self.model.n)
        arr = validate.array("sigma", sigma)
        if arr.ndim == 0:
            arr = np.full(shape, float(arr))
        if arr.shape != shape:
            raise InputError("sigma", f"expected a scalar or shape {shape}, got {arr.shape}")
        if np.any(arr <= 0):
            raise InputError("sigma", f"standard deviations must be > 0 (min {arr.min():g})")
        if np.any(arr < 1e-100):
            raise InputError("sigma", f"standard deviations down to {arr.min():g} are too small "
                             "for the solver (below 1e-100 their squares underflow); rescale "
                             "the values and their sds together")
        return arr

    def prepare(self, rgb, sigma=None) -> "_FitState":
        """Validate ``rgb`` (and ``sigma``) and scale the problem: a fresh fit state holding
        vec(M) / max M, the scale, the model in those units, the whitening weights (scale /
        sigma, or ones) and the fixed backscatter in those units (or None)."""
        M = self._check_rgb(rgb)
        sig = self.check_sigma(sigma)
        scale = float(np.max(M))
        if scale <= 0:
            raise InputError("rgb", "all values are zero; nothing to fit")
        s_fixed = None if self.free_s else self.fixed["backscatter"] / scale
        wt = np.ones(M.size) if sig is None else scale / self.budget.noise_sd(M, sig).ravel()
        Mv = M.ravel() / scale
        Mw = wt * Mv
        mdl = self.model.scaled(scale)
        return _FitState(mdl=mdl, Mv=Mv, wt=wt, noise_known=sig is not None,
                         scale=scale, s_fixed=s_fixed, f_exact=EXACT_FIT * float(Mw @ Mw),
                         wt_photon=None if sig is None else scale / sig.ravel(),
                         fit_mdl=mdl.reduced() if self.quadrature == "reduced"
                         and self.model.z == 1 else mdl)

    def initial_point(self, st, x0=None) -> dict:
        """Deterministic start: a coarse grid search over (C, a_CDOM) with w on eq 17 and the
        closed-form gain and s, unless ``x0`` (dict with 'chl' and/or 'cdom', or any free
        name) gives it; other free parameters start at the water's constants or the given
        geometry."""
        mdl = st.mdl
        chl_grid = np.array([self.fixed["chl"]]) if not self.free_chl else INIT_CHL
        cdom_grid = np.array([self.fixed["cdom"]]) if not self.free_cdom else INIT_CDOM
        start = {n: float(getattr(self, n)) if n in ("depth", "distance") else mdl.default(n)
                 for n in self.extras}
        if x0 is not None:
            allowed = {"chl", "cdom"} | set(self.extras)
            if not isinstance(x0, dict) or not set(x0) <= allowed:
                raise InputError("x0", f"expected a dict with keys among {sorted(allowed)}")
            if "chl" in x0 and self.free_chl:
                chl_grid = np.array([validate.scalar("x0['chl']", x0["chl"])])
            if "cdom" in x0 and self.free_cdom:
                cdom_grid = np.array([validate.scalar("x0['cdom']", x0["cdom"])])
            for n in self.extras:
                if n in x0:
                    start[n] = validate.scalar(f"x0[{n!r}]", x0[n], nonnegative=False)
        C, A = (v.ravel() for v in np.meshgrid(chl_grid, cdom_grid, indexing="ij"))
        u = np.full(mdl.z, 1.0 / mdl.z)
        W = np.multiply.outer(mdl.phyto_scale(C) / float(mdl.t440 @ u), u)
        grid = {"chl": C, "cdom": A, "w": W, "s": np.zeros((C.size, mdl.m)), "gain": 1.0}
        grid.update({n: np.full(C.size, v) for n, v in start.items()})
        j = int(np.argmin(self.grid_objective(st, grid, C.size)))
        x = {"chl": float(C[j]), "cdom": float(A[j]), "w": W[j].copy(), **start}
        x["gain"], x["s"] = self._closed_form(st, x)
        return x

    def grid_objective(self, st, grid, n, block_values: int | None = None) -> np.ndarray:
        """The objective at each of the ``n`` points of ``grid`` with the closed-form gain and
        s (the start grid's search).

        Parameters
        ----------
        st : _FitState
            The prepared fit (:meth:`prepare`).
        grid : dict
            The loop's point names -> (n, ...) arrays, or scalars (0-d arrays too) shared by
            every point.
        n : int
            Points.
        block_values : int, optional
            Evaluated in blocks of at most about this many (point, wavelength) values, so that
            a block's temporaries stay in a core's cache (default :data:`GRID_BLOCK_VALUES`), and of
            at least :data:`GRID_BLOCK_MIN_POINTS` points. Each point's value is computed on
            its own (elementwise operations, sums per point and matrix products whose rows do
            not mix), so the blocks change a value by rounding at most: BLAS may multiply a
            block's last rows by another kernel, summing in another order (a test checks
            1e-12 relative and the same best point).

        Returns
        -------
        ndarray, (n,)
            The (whitened) sums of squares.
        """
        mdl = st.mdl
        block_values = GRID_BLOCK_VALUES if block_values is None else block_values
        if isinstance(block_values, bool) or not isinstance(block_values, numbers.Integral) \
                or block_values < 1:
            raise InputError("block_values", f"must be a positive integer, got {block_values!r}")
        per_point = {k for k, v in grid.items() if isinstance(v, np.ndarray) and v.ndim}
        lengths = {k: len(grid[k]) for k in per_point}
        if any(size != n for size in lengths.values()):
            raise InputError("grid", f"every array must have n = {n} points, got {lengths}")
        blocks = max(1, min(-(-n * mdl.wavelengths.size // int(block_values)),
                            n // GRID_BLOCK_MIN_POINTS))
        edges = [n * i // blocks for i in range(blocks + 1)]  # even: none below the minimum
        out = np.empty(n)
        for a, b in zip(edges[:-1], edges[1:]):
            part = {k: v[a:b] if k in per_point else v for k, v in grid.items()}
            G = self.signal(st, part)
            gain, s = self.linear_part(st, G)
            r = st.wt * (st.Mv - gain[:, None] * G - np.repeat(s, mdl.n, axis=-1))
            out[a:b] = np.einsum("ij,ij->i", r, r)
        return out

    def _closed_form(self, st, x, G=None):
        """(gain, s) in closed form at ``x`` (``G``: its unit-gain signal, when computed)."""
        G = self.signal(st, {**x, "gain": 1.0, "s": None}) if G is None else G
        gain, s = self.linear_part(st, G[None])
        return float(gain[0]), np.array(s[0], dtype=float)

    # ----------------------------------------------------------------------------- the loop
    def fit(self, rgb, *, sigma=None, saturation=None, mode: str = "safeguarded",
            max_iter: int = 100, tol: float = 1e-10, x0=None, trace: dict | None = None) -> Estimate:
        """Run the sequential convex loop on measured patch values ``rgb`` (m, n), then assess
        the fit (:mod:`sca.verdict`: :meth:`settle`, then :func:`sca.verdict.finish`); see
        :func:`sca.estimate`. ``trace``: a dict that receives the loop's timing
        (solve_time_s, clarabel_time_s, n_solves, polish_rescues), for benchmarks.

        Parameters
        ----------
        rgb : array_like, (m, n)
            Measured patch values (model units, or any units with ``gain='free'``).
        sigma, saturation, mode, max_iter, tol, x0 :
            As :func:`sca.estimate` (keyword-only).
        trace : dict, optional
            Receives 'solve_time_s', 'clarabel_time_s' (s), 'n_solves', 'polish_rescues'.

        Returns
        -------
        Estimate
        """
        return tested(finish(self.settle(rgb, sigma=sigma, saturation=saturation, mode=mode,
                                         max_iter=max_iter, tol=tol, x0=x0, trace=trace)))

    def settle(self, rgb, *, sigma=None, saturation=None, mode: str = "safeguarded",
               max_iter: int = 100, tol: float = 1e-10, x0=None,
               trace: dict | None = None) -> Settled:
        """:meth:`fit` up to the fixed objective (:func:`sca.verdict.settle`): what decides the
        path models' support; :func:`sca.verdict.finish` makes it an :class:`Estimate`.
        Arguments as :meth:`fit`."""
        if mode not in MODES:
            raise InputError("mode", f"must be one of {MODES}, got {mode!r}")
        if int(max_iter) != max_iter or max_iter < 1:
            raise InputError("max_iter", f"must be a positive integer, got {max_iter!r}")
        tol = validate.scalar("tol", tol, positive=True)
        if saturation is not None:
            saturation = validate.scalar("saturation", saturation, positive=True)
        st = self.prepare(rgb, sigma)
        if mode == "lm":
            it = fit_lm(self, st, int(max_iter), x0)
        else:
            it = self._loop(st, mode, int(max_iter), tol, x0)
        if trace is not None:
            trace.update(solve_time_s=st.t_solve, clarabel_time_s=st.t_clarabel,
                         n_solves=st.n_solves, polish_rescues=st.rescues)
        return settle(self, st, mode, it, saturation)

    def _loop(self, st, mode, max_iter, tol, x0):
        """Linearise, solve the QP, judge the step with the true objective, repeat."""
        safeguarded = mode == "safeguarded"
        mdl = st.mdl
        from .subproblem import compiled_subproblem  # cvxpy: imported by the loop that uses it

        sub = compiled_subproblem(self.n_free, self.n_pos, None if self.w_bound else self.w_slice,
                                  mdl.wavelengths.size, mdl.m if self.free_s else 0, safeguarded,
                                  self.free_w)
        st.x = self.initial_point(st, x0)
        st.initial = {"chl": st.x["chl"], "cdom": st.x["cdom"]}
        st.f = self.objective(st, st.x)
        st.history.append(st.f)
        it = 0
        for it in range(1, max_iter + 1):
            if st.f <= st.f_exact:
                st.stop("exact fit (objective at rounding level)", True)
                it -= 1
                break
            lin = self._linearise(st)
            if lin.unit <= GRADIENT_VANISHES:
                st.stop("converged: the gradient vanishes", True)
                break
            v, failure = self._solve_step(sub, lin, st, safeguarded)
            if failure:
                st.stop(f"solver failed at iteration {it}: {failure}", False)
                break
            cand = self._candidate(st, lin, v, safeguarded)
            if not np.isfinite(cand.f):
                st.stop(f"non-finite objective at iteration {it}", False)
                break
            if self._judge(st, cand, tol, safeguarded):
                break
        else:
            st.stop("maximum number of iterations reached", False)
        if st.f <= st.f_exact and not st.converged:
            st.stop("exact fit (objective at rounding level)", True)
        return it

    def _scales(self, st) -> np.ndarray:
        """The scale D of every entry of delta (the QP's unknowns are x = x_t + D delta)."""
        mdl, x = st.mdl, st.x
        w_min = float(mdl.phyto_scale(CHL_SCALE_MIN)) / (mdl.z * float(np.max(mdl.t440)))
        out = []
        for name in self.order:
            if name == "gain":
                out.append(x["gain"] if x["gain"] > 0 else 1.0)
            elif name == "chl":
                out.append(max(x["chl"], CHL_SCALE_MIN))
            elif name == "cdom":
                out.append(max(x["cdom"], CDOM_SCALE_MIN))
            elif name == "w":
                out.extend(np.maximum(np.abs(x["w"]), w_min))
            else:
                out.append(max(abs(x[name]), PARAM_SCALE_MIN))
        return np.array(out, float)

    def _linearise(self, st) -> "_Linearisation":
        """The QP data at the current point: scaled Jacobian [A E] = Q R and the residual."""
        mdl, x = st.mdl, st.x
        pred = mdl.predict(self.params(x), [n for n in self.order], chl_floor=CHL_DERIVATIVE_FLOOR)
        scales = self._scales(st)
        r0 = st.wt * (st.Mv - pred.values)  # whitened when the noise is known
        AE = pred.jacobian * scales
        if self.free_s:
            AE = np.hstack([AE, np.repeat(np.eye(mdl.m), mdl.n, axis=0)])
        AE = AE * st.wt[:, None]
        Q, Rm = np.linalg.qr(AE)
        b = Q.T @ r0
        unit = float(np.linalg.norm(b))  # the step is solved for in units of ||Q^T r0||
        c0 = max(float(r0 @ r0 - b @ b), 0.0)  # the part of ||r0||^2 no step can remove
        return _Linearisation(AE, r0, Rm, b, unit, c0, scales)

    def _position(self, name):
        """Index of scalar ``name`` in delta."""
        i = self.order.index(name)
        if self.free_w and i > self.order.index("w"):
            i += self.model.z - 1
        return i

    def _eq17_row(self, st, lin):
        """Eq 17 linearised: t440.(w + D_w dw) = alpha(C) + alpha'(C) D_C dC, as (row, rhs)."""
        if not self.free_w:
            return None, 0.0
        mdl, x = st.mdl, st.x
        row = np.zeros(lin.R.shape[1])
        lo, hi = self.w_slice
        row[lo:hi] = mdl.t440 * lin.scales[lo:hi]
        if self.free_chl:
            alpha, dalpha = mdl.phyto_scale(x["chl"], derivative=True)
            i = self._position("chl")
            row[i] = -float(dalpha) * lin.scales[i]
            return row, float(alpha) - float(mdl.t440 @ x["w"])
        return row, float(mdl.phyto_scale(self.fixed["chl"])) - float(mdl.t440 @ x["w"])

    def _set_subproblem(self, sub, lin, st, safeguarded) -> str:
        """Write the QP's parameters (all in units of ``lin.unit``; :func:`sca.subproblem.assign`):
        '' or why they could not be written."""
        from .subproblem import assign, equality_step

        mdl, x = st.mdl, st.x
        unit = lin.unit
        if not (np.isfinite(unit) and np.all(np.isfinite(lin.R)) and np.all(np.isfinite(lin.b))):
            # before any LAPACK call on them (an SVD of NaN can fail, or not return)
            return "the linearised problem is not finite (R, b)"
        b = lin.b / unit
        vals = {"R": lin.R, "b": b}
        eq_row, eq_rhs = self._eq17_row(st, lin)
        # Bounds far beyond any step the model can want only hurt the interior-point start;
        # they are capped at BOUND_CAP times the least-squares step that respects the
        # linearised eq 17 (without it, C and w are nearly collinear and the unconstrained
        # step is meaningless).
        v_ls = equality_step(lin.R, b, eq_row, eq_rhs / unit)
        cap = BOUND_CAP * max(1.0, float(np.max(np.abs(v_ls))))
        if self.free_s:
            vals["s_lo"] = np.maximum(-x["s"] / unit, -cap)
        if self.n_pos:
            lo = []
            for name in self.order[:self.n_scalar_pos]:
                i = self._position(name)
                lo.append((lower_bound(name, self.water) - x[name]) / lin.scales[i])
            if self.w_bound:
                lo.append(-float(x["w"][0]) / float(lin.scales[self.w_slice[0]]))
            vals["lo"] = np.maximum(np.array(lo) / unit, -cap)
        if safeguarded and self.n_free:
            vals["hi"] = np.full(self.n_free, min(st.radius / unit, cap))
        if self.free_w:
            if not self.w_bound:
                TDw = mdl.T * lin.scales[self.w_slice[0]:self.w_slice[1]]
                vals["TDw"] = TDw
                vals["Tw_rhs"] = np.maximum(-(mdl.T @ x["w"]) / unit,
                                            -cap * np.abs(TDw).sum(axis=1))
            vals["a_eq"] = eq_row[:self.n_free]
            vals["b_eq"] = eq_rhs / unit
        return assign(sub, vals)

    def qp_problem(self, sub, lin):
        """The cvxpy problem and variable solved each iteration: the compiled DPP problem.
        (A benchmark baseline overrides this to rebuild the problem every time.)"""
        return sub.problem, sub.v

    def _solve_step(self, sub, lin, st, safeguarded):
        """Solve the QP (with the fallbacks and the active-set polish): the step in data units
        and '' or the reasons it failed."""
        from .subproblem import polish
        failure = self._set_subproblem(sub, lin, st, safeguarded)
        if failure:
            return None, failure
        t0 = time.perf_counter()
        problem, v_var = self.qp_problem(sub, lin)
        v_var.value = None  # a cached problem: never read a previous solve's values
        failure = _solve(problem)
        st.t_solve += time.perf_counter() - t0
        st.n_solves += 1
        stats = getattr(problem, "solver_stats", None)
        if stats is not None and stats.solve_time:
            st.t_clarabel += float(stats.solve_time)
        v = None
        if not failure:
            v, _ = polish(sub, np.asarray(v_var.value, float))
        elif v_var.value is not None and np.all(np.isfinite(v_var.value)):
            # Clarabel stopped early (e.g. its iteration limit on a degenerate, weakly active
            # bound) but returned an iterate: the active-set polish may turn it into a
            # feasible point that the model says is no worse than not moving (v = 0, feasible
            # in safeguarded mode). Counted in ``polish_rescues`` of the trace.
            v, rescued = polish(sub, np.asarray(v_var.value, float),
                                f_ref=1.0 if safeguarded else None)
            if rescued:
                failure = ""
                st.rescues += 1
        if failure:
            return None, failure
        st.qp_value = float(np.sum((lin.R @ v - lin.b / lin.unit) ** 2))
        return v * lin.unit, ""

    def _candidate(self, st, lin, v, safeguarded) -> "_Candidate":
        """The trial point of step ``v``, its true objective and the decrease the linearised
        model predicted for it."""
        mdl, x = st.mdl, st.x
        delta = v[:self.n_free]
        step = delta * lin.scales
        new = dict(x)
        for name in self.order:
            if name == "w":
                new["w"] = x["w"] + step[self.w_slice[0]:self.w_slice[1]]
                continue
            value = x[name] + step[self._position(name)]
            low = lower_bound(name, self.water)
            new[name] = max(value, low) if np.isfinite(low) else value
        if safeguarded:  # feasibility restoration: w back on eq 17, gain and s re-fitted in
            # closed form
            new["w"] = mdl.feasible_w(new["chl"], new["w"])
        G_new = self.signal(st, {**new, "s": None})
        if safeguarded:
            new["gain"], new["s"] = self._closed_form(st, new, G_new)
        else:
            new["s"] = np.maximum(x["s"] + v[self.n_free:], 0.0) if self.free_s else x["s"].copy()
        f_new = self.objective(st, new, G_new)
        pred = st.f - (st.qp_value * lin.unit**2 + lin.c0)
        size = float(np.max(np.abs(delta))) if delta.size else 0.0
        st.trials.append(f_new)
        return _Candidate(new, f_new, pred, size)

    def _judge(self, st, cand, tol, safeguarded) -> bool:
        """Accept or reject the candidate, update the trust region; True when the loop stops."""
        stationary = cand.pred <= tol * st.f or st.f <= st.f_exact
        if cand.f < st.f:  # accept
            decrease = st.f - cand.f
            st.x, st.f = cand.x, cand.f
            st.history.append(st.f)
            if not safeguarded:
                return False
            st.radius = update_radius(st.radius, decrease / cand.pred if cand.pred > 0 else 0.0,
                                      cand.step)
            if decrease <= tol * (st.f + decrease) and \
                    cand.pred <= CONVERGED_PRED_FACTOR * tol * (st.f + decrease):
                return st.stop("converged: relative decrease below tol", True)
            return False
        # the objective did not decrease
        if not safeguarded:
            if stationary:
                return st.stop("objective stopped decreasing at a stationary point", True)
            return st.stop("objective stopped decreasing after a full Taylor step, but the point "
                           "is not stationary (paper mode stopped early)", False)
        if stationary:
            return st.stop("converged: no further decrease predicted", True)
        st.radius = min(st.radius, cand.step) / TR_SHRINK
        if st.radius < TR_COLLAPSE:
            return st.stop("trust region collapsed without reaching a stationary point", False)
        return False


@dataclass
class _Linearisation:
    """The QP of one iteration: [A E] (scaled Jacobian and the s columns), r0, its QR factor R,
    Q^T r0, the unit ||Q^T r0||, the irreducible part c0 of ||r0||^2, and the scales D."""

    AE: np.ndarray
    r0: np.ndarray
    R: np.ndarray
    b: np.ndarray
    unit: float
    c0: float
    scales: np.ndarray


@dataclass
class _Candidate:
    x: dict
    f: float
    pred: float
    step: float


@dataclass
class _FitState:
    """Everything one fit changes (local to the call: an Estimator itself is never mutated)."""

    mdl: ChartModel
    Mv: np.ndarray
    wt: np.ndarray
    noise_known: bool
    scale: float
    s_fixed: np.ndarray | None
    f_exact: float
    x: dict = field(default_factory=dict)
    f: float = np.inf
    initial: dict = field(default_factory=dict)
    radius: float = TR_RADIUS0
    history: list = field(default_factory=list)
    trials: list = field(default_factory=list)
    status: str = ""
    converged: bool = False
    qp_value: float = 0.0
    n_solves: int = 0
    t_solve: float = 0.0
    t_clarabel: float = 0.0
    rescues: int = 0
    #: 1 / sigma (scaled units) of the photon and read noise alone (``wt`` adds the budget's
    #: per-patch term); None where the noise is unknown
    wt_photon: np.ndarray | None = None
    #: the budget's nuisance values at the fit (name -> float, or (m,) for 'balance')
    nuisance: dict = field(default_factory=dict)
    #: the model the inference layer fits (:meth:`sca.ChartModel.reduced`, or ``mdl`` itself
    #: where the quadrature is full or its certificate failed at the optimum)
    fit_mdl: ChartModel | None = None
    #: the largest reduction error at the optimum, in sds of the values (0: the full grid)
    quadrature_error: float = 0.0

    def stop(self, status: str, converged: bool) -> bool:
        self.status, self.converged = status, converged
        return True


def _solve(problem) -> str:
    """Solve with Clarabel; on failure retry with the fallbacks of ``CLARABEL_FALLBACKS``.

    Returns '' on success, else the reasons of every attempt.
    """
    import cvxpy as cp
    reasons = []
    for settings in CLARABEL_FALLBACKS:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # 'Solution may be inaccurate': judged below
                problem.solve(solver=cp.CLARABEL, warm_start=False, **settings)
        except (cp.SolverError, ValueError, ArithmeticError) as exc:
            reasons.append(f"{type(exc).__name__}: {exc}")
            continue
        if problem.status in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE) and problem.value is not None:
            return ""
        reasons.append(f"status {problem.status}")
    return "; ".join(reasons)



def estimate(rgb, *, depth, distance, sigma=None, saturation=None, camera=DEFAULT_CAMERA,
             illuminant=None, reflectances=None, wavelengths=None, basis=None,
             mode: str = "safeguarded", max_iter: int = 100,
             tol: float = 1e-10, fix=None, free=(), x0=None, water: Water | None = None,
             path_model: str | None = None, cdom_slope: float | None = None,
             setup: ChartSetup | None = None, gain: str = "known", uncertain=None,
             path_models=None, quadrature: str = "reduced", auxiliary=None) -> Estimate:
    """Estimate C, a_CDOM(440), w and backscatter s from a chart's patch values (eqs 15-18).

    Parameters
    ----------
    rgb : array_like, (m, n)
        Measured patch values in the model units of :func:`forward.simulate_chart`
        (exposure-normalised: a white reflector in air = 1 in the reference channel), or any
        units with ``gain='free'``.
    depth, distance : float
        The path of the measurement, m (keyword-only).
    sigma : float or (m, n), optional
        Standard deviation of each value of ``rgb`` (same units), e.g.
        ``forward.simulate_chart(...).rgb_sigma``. The fit is then weighted least squares, its
        chi^2 is tested and the intervals use the known noise. Without it the noise is
        estimated from the residual, the fit cannot be tested, and the estimate is not
        ``reliable`` (flag ``noise-unknown``).
    saturation : float, optional
        The sensor's clip level in the units of ``rgb`` for the ``saturated`` check; without
        it two values tied at the maximum count as clipped.
    camera, illuminant, reflectances, wavelengths, basis, setup :
        As :func:`forward.simulate_chart`; must describe the same camera and chart as the data.
    mode : {'safeguarded', 'paper', 'lm'}
        The safeguarded loop (default), the paper's literal loop, or 'lm': the batch's engine
        on this chart (variable projection and Levenberg-Marquardt, :mod:`sca.lm`; no cvxpy),
        which reaches the loop's optimum wherever the loop converges (decision
        0007-start-up); the verdict, intervals and budget are the same ``assess``'s.
    max_iter : int
        Maximum number of convex subproblems (Levenberg-Marquardt iterations with 'lm').
    tol : float
        Relative objective decrease at which the loop stops ('lm' stops at
        :data:`sca.lm.LM_TOL`).
    fix : dict, optional
        Held parameters, e.g. ``{'backscatter': 0}`` (chart a few cm away), ``{'cdom': 0.1}``
        or a forward.Water coefficient ``{'cdom_slope': 0.016}``.
    free : sequence of str
        Parameters estimated besides C, a_CDOM and s: any forward.Water coefficient of c(x)
        (e.g. ``('cdom_slope',)``: eq 6's slope, "usually between 0.014 and 0.019"), 'depth',
        'distance' or 'gain'. Each is one more linearised variable of the loop; its estimate
        and 95 % profile-likelihood interval are in ``values`` and ``intervals``.
    x0 : dict, optional
        Start ``{'chl': ..., 'cdom': ...}`` (and any free name) instead of the coarse grid.
    water : forward.Water, optional
        Constants, tables and path model (default the paper's); ``path_model`` and
        ``cdom_slope`` replace those fields.
    gain : {'known', 'free'}
        'known' (default: ``rgb`` in model units) or 'free': M = gain G(x) + s 1^T with the
        unknown exposure gain estimated with the water (``Estimate.gain``, ``gain_ci``); the
        intervals of the other parameters include its uncertainty.
    uncertain : dict, optional
        The uncertainty budget, name -> standard deviation (:mod:`sca.budget`): 'depth' and
        'distance' (m, or ``"5%"``), forward.Water constants (e.g. 'cdom_slope', nm^-1),
        'balance' (relative, per channel) and 'patch' (relative per-patch systematic error).
        Default (None): :data:`sca.budget.DEFAULT_UNCERTAIN`; ``{}``: the paper's exact model.
        With ``sigma`` the loop fits with the per-patch term in the noise and the nuisances
        at their priors' centres, then the one Levenberg-Marquardt engine (:mod:`sca.lm`)
        moves every nuisance within its prior to the penalised optimum; the intervals profile
        the nuisances, and ``Estimate.budget`` gives each source's share of the variance.
    path_models : sequence of str, optional
        The path models fitted (:mod:`sca.pathmodels`): the best-fitting is chosen by
        likelihood ratio, and where several fit about equally well the intervals span them
        (flag ``path-model-span``). Default: all of :data:`forward.water.PATH_MODELS` where a
        budget applies (``sigma`` given, ``uncertain`` not ``{}``), else only the water's.
    quadrature : {'reduced', 'full'}
        The grid of the Levenberg-Marquardt fits, the budget's refinement and the intervals:
        'reduced' (default) eq 1's integral on the certified 5 nm quadrature
        (:mod:`sca.quadrature`; the optimum checked against the full grid, and refitted on it
        where they differ by more than :data:`sca.quadrature.CERTIFY_SIGMA` of a value's
        noise), 'full' the grid as given. The convex loops ('safeguarded', 'paper') always
        run on the grid as given.
    auxiliary : dict, optional
        What was measured besides the photo (:func:`sca.auxiliary.auxiliary_observations`:
        'cdom' (value, sd) m^-1, 'secchi' (depth, sd) m, 'kd' {nm: (value, sd)} m^-1), fused
        in the fit from the budget's refinement on, and in the intervals (needs ``sigma``).

    Returns
    -------
    Estimate

    Notes
    -----
    Safe to call from several threads (each thread compiles its own subproblem).

    References
    ----------
    Blasinski & Farrell, "A Three Parameter Underwater Image Formation Model", eqs 15-18 (the
    problem and its sequential convex loop); J. Nocedal & S. J. Wright, Numerical
    Optimization, 2nd ed., Springer (2006), Algorithm 4.1 (the trust region of
    ``mode='safeguarded'``); D. J. Venzon & S. H. Moolgavkar, "A method for computing
    profile-likelihood-based confidence intervals", Applied Statistics 37 (1988) 87-94.

    Examples
    --------
    >>> import forward, sca
    >>> sim = forward.simulate_chart(2.0, 0.1, depth=5, distance=1, seed=0)
    >>> est = sca.estimate(sim.rgb, depth=5, distance=1, sigma=sim.rgb_sigma)
    >>> est.verdicts["c_490"], est.verdicts["chl"]
    ('measured', 'upper bound')
    >>> lo, hi = est.quantity_intervals["c_490"]
    >>> print(f"c(490) = {est.quantities['c_490']:.2f} m^-1, 95 % [{lo:.2f}, {hi:.2f}]")
    c(490) = 0.13 m^-1, 95 % [0.12, 0.15]
    """
    kw = dict(depth=depth, distance=distance, camera=camera, illuminant=illuminant,
              reflectances=reflectances, wavelengths=wavelengths, basis=basis, fix=fix,
              free=free, setup=setup, gain=gain, uncertain=uncertain, quadrature=quadrature,
              auxiliary=auxiliary)
    if auxiliary and sigma is None:
        raise InputError("auxiliary", "needs the photo's noise (sigma) to weigh against")
    est = Estimator(water=water, path_model=path_model, cdom_slope=cdom_slope, **kw)
    fit = dict(sigma=sigma, saturation=saturation, mode=mode, max_iter=max_iter, tol=tol, x0=x0)
    return over_path_models(est, path_models, sigma, lambda e: e.settle(rgb, **fit), kw)


def over_path_models(est: "Estimator", path_models, sigma, run, kw) -> Estimate:
    """``run(estimator)`` (a :class:`sca.verdict.Settled` fit) under every candidate path model
    (:func:`sca.pathmodels.candidates`), then each candidate finished
    (:func:`sca.verdict.finish`) only where the data support it
    (:func:`sca.pathmodels.supported`), the known gain's test only under the chosen one, and
    the results combined (:func:`sca.pathmodels.combine_single`: an unsupported candidate's
    intervals and tests are never read, so the result is that of finishing every candidate);
    ``kw``: the other arguments of :class:`Estimator`."""
    models = candidates(path_models, est.water, sigma is not None and not est.budget.exact)
    first = run(est)
    if len(models) == 1:
        first = tested(finish(first))
        return dataclasses.replace(first, path_models=(est.water.path_model,),
                                   path_objective={est.water.path_model: first.objective})
    settled = {models[0]: first}
    for m in models[1:]:
        settled[m] = run(Estimator(water=dataclasses.replace(est.water, path_model=m), **kw))
    best, ok = supported(np.array([[s.objective for s in settled.values()]]))
    return combine_single({m: finish(s, scale_test=bool(j == best[0])) if ok[0, j] else s
                           for j, (m, s) in enumerate(settled.items())})
