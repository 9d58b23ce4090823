"""Variable projection and Levenberg-Marquardt for many charts at once, for any free parameters.

The engine knows no physics: it calls :meth:`sca.model.ChartModel.predict` for the signals and
their Jacobian (for C, a_CDOM and the path alone, :func:`fused`, the same numbers chart by chart
in compiled code from :meth:`forward.WaterTerms.optical_depth`'s (weight, spectrum) pieces,
:func:`sca.projection.project_pieces`). For charts i with weights w2 = 1 / sigma^2 (ones where
the noise is unknown):

    G = predict(theta).signal / scale_i,   (gain, s) = closed form (:func:`sca.model.linear_part`),
    r = sqrt(w2) (M - gain G - s 1^T),   f = ||r||^2,
    J = -gain dG/dtheta projected off span{active channel indicators, G (free gain)}
        (Kaufman's variable-projection Jacobian: exact gradient g = J^T r, H = J^T J).

The iteration variable of C is u = C^e0 (:func:`sca.model.du_chain`); every other parameter is
its own coordinate. A Levenberg-Marquardt step with Marquardt scaling (diag of H) and projected
lower bounds (a variable at its bound whose gradient points outwards is held), solved per chart
in compiled code (Gaussian elimination of the unit-diagonal Marquardt matrix; a pivot below
:data:`SINGULAR_PIVOT` falls back to the diagonal); in the Python driver all charts advance
together and converged charts leave the active set.

Two drivers run this iteration with the same compiled step and acceptance (:func:`_step_one`,
:func:`_judge_one`): :func:`levenberg_marquardt`'s loop below, every active chart one
iteration at a time (any problem), and, for :func:`fused` problems, :mod:`sca.fusedlm`, each
chart's whole fit in compiled code (the weights from forward's own functions, compiled).

Codes (:data:`STATUS`): 0 relative decrease below tol, 1 exact fit, 2 no further decrease
predicted, 3 iteration limit, 4 damping grew without decrease.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from forward.water import TABLE_NAMES

from .compiled import njit
from .model import TINY, ChartModel, chl_from_u, du_chain, lower_bound
from .projection import SERIAL_BELOW, project, project_pieces

__all__ = [
    "FUSED_NAMES",
    "LM_DOWN",
    "LM_MU0",
    "LM_MU_MAX",
    "LM_MU_MIN",
    "LM_TOL",
    "LM_UP",
    "SINGULAR_PIVOT",
    "STATUS",
    "Problem",
    "compiled_driver",
    "evaluate",
    "fused",
    "levenberg_marquardt",
]

STATUS = {
    0: "converged: relative decrease below tol",
    1: "exact fit (objective at rounding level)",
    2: "converged: no further decrease predicted",
    3: "maximum number of iterations reached",
    4: "damping grew without decrease (not stationary)",
}

#: Levenberg-Marquardt damping: start, the largest divisor after a success, factor after a
#: failure. After a success the damping is multiplied by max(1 / LM_DOWN, 1 - (2 rho - 1)^3),
#: rho = actual / predicted decrease (Nielsen's rule): a step the Gauss-Newton model predicted
#: well (rho near 1) divides it by LM_DOWN, one that overshot (rho < 1/2: the model's minimum lies
#: short of the step) raises it, so that a fit does not zigzag across a narrow valley.
LM_MU0, LM_DOWN, LM_UP = 1e-4, 10.0, 10.0
#: Damping floor, and the damping above which a chart that cannot decrease stops (code 4).
LM_MU_MIN, LM_MU_MAX = 1e-12, 1e12
#: A Marquardt-scaled (unit-diagonal) step matrix with a pivot below this is treated as
#: singular: the step falls back to the diagonal (steepest descent scaled by the curvatures).
#: A pivot, not the determinant: the determinant of a unit-diagonal matrix of p strongly but
#: not fatally correlated columns (C with the budget's bio-optical scales, say) falls below any
#: fixed threshold as p grows, and the diagonal fallback then crawls along the valley and stops
#: short of the optimum (DECISIONS.md, "The defaults after real water").
SINGULAR_PIVOT = 1e-12
#: The relative decrease (and predicted decrease) at which a fit stops (the batch's default
#: ``tol`` and the one-chart 'lm' mode's; 1e-10 left one flat, almost black chart 1e-9 above the
#: DPP loop's objective, DECISIONS.md).
LM_TOL = 1e-12


@dataclass
class Problem:
    """N charts in scaled units (every chart's maximum is 1) and what is fixed about them.

    Attributes
    ----------
    model : ChartModel
        The chart model (unscaled units: its signals are divided by ``scale`` here).
    M : ndarray, (N, m n)
        Measurements / scale (row-major over channel, patch).
    W2 : ndarray, (N, m n)
        Weights (scale / sigma)^2, or ones where the noise is unknown.
    scale : ndarray, (N,)
        The data's scales (each chart's maximum, data units).
    names : tuple of str
        Free nonlinear parameters, in the order of theta's columns.
    fixed : dict
        name -> (N,) (or (N, m) for 'backscatter') values of everything else the model
        needs ('depth', 'distance' in m, and 'chl' (mg m^-3) / 'cdom' (m^-1) where they are
        held; the estimators pass a held backscatter as ``fixed_s`` instead).
    free_gain : bool
        The exposure gain is estimated (profiled out with s). Default False.
    fixed_s : ndarray, (N, m), or None
        Backscatter held (scaled units) or None (s free, s >= 0). Default None.
    prior_mean : ndarray, (N, p), or None
        Centre of each column's Gaussian prior (LM coordinates; the uncertainty budget's
        nuisance parameters, :mod:`sca.budget`). Default None: no prior.
    prior_weight : ndarray, (N, p), or None
        1 / sd^2 of each column's prior in the objective's units (0: no prior on that column).
        The objective is then f = ||r||^2 + sum prior_weight (theta - prior_mean)^2.
    lower : ndarray, (p,)
        Lower bound of each column of theta (:func:`sca.model.lower_bound`; set on
        construction).
    chl_col : int
        The column of C (iterated in u = C^e0), or -1 (set on construction).
    """

    model: ChartModel
    M: np.ndarray
    W2: np.ndarray
    scale: np.ndarray
    names: tuple
    fixed: dict
    free_gain: bool = False
    fixed_s: np.ndarray | None = None
    prior_mean: np.ndarray | None = None
    prior_weight: np.ndarray | None = None
    lower: np.ndarray = field(init=False)

    def __post_init__(self):
        self.lower = np.array([lower_bound(n, self.model.water) for n in self.names])
        self.chl_col = self.names.index("chl") if "chl" in self.names else -1
        #: the distinct names in column order (a name of m values, 'balance', has m columns)
        self.free = tuple(dict.fromkeys(self.names))
        #: 1 / scale (the factor of the model's signals)
        self.inv_scale = 1.0 / np.asarray(self.scale, float)

    def subset(self, idx) -> Problem:
        """The charts ``idx`` as a problem of their own."""
        def rows(a):
            return None if a is None else a[idx]
        return Problem(self.model, self.M[idx], self.W2[idx], self.scale[idx], self.names,
                       {k: v[idx] for k, v in self.fixed.items()}, self.free_gain,
                       rows(self.fixed_s), rows(self.prior_mean), rows(self.prior_weight))

    @property
    def size(self) -> int:
        """N, the number of charts."""
        return self.M.shape[0]

    def params(self, idx, theta) -> dict:
        """The model's parameters of charts ``idx`` at LM coordinates ``theta`` (len(idx), p).

        Parameters
        ----------
        idx : array_like of int, (k,)
            Chart indices.
        theta : ndarray, (k, p)
            LM coordinates (u = C^e0 for C).

        Returns
        -------
        dict
            name -> (k,) values for :meth:`sca.model.ChartModel.predict` (C in mg m^-3).
        """
        out = {k: v[idx] for k, v in self.fixed.items()}
        for name in self.free:
            cols = [j for j, n in enumerate(self.names) if n == name]
            if len(cols) > 1:
                out[name] = theta[:, cols]
            elif cols[0] == self.chl_col:
                out[name] = chl_from_u(theta[:, cols[0]], self.model.e0)
            else:
                out[name] = theta[:, cols[0]]
        return out

    def column_scales(self, idx, chl) -> np.ndarray:
        """(k, p) factors taking the model's dG/dtheta (data units, C in mg m^-3) to the
        problem's: 1 / scale, times dC/du for C."""
        out = np.repeat((1.0 / self.scale[idx])[:, None], len(self.names), axis=1)
        if self.chl_col >= 0:
            out[:, self.chl_col] *= du_chain(chl, self.model.e0)
        return out


