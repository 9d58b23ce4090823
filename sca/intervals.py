"""Profile-likelihood intervals of any free parameter, for many charts at once.

The 95 % interval of a parameter theta_j is {theta_j : min over the other parameters of f <= f_hat
+ delta} (:func:`sca.assess.profile_delta`). Each end is searched from the optimum on
z(theta_j) = sqrt(P(theta_j) - f_hat), which is linear in theta_j for a linear model: a first step
from the Gauss-Newton curvature, secant extrapolation until the target sqrt(delta) is
bracketed, then the Illinois method to 1e-3 of sqrt(delta). Every profile point P(theta_j) is
the Levenberg-Marquardt of :mod:`sca.lm` with theta_j held (the same engine and model function
as the fit, so every estimator's intervals agree), started from the previous point moved along
the profile's Gauss-Newton slope at the optimum (:func:`profile_slopes`). C is searched in
u = C^e0.
"""

from __future__ import annotations

import numpy as np

from .lm import SINGULAR_PIVOT, Problem, levenberg_marquardt

__all__ = ["BOUND_FOUND", "BOUND_ZERO", "BOUND_OPEN", "BOUND_FAILED", "PROFILE_MAX_ITER",
           "BRACKET_STEPS", "ILLINOIS_STEPS", "BRACKET_OVERSHOOT", "BRACKET_GROWTH",
           "ROOT_TOL", "profile_intervals", "profile_slopes", "effective_curvature"]

#: Result codes of a profile end: found, at the lower bound (e.g. 0), open (beyond the cap),
#: failed.
BOUND_FOUND, BOUND_ZERO, BOUND_OPEN, BOUND_FAILED = 0, 1, 2, 3
#: Levenberg-Marquardt iterations per profile point (warm-started from the previous point).
PROFILE_MAX_ITER = 20
#: Secant steps allowed to bracket the target, and Illinois steps to converge on it.
BRACKET_STEPS, ILLINOIS_STEPS = 80, 60
#: A secant extrapolation aims this much beyond the target (to bracket it) ...
BRACKET_OVERSHOOT = 1.05
#: ... and grows the step by at most this factor (or by 3x when z did not rise).
BRACKET_GROWTH, BRACKET_FLAT_GROWTH = 4.0, 3.0
#: Illinois stops when |z - sqrt(delta)| <= ROOT_TOL sqrt(delta).
ROOT_TOL = 1e-3
#: Relative size of a profile point's absolute stopping tolerance (fraction of delta).
POINT_ATOL = 1e-4
#: Overflow guard of the profile objective.
F_OVERFLOW = 1e300


def effective_curvature(H, j=None):
    """1 / (H^-1)_jj: the curvature of the profile of parameter j (H_jj where H is singular).

    Parameters
    ----------
    H : array_like, (N, p, p)
        Gauss-Newton matrices J^T J (LM coordinates) of N charts.
    j : int, optional
        The parameter's column (default: every column, from one inverse of each H).

    Returns
    -------
    ndarray, (N,), or (N, p) without ``j``
        The profile's Gauss-Newton curvature; H_jj where H is singular (zero or non-finite
        determinant) or 1 / (H^-1)_jj is not finite and positive, and for p = 1.
    """
    H = np.asarray(H, float)
    out = np.array(np.diagonal(H, axis1=1, axis2=2), float)  # (N, p)
    if H.shape[1] > 1:
        with np.errstate(all="ignore"):
            det = np.linalg.det(H)
        ok = np.isfinite(det) & (np.abs(det) > 0)
        if ok.any():
            with np.errstate(divide="ignore"):  # a zero gives inf: H_jj is kept below
                val = 1.0 / np.diagonal(np.linalg.inv(H[ok]), axis1=1, axis2=2)
            out[ok] = np.where(np.isfinite(val) & (val > 0), val, out[ok])
    return out if j is None else np.array(out[:, j])


def profile_slopes(H, col):
    """d theta / d theta_col along the profile of each row's parameter ``col[r]``, from the
    Gauss-Newton matrices ``H`` (R, p, p): 1 for the parameter itself, -H_oo^-1 H_o,col for the
    others (o), which minimise the quadratic model with theta_col held; zeros where H_oo,
    scaled to unit diagonal, has an eigenvalue below :data:`sca.lm.SINGULAR_PIVOT` (nearly
    collinear columns: the move would be huge) or the result is not finite.

    Parameters
    ----------
    H : ndarray, (R, p, p)
        Gauss-Newton matrices (LM coordinates).
    col : ndarray of int, (R,)
        The profiled parameter of each row.

    Returns
    -------
    ndarray, (R, p)
    """
    R, p = H.shape[0], H.shape[1]
    col = np.asarray(col, int)
    out = np.zeros((R, p))
    rows = np.arange(R)
    out[rows, col] = 1.0
    if p == 1 or R == 0:
        return out
    # each row's other parameters (o), in order: every H_oo has the same size, one batch
    others = np.array([[k for k in range(p) if k != j] for j in range(p)])[col]  # (R, p - 1)
    Hoo = H[rows[:, None, None], others[:, :, None], others[:, None, :]]
    Hoj = H[rows[:, None], others, col[:, None]]
    with np.errstate(all="ignore"):
        # well conditioned only: the smallest eigenvalue of H_oo scaled to unit diagonal
        # above SINGULAR_PIVOT (as the LM step's test); else the point starts where it was
        d = np.sqrt(np.abs(np.diagonal(Hoo, axis1=1, axis2=2)))
        scaled = Hoo / (d[:, :, None] * d[:, None, :])
        ok = np.all(np.isfinite(scaled), axis=(1, 2)) & np.all(d > 0, axis=1)
        ok[ok] = np.linalg.eigvalsh(scaled[ok])[:, 0] > SINGULAR_PIVOT
        if ok.any():
            sl = -np.linalg.solve(Hoo[ok], Hoj[ok][..., None])[..., 0]
            good = np.all(np.isfinite(sl), axis=1)
            keep = rows[ok][good]
            out[keep[:, None], others[keep]] = sl[good]
    return out


