"""The paper's estimator (eqs 15-18): sequential convex programming in cvxpy with Clarabel.

At iteration t the attenuation k(x) and the equality (17) are replaced by their first-order
Taylor expansions around x_t, the resulting QP (:mod:`sca.subproblem`) is solved, and its
solution becomes x_{t+1}; the loop repeats until the objective, evaluated with the true
nonlinear k, no longer decreases.

Two modes (DECISIONS.md):

* ``mode="paper"`` -- the literal loop: full Taylor steps, stop at the first step that does not
  decrease the objective (the previous point is returned).
* ``mode="safeguarded"`` (default) -- the same subproblem inside a trust region on the scaled
  parameters, shrunk when the true objective rises and grown when the model predicts well;
  iterates are put back on eq 17 (w rescaled) and s is re-fitted in closed form; stops when the
  relative decrease of the objective falls below ``tol`` or the model predicts none.

``converged`` is True only where the returned point is stationary (the subproblem predicts a
relative decrease below ``tol``) or fits the data to rounding error; every other end is
reported in ``status``.

The loop's parts (methods of :class:`Estimator`): ``_linearise`` (the QP's data at the current
point), ``_set_subproblem`` / ``_solve_step`` (Clarabel, its fallbacks, the active-set polish),
``_candidate`` (the trial point and the decrease the model predicts), ``_judge`` (acceptance and
the trust-region update, :func:`_update_radius`) and ``_result``.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field

import cvxpy as cp
import numpy as np
from scipy import stats

from forward import validate
from forward.imaging import ChartSetup, resolve_setup
from forward.spectra import DEFAULT_CAMERA
from forward.water import Water, resolve_water

from ._batch_kernel import BOUND_OPEN, gain_variance, intervals_serial, linear_part_numpy
from .assess import (
    CDOM_MAX,
    CHL_MAX,
    CONFIDENCE,
    estimate_flags,
    gain_wald,
    goodness,
    input_flags,
    is_reliable,
    profile_delta,
)
from .model import WaterModel, chl_weights_u
from .subproblem import compiled_subproblem, equality_step, polish

MODES = ("paper", "safeguarded")
FIXABLE = ("chl", "cdom", "backscatter")
#: 'known': the data are in model units (exposure-normalised); 'free': M = gain G(x) + s 1^T
#: with one unknown scalar gain (a photograph's exposure, any units), estimated with the water
GAINS = ("known", "free")

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

#: Coarse initial search grids (deterministic, independent of the data's truth).
INIT_CHL = np.concatenate([[0.0], np.logspace(-3, 2, 26)])
INIT_CDOM = np.concatenate([[0.0], np.logspace(-3, np.log10(3.0), 18)])

#: Relative objective at which the fit is exact to rounding error: ||residual|| <= 1e-12 ||M||.
EXACT_FIT = 1e-24
#: Largest accepted measurement: model units are O(1), and larger values overflow the
#: objective in data units (its square).
MAX_RGB = 1e150

# Trust region of the safeguarded mode, on the scaled unknowns (Nocedal & Wright, Numerical
# Optimization, 2nd ed., Springer 2006, Algorithm 4.1, with eta = 0: any decrease is accepted):
#: initial radius Delta_0
TR_RADIUS0 = 1.0
#: rho = actual / predicted decrease below this: shrink (Alg. 4.1's 1/4)
TR_ETA_SHRINK = 0.25
#: rho above this, with the step at the boundary: grow (Alg. 4.1's 3/4)
TR_ETA_GROW = 0.75
#: shrink divisor (Alg. 4.1: Delta / 4) and growth factor (Alg. 4.1: 2 Delta)
TR_SHRINK, TR_GROW = 4.0, 2.0
#: a step of at least this fraction of the radius counts as "at the boundary" (||p|| = Delta)
TR_AT_EDGE = 0.9
#: largest radius (Alg. 4.1's Delta-hat) and the floor after a shrink
TR_RADIUS_MAX, TR_RADIUS_MIN = 1e4, 1e-14
#: after a rejected step the radius falls to ||step|| / 4; below this the loop gives up
TR_COLLAPSE = 1e-12


@dataclass
class Estimate:
    """Result of :func:`estimate`. Units: chl mg m^-3, cdom and attenuation coefficient m^-1,
    backscatter and objective in the units of the measurements."""

    chl: float
    cdom: float
    #: standard errors of chl and cdom from the Gauss-Newton covariance at the estimate (with
    #: the residual as noise estimate): large values say the data cannot decide (e.g. a chart
    #: too dark to measure); 0 for a fixed parameter or an exact (noise-free) fit
    chl_se: float
    cdom_se: float
    #: 95 % profile-likelihood intervals (lower end 0 where the data allow 0, upper end inf
    #: where they cannot bound the parameter); Wald intervals for z > 1 basis functions
    chl_ci: tuple
    cdom_ci: tuple
    #: True only when nothing in ``flags`` blocks it (sca.assess.BLOCKING)
    reliable: bool
    flags: tuple
    fit_rms: float  # ||M - G - s|| / ||M||
    chi2_dof: float  # reduced chi^2 of the whitened residual (NaN: noise unknown)
    chi2_p: float  # its p-value
    dof: int
    noise_known: bool
    w: np.ndarray
    backscatter: np.ndarray
    attenuation: np.ndarray
    attenuation_coefficient: np.ndarray
    wavelengths: np.ndarray
    objective: float  # chi^2 when the noise is known, else ||M - G - s||^2 (data units)
    iterations: int
    converged: bool
    status: str
    history: list
    mode: str
    initial: dict
    fixed: dict
    eq17_residual: float
    solve_time_s: float = 0.0  # wall time inside cvxpy's solve calls
    clarabel_time_s: float = 0.0  # of which Clarabel itself (its own timer)
    n_solves: int = 0
    polish_rescues: int = 0  # subproblems Clarabel stopped early that the polish completed
    #: the true objective of every trial point, accepted or not (``history`` keeps the accepted)
    trials: list = field(default_factory=list)
    path_model: str = "beam"
    #: the exposure gain of M = gain G(x) + s (1 where it is known, ``gain="free"`` estimates it)
    gain: float = 1.0
    #: its 95 % Wald interval (Gauss-Newton standard error); (gain, gain) where it is known
    gain_ci: tuple = (1.0, 1.0)
    step_history: list = field(default_factory=list, repr=False)

    def to_dict(self) -> dict:
        out = {}
        for key, val in self.__dict__.items():
            if key == "step_history":
                continue
            out[key] = val.tolist() if isinstance(val, np.ndarray) else val
        out["fixed"] = {k: (np.asarray(v).tolist()) for k, v in self.fixed.items()}
        return out


class Estimator:
    """Estimator for one (camera, illuminant, chart, grid, water model, basis): build once, fit many.

    The cvxpy subproblem is compiled once per problem structure and per thread (see
    :func:`sca.subproblem.compiled_subproblem`); only parameter values change per iteration.
    An ``Estimator`` holds no state that a fit changes, so one may be shared between threads.
    """

    def __init__(self, *, depth, distance, camera=DEFAULT_CAMERA, illuminant=None,
                 reflectances=None, wavelengths=None, basis=None, water: Water | None = None,
                 path_model: str | None = None, cdom_slope: float | None = None, fix=None,
                 setup: ChartSetup | None = None, gain: str = "known"):
        if gain not in GAINS:
            raise ValueError(f"gain: must be one of {GAINS}, got {gain!r}")
        self.free_gain = gain == "free"
        depth = validate.scalar("depth", depth)
        distance = validate.scalar("distance", distance)
        self.setup = setup = resolve_setup(setup, camera, illuminant, reflectances, wavelengths)
        self.water = resolve_water(water, path_model=path_model, cdom_slope=cdom_slope)
        self.model = WaterModel(setup, depth, distance, basis=basis, water=self.water)
        self.depth, self.distance = depth, distance
        self.fixed = self._parse_fix(fix)
        mdl = self.model
        self.free_chl = "chl" not in self.fixed
        self.free_cdom = "cdom" not in self.fixed
        # with C fixed and one basis function, eq 17 fixes w too
        self.free_w = self.free_chl or mdl.z > 1
        self.free_s = "backscatter" not in self.fixed
        # eq 16's T w >= 0: with one nonnegative basis function it is simply w >= 0, a bound
        # like those on C and a_CDOM (one row instead of q in the subproblem)
        self.w_bound = self.free_w and mdl.z == 1 and bool(np.all(mdl.T >= 0) and np.any(mdl.T > 0))
        # the QP's delta: (gain?, C?, a_CDOM?, w...) -- the bounded ones first
        fg = int(self.free_gain)
        n_pos = fg + int(self.free_chl) + int(self.free_cdom) + int(self.w_bound)
        self.n_pos = n_pos
        self.n_free = fg + int(self.free_chl) + int(self.free_cdom) + (mdl.z if self.free_w else 0)
        if self.n_free == 0 and not self.free_s:
            raise ValueError("fix: nothing is left to estimate")
        n_cc = fg + int(self.free_chl) + int(self.free_cdom)
        self.w_slice = (n_cc, n_cc + mdl.z) if self.free_w else None
        self.chl_pos = fg  # where C sits in delta
        # the free entries of the extended x = (C, a_CDOM, w_1..w_z, gain) in delta's order
        self.cols = ([2 + mdl.z] if self.free_gain else []) + ([0] if self.free_chl else []) + \
            ([1] if self.free_cdom else []) + (list(range(2, 2 + mdl.z)) if self.free_w else [])

    def _parse_fix(self, fix):
        if fix is None:
            return {}
        if not isinstance(fix, dict):
            raise ValueError("fix: expected a dict like {'backscatter': 0, 'cdom': 0.1}")
        out = {}
        for key, val in fix.items():
            if key not in FIXABLE:
                raise ValueError(f"fix: unknown parameter {key!r}; choose from {FIXABLE}")
            if key == "backscatter":
                arr = validate.array("fix['backscatter']", np.broadcast_to(val, (self.model.m,)),
                                     nonnegative=True)
                out[key] = np.array(arr, dtype=float)
            else:
                out[key] = validate.scalar(f"fix[{key!r}]", val)
        return out

    # ----------------------------------------------------------------------------- helpers
    def _check_rgb(self, rgb):
        shape = (self.model.m, self.model.n)
        M = validate.array("rgb", rgb, shape=shape)
        if np.any(M < 0):
            raise ValueError(f"rgb: contains negative values (min {M.min():g}); measurements are "
                             "exposure-normalised sensor values >= 0")
        if M.max() > MAX_RGB:
            raise ValueError(f"rgb: values up to {M.max():g} exceed {MAX_RGB:g}; measurements in "
                             "model units are O(1) (a white reflector in air = 1)")
        return M

    @staticmethod
    def _objective(mdl, Mv, chl, cdom, w, s, gain=1.0):
        k = mdl.attenuation(chl, cdom, w)
        r = mdl.residual(Mv, gain * k, s)
        return float(r @ r), k

    def linear_part(self, mdl, Mv, G, s_fixed=None):
        """The closed-form linear unknowns for signals ``G`` (..., m n): (gain, s), gain >= 0
        and s >= 0 minimising the (whitened) residual; gain = 1 where it is known."""
        if not self.free_gain:
            s = mdl.best_backscatter(Mv, G, s_fixed)
            return np.ones(G.shape[:-1]), s
        G3 = np.asarray(G, float).reshape((-1, mdl.m, mdl.n))
        M3 = np.broadcast_to(np.asarray(Mv, float).reshape(1, mdl.m, mdl.n), G3.shape)
        fs = None if s_fixed is None else np.broadcast_to(s_fixed, (G3.shape[0], mdl.m))
        gain, s, _ = linear_part_numpy(M3, G3, (mdl.wt ** 2).reshape(1, mdl.m, mdl.n), fs)
        return gain.reshape(G.shape[:-1]), s.reshape(G.shape[:-1] + (mdl.m,))

    def check_sigma(self, sigma):
        """``sigma`` (None, a scalar or (m, n), data units) as a (m, n) array or None."""
        if sigma is None:
            return None
        shape = (self.model.m, self.model.n)
        arr = validate.array("sigma", sigma)
        if arr.ndim == 0:
            arr = np.full(shape, float(arr))
        if arr.shape != shape:
            raise ValueError(f"sigma: expected a scalar or shape {shape}, got {arr.shape}")
        if np.any(arr <= 0):
            raise ValueError(f"sigma: standard deviations must be > 0 (min {arr.min():g})")
        return arr

    def prepare(self, rgb, sigma=None):
        """Validate ``rgb`` (and ``sigma``) and scale the problem: returns (vec(M) / max M,
        max M, the model in those units -- whitened by ``sigma`` when given --, the fixed
        backscatter in those units or None)."""
        M = self._check_rgb(rgb)
        sig = self.check_sigma(sigma)
        scale = float(np.max(M))
        if scale <= 0:
            raise ValueError("rgb: all values are zero; nothing to fit")
        s_fixed = None if self.free_s else self.fixed["backscatter"] / scale
        mdl = self.model.scaled(scale, None if sig is None else sig.ravel())
        return M.ravel() / scale, scale, mdl, s_fixed

    def initial_point(self, Mv, x0=None, mdl=None, s_fixed=None):
        """Deterministic start: a coarse grid search over (C, a_CDOM) with w on eq 17 and the
        closed-form s, unless ``x0`` (dict with 'chl' and/or 'cdom') gives it. ``mdl`` and
        ``s_fixed`` are those of :meth:`prepare` (default: the unscaled model, s free)."""
        mdl = self.model if mdl is None else mdl
        chl_grid = np.array([self.fixed["chl"]]) if not self.free_chl else INIT_CHL
        cdom_grid = np.array([self.fixed["cdom"]]) if not self.free_cdom else INIT_CDOM
        if x0 is not None:
            if not isinstance(x0, dict) or not set(x0) <= {"chl", "cdom"}:
                raise ValueError("x0: expected a dict with keys 'chl' and/or 'cdom'")
            if "chl" in x0 and self.free_chl:
                chl_grid = np.array([validate.scalar("x0['chl']", x0["chl"])])
            if "cdom" in x0 and self.free_cdom:
                cdom_grid = np.array([validate.scalar("x0['cdom']", x0["cdom"])])
        C, A = np.meshgrid(chl_grid, cdom_grid, indexing="ij")
        C, A = C.ravel(), A.ravel()
        u = np.full(mdl.z, 1.0 / mdl.z)
        W = np.multiply.outer(mdl.phyto_scale(C) / float(mdl.t440 @ u), u)
        k = mdl.attenuation(C, A, W)
        G = mdl.signal(k)
        gain, s = self.linear_part(mdl, Mv, G, s_fixed)
        r = mdl.wt * (Mv - gain[:, None] * G - np.repeat(s, mdl.n, axis=-1))
        f = np.einsum("ij,ij->i", r, r)
        j = int(np.argmin(f))
        return float(C[j]), float(A[j]), W[j].copy()

    # ----------------------------------------------------------------------------- the loop
    def fit(self, rgb, *, sigma=None, saturation=None, mode: str = "safeguarded",
            max_iter: int = 100, tol: float = 1e-10, x0=None) -> Estimate:
        """Run the sequential convex loop on measured patch values ``rgb`` (m, n), then assess
        the fit (:mod:`sca.assess`); see :func:`sca.estimate`."""
        if mode not in MODES:
            raise ValueError(f"mode: must be one of {MODES}, got {mode!r}")
        if int(max_iter) != max_iter or max_iter < 1:
            raise ValueError(f"max_iter: must be a positive integer, got {max_iter!r}")
        tol = validate.scalar("tol", tol, positive=True)
        if saturation is not None:
            saturation = validate.scalar("saturation", saturation, positive=True)
        Mv, scale, mdl, s_fixed = self.prepare(rgb, sigma)
        return self._loop(mdl, Mv, scale, s_fixed, mode, int(max_iter), tol, x0, saturation)

    def _loop(self, mdl, Mv, scale, s_fixed, mode, max_iter, tol, x0, saturation=None):
        """Linearise, solve the QP, judge the step with the true objective, repeat."""
        safeguarded = mode == "safeguarded"
        sub = compiled_subproblem(self.n_free, self.n_pos, None if self.w_bound else self.w_slice,
                                  mdl.wavelengths.size, mdl.m if self.free_s else 0, safeguarded,
                                  self.free_w)
        Mw = mdl.wt * Mv
        st = _FitState(mdl=mdl, Mv=Mv, s_fixed=s_fixed, f_exact=EXACT_FIT * float(Mw @ Mw))
        chl, cdom, w = self.initial_point(Mv, x0, mdl, s_fixed)
        st.initial = {"chl": chl, "cdom": cdom}
        gain, s = self.linear_part(mdl, Mv, mdl.signal(mdl.attenuation(chl, cdom, w)), s_fixed)
        gain, s = float(gain), np.array(s, dtype=float)
        st.x = (chl, cdom, w, s, gain)
        st.f, _ = self._objective(mdl, Mv, chl, cdom, w, s, gain)
        st.history.append(st.f)
        it = 0
        for it in range(1, max_iter + 1):
            if st.f <= st.f_exact:
                st.stop("exact fit (objective at rounding level)", True)
                it -= 1
                break
            lin = self._linearise(st)
            if lin.unit <= 1e-300:
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
        return self._result(st, scale, mode, it, saturation)

    def _linearise(self, st) -> "_Linearisation":
        """The QP data at the current point: scaled Jacobian [A E] = Q R and the residual."""
        mdl = st.mdl
        chl, cdom, w, s, gain = st.x
        k, dk = mdl.attenuation_jacobian(chl, cdom, w)
        J = dk.T @ mdl.B.T  # (2 + z, m n)
        D_gain = gain if gain > 0 else 1.0
        if self.free_gain:  # rows of the extended x: gain dG/dx, then dG/dgain = G
            J = np.vstack([gain * J, mdl.signal(k)[None]])
        D_chl = max(chl, CHL_SCALE_MIN)
        D_cdom = max(cdom, CDOM_SCALE_MIN)
        w_min = float(mdl.phyto_scale(CHL_SCALE_MIN)) / (mdl.z * float(np.max(mdl.t440)))
        D_w = np.maximum(np.abs(w), w_min)
        scales = np.array(([D_gain] if self.free_gain else []) + ([D_chl] if self.free_chl else [])
                          + ([D_cdom] if self.free_cdom else []) + (list(D_w) if self.free_w else []))
        r0 = mdl.residual(st.Mv, gain * k, s)  # whitened when the noise is known
        AE = J[self.cols].T * scales
        if self.free_s:
            AE = np.hstack([AE, mdl.E])
        AE = AE * mdl.wt[:, None]
        Q, Rm = np.linalg.qr(AE)
        b = Q.T @ r0
        unit = float(np.linalg.norm(b))  # the step is solved for in units of ||Q^T r0||
        c0 = max(float(r0 @ r0 - b @ b), 0.0)  # the part of ||r0||^2 no step can remove
        return _Linearisation(AE, r0, Rm, b, unit, c0, scales, D_chl, D_cdom, D_w, D_gain)

    def _eq17_row(self, st, lin):
        """Eq 17 linearised: t440.(w + D_w dw) = alpha(C) + alpha'(C) D_C dC, as (row, rhs)."""
        if not self.free_w:
            return None, 0.0
        mdl = st.mdl
        chl, _, w, _, _ = st.x
        row = np.zeros(lin.R.shape[1])
        row[self.w_slice[0]:self.w_slice[1]] = mdl.t440 * lin.D_w
        if self.free_chl:
            alpha, dalpha = mdl.phyto_scale(chl, derivative=True)
            row[self.chl_pos] = -float(dalpha) * lin.D_chl
            return row, float(alpha) - float(mdl.t440 @ w)
        return row, float(mdl.phyto_scale(self.fixed["chl"])) - float(mdl.t440 @ w)

    def _set_subproblem(self, sub, lin, st, safeguarded):
        """Write the QP's parameters (all in units of ``lin.unit``)."""
        mdl = st.mdl
        chl, cdom, w, s, gain = st.x
        unit = lin.unit
        sub.R.value = lin.R
        sub.b.value = lin.b / unit
        eq_row, eq_rhs = self._eq17_row(st, lin)
        # Bounds far beyond any step the model can want only hurt the interior-point start;
        # they are capped at BOUND_CAP times the least-squares step that respects the
        # linearised eq 17 (without it, C and w are nearly collinear and the unconstrained
        # step is meaningless).
        v_ls = equality_step(lin.R, lin.b / unit, eq_row, eq_rhs / unit)
        cap = BOUND_CAP * max(1.0, float(np.max(np.abs(v_ls))))
        if self.free_s:
            sub.s_lo.value = np.maximum(-s / unit, -cap)
        if self.n_pos:
            lo = ([-gain / lin.D_gain] if self.free_gain else []) + \
                ([-chl / lin.D_chl] if self.free_chl else []) + \
                ([-cdom / lin.D_cdom] if self.free_cdom else []) + \
                ([-float(w[0]) / float(lin.D_w[0])] if self.w_bound else [])
            sub.lo.value = np.maximum(np.array(lo) / unit, -cap)
        if safeguarded and self.n_free:
            sub.hi.value = np.full(self.n_free, min(st.radius / unit, cap))
        if self.free_w:
            if not self.w_bound:
                TDw = mdl.T * lin.D_w
                sub.TDw.value = TDw
                sub.Tw_rhs.value = np.maximum(-(mdl.T @ w) / unit, -cap * np.abs(TDw).sum(axis=1))
            sub.a_eq.value = eq_row[:self.n_free]
            sub.b_eq.value = eq_rhs / unit

    def qp_problem(self, sub, lin):
        """The cvxpy problem and variable solved each iteration: the compiled DPP problem.
        (A benchmark baseline overrides this to rebuild the problem every time.)"""
        return sub.problem, sub.v

    def _solve_step(self, sub, lin, st, safeguarded):
        """Solve the QP (with the fallbacks and the active-set polish): the step in data units
        and '' or the reasons it failed."""
        self._set_subproblem(sub, lin, st, safeguarded)
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
            # in safeguarded mode). Counted in ``polish_rescues``.
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
        mdl = st.mdl
        chl, cdom, w, s, gain = st.x
        delta = v[:self.n_free]
        full = np.zeros(3 + mdl.z)  # extended x: (C, a_CDOM, w, gain)
        full[self.cols] = delta * lin.scales
        chl_new = max(chl + full[0], 0.0) if self.free_chl else chl
        cdom_new = max(cdom + full[1], 0.0) if self.free_cdom else cdom
        w_new = w + full[2:2 + mdl.z] if self.free_w else w
        gain_new = max(gain + full[2 + mdl.z], 0.0) if self.free_gain else gain
        if safeguarded:  # feasibility restoration: w back on eq 17, gain and s re-fitted in
            # closed form
            w_new = mdl.feasible_w(chl_new, w_new)
            G_new = mdl.signal(mdl.attenuation(chl_new, cdom_new, w_new))
            gain_new, s_new = self.linear_part(mdl, st.Mv, G_new, st.s_fixed)
            gain_new, s_new = float(gain_new), np.array(s_new, dtype=float)
        else:
            s_new = np.maximum(s + v[self.n_free:], 0.0) if self.free_s else s.copy()
        f_new, _ = self._objective(mdl, st.Mv, chl_new, cdom_new, w_new, s_new, gain_new)
        pred = st.f - (st.qp_value * lin.unit**2 + lin.c0)
        step = float(np.max(np.abs(delta))) if delta.size else 0.0
        st.steps.append(step)
        st.trials.append(f_new)
        return _Candidate((chl_new, cdom_new, w_new, s_new, gain_new), f_new, pred, step)

    def _judge(self, st, cand, tol, safeguarded) -> bool:
        """Accept or reject the candidate, update the trust region; True when the loop stops."""
        stationary = cand.pred <= tol * st.f or st.f <= st.f_exact
        if cand.f < st.f:  # accept
            decrease = st.f - cand.f
            st.x, st.f = cand.x, cand.f
            st.history.append(st.f)
            if not safeguarded:
                return False
            st.radius = _update_radius(st.radius, decrease / cand.pred if cand.pred > 0 else 0.0,
                                       cand.step)
            if decrease <= tol * (st.f + decrease) and cand.pred <= 10 * tol * (st.f + decrease):
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

    def _result(self, st, scale, mode, it, saturation=None) -> Estimate:
        """The Estimate of a finished fit, assessed (sca.assess): input sanity of the data,
        goodness of fit, intervals, flags and the verdict."""
        mdl = st.mdl
        chl, cdom, w, s, gain = st.x
        se_chl, se_cdom = mdl.standard_errors(st.Mv, chl, cdom, w, s,
                                              (self.free_chl, self.free_cdom), st.s_fixed,
                                              gain if self.free_gain else None)
        unit = 1.0 if mdl.noise_known else scale * scale  # objective: chi^2 or data units
        r = mdl.residual(st.Mv, gain * mdl.attenuation(chl, cdom, w), s) / mdl.wt
        n_s = 0 if not self.free_s else int(np.sum(np.asarray(s) > 0))
        dof = mdl.m * mdl.n - int(self.free_chl) - int(self.free_cdom) - n_s \
            - (mdl.z - 1 if self.free_w else 0) - int(self.free_gain)
        chi2_dof, chi2_p = goodness(st.f, dof, mdl.noise_known)
        chl_ci, cdom_ci, codes = self._intervals(st, se_chl, se_cdom, dof)
        gain_ci = self._gain_interval(st, dof)
        flags = estimate_flags(converged=st.converged, noise_known=mdl.noise_known,
                               p_value=float(chi2_p), chl=chl, cdom=cdom, chl_ci=chl_ci,
                               cdom_ci=cdom_ci, ci_codes=codes, free_chl=self.free_chl,
                               free_cdom=self.free_cdom)
        if codes is None and "no-interval" in flags:  # Wald intervals (z > 1)
            flags[flags.index("no-interval")] = "interval-approximate"
        sigma = (scale / mdl.wt).reshape(mdl.m, mdl.n) if mdl.noise_known else None
        flags = input_flags(st.Mv.reshape(mdl.m, mdl.n) * scale, sigma, saturation) + flags
        return Estimate(
            chl=float(chl), cdom=float(cdom), chl_se=se_chl, cdom_se=se_cdom,
            chl_ci=chl_ci, cdom_ci=cdom_ci, reliable=is_reliable(flags), flags=tuple(flags),
            fit_rms=float(np.linalg.norm(r) / np.linalg.norm(st.Mv)),
            chi2_dof=float(chi2_dof), chi2_p=float(chi2_p), dof=int(dof),
            noise_known=bool(mdl.noise_known),
            w=np.array(w, float), backscatter=s * scale,
            attenuation=mdl.attenuation(chl, cdom, w),
            attenuation_coefficient=mdl.coefficient(chl, cdom, w),
            wavelengths=mdl.wavelengths, objective=st.f * unit, iterations=it,
            converged=bool(st.converged), status=st.status,
            history=[f * unit for f in st.history], mode=mode, initial=st.initial,
            fixed=dict(self.fixed), eq17_residual=float(mdl.t440 @ w - mdl.phyto_scale(chl)),
            solve_time_s=st.t_solve, clarabel_time_s=st.t_clarabel, n_solves=st.n_solves,
            polish_rescues=st.rescues, trials=[f * unit for f in st.trials],
            path_model=self.water.path_model, gain=float(gain), gain_ci=gain_ci,
            step_history=st.steps,
        )

    def _gain_interval(self, st, dof):
        """95 % Wald interval of a free gain (``sca._batch_kernel.gain_variance``, the batch's
        too); (gain, gain) where it is known."""
        mdl = st.mdl
        chl, cdom, w, s, gain = st.x
        if not self.free_gain:
            return (float(gain), float(gain))
        if mdl.z != 1:  # no eq-17 reduction: the Wald interval of the general Jacobian
            return (float("nan"), float("nan"))
        terms = mdl.terms
        bm_phi, bm_dphi = chl_weights_u(mdl.water, np.array([chl]))
        var = gain_variance(bm_phi, bm_dphi, np.array([cdom]), np.array([float(mdl.L)]),
                            terms.shapes, terms.base, terms.cdom_shape, mdl.B.T, st.Mv[None],
                            (mdl.wt ** 2)[None], np.ones(1),
                            (st.s_fixed if st.s_fixed is not None else np.zeros(mdl.m))[None],
                            st.s_fixed is not None, mdl.m, mdl.n, np.array([gain]),
                            np.asarray(s, float)[None])
        lo, hi = gain_wald([gain], var, [st.f], [dof], mdl.noise_known)[0]
        return (float(lo), float(hi))

    def _intervals(self, st, se_chl, se_cdom, dof):
        """95 % intervals of C and a_CDOM: profile likelihood through the compiled profile of
        :mod:`sca._batch_kernel` (z = 1, w on eq 17: the same reduced problem), else Wald
        intervals from the standard errors (codes None)."""
        mdl = st.mdl
        chl, cdom, _, _, _ = st.x
        if mdl.z != 1:
            z95 = stats.norm.ppf(0.5 + CONFIDENCE / 2)
            return ((max(chl - z95 * se_chl, 0.0), chl + z95 * se_chl),
                    (max(cdom - z95 * se_cdom, 0.0), cdom + z95 * se_cdom), None)
        terms, water = mdl.terms, mdl.water
        has_fs = st.s_fixed is not None
        prob = (np.array([float(mdl.L)]), np.ones(1), np.ascontiguousarray(st.Mv[None]),
                np.ascontiguousarray((mdl.wt ** 2)[None]),
                np.ascontiguousarray((st.s_fixed if has_fs else np.zeros(mdl.m))[None]), has_fs,
                np.ascontiguousarray(terms.shapes), np.ascontiguousarray(terms.base),
                np.ascontiguousarray(terms.cdom_shape), np.ascontiguousarray(mdl.B.T), mdl.m,
                mdl.n, np.ascontiguousarray(water.chl_terms()), float(water.phyto_exponent),
                self.free_gain)
        e0 = float(water.phyto_exponent)
        Mw = mdl.wt * st.Mv
        delta = profile_delta(mdl.noise_known, np.array([st.f]), np.array([dof]),
                              np.array([Mw @ Mw]))
        ends, codes = intervals_serial(np.array([chl ** e0]), np.array([cdom]), delta, prob,
                                      self.free_chl, self.free_cdom, CHL_MAX ** e0, CDOM_MAX)
        ends, codes = ends[0], codes[0]
        chl_ci = [ends[0] ** (1 / e0), ends[1] ** (1 / e0)]
        cdom_ci = [ends[2], ends[3]]
        if codes[1] == BOUND_OPEN:
            chl_ci[1] = np.inf
        if codes[3] == BOUND_OPEN:
            cdom_ci[1] = np.inf
        return tuple(map(float, chl_ci)), tuple(map(float, cdom_ci)), tuple(int(c) for c in codes)


