"""Profile-likelihood intervals of any free parameter, for many charts at once.

The 95 % interval of a parameter theta_j is {theta_j : min over the other parameters of f <= f_hat
+ delta} (:func:`sca.assess.profile_delta`). Each end is searched from the optimum on
z(theta_j) = sqrt(P(theta_j) - f_hat), which is linear in theta_j for a linear model:

* first, by the method of Venzon & Moolgavkar (:func:`_vm_ends`): Newton's method on the end's two conditions together
  (z = sqrt(delta), the other parameters at their minimum), one evaluation of the model
  function (:func:`sca.lm.evaluate`) per step;
* an end it does not find within ``newton_steps`` (default :data:`VM_MAX_ITER`) evaluations,
  and every end elsewhere, by a first step from the
  Gauss-Newton curvature, secant extrapolation until the target sqrt(delta) is bracketed, then
  the Illinois method to 1e-3 of sqrt(delta) (:func:`_profile_ends`). Every profile point
  P(theta_j) is the Levenberg-Marquardt of :mod:`sca.lm` with theta_j held, started from the
  previous point moved along the profile's Gauss-Newton slope at the optimum
  (:func:`profile_slopes`).

Both use the same engine and model function as the fit (so every estimator's intervals agree)
and accept an end on the same tests (Newton's test of the other parameters' convergence, the
undamped Gauss-Newton decrease, is as strict as the profile points' or stricter). C is
searched in u = C^e0.

References
----------
D. J. Venzon & S. H. Moolgavkar, "A method for computing profile-likelihood-based confidence
intervals", Applied Statistics 37 (1988) 87-94.
"""

from __future__ import annotations

import numpy as np

from .lm import SINGULAR_PIVOT, evaluate, levenberg_marquardt
from .problem import Problem, undo_powers
from forward.errors import InputError

__all__ = ["BOUND_FOUND", "BOUND_ZERO", "BOUND_OPEN", "BOUND_FAILED", "PROFILE_MAX_ITER",
           "BRACKET_STEPS", "ILLINOIS_STEPS", "BRACKET_OVERSHOOT", "BRACKET_GROWTH",
           "ROOT_TOL", "VM_MAX_ITER", "own_units", "profile_intervals", "profile_slopes",
           "effective_curvature"]

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
#: Newton iterations of the Venzon-Moolgavkar search of an end (one evaluation of the model
#: function each); an end not found within them is searched by bracketing and Illinois.
VM_MAX_ITER = 6


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


def _others_system(H, col):
    """Each row's other parameters (o, in order: every H_oo has the same size, one batch),
    H_oo (R, p - 1, p - 1), H_o,col (R, p - 1) and whether H_oo is well conditioned: its
    smallest eigenvalue, scaled to unit diagonal, above :data:`sca.lm.SINGULAR_PIVOT` (as the
    LM step's test)."""
    R, p = H.shape[0], H.shape[1]
    rows = np.arange(R)
    others = np.array([[k for k in range(p) if k != j] for j in range(p)],
                      dtype=int).reshape(p, p - 1)[col]  # (R, p - 1)
    Hoo = H[rows[:, None, None], others[:, :, None], others[:, None, :]]
    Hoj = H[rows[:, None], others, col[:, None]]
    if p == 1:  # nothing else to minimise
        return others, Hoo, Hoj, np.ones(R, bool)
    with np.errstate(all="ignore"):
        d = np.sqrt(np.abs(np.diagonal(Hoo, axis1=1, axis2=2)))
        scaled = Hoo / (d[:, :, None] * d[:, None, :])
        ok = np.all(np.isfinite(scaled), axis=(1, 2)) & np.all(d > 0, axis=1)
        ok[ok] = np.linalg.eigvalsh(scaled[ok])[:, 0] > SINGULAR_PIVOT
    return others, Hoo, Hoj, ok


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
    others, Hoo, Hoj, ok = _others_system(H, col)
    with np.errstate(all="ignore"):
        if ok.any():
            sl = -np.linalg.solve(Hoo[ok], Hoj[ok][..., None])[..., 0]
            good = np.all(np.isfinite(sl), axis=1)
            keep = rows[ok][good]
            out[keep[:, None], others[keep]] = sl[good]
    return out


