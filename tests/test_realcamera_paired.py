"""The real camera's comparison (issue 50 item 7): one metric named in advance, a paired
per-chart test with its p-value, and leave-one-chart-out prediction (no data needed)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from experiments import realcamera
from experiments.report import realcamera_paired, realcamera_rows


def _summary(model, affine):
    """A run's result with only what summarise reads, per chart the two errors given."""
    def cv(m, a):
        v = {k: {"systematic": 0.3, "rms": 0.2} for k in realcamera.METHODS_CV}
        v["model + light field"] = {"systematic": m, "rms": 0.1}
        v["affine"] = {"systematic": a, "rms": 0.2}
        return v
    ch = [{"cv": cv(m, a), "greys": {"model": 1.0, "grey-world": 2.0, "white-patch": 0.7},
           "measure": {"flags": [], "reliable": False, "nuisance": {},
                       "greys": {"uw3p measure": 1.0, "grey-world": 2.0, "white-patch": 0.7}}}
          for m, a in zip(model, affine)]
    return realcamera.summarise({"available": True, "charts": ch, "names": []})


def test_the_metric_is_named_once_and_judges_the_wins():
    assert realcamera.PRIMARY_METRIC == "systematic"
    assert "named before the paired test" in realcamera.__doc__.replace("\n", " ")
    s = _summary([0.1, 0.3, 0.3], [0.2, 0.2, 0.2])
    assert s["metric"] == "systematic" and s["wins"]["model + light field"] == 1


def test_paired_sign_test_p_of_5_wins_in_17():
    rng = np.random.default_rng(3)
    affine = rng.uniform(0.1, 0.4, 17)
    model = affine + np.where(np.arange(17) < 5, -0.02, 0.03)
    t = realcamera.paired_test(model, affine)
    assert (t["wins"], t["losses"], t["n"]) == (5, 12, 17)
    assert t["p_sign"] == pytest.approx(stats.binomtest(5, 17, 0.5).pvalue)
    assert 0.1 < t["p_sign"] < 0.2  # the referee's p ~ 0.14
    assert t["p_wilcoxon"] == pytest.approx(stats.wilcoxon(model - affine).pvalue)


def test_leave_one_chart_out_chooses_without_the_chart():
    # a is better on most charts; on chart 0 b is far better, but chart 0 does not choose
    e = {"a": [0.5, 0.1, 0.1, 0.1], "b": [0.0, 0.2, 0.2, 0.2]}
    loco = realcamera.leave_one_chart_out(e)
    assert loco["chosen"] == ["a", "a", "a", "a"]
    assert loco["error"] == [0.5, 0.1, 0.1, 0.1]
    assert loco["counts"] == {"a": 4, "b": 0}


def test_report_prints_the_paired_test_and_loco():
    s = _summary([0.1, 0.3, 0.3, 0.25], [0.2, 0.2, 0.2, 0.2])
    text = realcamera_paired(s)
    assert f"p = {s['paired']['p_sign']:.2g}" in text and "Leave-one-chart-out" in text
    assert "1 of 4" in text
    assert realcamera_paired(s) in realcamera_rows(s)
