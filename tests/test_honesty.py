"""The honesty experiment (experiments/honesty.py): a reduced clean world is covered at the
nominal rate, garbage is never reliable, and the bookkeeping counts what it says.

Thresholds come from binomial reasoning, not from tuning. The full run (HONESTY.md: seed
20240611, 200 charts per world, default budget with the camera-curve shift) found in the
``clean`` world 200/200 reliable, C covered 199/200, a_CDOM 198/200, both 198/200: at least
the nominal rates (95 % per interval, 90 % jointly). The reduced run draws an independent
sample (another seed) and asserts each count is at least the 0.1 % quantile of the binomial
at the nominal rate (reliable: at the 0.98 the full run supports): if the intervals are as
calibrated as they claim, the test fails by chance with probability <= 0.1 % per assertion.
"""

from types import SimpleNamespace

import numpy as np
import pytest
from scipy import stats

from experiments import honesty as h

#: Charts of the reduced clean world and of each garbage world.
N_CLEAN = 40
N_GARBAGE = 6
#: An independent sample (the full run uses h.SEED).
TEST_SEED = 1
#: Chance of a false failure per assertion if the estimator is as good as the full run.
FALSE_FAIL = 0.001
#: The reliable fraction the full run supports (Clopper-Pearson 95 % lower bound of 200/200).
SUPPORTED_RELIABLE = 0.98
#: The nominal coverage: 95 % per interval, both 95 % intervals at least 90 %.
NOMINAL_COVERAGE = {"chl": 0.95, "cdom": 0.95, "joint": 0.90}
#: Garbage worlds the full run never found reliable (0/200 each).
NEVER_RELIABLE = ("corner_shift_0.5", "wrong_camera", "occluded_4")


def _at_least(n, p):
    """The smallest count that a Binomial(n, p) falls below with probability <= FALSE_FAIL."""
    return int(stats.binom.ppf(FALSE_FAIL, n, p))


@pytest.fixture(scope="module")
def clean():
    return h.run(N_CLEAN, TEST_SEED, charts=False, only=["clean"])["results"]["clean"]["fits"]


@pytest.mark.slow
def test_clean_world_is_reliable_at_the_supported_rate(clean):
    s = clean[h.DEFAULT_LABEL]
    assert s["n"] == N_CLEAN
    assert s["reliable"] >= _at_least(N_CLEAN, SUPPORTED_RELIABLE), s
    assert s["not_converged"] == 0 and s["nan_intervals"] == 0, s


@pytest.mark.slow
@pytest.mark.parametrize("what", ["chl", "cdom", "joint"])
def test_clean_world_coverage_at_the_nominal_rate(clean, what):
    s = clean[h.DEFAULT_LABEL]
    cov = s["coverage"][what]
    assert cov["covered"] >= _at_least(s["reliable"], NOMINAL_COVERAGE[what]), cov


@pytest.mark.slow
@pytest.mark.parametrize("world", NEVER_RELIABLE)
def test_garbage_is_never_reliable(world):
    s = h.run(N_GARBAGE, TEST_SEED, charts=False, only=[world])["results"][world]["fits"]
    assert s[h.DEFAULT_LABEL]["reliable"] == 0, s[h.DEFAULT_LABEL]["flags"]


@pytest.mark.slow
def test_the_illuminant_is_an_input_the_chart_cannot_check():
    """A known limitation, stated in HONESTY.md: tungsten light fitted as daylight is taken for
    CDOM (a good fit, a_CDOM too high). If this ever changes, the documentation must too."""
    world = "wrong_illuminant"
    assert {w.name: w for w in h.worlds()}[world].group == "limitation"
    s = h.run(N_GARBAGE, TEST_SEED, charts=False, only=[world])["results"][world]["fits"]
    assert s[h.DEFAULT_LABEL]["reliable"] > 0


# --------------------------------------------------------------------------- fast
def test_cli_has_quick_and_main(capsys):
    with pytest.raises(SystemExit) as exc:
        h.main(["--help"])
    assert exc.value.code == 0
    assert "--quick" in capsys.readouterr().out
    assert h.CHARTS_QUICK < h.CHARTS_FULL


def test_worlds_cover_every_criterion():
    groups = {w.group for w in h.worlds()}
    assert groups == {"clean", "priors", "ends", "geometry", "garbage", "limitation",
                      "diagnostic"}
    names = [w.name for w in h.worlds()]
    assert len(names) == len(set(names))
    assert all(n in names for n in (*NEVER_RELIABLE, "wrong_illuminant"))


