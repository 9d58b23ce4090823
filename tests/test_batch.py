"""The batched solver reaches the same optimum as the sca loop (correctness, not speed): both on
the full grid (``quadrature='full'``: the same model; the certified quadrature is tested against
it in tests/test_quadrature.py)."""

import itertools
import warnings

import numpy as np
import pytest

import forward
import sca

CASES = list(itertools.product([1e-3, 0.05, 1.0, 20.0, 100.0], [0.0, 0.02, 0.5, 2.0],
                               [1.0, 10.0, 30.0], [0.5, 5.0]))


@pytest.fixture(scope="module")
def charts():
    out = {}
    for noise in (False, True):
        sims = [forward.simulate_chart(c, a, d, r, noise=noise, seed=i)
                for i, (c, a, d, r) in enumerate(CASES)]
        out[noise] = np.array([s.rgb for s in sims])
    depth = np.array([c[2] for c in CASES])
    distance = np.array([c[3] for c in CASES])
    return out, depth, distance


@pytest.fixture(scope="module")
def fitted(charts):
    """The charts of one noise setting (False, True) fitted by the batch and, one at a time, by
    the sca loop (the reference): each made once for the module's tests."""
    stacks, depth, distance = charts
    done = {}

    def fits(noise):
        if noise not in done:
            M = stacks[noise]
            batch = sca.estimate_batch(M, depth=depth, distance=distance, uncertain={},
                                       quadrature="full")
            loop = [sca.estimate(M[i], depth=depth[i], distance=distance[i], uncertain={},
                                 quadrature="full") for i in range(len(M))]
            done[noise] = batch, loop
        return done[noise]
    return fits


@pytest.mark.slow
def test_noise_free_same_optimum_as_sca(fitted):
    b, ref = fitted(False)
    assert b.converged.all(), set(b.status[~b.converged])
    for i, e in enumerate(ref):
        assert e.converged
        assert abs(b.chl[i] - e.chl) <= 1e-6 * e.chl + 1e-9, CASES[i]  # 1e-9: for a truth of 0
        assert abs(b.cdom[i] - e.cdom) <= 1e-6 * e.cdom + 1e-9, CASES[i]
        np.testing.assert_allclose(b.attenuation[i], e.attenuation, rtol=1e-6, atol=1e-15)


@pytest.mark.slow
def test_noisy_objective_equal_or_lower_than_sca(charts, fitted):
    stacks, depth, distance = charts
    M = stacks[True]
    b, ref = fitted(True)
    obj = np.array([e.objective for e in ref])
    # wherever the loop converges, the batch converges too, to an equal or lower objective
    loop_ok = np.array([e.converged for e in ref])
    assert b.converged[loop_ok].all(), [CASES[i] for i in np.flatnonzero(loop_ok & ~b.converged)]
    assert np.sum(~b.converged) <= 2  # and where the loop fails too, rarely
    ok = b.objective <= obj * (1 + 1e-9)
    assert np.all(ok | ~loop_ok), np.max(b.objective / obj - 1)
    # a chart's result does not depend on the rest of the batch
    few = sca.estimate_batch(M[:3], depth=depth[:3], distance=distance[:3], uncertain={},
                           quadrature="full")
    np.testing.assert_allclose(few.objective, b.objective[:3], rtol=1e-12)


@pytest.mark.slow
@pytest.mark.parametrize("noise", [False, True])
def test_batch_reaches_the_loops_optimum(fitted, noise):
    """The batch (variable projection + LM) and the cvxpy loop minimise the same objective."""
    b, ref = fitted(noise)
    assert b.converged.sum() >= len(CASES) - 2
    for i in range(0, len(b), 3):
        e = ref[i]
        if b.converged[i] and e.converged:
            # equal objective (noise-free ones are at rounding level: compared absolutely)
            assert b.objective[i] <= e.objective * (1 + 1e-6) + 1e-20, i


