"""The one Levenberg-Marquardt of the package: every unit of any problem at once.

The engine knows no physics: it calls :meth:`sca.problem.Problem.evaluate` (the layout's data
terms -- a chart's model function and variable projection, a dive's photographs, a K_d
spectrum -- and the uncertainty budget's priors) for the objective f, half its gradient g and
the Gauss-Newton matrix H of every active unit. A step with Marquardt scaling (diag of H) and
projected lower bounds (a variable at its bound whose gradient points outwards is held) is
solved per unit in compiled code (Gaussian elimination of the unit-diagonal Marquardt matrix; a
pivot below :data:`SINGULAR_PIVOT` falls back to the diagonal) and accepted or rejected by
compiled code (:func:`_step_one`, :func:`_judge_one`); all units advance together, and a unit
that has converged leaves the active set. Every estimator (one chart, a batch, a dive's joint
fit, a K_d spectrum) and the profile-likelihood ends (:mod:`sca.intervals`) call it.

Codes (:data:`STATUS`): 0 relative decrease below tol, 1 exact fit, 2 no further decrease
predicted, 3 iteration limit, 4 damping grew without decrease.
"""

from __future__ import annotations

import numpy as np

from .compiled import njit
from .problem import Evaluation, Problem

__all__ = [
    "LM_DOWN",
    "LM_MU0",
    "LM_MU_MAX",
    "LM_MU_MIN",
    "LM_TOL",
    "LM_UP",
    "SINGULAR_PIVOT",
    "STATUS",
    "evaluate",
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
#: short of the optimum (decision 0043-lm-singular-pivot).
SINGULAR_PIVOT = 1e-12
#: The relative decrease (and predicted decrease) at which a fit stops (the batch's default
#: ``tol`` and the one-chart 'lm' mode's; 1e-10 left one flat, almost black chart 1e-9 above the
#: DPP loop's objective, decision 0028-batched-solver).
LM_TOL = 1e-12


def evaluate(prob: Problem, idx, theta, grad: bool = True) -> Evaluation:
    """The objective, half gradient and Gauss-Newton matrix of units ``idx`` of any problem
    (:meth:`sca.problem.Problem.evaluate`: its layout's data terms and the priors).

    Parameters
    ----------
    prob : sca.problem.Problem
        The units.
    idx : array_like of int, (k,)
        The units evaluated.
    theta : ndarray, (k, p)
        Their parameters (theta's coordinates: u = C^e0 for C).
    grad : bool, optional
        Also the gradient and Gauss-Newton matrix (default True).

    Returns
    -------
    sca.problem.Evaluation
    """
    return prob.evaluate(idx, theta, grad)


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


def levenberg_marquardt(prob: Problem, theta0, *, max_iter: int, tol: float, f_exact,
                        atol=None, hold=None, rows=None):
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
    ev = evaluate(prob, rows, theta, True)
    fa, g, H = ev.f, ev.g, ev.H
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
            ev = evaluate(prob, rows[ti], tn[trial], True)
            fn[trial], gn[trial], Hn[trial] = ev.f, ev.g, ev.H
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
