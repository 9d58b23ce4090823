"""The estimator: DPP structure, noise-free round trips, hard cases, noise, fixing parameters."""

import itertools

import cvxpy as cp
import numpy as np
import pytest

import forward
import sca
from sca.subproblem import build_subproblem, thread_builds

CHLS = np.logspace(-2, np.log10(20), 5)  # 0.01 ... 20
CDOMS = np.logspace(-2, 0, 4)  # 0.01 ... 1
DEPTHS = (1.0, 5.0, 10.0, 20.0)
DISTANCES = (0.5, 1.0, 5.0, 10.0)


def rel(a, b):
    return abs(a - b) / abs(b)


@pytest.mark.parametrize("trust_region", [True, False])
def test_subproblem_is_dpp_and_compiled_once(trust_region):
    # the structures the estimator uses: z = 1 (T w >= 0 as the bound w >= 0) and z = 2
    for args in ((3, 3, None, 301, 3, trust_region, True), (4, 2, (2, 4), 301, 3, trust_region, True)):
        sub = build_subproblem(*args)
        assert sub.problem.is_dpp() and sub.problem.is_dcp(dpp=True)
    sim = forward.simulate_chart(1.0, 0.1, 5.0, 1.0, noise=False)
    mode = "safeguarded" if trust_region else "paper"
    sca.estimate(sim.rgb, depth=5.0, distance=1.0, mode=mode, uncertain={})  # builds (or reuses) its problem
    before = thread_builds()
    sca.estimate(sim.rgb, depth=9.0, distance=2.0, mode=mode, uncertain={})
    sca.estimate(sim.rgb * 0.5, depth=20.0, distance=0.5, mode=mode, uncertain={})
    assert thread_builds() == before  # the same compiled problem served every fit


@pytest.mark.slow
@pytest.mark.parametrize("depth,distance", list(itertools.product(DEPTHS, DISTANCES)))
def test_noise_free_round_trip_grid(depth, distance):
    for chl, cdom in itertools.product(CHLS, CDOMS):
        sim = forward.simulate_chart(chl, cdom, depth, distance, noise=False)
        est = sca.estimate(sim.rgb, depth=depth, distance=distance, uncertain={})
        case = f"C={chl:g} cdom={cdom:g}: {est.status}"
        assert est.converged, case
        assert rel(est.chl, chl) < 1e-4, case
        assert rel(est.cdom, cdom) < 1e-4, case
        assert sca.rrmse(est.attenuation, sim.attenuation) < 1e-6, case
        np.testing.assert_allclose(est.backscatter, sim.backscatter, rtol=1e-4, atol=1e-9)


def test_paper_mode_stops_early_where_safeguarded_reaches_truth():
    sim = forward.simulate_chart(1.0, 0.1, 10.0, 5.0, noise=False)
    paper = sca.estimate(sim.rgb, depth=10.0, distance=5.0, mode="paper", uncertain={})
    safe = sca.estimate(sim.rgb, depth=10.0, distance=5.0, uncertain={})
    assert not paper.converged and "not stationary" in paper.status
    assert rel(paper.chl, 1.0) > 0.1
    assert safe.converged and rel(safe.chl, 1.0) < 1e-8 and rel(safe.cdom, 0.1) < 1e-8
    # paper mode stopped because its last full Taylor step raised the true objective: the
    # last trial is above the returned objective, which is the last accepted one
    assert paper.trials and paper.trials[-1] >= paper.objective
    assert paper.objective == paper.history[-1]
    assert len(paper.trials) == len(paper.history)  # every step but the last was accepted
    # and the reported objective is the forward model's misfit at the returned point
    fwd = forward.simulate_chart(paper.chl, paper.cdom, 10.0, 5.0, noise=False, backscatter=False)
    r = sim.rgb - fwd.rgb - paper.backscatter[:, None]
    assert abs(float(np.sum(r * r)) / paper.objective - 1) < 1e-9


def _recovered_or_flagged(chl, cdom, depth, distance, **kw):
    sim = forward.simulate_chart(chl, cdom, depth, distance, noise=False, **kw.pop("sim_kw", {}))
    est = sca.estimate(sim.rgb, depth=depth, distance=distance, **kw, uncertain={})
    for v in (est.chl, est.cdom, est.objective, *est.attenuation, *est.backscatter):
        assert np.isfinite(v)
    if est.converged:
        assert sca.rrmse(est.attenuation, sim.attenuation) < 1e-6, est.status
    else:
        assert est.status and "converged" not in est.status.split(":")[0]
    return sim, est