@pytest.mark.slow
@pytest.mark.parametrize("step_nm", [1.0, 10.0])
def test_benchmark_charts_reach_the_loops_optimum(step_nm):
    """Issue 21, target 4: on the benchmark's 60 charts (weighted by the sensor's noise), at the
    default grid and at 10 nm, the batch converges wherever the DPP loop does, to an objective
    equal to or below the loop's (``experiments.benchmark.loop_optimum``, which BENCHMARKS.md
    reports)."""
    from experiments.benchmark import chart_set, loop_optimum

    res = loop_optimum(*chart_set(), step_nm=step_nm)
    assert res["loop_converged"] >= res["n"] - 2
    assert res["at_optimum"] == res["loop_converged"], res["misses"]


def test_fields_shapes_and_fixed_backscatter():
    sim = forward.simulate_chart(2.0, 0.3, 5.0, 0.05, noise=False, backscatter=False)
    M = np.stack([sim.rgb, sim.rgb])
    b = sca.estimate_batch(M, depth=5.0, distance=0.05, fix={"backscatter": 0}, uncertain={},
                           quadrature="full")
    assert b.chl.shape == (2,) and b.backscatter.shape == (2, 3) and b.attenuation.shape == (2, 301)
    assert b.w.shape == (2, 1) and len(b) == 2
    np.testing.assert_array_equal(b.backscatter, 0.0)
    assert np.all(np.abs(b.chl / 2 - 1) < 1e-6) and np.all(np.abs(b.cdom / 0.3 - 1) < 1e-6)


def test_non_convergence_is_flagged():
    sim = forward.simulate_chart(1.0, 0.1, 10.0, 5.0, noise=False)
    b = sca.estimate_batch(sim.rgb[None], depth=10.0, distance=5.0, max_iter=1, uncertain={})
    assert not b.converged[0] and "maximum" in b.status[0]


def test_bad_input():
    M = forward.simulate_chart(1.0, 0.1, 10.0, 5.0, noise=False).rgb[None]
    with pytest.raises(ValueError, match="^rgb_stack:"):
        sca.estimate_batch(M[0], depth=1, distance=1, uncertain={})
    with pytest.raises(ValueError, match="^rgb_stack:"):
        sca.estimate_batch(np.full_like(M, np.nan), depth=1, distance=1, uncertain={})
    with pytest.raises(ValueError, match="^rgb_stack:"):
        sca.estimate_batch(np.zeros_like(M), depth=1, distance=1, uncertain={})
    with pytest.raises(ValueError, match="^depth:"):
        sca.estimate_batch(M, depth=-1, distance=1, uncertain={})
    with pytest.raises(ValueError, match="^basis:"):
        sca.estimate_batch(M, depth=1, distance=1, basis=np.ones((301, 2)), uncertain={})
    with pytest.raises(ValueError, match="^fix:"):
        sca.estimate_batch(M, depth=1, distance=1, fix={"cdom"}, uncertain={})
    with pytest.raises(ValueError, match="^depth:"):
        sca.estimate_batch(np.repeat(M, 3, axis=0), depth=[1.0, 2.0], distance=1, uncertain={})


def test_profile_slopes_minimise_the_quadratic_model():
    """Along the profile of theta_j the others follow -H_oo^-1 H_oj (the minimiser of the
    Gauss-Newton model with theta_j held); a singular H_oo gives no move."""
    from sca.intervals import profile_slopes

    H = np.array([[[2.0, 1.0, 0.5], [1.0, 3.0, 0.2], [0.5, 0.2, 1.0]]] * 3)
    H[2, 1:, 1:] = 0.0  # singular H_oo for the profile of theta_0
    sl = profile_slopes(H, np.array([0, 2, 0]))
    for r, j in ((0, 0), (1, 2)):
        others = [k for k in range(3) if k != j]
        x = np.zeros(3)
        x[j] = 1.0
        x[others] = -np.linalg.solve(H[r][np.ix_(others, others)], H[r][others, j])
        np.testing.assert_allclose(sl[r], x)
        grad = H[r] @ sl[r]  # the model's gradient in the other coordinates vanishes
        np.testing.assert_allclose(grad[others], 0.0, atol=1e-12)
    np.testing.assert_array_equal(sl[2], [1.0, 0.0, 0.0])


