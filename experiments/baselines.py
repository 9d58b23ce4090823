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
from sca.subproblem import Subproblem, constraints

__all__ = ["RebuildEstimator", "constant_problem"]


def constant_problem(sub: Subproblem, AE, r0):
    """The same QP as ``sub`` written as a CVX user would: the full least-squares residual
    ``r0 - AE v`` (m n rows, not QR-compressed) and every constraint of
    :func:`sca.subproblem.constraints` as a constant, in a fresh problem that cvxpy must
    canonicalise from scratch (the benchmark's baseline). Returns (problem, v)."""
    v = cp.Variable(sub.n_free + sub.n_s)
    problem = cp.Problem(cp.Minimize(cp.sum_squares(r0 - AE @ v)),
                         constraints(sub, v, numeric=True))
    return problem, v


class RebuildEstimator(sca.Estimator):
    """:class:`sca.Estimator` whose QP is rebuilt with constants every iteration."""

    def qp_problem(self, sub, lin):
        return constant_problem(sub, lin.AE, lin.r0 / lin.unit)