@pytest.mark.parametrize("chl", [1e-3, 100.0])
def test_hard_chlorophyll_extremes(chl):
    sim, est = _recovered_or_flagged(chl, 0.1, 5.0, 1.0)
    assert est.converged and rel(est.chl, chl) < 1e-4, est.status


@pytest.mark.parametrize("cdom", [0.0, 2.0])
def test_hard_cdom_extremes(cdom):
    sim, est = _recovered_or_flagged(1.0, cdom, 5.0, 1.0)
    assert est.converged, est.status
    assert abs(est.cdom - cdom) < 1e-4 * max(cdom, 1.0)
    assert rel(est.chl, 1.0) < 1e-4


def test_hard_deep_and_far_red_almost_dark():
    sim, est = _recovered_or_flagged(1.0, 0.1, 30.0, 10.0)
    # the red channel is almost dark: under 2 % of full scale, k(>= 650 nm) below 1e-6
    assert sim.codes[0].max() < 0.02 * (2**14 - 1)
    assert np.all(sim.attenuation[sim.wavelengths >= 650] < 1e-6)
    assert est.converged and rel(est.chl, 1.0) < 1e-4 and rel(est.cdom, 0.1) < 1e-4, est.status


def test_hard_one_channel_zero():
    cam = forward.camera_sensitivities().copy()
    cam[:, 0] = 0.0  # a camera whose red channel records nothing
    sim, est = _recovered_or_flagged(2.0, 0.3, 5.0, 2.0, camera=cam, sim_kw=dict(camera=cam))
    assert np.all(sim.rgb[0] == 0)
    assert est.converged and rel(est.chl, 2.0) < 1e-4 and rel(est.cdom, 0.3) < 1e-4, est.status


@pytest.mark.parametrize("truth,start", [((0.01, 0.01), (100.0, 2.0)), ((20.0, 1.0), (0.0, 0.0)),
                                         ((1.0, 0.1), (1e-3, 3.0))])
def test_hard_far_starting_points(truth, start):
    chl, cdom = truth
    sim, est = _recovered_or_flagged(chl, cdom, 5.0, 1.0, x0={"chl": start[0], "cdom": start[1]})
    assert est.initial == {"chl": start[0], "cdom": start[1]}
    assert est.converged and rel(est.chl, chl) < 1e-4 and rel(est.cdom, cdom) < 1e-4, est.status


def test_zero_chlorophyll_never_nan():
    sim, est = _recovered_or_flagged(0.0, 0.1, 5.0, 1.0)
    assert est.chl < 1e-6 and abs(est.cdom - 0.1) < 1e-4


@pytest.mark.slow
def test_noisy_estimates_unbiased_at_5m():
    chl, cdom, depth, distance = 1.0, 0.1, 5.0, 2.0
    est = [sca.estimate(forward.simulate_chart(chl, cdom, depth, distance, seed=s).rgb,
                        depth=depth, distance=distance, uncertain={}) for s in range(40)]
    assert all(e.converged for e in est)
    for name, truth in (("chl", chl), ("cdom", cdom)):
        vals = np.array([getattr(e, name) for e in est])
        se = vals.std(ddof=1) / np.sqrt(vals.size)
        assert se > 0
        assert abs(vals.mean() - truth) < 3.5 * se, (name, vals.mean(), se)


