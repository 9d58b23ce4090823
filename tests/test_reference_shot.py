"""The surface reference shot (sca.reference): the light at the site measured in air, then used
as the underwater fits' daylight prior (decision 0069-reference-shot)."""

import numpy as np
import pytest
from scipy.stats import binomtest

import forward
import sca
from forward.daylight import D_SERIES_CCT, daylight_spd, mired
from forward.errors import InputError
from sca.budget import DEFAULT_UNCERTAIN, resolve_budget
from sca.assess import BLOCKING
from sca.assess import CONFLICT_P
from sca.reference import (CONFLICT_FLAG, SKY_SD, bracket, measure_light, sky_sd,
                           with_reference)

SHIFT = 40.0  # mired warmer than D65: the site's light
WL = forward.wavelength_grid()
CHL, CDOM, DEPTH, DISTANCE = 1.0, 0.1, 5.0, 2.0


def _site_setup(shift, balance):
    """The world: daylight ``shift`` mired from D65, the camera's balance off by ``balance``."""
    ill = daylight_spd(1e6 / (mired(D_SERIES_CCT["D65"]) + shift), WL)
    return forward.chart_setup(illuminant=ill / ill.max(), channel_gains=1.0 + balance)


def _air_shot(seed, balance):
    sim = forward.simulate_chart(0.0, 0.0, 0.0, 0.0, setup=_site_setup(SHIFT, balance),
                                 seed=seed, backscatter=False)
    return measure_light(sim.rgb, sim.rgb_sigma)


def test_the_reference_shot_measures_the_light_with_intervals_that_cover():
    rng = np.random.default_rng(7)
    lights = [_air_shot(seed, rng.normal(0.0, 0.01, 3)) for seed in range(20)]
    hits = sum(abs(lt.centre - SHIFT) <= 1.96 * lt.sd for lt in lights)
    assert binomtest(hits, 20, 0.95).pvalue > 0.01
    # it measures: far narrower than the default prior it replaces
    assert max(lt.sd for lt in lights) < DEFAULT_UNCERTAIN["daylight"] / 5


@pytest.fixture(scope="module")
def site():
    """A reference shot and a photo underwater under the same shifted light, the camera's
    balance off by 1 %."""
    balance = np.array([0.01, -0.01, 0.0])
    light = _air_shot(1, balance)
    uw = forward.simulate_chart(CHL, CDOM, DEPTH, DISTANCE, setup=_site_setup(SHIFT, balance),
                                seed=2)
    truth = forward.simulate_chart(CHL, CDOM, DEPTH, DISTANCE, noise=False)
    c443 = truth.attenuation_coefficient[int(np.argmin(abs(WL - 443.0)))]
    return light, uw, c443


def _c443(uw, uncertain):
    est = sca.estimate_batch(uw.rgb[None], depth=DEPTH, distance=DISTANCE,
                             sigma=uw.rgb_sigma[None], gain="free", uncertain=uncertain)
    return est.quantity_intervals["c_443"][0], est.flags[0]


def test_the_reference_narrows_c443_as_the_bound_predicts_and_covers_the_truth(site):
    light, uw, c443 = site
    ref = with_reference(None, light, minutes=10)
    bound = [sca.precision(CHL, CDOM, depth=DEPTH, distance=DISTANCE, gain="free",
                           uncertain=u).quantity_sd["c_443"] for u in (None, ref)]
    predicted = bound[1] / bound[0]
    assert predicted < 0.6
    (lo0, hi0), _ = _c443(uw, None)
    (lo1, hi1), _ = _c443(uw, ref)
    assert lo1 <= c443 <= hi1
    assert (hi1 - lo1) / (hi0 - lo0) < 1.5 * predicted


def test_a_sky_change_beyond_its_sd_is_flagged_or_covered(site):
    light, _, c443 = site
    # the sky warmed by a further 20 mired between the shot and the dive: 2.3 sd of the prior
    # (sqrt(1.8^2 + 8.7^2) mired after 10 min). The photo underwater hardly sees the light's
    # colour (its pull stays ~0.2 sd), so beyond ~3 sd it is neither flagged nor covered:
    # decision 0069-reference-shot
    uw = forward.simulate_chart(CHL, CDOM, DEPTH, DISTANCE,
                                setup=_site_setup(SHIFT + 20.0, np.array([0.01, -0.01, 0.0])),
                                seed=3)
    (lo, hi), flags = _c443(uw, with_reference(None, light, minutes=10))
    assert "nuisance-pulled" in flags or lo <= c443 <= hi


def test_the_measured_prior_is_the_budgets_daylight_prior():
    light = sca.reference.Light(12.0, 2.0, D_SERIES_CCT["D65"], 1.0)
    ref = with_reference(None, light, minutes=30)
    mu, sd = resolve_budget(ref, depth=5.0, distance=1.0, water=forward.Water()).priors["daylight"]
    assert mu[0] == 12.0 and sd[0] == pytest.approx(np.hypot(2.0, sky_sd(30)))
    assert sky_sd(0) == 0.0 and sky_sd(1e6) == SKY_SD
    assert with_reference({}, light) == {}  # the paper's exact model stays exact
    with pytest.raises(InputError, match="minutes"):
        sky_sd(-1)
    with pytest.raises(InputError, match="daylight"):
        resolve_budget({"daylight": {"sd": 3.0}}, depth=5.0, distance=1.0,
                       water=forward.Water())