def evaluate(prob: Problem, idx, theta, grad: bool = True, attenuation: bool = True):
    """Objective, variable-projection gradient and Gauss-Newton matrix of charts ``idx``.

    Parameters
    ----------
    prob : Problem
        The charts.
    idx : array_like of int, (k,)
        The charts evaluated.
    theta : ndarray, (k, p)
        Their nonlinear parameters, LM coordinates (u = C^e0 for C).
    grad : bool, optional
        Also the gradient and Gauss-Newton matrix (default True).
    attenuation : bool, optional
        Also the attenuation k (default True; else k may be None).

    Returns
    -------
    f : ndarray, (k,)
        Weighted sum of squares (chi^2 where the noise is known; scaled units otherwise).
    g : ndarray, (k, p), or None
        J^T r, half the gradient of f (None without ``grad``).
    H : ndarray, (k, p, p), or None
        J^T J, the Gauss-Newton matrix (None without ``grad``).
    gain : ndarray, (k,)
        The closed-form gain (1 where it is known).
    s : ndarray, (k, m)
        The closed-form backscatter (scaled units).
    ssr : ndarray, (k,)
        Unweighted sum of squares (scaled units).
    k : ndarray, (k, q), or None
        The attenuation exp(-(depth + distance) c) (None without ``attenuation`` where the
        charts are evaluated by :func:`sca.projection.project_pieces`).

    Notes
    -----
    Where the problem is :func:`fused` the signal and its Jacobian rows are
    :meth:`sca.model.ChartModel.predict`'s, computed chart by chart in compiled code from
    :meth:`forward.WaterTerms.optical_depth`'s (weight, spectrum) pieces
    (:func:`sca.projection.project_pieces`; ``tests/test_fused.py`` checks them against
    ``predict``).

    References
    ----------
    L. Kaufman, "A variable projection method for solving separable nonlinear least squares
    problems", BIT 15 (1975) 49-57.
    """
    mdl = prob.model
    m, n = mdl.m, mdl.n
    params = prob.params(idx, theta)
    if fused(prob):
        return _evaluate_pieces(prob, idx, theta, params, grad, attenuation)
    pred = mdl.predict(params, prob.free if grad else (), chl_floor=TINY, jacobian=grad)
    inv = (1.0 / prob.scale[idx])[:, None]
    fs = None if prob.fixed_s is None else prob.fixed_s[idx]
    JR = np.zeros((len(idx), 0, m * n))
    col_scale = np.zeros((len(idx), 0))
    if grad:
        col_scale = prob.column_scales(idx, params.get("chl"))
        JR = pred.jacobian_rows
    f, g, H, gain, s, ssr = project(pred.signal * inv, JR, prob.M[idx], prob.W2[idx], fs,
                                    prob.free_gain, m, n, grad, col_scale)
    f, g, H = _with_priors(prob, idx, theta, f, g, H, grad)
    return f, g, H, gain, s, ssr, pred.attenuation