def test_fixing_at_truth_gives_same_answer():
    # a chart a few centimetres away: no backscatter
    sim = forward.simulate_chart(2.0, 0.3, 5.0, 0.05, noise=False, backscatter=False)
    free = sca.estimate(sim.rgb, depth=5.0, distance=0.05, uncertain={})
    fixed = sca.estimate(sim.rgb, depth=5.0, distance=0.05, fix={"backscatter": 0}, uncertain={})
    np.testing.assert_array_equal(fixed.backscatter, 0.0)
    for e in (free, fixed):
        assert e.converged and rel(e.chl, 2.0) < 1e-6 and rel(e.cdom, 0.3) < 1e-6
    assert rel(free.chl, fixed.chl) < 1e-6
    sim = forward.simulate_chart(2.0, 0.3, 10.0, 3.0, noise=False)
    fixed = sca.estimate(sim.rgb, depth=10.0, distance=3.0, fix={"cdom": 0.3}, uncertain={})
    assert fixed.converged and fixed.cdom == 0.3 and rel(fixed.chl, 2.0) < 1e-6
    fixed = sca.estimate(sim.rgb, depth=10.0, distance=3.0, fix={"chl": 2.0, "backscatter": sim.backscatter}, uncertain={})
    assert fixed.converged and rel(fixed.cdom, 0.3) < 1e-6


def test_two_basis_functions():
    T1, _ = forward.phytoplankton_basis()
    T = np.column_stack([T1[:, 0], np.linspace(1.0, 0.2, 301)])
    sim = forward.simulate_chart(2.0, 0.2, 5.0, 1.0, basis=T, weights=[1.0, 0.5], noise=False)
    est = sca.estimate(sim.rgb, depth=5.0, distance=1.0, basis=T, uncertain={})
    assert est.w.shape == (2,)
    assert np.all(T @ est.w >= -1e-12)
    assert abs(est.eq17_residual) < 1e-8
    assert sca.rrmse(est.attenuation, sim.attenuation) < 1e-4, est.status


@pytest.mark.parametrize("rgb,match", [
    (np.full((3, 24), np.nan), "^rgb:.*NaN"), (-np.ones((3, 24)), "^rgb:.*negative"),
    (np.ones((24, 3)), "^rgb:.*shape"), (np.zeros((3, 24)), "^rgb:.*zero"),
])
def test_bad_rgb(rgb, match):
    with pytest.raises(ValueError, match=match):
        sca.estimate(rgb, depth=5, distance=1, uncertain={})


def test_bad_arguments():
    rgb = forward.simulate_chart(1, 0.1, 5, 1, noise=False).rgb
    with pytest.raises(ValueError, match="^depth:"):
        sca.estimate(rgb, depth=-1, distance=1, uncertain={})
    with pytest.raises(ValueError, match="^distance:"):
        sca.estimate(rgb, depth=1, distance=np.nan, uncertain={})
    with pytest.raises(ValueError, match="^mode:"):
        sca.estimate(rgb, depth=1, distance=1, mode="fast", uncertain={})
    with pytest.raises(ValueError, match="^fix:"):
        sca.estimate(rgb, depth=1, distance=1, fix={"depth": 3}, uncertain={})
    with pytest.raises(ValueError, match=r"^fix\['backscatter'\]:"):
        sca.estimate(rgb, depth=1, distance=1, fix={"backscatter": -1}, uncertain={})
    # mismatched wavelength grids: a camera or basis array on another grid
    with pytest.raises(ValueError, match="^camera:"):
        sca.estimate(rgb, depth=1, distance=1, camera=np.ones((61, 3)), uncertain={})
    with pytest.raises(ValueError, match="^basis:"):
        sca.estimate(rgb, depth=1, distance=1, basis=np.ones(61), uncertain={})
    with pytest.raises(ValueError, match="^wavelengths:"):
        sca.estimate(rgb, depth=1, distance=1, wavelengths=np.arange(380, 701, 10), uncertain={})


def test_solver_failure_is_reported(monkeypatch):
    rgb = forward.simulate_chart(1, 0.1, 5, 1, noise=False).rgb

    def boom(self, *a, **k):
        raise cp.SolverError("injected failure")

    monkeypatch.setattr(cp.Problem, "solve", boom)
    est = sca.estimate(rgb, depth=5, distance=1, uncertain={})
    assert not est.converged and "solver failed" in est.status and "injected" in est.status
    assert np.isfinite(est.chl)  # the best point so far (the initial point) is returned


def test_rebuild_baseline_reaches_the_same_iterates():
    # the CVX-style baseline (new problem with constants each iteration) and the compiled DPP
    # problem solve the same QPs: same path, same optimum
    from experiments.baselines import RebuildEstimator

    sim = forward.simulate_chart(2.0, 0.2, 10.0, 5.0, seed=1)
    fast = sca.estimate(sim.rgb, depth=10.0, distance=5.0, uncertain={})
    slow = RebuildEstimator(depth=10.0, distance=5.0).fit(sim.rgb)
    assert fast.converged and slow.converged and fast.iterations == slow.iterations
    assert abs(fast.chl / slow.chl - 1) < 1e-7 and abs(fast.cdom / slow.cdom - 1) < 1e-7
    assert abs(fast.objective / slow.objective - 1) < 1e-9


