"""Dives with the reference shot (experiments/dive_honesty.py, DIVE.md section 3): a small
world (6 dives of 2 photos, the fit with the reference only) is covered two-sided, the light
measured in air is the surface light, and the acceptance fails on a world that is not covered."""

import pytest

from experiments import dive_honesty as r
from experiments.honesty import JOINT_QUANTITIES as QUANTITIES


@pytest.fixture(scope="module")
def small():
    return r.run_reference(6, seed=3, workers=1, photos=2, full=False)


def test_dives_with_the_reference_shot_are_covered(small):
    s = r.summarise_reference(small)
    ref = s["fits"][r.REF_WITH_REF]
    assert ref["reliable"] >= 4
    assert all(ref["coverage"][k]["n"] == ref["reliable"] for k, _ in QUANTITIES)
    assert r.reference_covered(s)


def test_the_shot_measures_the_surface_light_not_the_changed_one(small):
    for f in small["fits"]:
        light = f["light"]
        assert abs(light["centre_mired"] - f["surface_mired"]) < 4 * light["sd_mired"] + 1.0
        assert light["factors"] is not None  # the chart's response measured too


def _fits(lo, hi, k_miss, n=8):
    """n synthetic fits of truth 1: k_miss of them with every interval [lo, hi] beside it."""
    truth = {k: 1.0 for k, _ in QUANTITIES}
    good = {"reliable": True, "intervals": {k: [0.97, 1.03] for k, _ in QUANTITIES}}
    bad = {"reliable": True, "intervals": {k: [lo, hi] for k, _ in QUANTITIES}}
    return [{"truth": truth, "fits": {r.REF_WITH_REF: bad if i < k_miss else good},
             "light": {"centre_mired": 0.0}, "surface_mired": 0.0, "photo_mired": 0.0,
             "dive_s": 1.0} for i in range(n)]


def test_the_acceptance_fails_when_coverage_fails():
    out = {"seconds": 1.0, "workers": 1, "seed": 0, "photos": 2}
    assert r.reference_covered(r.summarise_reference({**out, "fits": _fits(1.1, 1.2, 0)}))
    assert not r.reference_covered(r.summarise_reference({**out, "fits": _fits(1.1, 1.2, 4)}))
    s = r.summarise_reference({**out, "fits": _fits(1.1, 1.2, 0)})
    assert s["fits"][r.REF_WITH_REF]["c_half_widths"]["c_443"]["median"] == pytest.approx(0.03)
    assert r.reference_target_met(s)
    assert not r.reference_target_met(r.summarise_reference({**out, "fits": _fits(0.5, 1.5, 8)}))