#: The names :func:`sca.projection.project_pieces` evaluates (everything of the chart model
#: that reaches it through the optical depth's pieces; the camera's curves and free Water
#: constants go through :meth:`sca.model.ChartModel.predict`): forward's piece table's names.
FUSED_NAMES = TABLE_NAMES


def fused(prob: Problem) -> bool:
    """True where :func:`evaluate` computes the charts from the optical depth's pieces
    (:func:`sca.projection.project_pieces`): every free and fixed name in :data:`FUSED_NAMES`,
    one phytoplankton shape.

    Parameters
    ----------
    prob : Problem
        The charts.

    Returns
    -------
    bool
    """
    return (set(prob.names) <= set(FUSED_NAMES) and set(prob.fixed) <= set(FUSED_NAMES)
            and not prob.model.terms.free_only)


def _evaluate_pieces(prob, idx, theta, params, grad, attenuation):
    """:func:`evaluate` of a :func:`fused` problem."""
    mdl = prob.model
    wrt = prob.free if grad else ()
    weights, spectra, dweights = mdl.terms.optical_depth(
        params["chl"], params.get("cdom", 0.0), params["depth"], params["distance"], wrt=wrt,
        floor=TINY, stacked=True)
    k_ = len(idx)
    weights = np.broadcast_to(weights, (k_, spectra.shape[0]))
    dW = np.zeros((k_, 0, spectra.shape[0])) if not grad else \
        np.stack([np.broadcast_to(dweights[n], weights.shape) for n in prob.names], axis=1)
    col_scale = prob.column_scales(idx, params.get("chl")) if grad else np.zeros((k_, 0))
    f, g, H, gain, s, ssr, k = project_pieces(
        weights, dW, spectra, mdl.Bt, prob.inv_scale, prob.M, prob.W2, prob.fixed_s,
        prob.free_gain, mdl.m, mdl.n, grad, col_scale, attenuation, rows=idx)
    f, g, H = _with_priors(prob, idx, theta, f, g, H, grad)
    return f, g, H, gain, s, ssr, (k if attenuation else None)


