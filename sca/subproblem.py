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
from forward.errors import InputError


@dataclass
class Subproblem:
    """One compiled QP: the problem, its variable v = (delta, ds), its parameters, and
    ``blocks``, the one description of its constraints (see :func:`constraints`).

    Every parameter holds a value in units of rho = ||Q^T r0|| (see the module docstring);
    the optional ones are None where the structure has no such constraint.

    Attributes
    ----------
    problem : cvxpy.Problem
        minimise ||R v - b||^2 subject to the constraints of ``blocks`` (DPP).
    v : cvxpy.Variable, (n_free + n_s,)
        The step: delta (scaled nonlinear parameters) then ds (backscatter).
    R : cvxpy.Parameter, (n_free + n_s, n_free + n_s)
        The triangular factor of [A E] = Q R.
    b : cvxpy.Parameter, (n_free + n_s,)
        Q^T r0 / rho.
    lo : cvxpy.Parameter, (n_pos,), or None
        Lower bounds of the first ``n_pos`` entries of delta (eq 16).
    s_lo : cvxpy.Parameter, (n_s,), or None
        Lower bounds of ds, -s_t / rho (eq 18).
    hi : cvxpy.Parameter, (n_free,), or None
        Trust-region half-width of delta (safeguarded mode).
    TDw : cvxpy.Parameter, (q, z_free), or None
        T D_w: the rows of eq 16's T w >= 0 in the step.
    Tw_rhs : cvxpy.Parameter, (q,), or None
        Their right-hand side, -T w_t / rho.
    a_eq : cvxpy.Parameter, (n_free,), or None
        The row of eq 17 linearised.
    b_eq : cvxpy.Parameter (scalar), or None
        Its right-hand side.
    n_free : int
        Entries of delta.
    n_s : int
        Entries of ds (m, or 0 when s is held).
    blocks : tuple
        The constraints, each (kind, slice of v, parameters): 'lower' v[sl] >= p; 'box'
        -p <= v[sl] <= p; 'rows' A v[sl] >= p2; 'equal' a . v[sl] == p2.
    """

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
    #: the constraints, each (kind, slice of v, parameters): 'lower' v[sl] >= p; 'box'
    #: -p <= v[sl] <= p; 'rows' A v[sl] >= p2; 'equal' a . v[sl] == p2
    blocks: tuple = ()


__all__ = ["Subproblem", "assign", "compiled_subproblem", "thread_builds", "build_subproblem",
           "constraints", "polish", "equality_step", "POLISH_ACTIVE_TOL", "POLISH_FEAS_TOL",
           "POLISH_ROUNDS"]

_LOCAL = threading.local()


def compiled_subproblem(*structure) -> "Subproblem":
    """The problem of :func:`build_subproblem` for ``structure``, built once per thread and
    reused by every later fit in that thread (the DPP compile happens on its first solve).

    Parameters
    ----------
    *structure
        The positional arguments of :func:`build_subproblem`: ``n_free``, ``n_pos``,
        ``w_slice``, ``q``, ``n_s``, ``trust_region``, ``has_equality`` (hashable: the cache
        key).

    Returns
    -------
    Subproblem
        This thread's problem of that structure (mutable: not to be shared between threads).
    """
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
    """How many subproblems this thread has built (a diagnostic for tests).

    Returns
    -------
    int
        Calls of :func:`build_subproblem` made by :func:`compiled_subproblem` in this thread.
    """
    return getattr(_LOCAL, "builds", 0)


