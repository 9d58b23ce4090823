"""The dive experiment's bookkeeping (experiments/dive_honesty.py, DIVE.md): coverage is tested
on both sides, a too-wide interval fails where the dives are drawn from the budget's priors, a
reliable dive with the truth outside is counted, and the clean dives' criterion fails on one.
Fast: synthetic numbers, no rendering or fitting."""

import numpy as np
import pytest

from experiments import dive_honesty as d
from experiments.honesty import CONSISTENCY_P, JOINT_QUANTITIES as QUANTITIES


def _pair(lo, hi, truth=1.0):
    """(truth, joint numbers) of one dive: every quantity's truth ``truth`` and interval
    [lo, hi]."""
    t = {k: truth for k, _ in QUANTITIES}
    f = {"reliable": True, "intervals": {k: [lo, hi] for k, _ in QUANTITIES}}
    return t, f


def _summary(pairs, narrower=True):
    return {"coverage": d._coverage(pairs, "two-sided"), "narrower": 1 if narrower else 0,
            "compared": 1, "mixed_reliable": 0}


def test_a_too_wide_interval_fails_the_two_sided_test():
    pairs = [_pair(0.0, 3.0)] * 120  # [0, 3 x the truth]: covers, says nothing
    cov = d._coverage(pairs, "two-sided")
    assert cov["chl"]["covered"] == 120 and cov["chl"]["median_half_width"] == pytest.approx(1.5)
    assert cov["chl"]["p"] < CONSISTENCY_P
    assert not d.honest(_summary(pairs))


def test_nominal_coverage_holds_and_misses_are_counted():
    nominal = [_pair(0.9, 1.1)] * 114 + [_pair(1.2, 1.3)] * 6  # 95 %
    assert d.honest(_summary(nominal))
    assert d._coverage(nominal, "two-sided")["cdom"]["covered"] == 114
    assert not d.honest(_summary(nominal, narrower=False))
    too_many = [_pair(0.9, 1.1)] * 100 + [_pair(1.2, 1.3)] * 20
    assert not d.honest(_summary(too_many))


def _clean_fit(ci_chl, reliable=True):
    t = {"chl": 1.0, "cdom": 0.1}
    rule = {"reliable": reliable, "intervals": {"chl": ci_chl, "cdom": [0.05, 0.2]}}
    return {"truth": t, "rules": {r: rule for r in d.RULES}}


def test_a_reliable_dive_with_the_truth_outside_is_counted_and_fails():
    assert d._wrong(_clean_fit([0.4, 0.93]), "now")  # the dive: confident, wrong
    assert not d._wrong(_clean_fit([0.4, 0.93], reliable=False), "now")
    assert not d._wrong(_clean_fit([0.7, 1.3]), "now")
    now = {"reliable_wrong": 1, "narrower": 3, "compared": 4}
    assert not d.clean_acceptance({"rules": {"now": now}})
    assert d.clean_acceptance({"rules": {"now": {**now, "reliable_wrong": 0}}})


def test_each_photo_has_its_own_part_of_the_chart_error():
    dive = d.draw_dive(np.random.default_rng(0), n=3)
    a, b = d.photo_options(dive, 0), d.photo_options(dive, 1)
    assert a["reflectance_factors"] != b["reflectance_factors"]
    shared = np.asarray(dive["options"]["reflectance_factors"])
    assert np.allclose(np.asarray(a["reflectance_factors"]) / shared, dive["photo_factors"][0])