def _with_priors(prob, idx, theta, f, g, H, grad):
    """f, g, H plus the budget's Gaussian priors f + sum w (theta - mu)^2 (g and H None
    without ``grad``)."""
    if prob.prior_mean is not None:
        pw = prob.prior_weight[idx]
        d = theta - prob.prior_mean[idx]
        f = f + np.einsum("ip,ip->i", pw, d * d)
        if grad:
            g = g + pw * d
            H = H + pw[:, :, None] * np.eye(theta.shape[1])
    if not grad:
        g = H = None
    return f, g, H


@njit(cache=True, error_model="numpy", inline="always")
def _lu_solve(A, b, x):  # pragma: no cover
    """Gaussian elimination with partial pivoting of A x = b (A and b overwritten): returns
    the smallest |pivot| (x unset where a pivot is 0 or not finite)."""
    p = A.shape[0]
    smallest = np.inf
    for c in range(p):
        piv = c
        for r in range(c + 1, p):
            if abs(A[r, c]) > abs(A[piv, c]):
                piv = r
        if piv != c:
            for k in range(p):
                A[c, k], A[piv, k] = A[piv, k], A[c, k]
            b[c], b[piv] = b[piv], b[c]
        smallest = min(smallest, abs(A[c, c]))
        if not (A[c, c] != 0.0 and np.isfinite(A[c, c])):
            return 0.0
        for r in range(c + 1, p):
            f = A[r, c] / A[c, c]
            for k in range(c, p):
                A[r, k] -= f * A[c, k]
            b[r] -= f * b[c]
    for c in range(p - 1, -1, -1):
        acc = b[c]
        for k in range(c + 1, p):
            acc -= A[c, k] * x[k]
        x[c] = acc / A[c, c]
    return smallest


@njit(cache=True, inline="always")
def _step_scratch(p):  # pragma: no cover
    """The work arrays of :func:`_step_one` for p parameters."""
    return (np.empty((p, p)), np.empty(p), np.empty(p), np.empty(p), np.empty(p, dtype=np.bool_),
            np.empty(p))