def test_scipy_reference_reaches_the_same_optimum():
    from sca.lsq import estimate_least_squares

    sim = forward.simulate_chart(2.0, 0.2, 10.0, 5.0, seed=1)
    ref = sca.estimate(sim.rgb, depth=10.0, distance=5.0, uncertain={})
    lsq = estimate_least_squares(sim.rgb, depth=10.0, distance=5.0, uncertain={})
    assert lsq.converged
    assert lsq.objective <= ref.objective * (1 + 1e-9)


@pytest.mark.slow
def test_standard_errors_track_the_spread_and_flag_undecidable_charts():
    fits = [sca.estimate(forward.simulate_chart(1.0, 0.1, 5.0, 2.0, seed=s).rgb, depth=5.0,
                         distance=2.0, uncertain={}) for s in range(30)]
    sd = np.std([e.chl for e in fits], ddof=1)
    se = np.median([e.chl_se for e in fits])
    assert 0.5 < sd / se < 3.0  # Gauss-Newton errors, homoscedastic: indicative, not exact
    # a chart too dark to measure (depth 30 m, C 100): the error is as large as the value
    dark = forward.simulate_chart(100.0, 0.5, 30.0, 0.5, seed=1)
    est = sca.estimate(dark.rgb, depth=30.0, distance=0.5, uncertain={})
    assert est.chl_se > 0.5 * est.chl
    # noise-free: (almost) no error; fixed parameters: zero
    exact = sca.estimate(forward.simulate_chart(1.0, 0.1, 5.0, 2.0, noise=False).rgb, depth=5.0,
                         distance=2.0, fix={"cdom": 0.1}, uncertain={})
    assert exact.chl_se < 1e-9 and exact.cdom_se == 0.0


#: How far a start-grid point's objective may move with the blocks: each point is computed on
#: its own, but BLAS may multiply a block's last rows by another kernel, which sums in another
#: order (seen on an AVX2 machine: one point of 513 by 1 ulp of its signal).
BLOCK_RTOL = 1e-12


def test_start_grid_blocks_change_only_rounding(monkeypatch):
    # the start grid's objective is evaluated in cache-sized blocks (sca.loop.GRID_BLOCK_VALUES,
    # at least GRID_BLOCK_MIN_POINTS points each): every block size gives the numbers of the
    # grid in one piece, to BLAS's rounding, and the same best point (the start)
    from forward.water.terms import _FEW_CHARTS
    assert sca.loop.GRID_BLOCK_MIN_POINTS >= _FEW_CHARTS  # below it the terms add another way
    sim = forward.simulate_chart(2.0, 0.3, 10.0, 3.0, seed=4)
    chl, cdom = (v.ravel() for v in np.meshgrid(sca.loop.INIT_CHL, sca.loop.INIT_CDOM,
                                                indexing="ij"))
    n = chl.size
    water = forward.Water()
    shape = water.on_grid(np.arange(400.0, 701.0, 1.0)).T[:, 0]
    two = np.column_stack([shape, np.linspace(0.5, 1.5, shape.size) * shape])
    for kw in ({}, {"gain": "free", "free": ("cdom_slope",)}, {"basis": two}):
        est = sca.Estimator(depth=10.0, distance=3.0, uncertain={}, **kw)  # the 1 nm grid
        st = est.prepare(sim.rgb, sim.rgb_sigma)
        mdl = st.mdl
        w = np.multiply.outer(mdl.phyto_scale(chl) / float(mdl.t440.sum()), np.ones(mdl.z))
        grid = {"chl": chl, "cdom": cdom, "w": w, "s": np.zeros((n, mdl.m)), "gain": 1.0}
        grid.update({name: np.full(n, water.cdom_slope) for name in est.extras})
        whole = est.grid_objective(st, grid, n, block_values=10**9)
        assert whole.shape == (n,) and np.all(np.isfinite(whole))
        for block_values in (None, 40_000, 301 * 7, 1):
            parts = est.grid_objective(st, grid, n, block_values)
            np.testing.assert_allclose(parts, whole, rtol=BLOCK_RTOL, atol=0)
            assert np.argmin(parts) == np.argmin(whole)
        # the start is the grid's best point (z = 1: initial_point's own grid)
        if mdl.z == 1:
            x = est.initial_point(st)
            j = int(np.argmin(whole))
            assert (x["chl"], x["cdom"]) == (chl[j], cdom[j])
    monkeypatch.setattr(sca.loop, "GRID_BLOCK_VALUES", 1)  # the default is read at the call
    smallest = est.grid_objective(st, grid, n)
    np.testing.assert_array_equal(smallest, est.grid_objective(st, grid, n, block_values=1))
    np.testing.assert_allclose(smallest, whole, rtol=BLOCK_RTOL, atol=0)
    grid["gain"] = np.array(1.0)  # a 0-d array is shared by every point, as a float is
    np.testing.assert_array_equal(est.grid_objective(st, grid, n), smallest)
    for bad in (0, True, 2.5, np.inf):
        with pytest.raises(ValueError, match="block_values"):
            est.grid_objective(st, grid, n, block_values=bad)
    with pytest.raises(ValueError, match="grid: every array must have n"):
        est.grid_objective(st, grid, n - 1)


