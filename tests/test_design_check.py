"""DESIGN.md's check (experiments.design_check): designs checked on worlds they did not assume
(issue 50 item 4, issue 47's design criterion): the worlds' draws, each criterion on small
numbers (each fails where the criterion fails), the realised error and the reference shot."""

import types

import numpy as np
import pytest

import sca
from experiments import design_check as dc
from experiments import independent_world as iw
from sca.protocols import Protocol
from sca.reference import REFERENCE_MINUTES, sky_sd

COASTAL = dc.DESIGNS[0]
AUX_SD = {"sample": 0.0025, "secchi": 1.0}
#: A design's prediction as the check reads it (its C and c half-widths).
SHOWN = types.SimpleNamespace(rel95={"chl": 0.25, "c": 0.08})


def draws(world, n, proto=Protocol((15.0, 2.0), (3.0,), "sample+secchi"), seed=0):
    rng = np.random.default_rng(seed)
    return [dc.draw_dive(rng, COASTAL, proto, AUX_SD, world) for _ in range(n)]


# --------------------------------------------------------------------------- the worlds
def test_the_water_is_drawn_log_uniform_around_the_guess_and_the_readings_of_it():
    dives = draws("beam", 300)
    d = dives[0]
    assert list(zip(d["depth"], d["distance"])) == [(15.0, 3.0), (2.0, 3.0)]
    for k in ("chl", "cdom"):
        x = np.log(np.array([t[k] for t in dives]) / COASTAL[k])
        lo, hi = np.log(dc.WATER_FACTOR)
        assert lo <= x.min() and x.max() <= hi
        # log-uniform: its quartiles a quarter of the way in, not all at the guess
        assert np.quantile(x, 0.25) == pytest.approx(lo + (hi - lo) / 4, abs=0.2)
        assert np.quantile(x, 0.75) == pytest.approx(lo + 3 * (hi - lo) / 4, abs=0.2)
    err = np.array([t["auxiliary"]["cdom"][0] - t["cdom"] for t in dives])
    assert abs(err.std() / AUX_SD["sample"] - 1) < 0.15 and abs(err.mean()) < 0.0005
    # the Secchi reading: Tyler's relation on the world's optics, its 20 % scatter
    assert all(t["auxiliary"]["secchi"][0] > 0 for t in dives)
    rng = np.random.default_rng(1)
    z = np.array([dc._secchi_truth(rng, d) for _ in range(400)])
    wl = np.array([554.5, 555.0, 555.5])
    o = iw.water_optics(wl, d["chl"], d["cdom"], cdom_slope=d["options"]["cdom_slope"],
                        nap_slope=d["options"]["nap_slope"])
    assert np.median(z) == pytest.approx(8.7 / (o["c"][1] + o["K_d"][1]), rel=0.05)
    assert np.std(z) / np.mean(z) == pytest.approx(0.2, rel=0.15)
    # the daylight drawn from the budget's prior (sd 30 mired), the beam path
    mired = np.array([t["options"]["daylight_mired"] for t in dives])
    assert abs(mired.std() / float(sca.DEFAULT_UNCERTAIN["daylight"]) - 1) < 0.15
    assert {t["options"]["path"] for t in dives} == {"paper"}
    assert dc.draw_dive(np.random.default_rng(1), COASTAL, Protocol((5.0,), (1.0,)), AUX_SD,
                        "beam")["auxiliary"] is None


def test_the_split_beyond_and_reference_worlds():
    assert {t["options"]["path"] for t in draws("split", 3)} == {"split"}
    spread = {w: np.std([np.asarray(t["options"]["reflectance_factors"]) for t in draws(w, 40)])
              for w in ("beam", "beyond")}
    assert spread["beyond"] / spread["beam"] == pytest.approx(dc.PATCH_BEYOND, rel=0.15)
    ref = draws("reference", 200)
    change = np.array([t["options"]["daylight_mired"] - t["surface_mired"] for t in ref])
    assert abs(change.std() / sky_sd(REFERENCE_MINUTES) - 1) < 0.15
    assert all("surface_mired" not in t for t in draws("beam", 3))


def test_the_reference_shot_measures_the_surface_light_on_the_independent_renderer():
    dive = draws("reference", 1, seed=3)[0]
    light = dc._reference_light(dive, np.random.default_rng(0))
    assert abs(light.centre - dive["surface_mired"]) < 4 * light.sd + 1.0
    assert light.sd < 5.0


def test_the_designs_and_their_commands():
    assert dc.command(COASTAL) == ("uw3p design --chl 1 --cdom 0.1 --depth 2 15 --distance 1 3 "
                                   "--target C=30% --sample-sd 0.0025")
    (ref,) = [s for s in dc.DESIGNS if s.get("reference_shot")]
    assert dc.command(ref).endswith("--target C=30% --reference-shot --sample-sd 0.02")
    assert ref["worlds"] == ("reference",)
    assert set(COASTAL["worlds"]) == {"beam", "split", "beyond"}


# --------------------------------------------------------------------------- the criteria
def fake(world, n, *, half=0.25, miss=0, flagged=0, ratio_est=1.0, seed=0):
    """``n`` dives of ``world`` and fits: C's interval of relative half-width ``half`` about
    ``ratio_est`` x the truth, the first ``miss`` of them missing the truth, the first
    ``flagged`` not reliable."""
    rng = np.random.default_rng(seed)
    truth, fits = [], []
    for i, t in enumerate(dc.draw_dive(rng, COASTAL, Protocol((15.0, 2.0), (3.0,), "sample"),
                                       AUX_SD, world) for _ in range(n)):
        est = t["chl"] * (ratio_est if i >= miss else 3.0)
        fits.append({"chl": est, "chl_ci": [est - half * t["chl"], est + half * t["chl"]],
                     "cdom": t["cdom"], "cdom_ci": [0.0, 1.0], "flags": [],
                     "quantity_intervals": {b: [0.0, 10.0] for b in dc.C_BANDS},
                     "reliable": i >= flagged, "cpu_s": 1.0})
        truth.append(t)
    return {"truth": truth, "fits": fits}