def _fake_estimate():
    """Four charts: covered, C missed, unreliable, a_CDOM missed."""
    return SimpleNamespace(
        reliable=np.array([True, True, False, True]),
        chl_ci=np.array([[0.5, 2.0], [2.0, 3.0], [0.0, np.inf], [0.5, 1.5]]),
        cdom_ci=np.array([[0.05, 0.2], [0.05, 0.2], [0.0, 1.0], [0.2, 0.3]]),
        converged=np.array([True, True, False, True]), flags=[(), (), ("misfit",), ()],
        budget={"chl": {"shares": {"noise": np.array([0.2, 0.1, 0.5, 0.3]),
                                   "patch": np.array([0.8, 0.9, 0.5, 0.7])}}},
        elapsed_s=0.0)


def test_summary_counts_coverage_among_reliable_charts():
    cond = {"chl": np.ones(4), "cdom": np.full(4, 0.1)}
    s = h.summarise(_fake_estimate(), cond)
    assert (s["n"], s["reliable"], s["confident_wrong"]) == (4, 3, 2)
    assert [s["coverage"][k]["covered"] for k in ("chl", "cdom", "joint")] == [2, 2, 1]
    assert s["commonest_largest_source_chl"] == "patch"
    assert s["median_largest_share_chl"] == pytest.approx(0.8)
    assert s["median_rel_halfwidth_chl"] == pytest.approx(0.5)
    assert s["not_converged"] == 1 and s["flags"] == {"misfit": 1}


def test_report_is_marked_generated_and_acceptance_reads_the_summary():
    cond = {"chl": np.ones(4), "cdom": np.full(4, 0.1)}
    s = h.summarise(_fake_estimate(), cond)
    out = {"config": {"charts_per_world": 4, "seed": 0}, "elapsed_s": 1.0,
           "results": {"occluded_4": {"group": "garbage", "description": "x", "render_s": 0.0,
                                      "fits": {h.DEFAULT_LABEL: s}}}}
    text = h.report(out)
    assert "Generated by `python -m experiments.honesty`; do not edit" in text
    (verdict,) = h.acceptance(out["results"])
    assert verdict["group"] == "garbage" and verdict["holds"] is False


# --------------------------------------------------------------------------- both sides
def _wide_estimate(n, factor=3.0, miss=0):
    """``n`` reliable charts of truth C = 1, a_CDOM = 0.1, every interval [0, factor x the
    truth]; the first ``miss`` of them [2, 3] x the truth instead (misses of both)."""
    chl_ci = np.tile([0.0, factor], (n, 1))
    chl_ci[:miss] = [2.0, 3.0]
    cdom_ci = np.tile([0.0, 0.1 * factor], (n, 1))
    cdom_ci[:miss] = [0.2, 0.3]
    return SimpleNamespace(
        reliable=np.ones(n, bool), chl_ci=chl_ci, cdom_ci=cdom_ci,
        converged=np.ones(n, bool), flags=[()] * n,
        budget={"chl": {"shares": {"patch": np.ones(n)}}}, elapsed_s=0.0,
        chl=np.ones(n), cdom=np.full(n, 0.1))


def test_two_sided_test_fails_too_few_misses_and_one_sided_does_not():
    assert h.coverage_p(200, 200, 0.95, "one-sided") == 1.0
    assert h.coverage_p(200, 200, 0.95, "two-sided") < h.CONSISTENCY_P  # too wide
    assert h.coverage_p(180, 200, 0.95, "two-sided") < h.CONSISTENCY_P  # too narrow
    assert h.coverage_p(180, 200, 0.95, "one-sided") < h.CONSISTENCY_P
    assert h.coverage_p(190, 200, 0.95, "two-sided") > 0.5  # nominal
    assert h.coverage_p(0, 0, 0.95, "two-sided") is None
    with pytest.raises(ValueError, match="test"):
        h.coverage_p(1, 2, 0.95, "both")


def test_an_interval_of_0_to_3x_the_truth_covers_and_says_nothing():
    """Every interval [0, 3 x truth]: covered 100 %, median half-width 150 %: in a world drawn
    from the budget's priors (two-sided) the criterion fails; one-sided it would hold."""
    cond = {"chl": np.ones(200), "cdom": np.full(200, 0.1)}
    s2 = h.summarise(_wide_estimate(200), cond, test="two-sided")
    assert s2["coverage"]["chl"]["fraction"] == 1.0
    assert s2["median_rel_halfwidth"]["chl"] == pytest.approx(1.5)
    assert s2["coverage"]["chl"]["p"] < h.CONSISTENCY_P
    results = {"priors": {"group": "priors", "fits": {h.DEFAULT_LABEL: s2}}}
    (verdict,) = h.acceptance(results)
    assert verdict["group"] == "priors" and verdict["holds"] is False
    s1 = h.summarise(_wide_estimate(200), cond, test="one-sided")
    assert h.acceptance({"priors": {"group": "priors", "fits": {h.DEFAULT_LABEL: s1}}})[0][
        "holds"] is True
    assert "says nothing" in h._width_text(results) and "±150 %" in h._width_text(results)


