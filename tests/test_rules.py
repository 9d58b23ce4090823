"""The verdict rules of REPRODUCTION.md (experiments/rules.py), the pieces the paper-like search
and the instrument study are built from, and the sweep cache's fingerprint. Fast."""

import numpy as np
import pytest

import forward
from experiments import rules, sweep


@pytest.mark.parametrize("value, verdict", [(0.02, "yes"), (0.01, "yes"), (0.04, "yes"),
                                            (0.009, "partly"), (0.08, "partly"), (0.0049, "no"),
                                            (0.081, "no"), (0.0, "no"), (float("nan"), "no")])
def test_level_is_a_factor_of_two_then_four(value, verdict):
    assert rules.verdict_level(value, 0.02) == verdict


def test_accuracy_bound_and_comparison():
    assert rules.verdict_at_most(1e-5, 0.02) == "yes"  # better than the paper is not a failure
    assert rules.verdict_at_most(0.05, 0.02) == "partly"
    assert rules.verdict_at_most(0.09, 0.02) == "no"
    assert rules.verdict_above([0.9, 0.71], 0.7) == "yes"
    assert rules.verdict_above([0.9, 0.7], 0.7) == "no"
    assert rules.verdict_comparison(1.5, 1.77) == "no"
    assert rules.verdict_comparison(2.0, 1.0) == "yes"
    assert rules.verdict_comparison(1.2, 1.0) == "partly"


def test_r2_range_needs_r2_to_vary_down_to_about_0_7():
    assert rules.verdict_r2_range([1.0, 1.0, 1.0]) == "no"  # r² = 1.00 everywhere: no, not partly
    assert rules.verdict_r2_range([1.0, 0.99, 0.72]) == "yes"
    assert rules.verdict_r2_range([1.0, 0.99, 0.47]) == "partly"
    assert rules.verdict_r2_range([0.8, 0.7, 0.65]) == "no"
    assert rules.verdict_r2_range([1.0, 0.95, 0.88]) == "partly"


def test_trend_is_judged_at_the_printed_precision():
    # 0.99996 -> 0.9992 is 1.00 -> 1.00 as printed: flat, not a fall with depth
    assert rules.verdict_trend([5, 10, 20], [0.99996, 0.9995, 0.9992], -1, r2=True) == "no (flat)"
    assert rules.verdict_trend([5, 10, 20], [1.0, 0.99, 0.53], -1, r2=True) == "yes"
    assert rules.verdict_trend([5, 10, 20], [1.0, 0.97, 0.99], -1, r2=True) == "partly"
    assert rules.verdict_trend([5, 10, 20], [0.5, 0.9, 1.0], -1, r2=True) == "no"
    assert not np.isfinite(rules.spearman_rounded([1, 2, 3], [1.0, 1.0, 1.0], r2=True))
    # other quantities at two significant digits
    assert rules.verdict_trend([1, 2, 5], [0.0141, 0.0144, 0.0139], +1) == "no (flat)"
    assert rules.worst("yes", "no (flat)") == "no" and rules.worst("yes", "partly") == "partly"


def test_rises_slightly_needs_both_variables_and_a_small_factor():
    d, r = [1, 5, 20], [0.5, 1, 10]
    assert rules.verdict_rises_slightly(d, [1, 1.5, 2.5], r, [1, 1.2, 1.5]) == "yes"
    assert rules.verdict_rises_slightly(d, [1, 3, 13], r, [1, 1.2, 1.5]) == "partly"  # not slightly
    assert rules.verdict_rises_slightly(d, [2, 1.5, 1], r, [2, 1.2, 1]) == "no"
    assert rules.verdict_rises_slightly(d, [1, 1.5, 2.5], r, [2, 1.5, 1.0]) == "partly"