def _point(prob, idx, col, t, psi, atol, slope=None):
    """P(theta_col = t) for rows idx (chart idx[r], parameter col[r]), minimising the others
    from ``psi`` (moved along ``slope``, :func:`profile_slopes`, to the new ``t``; kept within
    the bounds): (f, theta)."""
    theta = np.array(psi, float)
    rows = np.arange(theta.shape[0])
    if slope is not None:
        theta = np.maximum(theta + slope * (t - theta[rows, col])[:, None], prob.lower)
    theta[rows, col] = t
    hold = np.zeros(theta.shape, bool)
    hold[rows, col] = True
    theta, f, _, _ = levenberg_marquardt(prob, theta, max_iter=PROFILE_MAX_ITER, tol=0.0,
                                         f_exact=np.zeros(idx.size), atol=atol, hold=hold,
                                         rows=idx)
    return f, theta


def _profile_ends(prob, chart, col, side, theta_hat, f_hat, delta, heff, limit, limit_code,
                  slope=None):
    """Interval ends searched together, one per row: chart ``chart[r]``, parameter ``col[r]``,
    ``side[r]`` -1 (lower) or +1 (upper); the search stops at ``limit[r]`` with
    ``limit_code[r]``. ``theta_hat``, ``f_hat``, ``delta`` and ``heff`` are per row."""
    R = chart.size
    rows = np.arange(R)
    down = side < 0
    t_hat = theta_hat[rows, col]
    res = t_hat.copy()
    code = np.full(R, BOUND_FOUND)
    todo = delta > 0  # an exact fit with the noise estimated from it: zero width
    at_limit = todo & down & (t_hat <= limit)
    res[at_limit], code[at_limit] = limit[at_limit], limit_code[at_limit]
    todo &= ~at_limit
    zt = np.sqrt(np.maximum(delta, 0.0))
    atol = POINT_ATOL * delta
    with np.errstate(divide="ignore", invalid="ignore"):
        step = np.where(heff > 0, np.sqrt(delta / heff), 0.0)
    step = np.where((step > 0) & (step < F_OVERFLOW), step, np.maximum(np.abs(t_hat), 1e-3))
    t_lo, z_lo, psi = t_hat.copy(), np.zeros(R), theta_hat.copy()
    t1 = t_hat + side * step
    t_hi, z_hi = t1.copy(), np.zeros(R)
    bracketing = todo.copy()
    refining = np.zeros(R, bool)
    for _ in range(BRACKET_STEPS):
        ia = np.flatnonzero(bracketing)
        if ia.size == 0:
            break
        lim = limit[ia]
        t = np.where(down[ia], np.maximum(t1[ia], lim), np.minimum(t1[ia], lim))
        f1, psi1 = _point(prob, chart[ia], col[ia], t, psi[ia], atol[ia],
                          None if slope is None else slope[ia])
        failed = ~(f1 < F_OVERFLOW)
        z1 = np.sqrt(np.maximum(f1 - f_hat[ia], 0.0))
        hit = ~failed & (z1 >= zt[ia])
        at_end = ~failed & ~hit & np.where(down[ia], t <= lim, t >= lim)
        go = ~failed & ~hit & ~at_end
        res[ia[failed]], code[ia[failed]] = np.nan, BOUND_FAILED
        res[ia[at_end]], code[ia[at_end]] = lim[at_end], limit_code[ia[at_end]]
        t_hi[ia[hit]], z_hi[ia[hit]] = t[hit], z1[hit]
        refining[ia[hit]] = True
        bracketing[ia[failed | hit | at_end]] = False
        g = ia[go]
        span = t[go] - t_lo[g]
        dz = z1[go] - z_lo[g]
        tn = t[go] + BRACKET_FLAT_GROWTH * span
        with np.errstate(divide="ignore", invalid="ignore"):
            sec = t[go] + (zt[g] - z1[go]) * span / dz * BRACKET_OVERSHOOT
        sec = np.where(np.abs(sec - t[go]) > BRACKET_GROWTH * np.abs(span),
                       t[go] + BRACKET_GROWTH * span, sec)
        tn = np.where(dz > 0, sec, tn)
        t_lo[g], z_lo[g], psi[g] = t[go], z1[go], psi1[go]
        t1[g] = tn
    res[bracketing], code[bracketing] = np.nan, BOUND_FAILED
    a, fa = t_lo.copy(), z_lo - zt
    b, fb = t_hi.copy(), z_hi - zt
    for _ in range(ILLINOIS_STEPS):
        ia = np.flatnonzero(refining)
        if ia.size == 0:
            break
        done = (np.abs(fb[ia]) <= ROOT_TOL * zt[ia]) | (
            np.abs(b[ia] - a[ia]) <= 1e-12 * np.maximum(np.abs(a[ia]), np.abs(b[ia])))
        res[ia[done]] = b[ia[done]]
        refining[ia[done]] = False
        ia = ia[~done]
        if ia.size == 0:
            break
        c = b[ia] - fb[ia] * (b[ia] - a[ia]) / (fb[ia] - fa[ia])
        fc_, psi_new = _point(prob, chart[ia], col[ia], c, psi[ia], atol[ia],
                              None if slope is None else slope[ia])
        psi[ia] = psi_new
        failed = ~(fc_ < F_OVERFLOW)
        res[ia[failed]], code[ia[failed]] = np.nan, BOUND_FAILED
        refining[ia[failed]] = False
        fc = np.sqrt(np.maximum(fc_ - f_hat[ia], 0.0)) - zt[ia]
        flip = fc * fb[ia] < 0
        a[ia] = np.where(flip, b[ia], a[ia])
        fa[ia] = np.where(flip, fb[ia], 0.5 * fa[ia])  # Illinois: halve the retained end
        b[ia], fb[ia] = c, fc
        b[ia[failed]] = np.nan
    res[refining] = b[refining]
    return res, code