def test_effective_curvature_of_every_column_from_one_inverse():
    """Without a column, effective_curvature gives every column's 1 / (H^-1)_jj at once: the
    same numbers as one column at a time, H_jj where H is singular; profile_slopes of no rows
    is empty."""
    from sca.intervals import effective_curvature, profile_slopes

    H = np.array([[[2.0, 1.0, 0.5], [1.0, 3.0, 0.2], [0.5, 0.2, 1.0]],
                  [[1.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, 4.0]]])  # the second singular
    every = effective_curvature(H)
    assert every.shape == (2, 3)
    for j in range(3):
        np.testing.assert_array_equal(every[:, j], effective_curvature(H, j))
    np.testing.assert_allclose(every[0], 1.0 / np.diag(np.linalg.inv(H[0])))
    np.testing.assert_array_equal(every[1], np.diag(H[1]))
    assert profile_slopes(H[:0], np.zeros(0, int)).shape == (0, 3)
    np.testing.assert_array_equal(profile_slopes(H, [0, 2]), profile_slopes(H, np.array([0, 2])))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a zero in another column's inverse: no warning
        np.testing.assert_array_equal(effective_curvature(np.array([[[1.0, 1.0], [1.0, 0.0]]]),
                                                          1), [0.0])


def test_linear_part_with_the_gain_known_is_the_clipped_weighted_mean():
    """With the gain known (1), s of each channel is max(0, sum w (M - G) / sum w): the sums
    of the gain's own normal equations are not needed (and not computed)."""
    from sca.model import linear_part

    rng = np.random.default_rng(5)
    M = rng.uniform(0.2, 1.0, (1, 3, 24))
    G = M - rng.normal(0.0, 0.05, (4, 3, 24)) - np.array([0.05, -0.2, 0.0])[:, None]
    w2 = rng.uniform(0.5, 2.0, (1, 3, 24))
    gain, s, active = linear_part(M, G, w2, free_gain=False)
    want = np.maximum((w2 * (M - G)).sum(-1) / w2.sum(-1), 0.0)
    np.testing.assert_array_equal(gain, 1.0)
    np.testing.assert_allclose(s, want, rtol=1e-13, atol=1e-15)
    np.testing.assert_array_equal(active, s > 0)
    assert np.any(s == 0) and np.any(s > 0)


def test_profile_slopes_leave_nearly_collinear_columns_alone():
    """A nearly singular H_oo (two almost collinear nuisance columns) gives no move: the
    profile point starts where it was instead of far away."""
    from sca.intervals import profile_slopes

    H = np.array([[[2.0, 0.5, 0.5], [0.5, 1.0, 1.0 - 1e-14], [0.5, 1.0 - 1e-14, 1.0]]])
    np.testing.assert_array_equal(profile_slopes(H, np.array([0]))[0], [1.0, 0.0, 0.0])


def test_interval_ends_in_own_units_keep_a_failed_end_nan():
    """sca.intervals.own_units, the one place every estimator turns profile ends into what it
    reports: C's ends undone from u = C^e0 (an end <= 0 gives 0), open ends infinite, a failed
    end NaN for C as for a_CDOM (the batch reported a failed end of C as 0)."""
    from sca.intervals import BOUND_FAILED, BOUND_FOUND, BOUND_OPEN, BOUND_ZERO, own_units

    e0 = 0.627
    ends = np.array([[[-0.1, 2.0 ** e0], [np.nan, 3.0 ** e0], [np.nan, 0.4]]])
    codes = np.array([[[BOUND_ZERO, BOUND_OPEN], [BOUND_FAILED, BOUND_FOUND],
                       [BOUND_FAILED, BOUND_FOUND]]])
    out = own_units(ends, codes, np.array([e0, e0, 0.0]))
    assert out[0, 0, 0] == 0.0 and out[0, 0, 1] == np.inf
    assert np.isnan(out[0, 1, 0]) and out[0, 1, 1] == pytest.approx(3.0, rel=1e-12)
    assert np.isnan(out[0, 2, 0]) and out[0, 2, 1] == 0.4
