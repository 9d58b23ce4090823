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
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field

import cvxpy as cp
import numpy as np

from forward import _validate
from forward.imaging import ChartSetup, resolve_setup
from forward.spectra import DEFAULT_CAMERA
from forward.water import CDOM_SLOPE

from .model import WaterModel
from .subproblem import build_subproblem, constant_problem, equality_step, polish

MODES = ("paper", "safeguarded")
FIXABLE = ("chl", "cdom", "backscatter")

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
    w: np.ndarray
    backscatter: np.ndarray
    attenuation: np.ndarray
    attenuation_coefficient: np.ndarray
    wavelengths: np.ndarray
    objective: float
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
    """Estimator for one (camera, illuminant, chart, grid, basis, path): build once, fit many.

    The cvxpy subproblem is compiled once per problem structure and shared (see
    :func:`sca.subproblem.build_subproblem`); only parameter values change per iteration.
    """

    def __init__(self, *, depth, distance, camera=DEFAULT_CAMERA, illuminant=None,
                 reflectances=None, wavelengths=None, basis=None, path_model: str = "beam",
                 cdom_slope: float = CDOM_SLOPE, fix=None, setup: ChartSetup | None = None,
                 rebuild: bool = False):
        #: rebuild=True: build and canonicalise a new cvxpy problem with constants every
        #: iteration instead of updating the parameters of the compiled one (benchmark baseline)
        self.rebuild = bool(rebuild)
        depth = _validate.scalar("depth", depth)
        distance = _validate.scalar("distance", distance)
        self.setup = setup = resolve_setup(setup, camera, illuminant, reflectances, wavelengths)
        self.model = WaterModel(setup, depth, distance, basis=basis, path_model=path_model,
                                cdom_slope=cdom_slope)
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
        n_pos = int(self.free_chl) + int(self.free_cdom) + int(self.w_bound)
        self.n_pos = n_pos
        self.n_free = int(self.free_chl) + int(self.free_cdom) + (mdl.z if self.free_w else 0)
        if self.n_free == 0 and not self.free_s:
            raise ValueError("fix: nothing is left to estimate")
        n_cc = int(self.free_chl) + int(self.free_cdom)
        self.w_slice = (n_cc, n_cc + mdl.z) if self.free_w else None

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
                arr = _validate.array("fix['backscatter']", np.broadcast_to(val, (self.model.m,)),
                                      nonnegative=True)
                out[key] = np.array(arr, dtype=float)
            else:
                out[key] = _validate.scalar(f"fix[{key!r}]", val)
        return out

    # ----------------------------------------------------------------------------- helpers
    def _check_rgb(self, rgb):
        shape = (self.model.m, self.model.n)
        M = _validate.array("rgb", rgb, shape=shape)
        if np.any(M < 0):
            raise ValueError(f"rgb: contains negative values (min {M.min():g}); measurements are "
                             "exposure-normalised sensor values >= 0")
        return M

    @staticmethod
    def _objective(mdl, Mv, chl, cdom, w, s):
        k = mdl.attenuation(chl, cdom, w)
        r = mdl.residual(Mv, k, s)
        return float(r @ r), k

    def prepare(self, rgb):
        """Validate ``rgb`` and scale the problem: returns (vec(M) / max M, max M, the model
        in those units, the fixed backscatter in those units or None)."""
        M = self._check_rgb(rgb)
        scale = float(np.max(M))
        if scale <= 0:
            raise ValueError("rgb: all values are zero; nothing to fit")
        s_fixed = None if self.free_s else self.fixed["backscatter"] / scale
        return M.ravel() / scale, scale, self.model.scaled(scale), s_fixed

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
                chl_grid = np.array([_validate.scalar("x0['chl']", x0["chl"])])
            if "cdom" in x0 and self.free_cdom:
                cdom_grid = np.array([_validate.scalar("x0['cdom']", x0["cdom"])])
        C, A = np.meshgrid(chl_grid, cdom_grid, indexing="ij")
        C, A = C.ravel(), A.ravel()
        u = np.full(mdl.z, 1.0 / mdl.z)
        W = np.multiply.outer(mdl.phyto_scale(C) / float(mdl.t440 @ u), u)
        k = mdl.attenuation(C, A, W)
        G = mdl.signal(k)
        s = mdl.best_backscatter(Mv, G, s_fixed)
        r = Mv - G - np.repeat(s, mdl.n, axis=-1)
        f = np.einsum("ij,ij->i", r, r)
        j = int(np.argmin(f))
        return float(C[j]), float(A[j]), W[j].copy()

    # ----------------------------------------------------------------------------- the loop
    def fit(self, rgb, *, mode: str = "safeguarded", max_iter: int = 100, tol: float = 1e-10,
            x0=None) -> Estimate:
        """Run the sequential convex loop on measured patch values ``rgb`` (m, n)."""
        if mode not in MODES:
            raise ValueError(f"mode: must be one of {MODES}, got {mode!r}")
        if int(max_iter) != max_iter or max_iter < 1:
            raise ValueError(f"max_iter: must be a positive integer, got {max_iter!r}")
        tol = _validate.scalar("tol", tol, positive=True)
        Mv, scale, mdl, s_fixed = self.prepare(rgb)
        return self._loop(mdl, Mv, scale, s_fixed, mode, int(max_iter), tol, x0)

    def _loop(self, mdl, Mv, scale, s_fixed, mode, max_iter, tol, x0):
        safeguarded = mode == "safeguarded"
        n_s = mdl.m if self.free_s else 0
        sub = build_subproblem(self.n_free, self.n_pos, None if self.w_bound else self.w_slice,
                               mdl.wavelengths.size, n_s, safeguarded, self.free_w)
        E = np.kron(np.eye(mdl.m), np.ones((mdl.n, 1)))  # s -> every patch of its channel
        f_exact = EXACT_FIT * float(Mv @ Mv)

        chl, cdom, w = self.initial_point(Mv, x0, mdl, s_fixed)
        initial = {"chl": chl, "cdom": cdom}
        G = mdl.signal(mdl.attenuation(chl, cdom, w))
        s = np.array(mdl.best_backscatter(Mv, G, s_fixed), dtype=float)
        f, k = self._objective(mdl, Mv, chl, cdom, w, s)
        history, steps = [f * scale**2], []
        radius = 1.0
        status, converged = "maximum number of iterations reached", False
        n_solves, t_solve, t_clarabel, rescues = 0, 0.0, 0.0, 0
        it = 0
        for it in range(1, max_iter + 1):
            if f <= f_exact:
                status, converged = "exact fit (objective at rounding level)", True
                it -= 1
                break
            k, dk = mdl.attenuation_jacobian(chl, cdom, w)
            G = mdl.signal(k)
            J = dk.T @ mdl.B.T  # (2 + z, m n)
            D_chl = max(chl, CHL_SCALE_MIN)
            D_cdom = max(cdom, CDOM_SCALE_MIN)
            w_min = float(mdl.phyto_scale(CHL_SCALE_MIN)) / (mdl.z * float(np.max(mdl.t440)))
            D_w = np.maximum(np.abs(w), w_min)
            cols, scales = [], []
            if self.free_chl:
                cols.append(0)
                scales.append(D_chl)
            if self.free_cdom:
                cols.append(1)
                scales.append(D_cdom)
            if self.free_w:
                cols += list(range(2, 2 + mdl.z))
                scales += list(D_w)
            scales = np.array(scales)
            r0 = Mv - G - np.repeat(s, mdl.n)
            AE = J[cols].T * scales
            if self.free_s:
                AE = np.hstack([AE, E])
            Q, Rm = np.linalg.qr(AE)
            b = Q.T @ r0
            unit = float(np.linalg.norm(b))  # the step is solved for in units of ||Q^T r0||
            c0 = max(float(r0 @ r0 - b @ b), 0.0)  # the part of ||r0||^2 no step can remove
            if unit <= 1e-300:
                status, converged = "converged: the gradient vanishes", True
                break
            sub.R.value = Rm
            sub.b.value = b / unit
            eq_row, eq_rhs = None, 0.0
            if self.free_w:  # eq 17 linearised: t440.(w + D_w dw) = alpha(C) + alpha'(C) D_C dC
                alpha, dalpha = mdl.phyto_scale(chl, derivative=True)
                eq_row = np.zeros(Rm.shape[1])
                eq_row[self.w_slice[0]:self.w_slice[1]] = mdl.t440 * D_w
                if self.free_chl:
                    eq_row[0] = -float(dalpha) * D_chl
                    eq_rhs = float(alpha) - float(mdl.t440 @ w)
                else:
                    eq_rhs = float(mdl.phyto_scale(self.fixed["chl"])) - float(mdl.t440 @ w)
            # Bounds far beyond any step the model can want only hurt the interior-point
            # start; they are capped at BOUND_CAP times the least-squares step that respects
            # the linearised eq 17 (without it, C and w are nearly collinear and the
            # unconstrained step is meaningless).
            v_ls = equality_step(Rm, b / unit, eq_row, eq_rhs / unit)
            cap = BOUND_CAP * max(1.0, float(np.max(np.abs(v_ls))))
            if self.free_s:
                sub.s_lo.value = np.maximum(-s / unit, -cap)
            if self.n_pos:
                lo = []
                if self.free_chl:
                    lo.append(-chl / D_chl)
                if self.free_cdom:
                    lo.append(-cdom / D_cdom)
                if self.w_bound:
                    lo.append(-float(w[0]) / float(D_w[0]))
                sub.lo.value = np.maximum(np.array(lo) / unit, -cap)
            if safeguarded and self.n_free:
                sub.hi.value = np.full(self.n_free, min(radius / unit, cap))
            if self.free_w:
                if not self.w_bound:
                    TDw = mdl.T * D_w
                    sub.TDw.value = TDw
                    sub.Tw_rhs.value = np.maximum(-(mdl.T @ w) / unit,
                                                  -cap * np.abs(TDw).sum(axis=1))
                sub.a_eq.value = eq_row[:self.n_free]
                sub.b_eq.value = eq_rhs / unit
            t0 = time.perf_counter()
            if self.rebuild:  # the CVX-style baseline: a new problem every iteration
                problem, v_var = constant_problem(sub, AE, r0 / unit)
            else:
                problem, v_var = sub.problem, sub.v
            v_var.value = None  # a shared, cached problem: never read a previous solve's values
            failure = _solve(problem)
            t_solve += time.perf_counter() - t0
            n_solves += 1
            stats = getattr(problem, "solver_stats", None)
            if stats is not None and stats.solve_time:
                t_clarabel += float(stats.solve_time)
            if not failure:
                v, _ = polish(sub, np.asarray(v_var.value, float))
            else:
                # Clarabel stopped early (e.g. its iteration limit on a degenerate, weakly
                # active bound) but returned an iterate: the active-set polish may turn it into
                # a feasible point that the model says is no worse than not moving (v = 0,
                # feasible in safeguarded mode). Counted in ``polish_rescues``; a solve that
                # returned nothing usable stays a reported failure.
                if v_var.value is not None and np.all(np.isfinite(v_var.value)):
                    v, rescued = polish(sub, np.asarray(v_var.value, float),
                                        f_ref=1.0 if safeguarded else None)
                    if rescued:
                        failure = ""
                        rescues += 1
            if failure:
                status = f"solver failed at iteration {it}: {failure}"
                break
            qp_value = float(np.sum((Rm @ v - b / unit) ** 2))
            v = v * unit
            delta = v[:self.n_free]
            # decrease predicted by the linearised model
            pred = f - (qp_value * unit**2 + c0)
            # the candidate
            full = np.zeros(2 + mdl.z)
            full[cols] = delta * scales
            chl_new = max(chl + full[0], 0.0) if self.free_chl else chl
            cdom_new = max(cdom + full[1], 0.0) if self.free_cdom else cdom
            w_new = w + full[2:] if self.free_w else w
            if safeguarded:
                w_new = mdl.feasible_w(chl_new, w_new)
                G_new = mdl.signal(mdl.attenuation(chl_new, cdom_new, w_new))
                s_new = np.array(mdl.best_backscatter(Mv, G_new, s_fixed), dtype=float)
            else:
                s_new = np.maximum(s + v[self.n_free:], 0.0) if self.free_s else s.copy()
            f_new, _ = self._objective(mdl, Mv, chl_new, cdom_new, w_new, s_new)
            steps.append(float(np.max(np.abs(delta))) if delta.size else 0.0)
            stationary = pred <= tol * f or f <= f_exact
            if not np.isfinite(f_new):
                status = f"non-finite objective at iteration {it}"
                break
            if f_new < f:
                decrease = f - f_new
                chl, cdom, w, s, f = chl_new, cdom_new, w_new, s_new, f_new
                history.append(f * scale**2)
                if safeguarded:
                    rho = decrease / pred if pred > 0 else 0.0
                    at_edge = steps[-1] >= 0.9 * radius
                    if rho > 0.75 and at_edge:
                        radius = min(2.0 * radius, 1e4)
                    elif rho < 0.25:
                        radius = max(radius / 4.0, 1e-14)
                    if decrease <= tol * (f + decrease) and pred <= 10 * tol * (f + decrease):
                        status, converged = "converged: relative decrease below tol", True
                        break
                continue
            # the objective did not decrease
            if not safeguarded:
                if stationary:
                    status, converged = "objective stopped decreasing at a stationary point", True
                else:
                    status = ("objective stopped decreasing after a full Taylor step, but the "
                              "point is not stationary (paper mode stopped early)")
                break
            if stationary:
                status, converged = "converged: no further decrease predicted", True
                break
            radius = min(radius, steps[-1]) / 4.0
            if radius < 1e-12:
                status = "trust region collapsed without reaching a stationary point"
                break
        if f <= f_exact and not converged:
            status, converged = "exact fit (objective at rounding level)", True
        k = mdl.attenuation(chl, cdom, w)
        se_chl, se_cdom = mdl.standard_errors(Mv, chl, cdom, w, s, (self.free_chl, self.free_cdom),
                                              s_fixed)
        return Estimate(
            chl=float(chl), cdom=float(cdom), chl_se=se_chl, cdom_se=se_cdom,
            w=np.array(w, float), backscatter=s * scale,
            attenuation=k, attenuation_coefficient=mdl.coefficient(chl, cdom, w),
            wavelengths=mdl.wavelengths, objective=f * scale**2, iterations=it,
            converged=bool(converged), status=status, history=history, mode=mode,
            initial=initial, fixed=dict(self.fixed),
            eq17_residual=float(mdl.t440 @ w - mdl.phyto_scale(chl)),
            solve_time_s=t_solve, clarabel_time_s=t_clarabel, n_solves=n_solves,
            polish_rescues=rescues,
            step_history=steps,
        )


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