def profile_intervals(prob: Problem, theta_hat, f_hat, delta, H, caps, which=None):
    """Profile-likelihood ends of the parameters ``which`` (default: all) of every chart.

    Parameters
    ----------
    prob : sca.lm.Problem
        The charts (scaled units) and what is fixed about them.
    theta_hat : ndarray, (N, p)
        The optimum, LM coordinates (u = C^e0 for C, own units otherwise).
    f_hat : ndarray, (N,)
        The objective there (problem units).
    delta : ndarray, (N,)
        The rise that bounds the interval (:func:`sca.assess.profile_delta`); 0 gives a
        zero-width interval.
    H : ndarray, (N, p, p)
        Gauss-Newton matrix at the optimum (its curvature sets the first step).
    caps : ndarray, (p,)
        Where an upper end is open (LM coordinates; :func:`sca.model.upper_cap`); minus it is
        where a lower end is open for a parameter without lower bound.
    which : iterable of int, optional
        The columns whose intervals are searched (default: all); the others keep
        ``theta_hat`` as both ends with code ``BOUND_FOUND``.

    Returns
    -------
    ends : ndarray, (N, p, 2)
        Lower and upper ends (LM coordinates; NaN where the search failed).
    codes : ndarray of int, (N, p, 2)
        ``BOUND_FOUND``, ``BOUND_ZERO`` (at the lower bound), ``BOUND_OPEN`` (beyond the cap;
        the end returned is the cap) or ``BOUND_FAILED``.

    References
    ----------
    D. J. Venzon & S. H. Moolgavkar, "A method for computing profile-likelihood-based
    confidence intervals", Applied Statistics 37 (1988) 87-94.
    """
    N, p = theta_hat.shape
    which = list(range(p) if which is None else which)
    ends = np.repeat(theta_hat[:, :, None], 2, axis=2).astype(float)
    codes = np.full((N, p, 2), BOUND_FOUND)
    if not which or N == 0:
        return ends, codes
    # every end of every chart searched together: one row per (chart, parameter, side)
    charts, cols, sides = (a.ravel() for a in np.meshgrid(np.arange(N), which, (-1.0, 1.0),
                                                           indexing="ij"))
    heff = effective_curvature(H)  # (N, p)
    lower_open = ~np.isfinite(prob.lower)
    lower = np.where(lower_open, -np.asarray(caps, float), prob.lower)
    down = sides < 0
    limit = np.where(down, lower[cols], np.asarray(caps, float)[cols])
    limit_code = np.where(down & ~lower_open[cols], BOUND_ZERO, BOUND_OPEN)
    # the two sides of a (chart, parameter) are adjacent rows and share its slope
    slopes = np.repeat(profile_slopes(np.asarray(H, float)[charts[::2]], cols[::2]), 2, axis=0)
    res, code = _profile_ends(prob, charts, cols, sides, theta_hat[charts], f_hat[charts],
                              delta[charts], heff[charts, cols], limit, limit_code, slopes)
    k = (sides > 0).astype(int)
    ends[charts, cols, k] = res
    codes[charts, cols, k] = code
    return ends, codes