@njit(cache=True, error_model="numpy", inline="always")
def _step_one(g, H, mu, theta, lower, hold, singular_pivot, d, scratch):  # pragma: no cover
    """One chart's projected, Marquardt-scaled step into ``d`` (p,) from its gradient ``g``
    (p,), Gauss-Newton matrix ``H`` (p, p), damping ``mu``, point ``theta`` and held
    coordinates ``hold``; returns the decrease the Gauss-Newton model predicts.
    ``scratch``: :func:`_step_scratch`."""
    A, y, b, root, free, rhs = scratch
    p = g.shape[0]
    for a in range(p):
        diag = H[a, a]
        free[a] = (not (theta[a] <= lower[a] and g[a] > 0.0)) and diag > 0.0 and not hold[a]
        dA = diag * (1.0 + mu) if free[a] else 1.0
        root[a] = np.sqrt(dA)
        b[a] = (-g[a] if free[a] else 0.0) / root[a]
    # the Marquardt-scaled matrix (unit diagonal scaling): D^-1/2 A D^-1/2 y = D^-1/2 b
    for a in range(p):
        for c in range(p):
            A[a, c] = H[a, c] / (root[a] * root[c]) if (free[a] and free[c]) else 0.0
        A[a, a] = 1.0
    for a in range(p):
        rhs[a] = b[a]
    if _lu_solve(A, b, y) > singular_pivot:
        for a in range(p):
            d[a] = y[a] / root[a]
    else:
        for a in range(p):
            d[a] = rhs[a] / root[a]
    return _predicted(g, H, d)


@njit(cache=True, inline="always")
def _predicted(g, H, d):  # pragma: no cover
    """The decrease -2 g.d - d.H.d the Gauss-Newton model predicts for the step d."""
    p = g.shape[0]
    acc = 0.0
    for a in range(p):
        acc -= 2.0 * g[a] * d[a]
        for c in range(p):
            acc -= d[a] * H[a, c] * d[c]
    return acc


@njit(cache=True, error_model="numpy")
def _step_many(g, H, mu, theta, lower, hold, singular_pivot):  # pragma: no cover
    N, p = g.shape
    d = np.zeros((N, p))
    pred = np.zeros(N)
    scratch = _step_scratch(p)
    for i in range(N):
        pred[i] = _step_one(g[i], H[i], mu[i], theta[i], lower, hold[i], singular_pivot, d[i],
                            scratch)
    return d, pred


@njit(cache=True, error_model="numpy", inline="always")
def _judge_one(fa, fn, stat, g, H, th, tn, mu, tol, f_exact, dc):  # pragma: no cover
    """Accept or reject one chart's trial point ``tn`` (objective ``fn``; inf where no trial
    was made, ``stat``) from ``th`` (objective ``fa``, gradient ``g``, Gauss-Newton matrix
    ``H``): returns (accepted, the new damping, the stop code or -1). The damping follows
    the gain ratio of the step actually taken (clipped at the bounds; Nielsen's rule, see
    :data:`LM_DOWN`). ``dc`` is scratch (p,)."""
    trial = not stat
    ok = trial and fn < fa
    if ok:
        for a in range(th.shape[0]):
            dc[a] = tn[a] - th[a]
        pred_c = _predicted(g, H, dc)
        rho = (fa - fn) / pred_c
        if np.isfinite(rho):
            r = min(max(rho, 0.0), 1.0)
            factor = max(1.0 / LM_DOWN, 1.0 - (2.0 * r - 1.0) ** 3)
        else:
            factor = 1.0 / LM_DOWN
        mu = max(mu * factor, LM_MU_MIN)
    elif trial:
        mu *= LM_UP
    fin = -1
    if ok and fa - fn <= tol * fa:
        fin = 0
    if stat:
        fin = 2
    if (fn if ok else fa) <= f_exact:
        fin = 1
    if trial and not ok and mu > LM_MU_MAX:
        fin = 4
    return ok, mu, fin