def _update_radius(radius, rho, step):
    """Trust-region radius after an accepted step (Nocedal & Wright, Alg. 4.1): grow when the
    model predicted the decrease well and the step reached the boundary, shrink when it did
    not."""
    if rho > TR_ETA_GROW and step >= TR_AT_EDGE * radius:
        return min(TR_GROW * radius, TR_RADIUS_MAX)
    if rho < TR_ETA_SHRINK:
        return max(radius / TR_SHRINK, TR_RADIUS_MIN)
    return radius


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
    D_chl: float
    D_cdom: float
    D_w: np.ndarray
    D_gain: float = 1.0


@dataclass
class _Candidate:
    x: tuple
    f: float
    pred: float
    step: float


@dataclass
class _FitState:
    """Everything one fit changes (local to the call: an Estimator itself is never mutated)."""

    mdl: WaterModel
    Mv: np.ndarray
    s_fixed: np.ndarray | None
    f_exact: float
    x: tuple = ()
    f: float = np.inf
    initial: dict = field(default_factory=dict)
    radius: float = TR_RADIUS0
    history: list = field(default_factory=list)
    trials: list = field(default_factory=list)
    steps: list = field(default_factory=list)
    status: str = ""
    converged: bool = False
    qp_value: float = 0.0
    n_solves: int = 0
    t_solve: float = 0.0
    t_clarabel: float = 0.0
    rescues: int = 0

    def stop(self, status: str, converged: bool) -> bool:
        self.status, self.converged = status, converged
        return True


