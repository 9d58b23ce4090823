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


def test_cache_fingerprint_covers_what_a_fit_depends_on(monkeypatch, tmp_path):
    """The cached fits' key changes when the model's code, the sweep, the independent renderer,
    a data table or a library's version changes, and not for a file no fit reads (a tree of
    the same layout in tmp_path stands for the checkout)."""
    from importlib import metadata

    files = ["forward/model.py", "sca/fit.py", "experiments/sweep.py",
             "experiments/independent_world.py", "data/table.csv", "docs/notes.md"]
    for name in files:
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(name)
    monkeypatch.setattr(sweep, "__file__", str(tmp_path / "experiments" / "sweep.py"))
    versions = {}
    monkeypatch.setattr(metadata, "version", lambda name: versions.get(name, "1.0"))
    before = sweep._code_fingerprint()
    for name in files:
        (tmp_path / name).write_text(name + " changed")
        assert (sweep._code_fingerprint() != before) == (name != "docs/notes.md"), name
        (tmp_path / name).write_text(name)
    assert sweep._code_fingerprint() == before
    assert {"numpy", "cvxpy", "clarabel", "colour-science"} <= set(sweep.FINGERPRINT_PACKAGES)
    for package in sweep.FINGERPRINT_PACKAGES:
        versions[package] = "2.0"
        assert sweep._code_fingerprint() != before, package
        del versions[package]
    # the estimator's grid is part of the condition, so of the key
    a = sweep.condition(1.0, 0.1, 5.0, 1.0, 0)
    b = sweep.condition(1.0, 0.1, 5.0, 1.0, 0, estimation_step_nm=20.0)
    assert a["seed"] == b["seed"] and sweep.key(a) != sweep.key(b)


# ------------------------------------------------------------------ issue 39: every rule can fail
def test_new_rules_can_say_yes_and_no():
    assert rules.verdict_independent([0.02, 0.03, 0.025]) == "yes"
    assert rules.verdict_independent([0.01, 0.03]) == "partly"
    assert rules.verdict_independent([0.01, 0.05]) == "no"
    assert rules.verdict_correction(5.0, 4.5, (8.0, 7.0)) == "yes"
    assert rules.verdict_correction(5.0, 2.0, (8.0, 7.0)) == "partly"  # far from the control
    assert rules.verdict_correction(9.0, 8.5, (8.0, 7.0)) == "partly"  # worse than a baseline
    assert rules.verdict_correction(9.0, 2.0, (8.0, 7.0)) == "no"
    assert rules.verdict_ranked(0.1, 0.12, 0.2) == "yes"
    assert rules.verdict_ranked(0.15, 0.12, 0.2) == "partly"
    assert rules.verdict_ranked(0.25, 0.12, 0.2) == "no"
    assert not rules.discriminates_bound([1.0, 0.99996, 0.9996])  # 1.000 as printed
    assert rules.discriminates_bound([1.0, 0.999, 0.9])
    # the two-sided level: an error a hundred times smaller than "about 2 %" is not about 2 %
    assert rules.verdict_level(0.00026, 0.02) == "no"