@njit(cache=True, error_model="numpy")
def _judge_many(fa, fn, stat, g, H, th, tn, mu, tol, f_exact):  # pragma: no cover
    """:func:`_judge_one` of every active chart: (accepted, new damping, stop code or -1)."""
    K = fa.shape[0]
    ok = np.zeros(K, dtype=np.bool_)
    mu_new = np.empty(K)
    fin = np.empty(K, dtype=np.int64)
    dc = np.empty(th.shape[1])
    for k in range(K):
        ok[k], mu_new[k], fin[k] = _judge_one(fa[k], fn[k], stat[k], g[k], H[k], th[k], tn[k],
                                              mu[k], tol, f_exact[k], dc)
    return ok, mu_new, fin


def _step(g, H, mu, theta, lower, hold):
    """The projected, Marquardt-scaled step d and the decrease the Gauss-Newton model predicts
    (compiled, chart by chart: a free coordinate is not at its bound with the gradient pointing
    out, has positive curvature and is not held; a step matrix with a pivot below
    :data:`SINGULAR_PIVOT` falls back to the diagonal)."""
    if g.shape[0] == 0:
        return np.zeros(g.shape), np.zeros(0)
    return _step_many(np.ascontiguousarray(g, float), np.ascontiguousarray(H, float),
                      np.ascontiguousarray(mu, float), np.ascontiguousarray(theta, float),
                      np.ascontiguousarray(lower, float), np.ascontiguousarray(hold, bool),
                      SINGULAR_PIVOT)


def compiled_driver(prob: Problem, n: int) -> bool:
    """True where :func:`levenberg_marquardt`, by default, fits ``n`` charts of ``prob``
    chart by chart in compiled code (:func:`sca.fusedlm.fit_fused`): a problem it can fit
    (:func:`sca.fusedlm.compiled_fit`), fewer than :data:`sca.projection.SERIAL_BELOW` charts or
    a grid coarser than :data:`sca.fusedlm.BLAS_FROM` wavelengths (BLAS over many charts at once
    beats chart-by-chart on fine grids).

    Parameters
    ----------
    prob : Problem
    n : int
        Charts fitted together.

    Returns
    -------
    bool
    """
    from .fusedlm import BLAS_FROM, compiled_fit  # (fusedlm imports this module)

    return (n < SERIAL_BELOW or prob.model.wavelengths.size < BLAS_FROM) and compiled_fit(prob)