def _vm_step(theta, f, g, H, col, side, f_hat, delta, held):
    """One Venzon-Moolgavkar step of every row from its point ``theta`` (objective ``f``, half
    gradient ``g``, Gauss-Newton matrix ``H``) on the quadratic model: the others at their
    minimum given theta_col, theta + a + b dt (a = -H_oo^-1 g_o, b = -H_oo^-1 H_o,col on the
    others; a_col = 0, b_col = 1).

    dt is Newton's step on z = sqrt(P - ``f_hat``) to sqrt(``delta``), where P = A dt^2 + B dt
    + C is the quadratic profile (dz/dtheta_col = B / 2 z; z is nearly linear in theta_col), or,
    at the optimum (z = 0) or where the profile falls towards the end, the root of P = f_hat +
    delta (the larger for an upper end, ``side`` +1). The parameters ``held`` (R, p) stay where
    they are (their rows and columns of H, and their g, replaced by those of a parameter that
    does not move).

    Returns
    -------
    a, b : ndarray, (R, p)
        NaN where H_oo is not well conditioned.
    dt : ndarray, (R,)
        NaN where the quadratic profile misses the target.
    decrease : ndarray, (R,)
        g_o^T H_oo^-1 g_o, the decrease that re-optimising the others at this theta_col would
        bring (inf where unknown).
    """
    R, p = theta.shape
    rows = np.arange(R)
    a_full, b_full = np.full((R, p), np.nan), np.full((R, p), np.nan)
    dt_out, decrease = np.full(R, np.nan), np.full(R, np.inf)
    if held.any():
        H, g = np.array(H), np.where(held, 0.0, g)
        hr, hi = np.nonzero(held)
        H[hr, hi, :] = 0.0
        H[hr, :, hi] = 0.0
        H[hr, hi, hi] = 1.0
    others, Hoo, Hoj, ok = _others_system(H, col)
    if not ok.any():
        return a_full, b_full, dt_out, decrease
    go = g[rows[:, None], others]
    r, c = rows[ok], col[ok]
    with np.errstate(all="ignore"):
        sol = np.linalg.solve(Hoo[ok], np.stack([go[ok], Hoj[ok]], axis=-1)) if p > 1 else \
            np.zeros((r.size, 0, 2))
        a, b = -sol[..., 0], -sol[..., 1]
        A = H[r, c, c] + np.einsum("ro,ro->r", Hoj[ok], b)  # the profile's curvature
        B = 2.0 * (g[r, c] + np.einsum("ro,ro->r", go[ok], b))
        drop = -np.einsum("ro,ro->r", go[ok], a)
        C = f[ok] - drop
        root = np.sqrt(B * B - 4.0 * A * (C - f_hat[ok] - delta[ok]))
        dt = np.where(side[ok] > 0, -B + root, -B - root) / (2.0 * A)
        dt = np.where(A > 0, dt, np.nan)
        z = np.sqrt(np.maximum(C - f_hat[ok], 0.0))
        newton = (z > 0) & (side[ok] * B > 0)
        dt = np.where(newton, (np.sqrt(delta[ok]) - z) * 2.0 * z / B, dt)
    a_full[ok], b_full[ok] = 0.0, 0.0
    a_full[r[:, None], others[ok]] = a
    b_full[r[:, None], others[ok]] = b
    b_full[r, c] = 1.0
    dt_out[ok], decrease[ok] = dt, drop
    return a_full, b_full, dt_out, decrease


def _vm_ends(prob, chart, col, side, theta_hat, f_hat, delta, H, limit, limit_code,
             max_iter=VM_MAX_ITER):
    """The ends of the rows (as :func:`_profile_ends`' rows) by the Venzon-Moolgavkar method:
    Newton's method on the two conditions of an end, P(theta_col) = f_hat + delta and the others
    at their minimum, one model evaluation per iteration (:func:`_vm_step`), from the optimum.

    A parameter at its lower bound with the gradient not pointing into the bounds (g >= 0;
    at the optimum, where g is taken as 0, every parameter at its bound) is held there, and a
    step below a bound is cut to it. A step of theta_col beyond ``limit`` stops at the limit;
    one back across the optimum, or none (the quadratic profile misses the target) while the
    others are unsettled, is not taken (the others alone move). An end is found where the
    others' remaining decrease is below :data:`POINT_ATOL` delta (the undamped Gauss-Newton
    decrease: as strict as, or stricter than, the test of the search's profile points) and
    sqrt(P - f_hat) is below sqrt(delta) at the limit (the end is the limit, code
    ``limit_code``, as the search's) or within :data:`ROOT_TOL` of it (the search's test). A
    row whose H_oo is not well conditioned, whose profile misses the target with the others
    settled, whose objective overflows or which is not found within ``max_iter`` evaluations
    stops unfound (to be searched by :func:`_profile_ends`).

    Returns
    -------
    ends, codes : ndarray, (R,)
    found : ndarray of bool, (R,)
    """
    R, p = theta_hat.shape
    rows = np.arange(R)
    theta = np.array(theta_hat, float)
    f = np.array(f_hat, float)
    g = np.zeros((R, p))
    Hc = np.array(H, float)
    zt = np.sqrt(delta)
    atol = POINT_ATOL * delta
    t_hat = theta_hat[rows, col]
    res = np.full(R, np.nan)
    code = np.full(R, BOUND_FOUND)
    found = np.zeros(R, bool)
    active = rows.copy()
    for it in range(max_iter + 1):
        if active.size == 0:
            break
        k = np.arange(active.size)
        th, ca, sa = theta[active], col[active], side[active]
        # a parameter at its lower bound stays there while the gradient points out of bounds
        held = (th <= prob.lower) & (g[active] >= 0.0)
        held[k, ca] = False
        a, b, dt, decrease = _vm_step(th, f[active], g[active], Hc[active], ca, sa,
                                      f_hat[active], delta[active], held)
        t, lim = th[k, ca], limit[active]
        z = np.sqrt(np.maximum(f[active] - f_hat[active], 0.0))
        settled = decrease <= atol[active]
        # at the limit with the profile below the target, the end is the limit (as the
        # search's 'at end'), before the target's tolerance band is tested
        hit_limit = settled & (t == lim) & (z < zt[active])
        hit = settled & ~hit_limit & (np.abs(z - zt[active]) <= ROOT_TOL * zt[active])
        res[active[hit]] = t[hit]
        res[active[hit_limit]] = lim[hit_limit]
        code[active[hit_limit]] = limit_code[active[hit_limit]]
        found[active[hit | hit_limit]] = True
        with np.errstate(invalid="ignore"):
            # no step of theta_col (the profile misses the target): the others alone move
            # while they are unsettled; settled, the row stops
            lost = ~np.isfinite(dt)
            dt = np.where(lost & ~settled, 0.0, dt)
            dt = np.where(sa * (t + dt - t_hat[active]) > 0, dt, 0.0)  # not back across
            dt = np.where(lost & settled, np.nan, dt)
            beyond = ~(sa * (lim - (t + dt)) > 0) & np.isfinite(dt)  # stopped at the limit
        new = np.maximum(th + a + b * np.where(beyond, lim - t, dt)[:, None], prob.lower)
        new[k, ca] = np.where(beyond, lim, t + dt)  # (NaN stays NaN)
        go = ~(hit | hit_limit) & np.all(np.isfinite(new), axis=1)
        if it == max_iter:
            break
        active, new = active[go], new[go]
        if active.size == 0:
            break
        with np.errstate(all="ignore"):  # a step far out overflows: the row stops (below)
            ev = evaluate(prob, chart[active], new, True)
            fn, gn, Hn = ev.f, ev.g, ev.H
        ok = fn < F_OVERFLOW
        active, new = active[ok], new[ok]
        theta[active], f[active], g[active], Hc[active] = new, fn[ok], gn[ok], Hn[ok]
    return res, code, found


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