def _passing_numbers():
    """One setting's numbers with every claim of the report holding ("yes")."""
    from experiments.fig07_depth_distance import DEPTHS_M, DISTANCES_M

    blue, green = (0.1, 0.3, 0.9), (0.2, 0.9, 0.3)
    acc = {"distance": [(1.0, 48, 0.98, 1.1, 1.0), (5.0, 48, 0.9, 1.3, 1.0)]}
    fig12 = dict(depths=[5.0, 10.0, 20.0], r=[0.99, 0.95, 0.85], r2=[0.98, 0.9, 0.72],
                 r2_linear=[0.99, 0.95, 0.8], factor=[1.1, 1.3, 2.0], deep=20.0,
                 groups=[(0.01, 0.6), (0.1, 0.7), (0.5, 0.9)], accuracy=acc,
                 dist=[1.0, 2.0, 5.0, 10.0], dist_r2=[0.98, 0.95, 0.9, 0.8],
                 dist_factor=[1.1, 1.2, 1.3, 1.5])
    fig13 = dict(fig12, groups=[(0.05, 0.9), (1.0, 0.8), (10.0, 0.6)])
    return {
        "app": dict(fan=blue, mon=green, chl_white=[blue, green],
                    by_depth={d: 0.3 / (1 + i) for i, d in enumerate(DEPTHS_M)},
                    by_dist={r: 0.3 / (1 + 0.1 * i) for i, r in enumerate(DISTANCES_M)}),
        "fig9": dict(chl=1.0, cdom=0.1, q=31, rrmse=0.02, rrmse_nosq=0.11),
        "fig10": dict(reading="eq19", q=31, mean=0.02, lo=0.015, hi=0.03, depth_ratio=2.0,
                      dist_ratio=1.5, depths=[1.0, 5.0, 20.0], dists=[0.5, 1.0, 5.0],
                      by_depth=[0.015, 0.02, 0.03], by_dist=[0.016, 0.02, 0.024],
                      medium={"chl": [(0.1, 0.02), (1.0, 0.022)],
                              "cdom": [(0.01, 0.02), (0.5, 0.025)]}, converged=10, n=10),
        "fig11": [dict(depth_m=10.0, mean_de2000_captured=30.0, mean_de2000_von_kries=5.0,
                       mean_de2000_von_kries_true_k=4.5, mean_de2000_grey_world=8.0,
                       mean_de2000_white_patch=7.0)],
        "fig12": fig12, "fig13": fig13,
    }


def _set(path, value):
    def mutate(x):
        *keys, last = path
        for k in keys:
            x = x[k]
        x[last] = value(x[last]) if callable(value) else value
    return mutate


#: For each claim of the report, a change of the result that must turn its verdict
MUTATIONS = {
    "Fig 5": _set(("app", "fan"), (0.9, 0.2, 0.2)),
    "Fig 6": _set(("app", "mon"), (0.1, 0.3, 0.9)),
    "Fig 7": _set(("app", "by_depth"), lambda d: {k: 0.3 for k in d}),
    "Fig 8": _set(("app", "chl_white"), lambda w: [w[1], w[0]]),
    "Fig 9": _set(("fig9", "rrmse"), 0.0002),  # a hundred times better than the paper: no
    "Fig 10 (level)": _set(("fig10", "mean"), 0.0002),
    "Fig 10 (trend)": _set(("fig10", "by_depth"), [0.03, 0.02, 0.015]),
    "Fig 10 (medium)": _set(("fig10", "medium"), {"chl": [(0.1, 0.01), (1.0, 0.05)],
                                                  "cdom": [(0.01, 0.02)]}),
    "Fig 11": _set(("fig11",), lambda rows: [dict(r, mean_de2000_von_kries=12.0) for r in rows]),
    "Fig 12 (r)": _set(("fig12", "r"), [0.99, 0.9, 0.6]),
    "Fig 12 (r²)": _set(("fig12", "r2"), [1.0, 1.0, 1.0]),
    "Fig 12 (depth)": _set(("fig12", "r2"), [0.7, 0.8, 0.98]),
    "Fig 12 (distance)": _set(("fig12", "dist_r2"), [0.8, 0.9, 0.95, 0.98]),
    "Fig 12 (groups)": _set(("fig12", "groups"), [(0.01, 0.9), (0.1, 0.7), (0.5, 0.6)]),
    "Fig 13 (r)": _set(("fig13", "r"), [0.99, 0.9, 0.6]),
    "Fig 13 (r²)": _set(("fig13", "r2"), [0.5, 0.5, 0.5]),
    "Fig 13 (depth)": _set(("fig13", "r2"), [0.7, 0.8, 0.98]),
    "Fig 13 (distance)": _set(("fig13", "dist_r2"), [0.8, 0.9, 0.95, 0.98]),
    "Fig 13 (groups)": _set(("fig13", "groups"), [(0.05, 0.6), (1.0, 0.8), (10.0, 0.9)]),
}