def constraints(sub: Subproblem, v, numeric: bool = False) -> list:
    """The QP's constraints on ``v`` from ``sub.blocks``: with the parameters themselves (the
    DPP problem) or, ``numeric``, with their current values as constants (a problem rebuilt
    from scratch, the benchmark's baseline).

    Parameters
    ----------
    sub : Subproblem
        Its ``blocks`` describe the constraints.
    v : cvxpy.Variable or cvxpy.Expression, (n_free + n_s,)
        The step the constraints apply to.
    numeric : bool, optional
        Use the parameters' current values instead of the parameters (default False).

    Returns
    -------
    list of cvxpy.Constraint
        One per 'lower', 'rows' and 'equal' block, two per 'box' block, in the order of
        ``sub.blocks``.
    """
    def val(p):
        return p.value if numeric else p

    out = []
    for kind, sl, *params in sub.blocks:
        x = v[sl]
        if kind == "lower":
            out.append(x >= val(params[0]))
        elif kind == "box":
            out += [x <= val(params[0]), x >= -val(params[0])]
        elif kind == "rows":
            out.append(val(params[0]) @ x >= val(params[1]))
        else:  # equal
            out.append(val(params[0]) @ x == val(params[1]))
    return out


def build_subproblem(n_free: int, n_pos: int, w_slice: tuple | None, q: int, n_s: int,
                     trust_region: bool, has_equality: bool) -> Subproblem:
    """Build the DPP QP above (a new problem; :func:`compiled_subproblem` caches it per thread).

    Parameters
    ----------
    n_free : int
        Number of entries of delta; the first ``n_pos`` are bounded below (C, a_CDOM, ...).
    n_pos : int
        Number of entries of delta bounded below (a leading slice of delta).
    w_slice : (start, stop) or None
        The w entries inside delta where eq 16 needs q rows (None: w not free, or bounded
        among the first ``n_pos``).
    q : int
        Number of wavelengths.
    n_s : int
        Number of free backscatter entries (m, or 0 when s is fixed).
    trust_region : bool
        Bound |delta| by a radius.
    has_equality : bool
        Eq 17 constrains delta.

    Returns
    -------
    Subproblem
        Its parameters without values (set them before solving).

    Raises
    ------
    ValueError
        If the step has no entries (n_free + n_s == 0).

    References
    ----------
    Blasinski & Farrell, "A Three Parameter Underwater Image Formation Model", eqs 15-18
    (linearised).
    """
    nv = n_free + n_s
    if nv == 0:
        raise InputError("fix", "nothing is left to estimate")
    v = cp.Variable(nv, name="v")
    R = cp.Parameter((nv, nv), name="R")
    b = cp.Parameter(nv, name="b")
    lo = s_lo = hi = TDw = Tw_rhs = a_eq = b_eq = None
    blocks = []
    if n_pos:
        lo = cp.Parameter(n_pos, name="lo")
        blocks.append(("lower", slice(0, n_pos), lo))
    if trust_region and n_free:
        hi = cp.Parameter(n_free, nonneg=True, name="hi")
        blocks.append(("box", slice(0, n_free), hi))
    if w_slice is not None:
        zf = w_slice[1] - w_slice[0]
        TDw = cp.Parameter((q, zf), name="TDw")
        Tw_rhs = cp.Parameter(q, name="Tw_rhs")
        blocks.append(("rows", slice(*w_slice), TDw, Tw_rhs))
    if has_equality:
        a_eq = cp.Parameter(n_free, name="a_eq")
        b_eq = cp.Parameter(name="b_eq")
        blocks.append(("equal", slice(0, n_free), a_eq, b_eq))
    if n_s:
        s_lo = cp.Parameter(n_s, name="s_lo")
        blocks.append(("lower", slice(n_free, nv), s_lo))
    sub = Subproblem(None, v, R, b, lo, s_lo, hi, TDw, Tw_rhs, a_eq, b_eq, n_free, n_s,
                     tuple(blocks))
    sub.problem = cp.Problem(cp.Minimize(cp.sum_squares(R @ v - b)), constraints(sub, v))
    return sub


