"""Benchmark-only baselines (not used by the package's estimators).

* :class:`RebuildEstimator` -- the paper's loop as a CVX user would write it: every iteration
  builds a new cvxpy problem with the QP's numbers as constants (the full m n-row least-squares
  residual, not QR-compressed), which cvxpy must canonicalise from scratch. It solves the same
  QPs as :class:`sca.Estimator` (same iterates), so its time per iteration against the compiled
  DPP problem is the value of building the problem once.
"""

from __future__ import annotations

import cvxpy as cp

import sca
from sca.subproblem import Subproblem

__all__ = ["RebuildEstimator", "constant_problem"]


def constant_problem(sub: Subproblem, AE, r0):
    """The same QP as ``sub`` written as a CVX user would: the full least-squares residual
    ``r0 - AE v`` (m n rows, not QR-compressed) and every bound as a constant, in a fresh
    problem that cvxpy must canonicalise from scratch (the benchmark's baseline).
    Returns (problem, v)."""
    nv = sub.n_free + sub.n_s
    v = cp.Variable(nv)
    cons = []
    if sub.lo is not None:
        cons.append(v[:sub.lo.value.size] >= sub.lo.value)
    if sub.hi is not None:
        cons += [v[:sub.n_free] <= sub.hi.value, v[:sub.n_free] >= -sub.hi.value]
    if sub.TDw is not None:
        w0 = sub.n_free - sub.TDw.value.shape[1]
        cons.append(sub.TDw.value @ v[w0:sub.n_free] >= sub.Tw_rhs.value)
    if sub.a_eq is not None:
        cons.append(sub.a_eq.value @ v[:sub.n_free] == sub.b_eq.value)
    if sub.s_lo is not None:
        cons.append(v[sub.n_free:] >= sub.s_lo.value)
    problem = cp.Problem(cp.Minimize(cp.sum_squares(r0 - AE @ v)), cons)
    return problem, v


class RebuildEstimator(sca.Estimator):
    """:class:`sca.Estimator` whose QP is rebuilt with constants every iteration."""

    def qp_problem(self, sub, lin):
        return constant_problem(sub, lin.AE, lin.r0 / lin.unit)