def test_every_claim_of_the_report_can_fail():
    """Each row's rule says yes on a result that meets the claim and turns when the result is
    changed (a rule that cannot fail would not turn); every row has its mutation."""
    import copy

    from experiments.report import claims

    base = _passing_numbers()
    rows = {c: v["s"] for c, _w, _t, v, _r in claims({"s": base})}
    assert set(rows) == set(MUTATIONS), "a claim without its mutation test"
    assert all(v == "yes" for v in rows.values()), rows
    for claim, mutate in MUTATIONS.items():
        x = copy.deepcopy(base)
        mutate(x)
        got = {c: v["s"] for c, _w, _t, v, _r in claims({"s": x})}[claim]
        assert got.split(" ")[0] != "yes", (claim, got)


def test_a_bound_at_its_ceiling_is_marked_not_discriminating_and_not_counted():
    import copy

    from experiments.report import NOT_DISCRIMINATING, claims, counted

    x = copy.deepcopy(_passing_numbers())
    x["fig12"]["r"] = [1.0, 0.99996, 0.9997]
    v = {c: v["default"] for c, _w, _t, v, _r in claims({"default": x})}["Fig 12 (r)"]
    assert v == f"yes ({NOT_DISCRIMINATING})"
    assert not counted("Fig 12 (r)", "default", v)
    assert counted("Fig 12 (r)", "default", "yes")
    assert not counted("Fig 12 (r)", "same-code", "yes")  # the machinery check never counts
    assert not counted("Fig 10 (level)", "paper-like", "yes")  # tuned on it


def test_real_camera_verdicts_can_fail():
    from experiments.report import realcamera_verdicts

    def s(m):
        return {"median": m, "min": m, "max": m}
    r = {"cv_systematic": {"model": s(0.2), "model + light field": s(0.11), "affine": s(0.12),
                           "diagonal": s(0.3)},
         "greys_held_out": {"model": s(0.5), "grey-world": s(2.0), "white-patch": s(0.8)},
         "greys_measure": {"uw3p measure": s(1.0), "grey-world": s(2.0), "white-patch": s(0.6)}}
    v = realcamera_verdicts(r)
    assert (v["fit"], v["held"], v["measure"]) == ("yes", "yes", "partly")
    r["cv_systematic"]["model + light field"] = s(0.4)
    r["greys_held_out"]["model"] = s(3.0)
    r["greys_measure"]["uw3p measure"] = s(4.2)
    v = realcamera_verdicts(r)
    assert (v["fit"], v["held"], v["measure"]) == ("no", "no", "no")


def test_default_setting_fits_charts_of_the_independent_renderer():
    """The default figures fit charts the independent renderer made (its own tables, grid,
    veil and the clean world's tolerances): their error is not the noise floor of the
    same-code charts, and the two worlds share the condition's seed but not its cache key."""
    from experiments import grids, honesty
    from experiments.estimation import condition_kw

    assert grids.SETTINGS["default"]["world"] == "independent"
    assert grids.SETTINGS["same-code"]["machinery_check"]
    # the clean world of HONESTY.md, its noise settings left to the sensor
    assert grids.INDEPENDENT_OPTIONS == {k: v for k, v in honesty.CLEAN_OPTIONS.items()
                                         if k not in ("noise", "pixels_per_patch")}
    same = sweep.condition(1.0, 0.1, 10.0, 5.0, **condition_kw(grids.setting("same-code")))
    indep = sweep.condition(1.0, 0.1, 10.0, 5.0, **condition_kw(grids.setting("default")))
    assert same["seed"] == indep["seed"] and sweep.key(same) != sweep.key(indep)
    a, b = sweep.fit_condition(same), sweep.fit_condition(indep)
    assert b["rrmse_k"] > 3 * a["rrmse_k"]
    assert len(b["wavelengths"]) == 601  # the renderer's 0.5 nm grid, not forward's