def assign(sub: Subproblem, values: dict) -> str:
    """Write parameter values of ``sub`` without cvxpy's per-value validation (about 30 µs a
    value, eight values an iteration): the checks it makes on these parameters (shape, real,
    the sign of a nonnegative one) are made here, once, and values must be finite. The values
    are stored as given (the loop passes float64 arrays and floats, which cvxpy's setter
    stored unconverted too).

    Parameters
    ----------
    sub : Subproblem
        The QP.
    values : dict
        Parameter name (an attribute of ``sub``: 'R', 'b', 'lo', ...) -> value in the QP's
        units, of the parameter's shape.

    Returns
    -------
    str
        '' when every value was written; else which values are not finite (NaN or infinite),
        and none is written (the loop reports it as the solve's failure).

    Raises
    ------
    ValueError
        For a value of the wrong shape, a complex value, or a negative value of a nonnegative
        parameter.
    """
    bad = []
    for name, val in values.items():
        param = getattr(sub, name)
        if np.shape(val) != param.shape:
            raise InputError(name, f"a value of shape {np.shape(val)} for the QP's parameter "
                             f"of shape {param.shape}")
        if np.iscomplexobj(val):
            raise InputError(name, "the QP's parameters are real, got a complex value")
        if not np.all(np.isfinite(val)):
            bad.append(name)
        elif param.attributes["nonneg"] and np.any(np.asarray(val) < 0):
            raise InputError(name, "the QP's parameter is nonnegative, got a value below 0")
    if bad:
        return "the linearised problem is not finite (" + ", ".join(bad) + ")"
    for name, val in values.items():
        getattr(sub, name).save_value(val)
    return ""


def _rows(sub: Subproblem):
    """Every constraint of ``sub`` at its current values as rows: inequalities (A, lb) with
    A v >= lb, and equalities (C, d) with C v = d."""
    nv = sub.n_free + sub.n_s
    ineq, lbs, eq, rhs = [], [], [], []
    for kind, sl, *params in sub.blocks:
        idx = np.arange(nv)[sl]
        if kind in ("lower", "box"):
            val = np.broadcast_to(np.asarray(params[0].value, float), idx.shape)
            E = np.eye(nv)[idx]
            if kind == "lower":  # v_i >= lo_i
                ineq.append(E)
                lbs.append(val)
            else:  # -hi_i <= v_i <= hi_i, as -v_i >= -hi_i and v_i >= -hi_i
                both = np.empty((2 * idx.size, nv))
                both[0::2], both[1::2] = -E, E
                ineq.append(both)
                lbs.append(np.repeat(-val, 2))
            continue
        A = np.zeros((np.atleast_2d(params[0].value).shape[0], nv))
        A[:, idx] = np.atleast_2d(params[0].value)
        (ineq if kind == "rows" else eq).append(A)
        (lbs if kind == "rows" else rhs).append(np.atleast_1d(np.asarray(params[1].value, float)))

    def stack(parts, shape):
        return np.concatenate(parts) if parts else np.zeros(shape)
    return (stack(ineq, (0, nv)), stack(lbs, (0,)), stack(eq, (0, nv)), stack(rhs, (0,)))


#: The active-set polish: constraints within this (relative) distance of their bound are taken
#: as active; a result must meet every constraint to POLISH_FEAS_TOL; at most POLISH_ROUNDS
#: rounds of adding violated constraints.
POLISH_ACTIVE_TOL, POLISH_FEAS_TOL, POLISH_ROUNDS = 1e-4, 1e-9, 10
#: A polished step is kept when its objective is not above the interior point's by more than
#: this (relative) amount.
POLISH_SLACK = 1e-14