def _polish_every_round(sub, v, active_tol=1e-4, feas_tol=1e-9, max_rounds=10):
    """The active-set polish as it was before it stopped early: every round to max_rounds
    (the oracle of the test below; returns (v, polished, rounds))."""
    from sca.subproblem import POLISH_SLACK, _rows
    R, b = sub.R.value, sub.b.value
    nv = R.shape[1]
    scale = 1.0 + float(np.max(np.abs(v)))
    A_in, lb, C_eq, d_eq = _rows(sub)
    norms = 1.0 + np.abs(A_in).sum(axis=1)
    active = (A_in @ v - lb) <= active_tol * scale * norms
    H, g = R.T @ R, R.T @ b
    for rounds in range(1, max_rounds + 1):
        C = np.vstack([C_eq, A_in[active]])
        d = np.concatenate([d_eq, lb[active]])
        K = np.block([[H, C.T], [C, np.zeros((C.shape[0], C.shape[0]))]])
        vp = np.linalg.lstsq(K, np.concatenate([g, d]), rcond=None)[0][:nv]
        if not np.all(np.isfinite(vp)):
            return v, False, rounds
        bad = lb - A_in @ vp > feas_tol * scale * norms
        if not bad.any():
            break
        active |= bad
    else:
        return v, False, rounds
    if C_eq.shape[0] and np.any(np.abs(C_eq @ vp - d_eq) > feas_tol * scale):
        return v, False, rounds
    if np.any(lb - A_in @ vp > feas_tol * scale * norms):
        return v, False, rounds
    f_v = float(np.sum((R @ v - b) ** 2))
    if float(np.sum((R @ vp - b) ** 2)) <= f_v + POLISH_SLACK * max(1.0, f_v):
        return vp, True, rounds
    return v, False, rounds