def profile_intervals(prob: Problem, theta_hat, f_hat, delta, H, caps, which=None, *,
                      newton_steps: int = VM_MAX_ITER):
    """Profile-likelihood ends of the parameters ``which`` (default: all) of every chart.

    Parameters
    ----------
    prob : sca.problem.Problem
        The units (any layout).
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
    newton_steps : int, optional
        Model evaluations allowed to the Venzon-Moolgavkar search of each end (default
        :data:`VM_MAX_ITER`; 0: every end by bracketing and Illinois alone).

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
    if int(newton_steps) != newton_steps or newton_steps < 0:
        raise InputError("newton_steps", f"must be a whole number >= 0, got {newton_steps!r}")
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
    res = np.full(charts.size, np.nan)
    code = np.full(charts.size, BOUND_FOUND)
    th, fh, dl = theta_hat[charts], f_hat[charts], delta[charts]
    # the Venzon-Moolgavkar search where the end is inside the limits; the rest, and every end
    # it does not find, by bracketing and Illinois
    t_hat = th[np.arange(charts.size), cols]
    newton = newton_steps > 0
    vm = np.flatnonzero((dl > 0) & (sides * (limit - t_hat) > 0) & np.isfinite(fh)) \
        if newton else np.zeros(0, int)
    found = np.zeros(charts.size, bool)
    if vm.size:
        res[vm], code[vm], found[vm] = _vm_ends(
            prob, charts[vm], cols[vm], sides[vm], th[vm], fh[vm], dl[vm],
            np.asarray(H, float)[charts[vm]], limit[vm], limit_code[vm], int(newton_steps))
    rest = np.flatnonzero(~found)
    if rest.size:
        res[rest], code[rest] = _profile_ends(
            prob, charts[rest], cols[rest], sides[rest], th[rest], fh[rest], dl[rest],
            heff[charts[rest], cols[rest]], limit[rest], limit_code[rest], slopes[rest])
    k = (sides > 0).astype(int)
    ends[charts, cols, k] = res
    codes[charts, cols, k] = code
    return ends, codes


def own_units(ends, codes, powers):
    """Interval ends (:func:`profile_intervals`) in the parameters' own units: the one place an
    estimator turns them into what it reports.

    A power coordinate's ends are undone (:func:`sca.problem.undo_powers`: C = u^(1/e0), an
    end <= 0 gives 0); an open end (``BOUND_OPEN``) becomes -inf (lower) or +inf (upper); a
    failed end stays NaN.

    Parameters
    ----------
    ends, codes : ndarray, (..., p, 2)
        The ends in theta's coordinates and their codes.
    powers : ndarray, (p,)
        Each column's exponent (:attr:`sca.problem.Problem.powers`).

    Returns
    -------
    ndarray, (..., p, 2)
    """
    ends = np.asarray(ends, float)
    x = np.where(np.isnan(ends), np.nan, undo_powers(ends, np.asarray(powers, float)[:, None]))
    return np.where(np.asarray(codes) == BOUND_OPEN, np.array([-np.inf, np.inf]), x)