def polish(sub: Subproblem, v: np.ndarray, *, active_tol: float = POLISH_ACTIVE_TOL,
           feas_tol: float = POLISH_FEAS_TOL, f_ref: float | None = None,
           max_rounds: int = POLISH_ROUNDS):
    """Active-set polish of an approximate solution ``v`` of ``sub`` (in its units).

    Interior-point methods stop a little inside the bounds that are active at the solution,
    and where a bound is *weakly* active (zero multiplier: e.g. s = 0 for a chart with no
    backscatter, or a_CDOM = 0) they can be far less accurate than their tolerance, or stop
    at their iteration limit. Here the constraints within ``active_tol`` of their bound are
    taken as active, the equality-constrained least-squares problem (with eq 17) is solved
    exactly (KKT system), and constraints the result violates are added to the active set
    (up to ``max_rounds`` times).

    Parameters
    ----------
    sub : Subproblem
        Its parameters hold the QP solved.
    v : ndarray
        The approximate solution.
    active_tol, feas_tol : float
        Relative distance to a bound taken as active; feasibility required of the result.
    f_ref : float, optional
        The objective the result must not exceed (default: that of ``v``).
    max_rounds : int
        Most rounds of adding violated constraints (default :data:`POLISH_ROUNDS`).

    Returns
    -------
    v : ndarray
        The polished step, or ``v`` itself where the polish fails.
    polished : bool
        True where the polished step is returned.

    References
    ----------
    J. Nocedal & S. J. Wright, Numerical Optimization, 2nd ed., Springer (2006), secs. 16.1
    and 16.5 (KKT system, active-set methods).
    """
    R, b = sub.R.value, sub.b.value
    nv = R.shape[1]
    scale = 1.0 + float(np.max(np.abs(v)))
    A_in, lb, C_eq, d_eq = _rows(sub)
    norms = 1.0 + np.abs(A_in).sum(axis=1)
    active = (A_in @ v - lb) <= active_tol * scale * norms
    H, g = R.T @ R, R.T @ b
    vp = None
    for _ in range(max_rounds):
        C = np.vstack([C_eq, A_in[active]])
        d = np.concatenate([d_eq, lb[active]])
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
        if not np.any(bad & ~active):
            # only constraints already held are violated (e.g. both sides of a box): the active
            # set cannot grow, so every further round would repeat this one to max_rounds
            return v, False
        active |= bad
    else:
        return v, False
    if C_eq.shape[0] and np.any(np.abs(C_eq @ vp - d_eq) > feas_tol * scale):
        return v, False
    if np.any(lb - A_in @ vp > feas_tol * scale * norms):
        return v, False
    f_v = float(np.sum((R @ v - b) ** 2)) if f_ref is None else f_ref
    f_p = float(np.sum((R @ vp - b) ** 2))
    if f_p <= f_v + POLISH_SLACK * max(1.0, f_v):
        return vp, True
    return v, False


def equality_step(R, b, eq_row=None, eq_rhs=0.0):
    """Minimiser of ||R v - b||^2 subject to eq_row . v = eq_rhs (no inequalities): the KKT
    system, solved in the least-squares sense (minimum norm where singular).

    Parameters
    ----------
    R : ndarray, (k, nv)
        The least-squares matrix (the subproblem's triangular factor).
    b : ndarray, (k,)
        The right-hand side.
    eq_row : ndarray, (nv,), optional
        The equality's row (eq 17 linearised); None: unconstrained least squares.
    eq_rhs : float, optional
        The equality's right-hand side (default 0).

    Returns
    -------
    ndarray, (nv,)
        The step v (``numpy.linalg.lstsq`` of the KKT system [[R^T R, a], [a^T, 0]], or of
        R v = b without the equality).

    References
    ----------
    J. Nocedal & S. J. Wright, Numerical Optimization, 2nd ed., Springer (2006), sec. 16.1
    (equality-constrained quadratic programs, the KKT system).
    """
    if eq_row is None:
        return np.linalg.lstsq(R, b, rcond=None)[0]
    nv = R.shape[1]
    K = np.zeros((nv + 1, nv + 1))
    K[:nv, :nv] = R.T @ R
    K[:nv, nv] = K[nv, :nv] = eq_row
    rhs = np.concatenate([R.T @ b, [eq_rhs]])
    return np.linalg.lstsq(K, rhs, rcond=None)[0][:nv]