def _solve(problem) -> str:
    """Solve with Clarabel; on failure retry with the fallbacks of ``CLARABEL_FALLBACKS``.

    Returns '' on success, else the reasons of every attempt.
    """
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
             tol: float = 1e-10, fix=None, x0=None, water: Water | None = None,
             path_model: str | None = None, cdom_slope: float | None = None,
             setup: ChartSetup | None = None, gain: str = "known") -> Estimate:
    """Estimate C, a_CDOM(440), w and backscatter s from a chart's patch values (eqs 15-18).

    Parameters
    ----------
    rgb : (m, n) measured patch values in the model units of :func:`forward.simulate_chart`
        (exposure-normalised: a white reflector in air = 1 in the reference channel).
    depth, distance : m, the path of the measurement (known to the diver).
    sigma : standard deviation of each value of ``rgb`` (scalar or (m, n), same units), e.g.
        ``forward.simulate_chart(...).rgb_sigma``. The fit is then weighted least squares, its
        chi^2 is tested and the intervals use the known noise. Without it the noise is
        estimated from the residual, the fit cannot be tested, and the estimate is not
        ``reliable`` (flag ``noise-unknown``).
    saturation : the sensor's clip level in the units of ``rgb`` (``ChartSimulation.saturation``)
        for the ``saturated`` check; without it two values tied at the maximum count as clipped.
    camera, illuminant, reflectances, wavelengths, basis : as in
        :func:`forward.simulate_chart`; must describe the same camera and chart as the data.
    water : :class:`forward.Water` (constants, tables, path model; default the paper's);
        ``path_model`` and ``cdom_slope`` replace those fields.
    mode : 'safeguarded' (default) or 'paper' (the literal loop).
    max_iter : maximum number of convex subproblems.
    tol : relative objective decrease at which the loop stops.
    fix : hold parameters fixed, e.g. ``{'backscatter': 0}`` (chart a few cm away) or
        ``{'cdom': 0.1}``; the loop then solves the smaller problem.
    x0 : optional start ``{'chl': ..., 'cdom': ...}`` instead of the coarse grid search.
    gain : 'known' (default: ``rgb`` in model units) or 'free': ``rgb`` in any units (a
        photograph's raw values), M = gain G(x) + s 1^T with the unknown exposure gain estimated
        with the water -- one more linearised variable of the loop (``Estimate.gain``,
        ``gain_ci``); the intervals of C and a_CDOM include its uncertainty.

    Safe to call from several threads (each thread compiles its own subproblem).
    """
    est = Estimator(depth=depth, distance=distance, camera=camera, illuminant=illuminant,
                    reflectances=reflectances, wavelengths=wavelengths, basis=basis, water=water,
                    path_model=path_model, cdom_slope=cdom_slope, fix=fix, setup=setup, gain=gain)
    return est.fit(rgb, sigma=sigma, saturation=saturation, mode=mode, max_iter=max_iter, tol=tol,
                   x0=x0)


#: The paper's q = 31 bands (every 10 nm, 400-700 nm): eq 19 divides by sqrt(q), so its value
#: depends on the grid; the figures, the benchmark and sca.precision evaluate it on these.
RRMSE_BANDS_NM = np.arange(400.0, 701.0, 10.0)


def rrmse_bands(wavelengths, estimate, truth) -> float:
    """Eq 19 on the :data:`RRMSE_BANDS_NM` samples of two spectra on ``wavelengths``."""
    sel = np.isin(np.asarray(wavelengths), RRMSE_BANDS_NM)
    return rrmse(np.asarray(estimate)[sel], np.asarray(truth)[sel])


def rrmse(estimate, truth) -> float:
    """Relative root-mean-squared error of eq 19: ||y_hat - y|| / (sqrt(q) ||y||)."""
    y_hat = np.asarray(estimate, float)
    y = np.asarray(truth, float)
    return float(np.linalg.norm(y_hat - y) / (np.sqrt(y.size) * np.linalg.norm(y)))
