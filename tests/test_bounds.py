"""Intervals honest at the bounds (issue 46, item 4; sca.derived.bound_points): where the fit
puts C at its lower bound 0, a derived quantity's interval still holds the values the data
allow. Before, c(670)'s interval collapsed to the water's own (±1.9 %) and held the truth in
15 of 42 such charts of HONESTY.md's budget-prior world."""

import numpy as np
import pytest
from scipy import stats

import forward
import sca
from sca.derived import bound_points

from conftest import budget_prior_world

#: Charts of the budget-prior world (the independent renderer); its own seed.
N = 80
SEED = 5
#: Chance of a false failure of the coverage test if the intervals hold the truth 95 % of
#: the time.
FALSE_FAIL = 0.001


@pytest.fixture(scope="module")
def priors_world():
    est, r, _ = budget_prior_world(SEED, N)
    return est, r["truth"]


@pytest.mark.parametrize("name", ["c_443", "c_490", "c_555", "c_670", "a_nw_440"])
def test_charts_at_the_bound_are_covered_at_the_nominal_rate(priors_world, name):
    est, truth = priors_world
    at = est.reliable & (est.chl <= 0.0)
    assert at.sum() >= 8  # the world puts enough charts at the bound to test them
    ci, t = est.quantity_intervals[name][at], np.asarray(truth[name])[at]
    covered = int(np.sum((ci[:, 0] <= t) & (t <= ci[:, 1])))
    assert covered >= stats.binom.ppf(FALSE_FAIL, at.sum(), 0.95), (covered, at.sum())


def test_one_chart_and_the_batch_widen_alike_at_the_bound():
    """The single-chart estimator and the batch are layouts of the same rule: at C = 0 their
    intervals of every quantity agree (and hold the estimate)."""
    sim = forward.simulate_chart(0.02, 0.05, depth=3.0, distance=1.0, seed=1)
    e = sca.estimate(sim.rgb, depth=3.0, distance=1.0, sigma=sim.rgb_sigma, gain="free",
                     path_models=("beam",))
    b = sca.estimate_batch(sim.rgb[None], depth=3.0, distance=1.0, sigma=sim.rgb_sigma[None],
                           gain="free", path_models=("beam",))
    assert e.chl == 0.0 and b.chl[0] == 0.0 and np.isfinite(e.chl_ci[1])
    for name in ("c_443", "c_555", "c_670", "a_nw_440"):
        lo, hi = e.quantity_intervals[name]
        assert lo <= e.quantities[name] <= hi
        np.testing.assert_allclose(b.quantity_intervals[name][0], (lo, hi), rtol=0.02)


def test_bound_points_hold_the_bounded_column_and_leave_other_units_alone():
    """sca.derived.bound_points on a toy problem: the unit at its bound gets the point at the
    column's upper end (the column held there, the other column re-optimised), the unit away
    from its bound keeps its optimum."""
    from sca.problem import Evaluation, Problem

    class Pair(Problem):  # f = (x - a)^2 + (y - x)^2 with x >= 0
        size = 2

        def lower_bound(self, name):
            return 0.0 if name == "x" else -np.inf

        def data_terms(self, idx, theta, params, chain, grad):
            a = np.array([-1.0, 1.0])[idx]
            r = np.stack([theta[:, 0] - a, theta[:, 1] - theta[:, 0]], axis=1)
            J = np.broadcast_to(np.array([[1.0, 0.0], [-1.0, 1.0]]), (len(idx), 2, 2))
            return Evaluation(np.einsum("ij,ij->i", r, r),
                              np.einsum("kij,ki->kj", J, r) if grad else None,
                              np.einsum("kij,kil->kjl", J, J) if grad else None)
    prob = Pair(("x", "y"), {})
    theta = np.array([[0.0, 0.0], [1.0, 1.0]])  # unit 0 at its bound x = 0, unit 1 inside
    (point,) = bound_points(prob, theta, {0: np.array([0.5, 2.0])})
    np.testing.assert_allclose(point[0], [0.5, 0.5], atol=1e-8)
    np.testing.assert_array_equal(point[1], theta[1])