def test_misses_are_counted_and_too_many_fail_both_tests():
    cond = {"chl": np.ones(200), "cdom": np.full(200, 0.1)}
    for test in ("one-sided", "two-sided"):
        s = h.summarise(_wide_estimate(200, miss=30), cond, test=test)
        assert s["coverage"]["chl"]["covered"] == 170 and s["confident_wrong"] == 30
        assert not h._honest(s)
    # 10 misses in 200 is the nominal rate: both tests hold
    s = h.summarise(_wide_estimate(200, miss=10), cond, test="two-sided")
    assert h._honest(s)


def test_attenuation_criterion_counts_misses_and_width():
    """The c(lambda) criterion among the reliable: a miss is counted, a wide interval fails the
    width even when every truth is inside."""
    n = 100
    ok = {"depth": [5.0] * n, "reliable": [True] * n, "geometry": [0.05] * n}
    for band in h.C_BANDS:
        ok[f"inside:{band}"] = [True] * 95 + [False] * 5
        ok[f"half:{band}"] = [0.05] * n
    v = h._band_numbers([ok], h.C_BANDS[0], "two-sided")
    assert (v["covered"], v["reliable"]) == (95, 100) and v["p_two_sided"] > h.CONSISTENCY_P
    crit, _ = h._attenuation_numbers({"clean": {"clear": ok}})
    assert all(b["holds"] for b in crit["clean"].values())
    wide = {**ok, **{f"half:{b}": [0.2] * n for b in h.C_BANDS},
            **{f"inside:{b}": [True] * n for b in h.C_BANDS}}
    crit, _ = h._attenuation_numbers({"clean": {"clear": wide}})
    assert not any(b["holds"] for b in crit["clean"].values())
    missed = {**ok, **{f"inside:{b}": [True] * 80 + [False] * 20 for b in h.C_BANDS}}
    crit, _ = h._attenuation_numbers({"clean": {"clear": missed}})
    assert not any(b["holds"] for b in crit["clean"].values())


# --------------------------------------------------------------------------- issue 50 item 5
def _band_rows(n, inside):
    rows = {"depth": [5.0] * n, "reliable": [True] * n, "geometry": [0.05] * n}
    for band in h.C_BANDS:
        rows[f"inside:{band}"] = [True] * inside + [False] * (n - inside)
        rows[f"half:{band}"] = [0.05] * n
    return rows


def test_a_worlds_sidedness_is_defined_once_and_every_section_reads_it():
    """The c(lambda) criterion tests each world by the world's own test: `clean` one-sided (its
    over-coverage is expected), `priors` two-sided (over-coverage fails), as the main table."""
    assert h.world_test("clean") == "one-sided" and h.world_test("priors") == "two-sided"
    assert h.test_of("reference") == "two-sided" and h.test_of("sky-beyond") == "one-sided"
    every = _band_rows(200, 200)  # 100 % covered: too wide for a two-sided test
    crit, breakdown = h._attenuation_numbers({"clean": {"clear": every}, "priors": {"clear": every}})
    assert all(v["test"] == "one-sided" and v["holds"] for v in crit["clean"].values())
    assert all(v["test"] == "two-sided" and not v["holds"] for v in crit["priors"].values())
    assert all(b["test"] == "one-sided" for d in breakdown["clean"]["clear"].values()
               for b in d.values())
    att = {"criterion": crit, "breakdown": breakdown, "n": 200, "seed": 1, "elapsed_s": 1.0}
    table = [ln for ln in h._attenuation_text(att) if ln.startswith("| clean | c_")]
    assert table and all("| one-sided |" in ln for ln in table)
    texts = [v["criterion"] for v in h.acceptance({}, att)]
    assert not any("one-sided" in t or "two-sided" in t for t in texts)


def test_c_is_named_the_paths_attenuation_coefficient_not_the_beam_attenuation():
    crit, breakdown = h._attenuation_numbers({"clean": {"clear": _band_rows(100, 95)}})
    att = {"criterion": crit, "breakdown": breakdown, "n": 100, "seed": 1, "elapsed_s": 1.0}
    text = "\n".join(h._attenuation_text(att))
    assert h.C_NAME in text and "not the beam attenuation" in h.C_NAME
    assert "(the beam attenuation" not in text


def test_the_wrong_illuminant_is_said_plainly_with_what_prevents_it():
    s = {"n": 10, "reliable": 8, "reliable_fraction": 0.8, "confident_wrong": 5, "flags": {},
         "coverage": {k: {"covered": 3, "p": 1e-6} for k in (*h.TESTED, "joint")}}
    results = {"wrong_illuminant": {"group": "limitation", "fits": {h.DEFAULT_LABEL: s}}}
    check = {"A": {"n": 4, "refused": 4, "cct_median": 2370.0, "chi2_dof_median": 2.3}}
    text = "\n".join(h._limitation_text(results, check))
    assert "outside what one underwater photo can see" in text
    assert "0069-reference-shot" in text and "--reference" in text
    assert "refused 4 of 4" in text