def levenberg_marquardt(prob: Problem, theta0, *, max_iter: int, tol: float, f_exact,
                        atol=None, hold=None, compiled: bool | None = None,
                        final: dict | None = None, rows=None):
    """Projected Levenberg-Marquardt of every chart from ``theta0`` (N, p), LM coordinates.

    Parameters
    ----------
    prob : Problem
        The charts.
    theta0 : ndarray, (N, p)
        The start, LM coordinates.
    max_iter : int
        Iteration limit (keyword-only).
    tol : float
        Relative decrease (and predicted decrease) at which a chart stops (keyword-only).
    f_exact : ndarray, (N,)
        Objective at which the fit is exact to rounding (keyword-only).
    atol : ndarray, (N,), optional
        Absolute predicted decrease at which a chart stops (profile points; default 0).
    hold : ndarray of bool, (N, p), optional
        Coordinates held where they are (profile points; default none).
    compiled : bool or None, optional
        True: fit :func:`sca.fusedlm.compiled_fit` problems chart by chart in compiled code
        (:func:`sca.fusedlm.fit_fused`). False: the driver below, one iteration of every chart
        at a time (any problem; on fine grids its projections of many charts at once by one
        BLAS product are faster). Default None: compiled for fewer than
        :data:`sca.projection.SERIAL_BELOW` charts or grids coarser than
        :data:`sca.fusedlm.BLAS_FROM` wavelengths. Both drivers call the same step and
        acceptance (:func:`_step_one`, :func:`_judge_one`) and reach the same optimum; their
        rounding differs, which can move an acceptance or a stop by one iteration.
    final : dict, optional
        The compiled driver fills it with 'g', 'H', 'gain', 's', 'ssr' and 'k' at the returned
        points (what :func:`evaluate` returns there, without evaluating them again); the
        Python driver leaves it empty.
    rows : array_like of int, (N,), optional
        The charts of ``prob`` that the rows of ``theta0`` are (default 0..N-1): a subset
        fitted without copying its data (the profile points).

    Returns
    -------
    theta : ndarray, (N, p)
        The final point, LM coordinates.
    f : ndarray, (N,)
        Its objective (as :func:`evaluate`).
    iterations : ndarray of int, (N,)
        Iterations of each chart.
    code : ndarray of int, (N,)
        Why each chart stopped (:data:`STATUS`).

    References
    ----------
    D. W. Marquardt, "An algorithm for least-squares estimation of nonlinear parameters",
    J. SIAM 11 (1963) 431-441; J. Nocedal & S. J. Wright, Numerical Optimization, 2nd ed.,
    Springer (2006), ch. 10; L. Kaufman, BIT 15 (1975) 49-57 (variable projection);
    H. B. Nielsen, "Damping parameter in Marquardt's method", IMM-REP-1999-05, Technical
    University of Denmark (1999) (the damping update).
    """
    from .fusedlm import compiled_fit, fit_fused  # (fusedlm imports this module)

    if compiled_driver(prob, len(theta0)) if compiled is None else (
            compiled and compiled_fit(prob)):
        return fit_fused(prob, theta0, max_iter=max_iter, tol=tol, f_exact=f_exact, atol=atol,
                         hold=hold, final=final, rows=rows)
    N, p = theta0.shape
    theta = np.array(theta0, float)
    hold = np.zeros((N, p), bool) if hold is None else np.asarray(hold, bool)
    atol = np.zeros(N) if atol is None else np.asarray(atol, float)
    iters = np.zeros(N, dtype=int)
    code = np.full(N, 3)
    mu = np.full(N, LM_MU0)
    f = np.zeros(N)
    if N == 0:
        return theta, f, iters, code
    rows = np.arange(N) if rows is None else np.asarray(rows, np.int64)
    f_exact = np.asarray(f_exact, float)
    fa, g, H, *_ = evaluate(prob, rows, theta, True, False)
    f[:] = fa
    done = fa <= f_exact
    code[done] = 1
    active = np.flatnonzero(~done)
    fa, g, H = fa[active], g[active], H[active]
    for it in range(1, int(max_iter) + 1):
        if active.size == 0:
            break
        th = theta[active]
        d, pred = _step(g, H, mu[active], th, prob.lower, hold[active])
        iters[active] = it
        # stationary: the model predicts (relatively) nothing more; stop without a trial
        stat = pred <= np.maximum(tol * fa, atol[active])
        tn = np.maximum(th + d, prob.lower)
        trial = ~stat
        ti = active[trial]
        fn = np.full(active.size, np.inf)
        gn = np.zeros_like(g)
        Hn = np.zeros_like(H)
        if ti.size:
            fn[trial], gn[trial], Hn[trial], *_ = evaluate(prob, rows[ti], tn[trial], True,
                                                           False)
        ok, mu[active], fin = _judge_many(fa, fn, stat, g, H, th, tn, mu[active], float(tol),
                                          f_exact[active])
        acc = active[ok]
        theta[acc], f[acc] = tn[ok], fn[ok]
        stop = fin >= 0
        code[active[stop]] = fin[stop]
        fa[ok], g[ok], H[ok] = fn[ok], gn[ok], Hn[ok]
        if stop.any():
            go = ~stop
            active, fa, g, H = active[go], fa[go], g[go], H[go]
    return theta, f, iters, code