def test_polish_stops_early_only_where_more_rounds_would_change_nothing(monkeypatch):
    # sca.subproblem.polish returns as soon as the violated constraints are all in the active
    # set already (the set cannot grow: every later round would repeat this one); on the
    # subproblems of real fits it returns exactly what the every-round polish returns
    from sca import subproblem
    polish, seen = subproblem.polish, {"calls": 0, "all_rounds_failed": 0}

    def checked(sub, v, **kw):
        out = polish(sub, v, **kw)
        if "f_ref" not in kw:
            ref, ok, rounds = _polish_every_round(sub, v)
            assert out[1] == ok and np.array_equal(out[0], ref)
            seen["calls"] += 1
            seen["all_rounds_failed"] += int(rounds == 10 and not ok)
        return out
    monkeypatch.setattr(subproblem, "polish", checked)
    for chl, cdom, depth, distance in ((1.0, 0.5, 10.0, 5.0), (0.001, 0.0, 30.0, 5.0),
                                       (20.0, 2.0, 1.0, 0.5), (0.05, 0.05, 10.0, 0.5)):
        sim = forward.simulate_chart(chl, cdom, depth, distance, seed=5)
        for mode in ("safeguarded", "paper"):
            sca.estimate(sim.rgb, depth=depth, distance=distance, sigma=sim.rgb_sigma,
                         uncertain={}, mode=mode, wavelengths=np.arange(400.0, 701.0, 10.0))
    assert seen["calls"] > 20
    assert seen["all_rounds_failed"] > 0  # the early stop was exercised
    # and where a round adds a constraint the polish goes on: min |v - (-1, 1)|^2 with v >= 0
    # from an interior point near (0, 1) (no bound active at the start; the first round's
    # unconstrained step violates v_0 >= 0, the second holds it)
    sub = build_subproblem(2, 2, None, 1, 0, False, False)
    sub.R.value, sub.b.value, sub.lo.value = np.eye(2), np.array([-1.0, 1.0]), np.zeros(2)
    v, polished = subproblem.polish(sub, np.array([1e-2, 0.999]))
    assert polished and np.allclose(v, [0.0, 1.0], rtol=0, atol=1e-12)
    ref, ok, rounds = _polish_every_round(sub, np.array([1e-2, 0.999]))
    assert ok and rounds == 2 and np.array_equal(ref, v)


def test_assign_checks_what_cvxpys_setter_checked_and_reports_non_finite_data(monkeypatch):
    # the loop writes the QP's parameters with sca.subproblem.assign (cvxpy's own setter
    # validates each value again, ~30 us): shapes and signs raise, non-finite data is a reason
    # (nothing written), and the loop reports it as the solve's failure
    from sca import subproblem
    sub = build_subproblem(3, 3, None, 301, 3, True, True)
    vals = {"R": np.eye(6), "b": np.ones(6), "lo": -np.ones(3), "hi": np.ones(3),
            "s_lo": -np.ones(3), "a_eq": np.ones(3), "b_eq": 0.5}
    assert subproblem.assign(sub, vals) == ""
    assert sub.b.value is vals["b"] and sub.b_eq.value == 0.5
    with pytest.raises(ValueError, match="b: a value of shape"):
        subproblem.assign(sub, dict(vals, b=np.ones(5)))
    with pytest.raises(ValueError, match="hi: the QP's parameter is nonnegative"):
        subproblem.assign(sub, dict(vals, hi=-np.ones(3)))
    reason = subproblem.assign(sub, dict(vals, R=np.full((6, 6), np.nan), lo=np.ones(3),
                                         b_eq=np.inf))
    assert reason == "the linearised problem is not finite (R, b_eq)"
    assert np.array_equal(sub.lo.value, -np.ones(3))  # nothing written
    # in the loop: a linearisation that is not finite ends the fit, reported
    linearise = sca.Estimator._linearise

    def broken(self, st):
        lin = linearise(self, st)
        lin.b[0] = np.nan
        return lin
    monkeypatch.setattr(sca.Estimator, "_linearise", broken)
    sim = forward.simulate_chart(1.0, 0.1, 5.0, 1.0, seed=2)
    est = sca.estimate(sim.rgb, depth=5.0, distance=1.0, sigma=sim.rgb_sigma, uncertain={},
                       wavelengths=np.arange(400.0, 701.0, 10.0))
    assert not est.converged and not est.reliable
    assert est.status == "solver failed at iteration 1: the linearised problem is not finite (R, b)"
    # a NaN in R is caught before any LAPACK call on it (an SVD of NaN fails or does not
    # return), with C free (eq 17 in the step) and held (no equality)
    def broken_r(self, st):
        lin = linearise(self, st)
        lin.R[0, 0] = np.nan
        return lin
    monkeypatch.setattr(sca.Estimator, "_linearise", broken_r)
    for fix in (None, {"chl": 1.0}):
        est = sca.estimate(sim.rgb, depth=5.0, distance=1.0, sigma=sim.rgb_sigma, uncertain={},
                           wavelengths=np.arange(400.0, 701.0, 10.0), fix=fix)
        assert not est.converged and "the linearised problem is not finite" in est.status
    with pytest.raises(ValueError, match="b: the QP's parameters are real"):
        subproblem.assign(sub, dict(vals, b=np.ones(6) + 0j))