def test_measure_takes_a_reference_shot_and_says_which_daylight_it_used(chart_photos, tmp_path):
    import io
    import json

    from uw3p.cli import main

    ph = chart_photos
    prof = tmp_path / "profile.json"
    prof.write_text(ph["profile"].to_json())
    corners = " ".join(f"{x},{y}" for x, y in ph["corners"])
    base = ["measure", str(ph["uw"]), "--profile", str(prof), "--depth", "5", "--distance",
            "1.5", "--corners", corners, "--tiff", "none"]

    def run(extra, out_dir):
        out, err = io.StringIO(), io.StringIO()
        code = main(base + ["--out", str(out_dir)] + extra, out, err)
        return code, out.getvalue(), err.getvalue()
    code, text, _ = run(["--reference", f"{ph['air']}:20"], tmp_path / "ref")
    assert code in (0, 1) and "daylight: measured at the site" in text
    day = json.loads((tmp_path / "ref" / "measurement.json").read_text())["inputs"][
        "uncertain"]["daylight"]
    assert day["minutes"] == 20 and day["sd"] < DEFAULT_UNCERTAIN["daylight"]
    code, text, _ = run([], tmp_path / "default")
    assert "daylight: prior 30 mired" in text
    code, _, err = run(["--reference", f"{ph['air']}:-5"], tmp_path / "bad")
    assert code == 2 and "--reference" in err
    two = ["--reference", f"{ph['air']}:5", "--reference", f"{ph['air']}:15"]
    code, text, _ = run(two, tmp_path / "two")
    day = json.loads((tmp_path / "two" / "measurement.json").read_text())["inputs"][
        "uncertain"]["daylight"]
    assert "measured at the site by two shots" in text and len(day["shots"]) == 2
    assert not day["conflict"] and "reference-conflict" not in text
    code, _, err = run(two + ["--reference", str(ph["air"])], tmp_path / "three")
    assert code == 2 and "--reference" in err


def _bracket(after, minutes=(5.0, 5.0)):
    """Shots before (at SHIFT) and after (at SHIFT + ``after``) the dive, the same camera."""
    balance = np.array([0.01, -0.01, 0.0])
    lights = [measure_light(s.rgb, s.rgb_sigma) for s in (
        forward.simulate_chart(0.0, 0.0, 0.0, 0.0, setup=_site_setup(SHIFT + d, balance),
                               seed=11 + i, backscatter=False) for i, d in enumerate((0, after)))]
    return bracket(lights, minutes)


def test_two_reference_shots_that_disagree_are_flagged_and_block_the_estimate(site):
    _, uw, _ = site
    b = _bracket(40.0)
    assert b.conflict and b.p < CONFLICT_P
    prior = with_reference(None, b)["daylight"]
    assert prior["conflict"] and prior["sd"] >= sky_sd(5.0)
    _, flags = _c443(uw, with_reference(None, b))
    assert CONFLICT_FLAG in flags and CONFLICT_FLAG in BLOCKING


def test_two_reference_shots_that_agree_cover_the_sky_between_them(site):
    _, uw, _ = site
    b = _bracket(5.0)
    assert not b.conflict
    prior = with_reference(None, b)["daylight"]
    # the sky drifted from SHIFT to SHIFT + 5 over the dive: every value between is covered
    assert all(abs(prior["centre"] - x) <= 1.96 * prior["sd"] for x in (SHIFT, SHIFT + 5.0))
    assert prior["sd"] >= sky_sd(5.0)
    _, flags = _c443(uw, with_reference(None, b))
    assert CONFLICT_FLAG not in flags
    with pytest.raises(InputError, match="lights"):
        bracket(b.lights[:1], (5.0,))


def test_a_dives_metadata_names_its_reference_shots_and_the_photos_fit_takes_them(
        chart_photos, tmp_path):
    from measure.dive.metadata import read_metadata
    from measure.dive.worker import _budget

    from pathlib import Path

    air = Path(chart_photos["air"])
    csv = tmp_path / "dive_ref.csv"
    (tmp_path / air.name).write_bytes(air.read_bytes())
    air = tmp_path / air.name
    csv.write_text(f"image,depth_m,distance_m,reference,reference_after\n"
                   f"UW.dng,5,1.5,{air.name}:5,{air.name}:15\n")
    row = read_metadata(csv)["UW.dng"]
    assert row["reference"] == [[str(air), 5.0], [str(air), 15.0]]
    prof = tmp_path / "profile.json"
    prof.write_text(chart_photos["profile"].to_json())
    options = {"camera": forward.DEFAULT_CAMERA, "profile": str(prof)}
    day = _budget(options, {"reference": row["reference"]})["daylight"]
    assert len(day["shots"]) == 2 and not day["conflict"] and day["sd"] < SKY_SD
    assert _budget(options, {"reference": []}) is None  # none: the run's budget
    csv.write_text("image,depth_m,distance_m,reference\nUW.dng,5,1.5,missing.dng:5\n")
    with pytest.raises(InputError, match="reference: file not found"):
        read_metadata(csv)