def summary(worlds, meets=True):
    design = types.SimpleNamespace(
        meets=meets, protocol=None, limiting="patch", without_limiting=0.28,
        reference_shot=False,
        best=types.SimpleNamespace(rel95=SHOWN.rel95, bound_rel95={"chl": 0.2}, span=("beam",),
                                   protocol=Protocol((15.0, 2.0), (3.0,), "sample")))
    if meets:
        design.protocol = design.best
    return dc.summarise({"spec": COASTAL, "design": design, "worlds": worlds})


def crit(s, word):
    (v,) = [v for k, v in dc.check(s).items() if word in k]
    return v[0]


def test_the_ratio_criterion_fails_outside_its_range_per_world():
    ok = summary({"beam": fake("beam", 20, miss=1), "split": fake("split", 20, miss=1)})
    assert crit(ok, "beam path: realised / designed") and crit(ok, "split path")
    wide = summary({"beam": fake("beam", 20, half=0.4, miss=1),
                    "split": fake("split", 20, half=0.15, miss=1)})
    assert not crit(wide, "beam path: realised / designed")  # 1.6
    assert not crit(wide, "split path")  # 0.6
    text = dc.report([wide], "cmd")
    assert "| beam path: realised / designed C half-width in 0.75-1.33 | **no** | 1.60 |" in text
    assert "nan" not in text.lower()


def test_the_coverage_criterion_sees_over_and_under_coverage_pooled():
    # nominal: 10 misses in 200 pooled
    ok = summary({"beam": fake("beam", 100, miss=5), "split": fake("split", 100, miss=5)})
    assert crit(ok, "C covered") and ok["pooled"]["reliable"] == 200
    # every interval holds the truth: over-coverage, p < 0.01 with 200 dives pooled
    over = summary({"beam": fake("beam", 100), "split": fake("split", 100)})
    assert not crit(over, "C covered")
    under = summary({"beam": fake("beam", 100, miss=15), "split": fake("split", 100, miss=15)})
    assert not crit(under, "C covered")
    # and over every design's worlds
    assert dc.overall([ok, ok])["holds"] and not dc.overall([ok, over, over])["holds"]


def test_the_world_beyond_the_budget_is_flagged_or_covered_and_not_pooled():
    beyond = fake("beyond", 40, miss=12)
    s = summary({"beam": fake("beam", 40, miss=2), "beyond": beyond})
    assert s["pooled"]["dives"] == 40  # the world beyond the budget is not pooled
    assert not crit(s, "flagged or covered")
    flagged = fake("beyond", 40, miss=12, flagged=12)  # the wrong ones flagged: honest
    s = summary({"beam": fake("beam", 40, miss=2), "beyond": flagged})
    assert crit(s, "flagged or covered")


def test_the_realised_error_beside_the_width():
    e = dc.realised_error(np.full(50, 1.1) * np.linspace(1, 1.001, 50), np.ones(50))
    assert e["bias"][0] == pytest.approx(0.1, abs=0.002)
    assert e["bias"][1] <= e["bias"][0] <= e["bias"][2]
    assert e["p95"][0] == pytest.approx(0.1, abs=0.002)
    rng = np.random.default_rng(0)
    err = rng.normal(0, 0.1, 400)
    e = dc.realised_error(1 + err, np.ones(400))
    assert e["p95"][0] == pytest.approx(1.96 * 0.1, rel=0.1)
    assert e["p95"][1] < 1.96 * 0.1 < e["p95"][2] and e["bias"][1] < 0 < e["bias"][2]
    s = summary({"beam": fake("beam", 30, ratio_est=1.2)})
    assert s["worlds"]["beam"]["error"]["bias"][0] == pytest.approx(0.2)
    assert "| C: bias, median Ĉ/C − 1 (bootstrap 95 % interval) | +20 % (+20 % to +20 %) |" \
        in dc.report([s], "cmd")


def test_a_design_that_promises_nothing_is_not_rendered():
    d = sca.design(1.0, 0.1, depth=5.0, distance=1.0, uncertain={}, targets={"chl": 0.001},
                   max_photos=2, auxiliary=("none",))
    spec = {**COASTAL, "worlds": ()}
    s = dc.summarise({"spec": spec, "design": d, "worlds": {}})
    assert not s["meets"] and dc.check(s) == {}
    text = dc.report([s], "cmd")
    assert "No protocol of the space meets the target" in text and "limits it: noise" in text
    assert "Not rendered" in text


@pytest.mark.slow
def test_design_check_runs_every_world_end_to_end():
    (ref,) = [s for s in dc.DESIGNS if s.get("reference_shot")]
    res = dc.run(dives=1, workers=1, specs=[COASTAL])
    s = dc.summarise(res[0])
    assert s["meets"] and set(s["worlds"]) == {"beam", "split", "beyond"}
    assert all(x["dives"] == 1 for x in s["worlds"].values())
    assert "| C: realised / designed |" in dc.report([s], "cmd")
    assert ref["worlds"] == ("reference",)