def test_one_hue_rule():
    # G/B = 1.00 with little red is cyan: neither blue nor green ("partly" for either)
    cyan = (0.38, 0.94, 0.94)
    assert rules.hue_name(cyan) == "cyan"
    assert rules.verdict_hue(cyan, "blue") == "partly" and rules.verdict_hue(cyan, "green") == "partly"
    assert rules.hue_name((0.1, 0.3, 0.9)) == "blue" and rules.hue_name((0.2, 0.9, 0.3)) == "green"
    assert rules.hue_name((0.5, 0.5, 0.52)) == "grey"
    assert rules.verdict_hue((0.9, 0.2, 0.2), "blue") == "no"
    blue, green = (0.1, 0.3, 0.9), (0.2, 0.9, 0.3)
    assert rules.verdict_hue_change(blue, green, "blue", "green") == "yes"
    assert rules.verdict_hue_change(green, blue, "blue", "green") == "no"
    assert rules.verdict_hue_change(cyan, green, "blue", "green") == "partly"
    assert rules.verdict_hue_stronger(green, cyan, "green") == "no"  # moves away from green


def test_depth_ranges_report_every_depth_not_the_deepest():
    from experiments.instrument import DEPTHS_M, depth_ranges, format_ranges

    ok = {1.0: 0.5, 2.0: 0.2, 3.0: 0.2, 5.0: 0.5}
    rows = [dict(camera="c", lux=1.0, water="w", distance=1.0, depth=d, k=ok.get(d, 0.1))
            for d in DEPTHS_M]
    runs = depth_ranges(rows, "c", 1.0, "w", 1.0, "k", 0.3)
    assert runs == [(2.0, 3.0), (7.0, 30.0)]
    assert format_ranges(runs) == "2–3, 7–30 m"
    assert format_ranges([]) == "–" and format_ranges([(20.0, 20.0)]) == "20 m"


def test_world_capture_equals_simulate_chart_and_iset_ignores_the_light():
    from experiments.paper_like import World

    sensor = forward.SensorSettings(illuminance_lux=300.0)
    nf = forward.simulate_chart(1.0, 0.1, 10.0, 5.0, noise=False)
    got = World.capture([nf], sensor, 77)[0]
    assert np.array_equal(got, forward.simulate_chart(1.0, 0.1, 10.0, 5.0, seed=77, sensor=sensor).rgb)
    a, b = (forward.simulate_chart(1.0, 0.1, 20.0, 5.0, seed=3, sensor=forward.SensorSettings(
        illuminance_lux=lux, exposure_mode="iset")).rgb for lux in (20.0, 20000.0))
    np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-15)


def test_estimation_grid_and_q_of_eq19():
    assert sweep.estimation_grid(1.0) is None
    assert sweep.estimation_grid(20.0).size == 16 and sweep.estimation_grid(20.0)[-1] == 700.0
    assert [sweep.q_eq19(s) for s in (1, 5, 10, 20)] == [31, 31, 31, 16]
    wl = forward.wavelength_grid()
    k = np.exp(-0.01 * (wl - 380))
    wl20 = sweep.estimation_grid(20.0)
    assert sweep.rrmse_on_grid(wl20, np.interp(wl20, wl, k), wl, k) == 0.0
    k_hat = 1.01 * np.interp(wl20, wl, k)  # 1 % everywhere: eq 19 = 0.01 / sqrt(16)
    assert sweep.rrmse_on_grid(wl20, k_hat, wl, k) == pytest.approx(0.01 / 4)
    assert sweep.rrmse_on_grid(wl, 1.01 * k, wl, k) == pytest.approx(0.01 / np.sqrt(31))


def test_cache_fingerprint_covers_what_a_fit_depends_on(monkeypatch):
    import inspect

    src = inspect.getsource(sweep._code_fingerprint)
    for part in ('"forward", "sca"', "__file__", '"data"', "FINGERPRINT_PACKAGES"):
        assert part in src
    assert {"numpy", "cvxpy", "clarabel", "colour-science"} <= set(sweep.FINGERPRINT_PACKAGES)
    # the estimator's grid is part of the condition, so of the key
    a = sweep.condition(1.0, 0.1, 5.0, 1.0, 0)
    b = sweep.condition(1.0, 0.1, 5.0, 1.0, 0, estimation_step_nm=20.0)
    assert a["seed"] == b["seed"] and sweep.key(a) != sweep.key(b)