def estimate(rgb, *, depth, distance, camera=DEFAULT_CAMERA, illuminant=None, reflectances=None,
             wavelengths=None, basis=None, mode: str = "safeguarded", max_iter: int = 100,
             tol: float = 1e-10, fix=None, x0=None, path_model: str = "beam",
             cdom_slope: float = CDOM_SLOPE, setup: ChartSetup | None = None) -> Estimate:
    """Estimate C, a_CDOM(440), w and backscatter s from a chart's patch values (eqs 15-18).

    Parameters
    ----------
    rgb : (m, n) measured patch values in the model units of :func:`forward.simulate_chart`
        (exposure-normalised: a white reflector in air = 1 in the reference channel).
    depth, distance : m, the path of the measurement (known to the diver).
    camera, illuminant, reflectances, wavelengths, basis, path_model, cdom_slope : as in
        :func:`forward.simulate_chart`; must describe the same camera and chart as the data.
    mode : 'safeguarded' (default) or 'paper' (the literal loop).
    max_iter : maximum number of convex subproblems.
    tol : relative objective decrease at which the loop stops.
    fix : hold parameters fixed, e.g. ``{'backscatter': 0}`` (chart a few cm away) or
        ``{'cdom': 0.1}``; the loop then solves the smaller problem.
    x0 : optional start ``{'chl': ..., 'cdom': ...}`` instead of the coarse grid search.
    """
    est = Estimator(depth=depth, distance=distance, camera=camera, illuminant=illuminant,
                    reflectances=reflectances, wavelengths=wavelengths, basis=basis,
                    path_model=path_model, cdom_slope=cdom_slope, fix=fix, setup=setup)
    return est.fit(rgb, mode=mode, max_iter=max_iter, tol=tol, x0=x0)


def rrmse(estimate, truth) -> float:
    """Relative root-mean-squared error of eq 19: ||y_hat - y|| / (sqrt(q) ||y||)."""
    y_hat = np.asarray(estimate, float)
    y = np.asarray(truth, float)
    return float(np.linalg.norm(y_hat - y) / (np.sqrt(y.size) * np.linalg.norm(y)))
