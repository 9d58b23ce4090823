"""The convex subproblem of the sequential convex loop, built once as a DPP cvxpy problem.

At the centre (x_t, s_t), with the free parameters scaled, x = x_t + D delta, s = s_t + ds, the
paper's Taylor linearisations of k(x) and of eq 17 give the QP in the step v = (delta, ds)

    minimise    || r0 - [A E] v ||^2                                (eq 15, linearised k)
    subject to  delta_pos >= -x_pos / D                             (eq 16: C, a_CDOM >= 0)
                -hi <= delta <= hi                                  (trust region, if any)
                T D_w delta_w >= -T w_t                             (eq 16: T w >= 0)
                a_eq . delta = b_eq                                 (eq 17, linearised)
                ds >= -s_t                                          (eq 18: s >= 0)

where r0 = vec(M - G(x_t) - s_t 1^T) (72 entries for 3 x 24), A = dG/dx D and E maps s to
every patch of its channel. Two exact reformulations keep the solver's numbers O(1):

* the least-squares term is passed in QR-compressed form: with [A E] = Q R (thin QR),
  ||r0 - [A E] v||^2 = ||Q^T r0 - R v||^2 + (||r0||^2 - ||Q^T r0||^2), a (p + m)-row
  residual instead of m n rows, with the same minimiser;
* the step is measured in units of rho = ||Q^T r0|| (every right-hand side is divided by rho),
  so that near convergence, where the step and residual are tiny, the interior-point method
  still solves a well-scaled problem and returns the step to full relative accuracy.

R, Q^T r0 / rho and the bounds / rho are ``cp.Parameter`` s set each iteration (no product of
two parameters, so the problem compiles once). The problem depends only on its
*structure* (which unknowns are free, z, q, m, trust region or not), so one compiled problem
serves every depth, distance and data set of that structure. A compiled problem is mutable
(its parameter values, its variable's value), so each thread has its own
(:func:`compiled_subproblem`): fits in several threads never share one.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

import cvxpy as cp
import numpy as np


@dataclass
class Subproblem:
    problem: cp.Problem
    v: cp.Variable
    R: cp.Parameter
    b: cp.Parameter
    lo: cp.Parameter | None
    s_lo: cp.Parameter | None
    hi: cp.Parameter | None
    TDw: cp.Parameter | None
    Tw_rhs: cp.Parameter | None
    a_eq: cp.Parameter | None
    b_eq: cp.Parameter | None
    n_free: int
    n_s: int


_LOCAL = threading.local()


def compiled_subproblem(*structure) -> "Subproblem":
    """The problem of :func:`build_subproblem` for ``structure``, built once per thread and
    reused by every later fit in that thread (the DPP compile happens on its first solve)."""
    cache = getattr(_LOCAL, "cache", None)
    if cache is None:
        cache = _LOCAL.cache = {}
        _LOCAL.builds = 0
    sub = cache.get(structure)
    if sub is None:
        sub = cache[structure] = build_subproblem(*structure)
        _LOCAL.builds += 1
    return sub


def thread_builds() -> int:
    """How many subproblems this thread has built (a diagnostic for tests)."""
    return getattr(_LOCAL, "builds", 0)


def build_subproblem(n_free: int, n_pos: int, w_slice: tuple | None, q: int, n_s: int,
                     trust_region: bool, has_equality: bool) -> Subproblem:
    """Build the DPP QP above (a new problem; :func:`compiled_subproblem` caches it per thread).

    ``n_free``: number of free entries of delta, the first ``n_pos`` of which (C, a_CDOM) are
    bounded below; ``w_slice``: (start, stop) of the w entries inside delta (None if w is not
    free); ``n_s``: number of free backscatter entries (m, or 0 when s is fixed);
    ``has_equality``: whether eq 17 constrains delta.
    """
    nv = n_free + n_s
    if nv == 0:
        raise ValueError("fix: nothing is left to estimate")
    v = cp.Variable(nv, name="v")
    R = cp.Parameter((nv, nv), name="R")
    b = cp.Parameter(nv, name="b")
    lo = s_lo = hi = TDw = Tw_rhs = a_eq = b_eq = None
    cons = []
    delta = v[:n_free]
    if n_pos:
        lo = cp.Parameter(n_pos, name="lo")
        cons.append(v[:n_pos] >= lo)
    if trust_region and n_free:
        hi = cp.Parameter(n_free, nonneg=True, name="hi")
        cons += [delta <= hi, delta >= -hi]
    if w_slice is not None:
        zf = w_slice[1] - w_slice[0]
        TDw = cp.Parameter((q, zf), name="TDw")
        Tw_rhs = cp.Parameter(q, name="Tw_rhs")
        cons.append(TDw @ v[w_slice[0]:w_slice[1]] >= Tw_rhs)
    if has_equality:
        a_eq = cp.Parameter(n_free, name="a_eq")
        b_eq = cp.Parameter(name="b_eq")
        cons.append(a_eq @ delta == b_eq)
    if n_s:
        s_lo = cp.Parameter(n_s, name="s_lo")
        cons.append(v[n_free:] >= s_lo)
    problem = cp.Problem(cp.Minimize(cp.sum_squares(R @ v - b)), cons)
    return Subproblem(problem, v, R, b, lo, s_lo, hi, TDw, Tw_rhs, a_eq, b_eq, n_free, n_s)


def _inequalities(sub: Subproblem):
    """Every inequality of ``sub`` as rows of (A, lb) with A v >= lb."""
    n_free, nv = sub.n_free, sub.n_free + sub.n_s
    rows, lbs = [], []
    eye = np.eye(nv)
    if sub.lo is not None:
        for i, l_val in enumerate(sub.lo.value):
            rows.append(eye[i])
            lbs.append(l_val)
    if sub.s_lo is not None:
        for i, l_val in zip(range(n_free, nv), sub.s_lo.value):
            rows.append(eye[i])
            lbs.append(l_val)
    if sub.hi is not None:
        for i in range(n_free):
            rows += [-eye[i], eye[i]]
            lbs += [-sub.hi.value[i], -sub.hi.value[i]]
    if sub.TDw is not None:
        w0 = n_free - sub.TDw.value.shape[1]  # the w block: trailing z entries of delta
        for j in range(sub.TDw.value.shape[0]):
            e = np.zeros(nv)
            e[w0:n_free] = sub.TDw.value[j]
            rows.append(e)
            lbs.append(sub.Tw_rhs.value[j])
    if not rows:
        return np.zeros((0, nv)), np.zeros(0)
    return np.array(rows), np.array(lbs)


def polish(sub: Subproblem, v: np.ndarray, *, active_tol: float = 1e-4, feas_tol: float = 1e-9,
           f_ref: float | None = None, max_rounds: int = 10):
    """Active-set polish of an approximate solution ``v`` of ``sub`` (in its units).

    Interior-point methods stop a little inside the bounds that are active at the solution,
    and where a bound is *weakly* active (zero multiplier: e.g. s = 0 for a chart with no
    backscatter, or a_CDOM = 0) they can be far less accurate than their tolerance, or stop
    at their iteration limit. Here the constraints within ``active_tol`` of their bound are
    taken as active, the equality-constrained least-squares problem (with eq 17) is solved
    exactly (KKT system), and constraints the result violates are added to the active set
    (up to ``max_rounds`` times). The result is returned if it satisfies every constraint to
    ``feas_tol`` and its objective is not above ``f_ref`` (default: that of ``v``); otherwise
    ``v`` itself. Returns (v, polished: bool).
    """
    R, b = sub.R.value, sub.b.value
    nv = R.shape[1]
    scale = 1.0 + float(np.max(np.abs(v)))
    A_in, lb = _inequalities(sub)
    eq_rows, eq_rhs = [], []
    if sub.a_eq is not None:
        e = np.zeros(nv)
        e[:sub.n_free] = sub.a_eq.value
        eq_rows.append(e)
        eq_rhs.append(float(sub.b_eq.value))
    norms = 1.0 + np.abs(A_in).sum(axis=1)
    active = (A_in @ v - lb) <= active_tol * scale * norms
    H, g = R.T @ R, R.T @ b
    vp = None
    for _ in range(max_rounds):
        C = np.vstack([np.array(eq_rows).reshape(-1, nv), A_in[active]])
        d = np.concatenate([eq_rhs, lb[active]])
        if C.shape[0]:
            k = C.shape[0]
            K = np.block([[H, C.T], [C, np.zeros((k, k))]])
            vp = np.linalg.lstsq(K, np.concatenate([g, d]), rcond=None)[0][:nv]
        else:
            vp = np.linalg.lstsq(R, b, rcond=None)[0]
        if not np.all(np.isfinite(vp)):
            return v, False
        viol = lb - A_in @ vp
        bad = viol > feas_tol * scale * norms
        if not bad.any():
            break
        active |= bad
    else:
        return v, False
    if eq_rows and abs(eq_rows[0] @ vp - eq_rhs[0]) > feas_tol * scale:
        return v, False
    if np.any(lb - A_in @ vp > feas_tol * scale * norms):
        return v, False
    f_v = float(np.sum((R @ v - b) ** 2)) if f_ref is None else f_ref
    f_p = float(np.sum((R @ vp - b) ** 2))
    if f_p <= f_v + 1e-14 * max(1.0, f_v):
        return vp, True
    return v, False


def equality_step(R, b, eq_row=None, eq_rhs=0.0):
    """Minimiser of ||R v - b||^2 subject to eq_row . v = eq_rhs (no inequalities): the KKT
    system, solved in the least-squares sense (minimum norm where singular)."""
    if eq_row is None:
        return np.linalg.lstsq(R, b, rcond=None)[0]
    nv = R.shape[1]
    K = np.zeros((nv + 1, nv + 1))
    K[:nv, :nv] = R.T @ R
    K[:nv, nv] = K[nv, :nv] = eq_row
    rhs = np.concatenate([R.T @ b, [eq_rhs]])
    return np.linalg.lstsq(K, rhs, rcond=None)[0][:nv]
