"""One water from many photos (issue 18, part 3): sca.joint.estimate_joint, measure.fit_joint
and the dive's Cramér-Rao bound (sca.precision(..., dive=True))."""

import numpy as np
import pytest

import forward
import sca
from forward.imaging import resolve_setup
from measure.joint import fit_joint
from sca.joint import estimate_joint

SETUP = resolve_setup(None, forward.DEFAULT_CAMERA, None, None, None)
DEPTHS = np.array([4.0, 6.0, 9.0, 12.0])
DISTANCES = np.array([1.0, 1.5, 2.0, 2.5])
GAINS = np.array([3.0, 1.0, 7.0, 2.0])  # each photo's own exposure


def _dive(chl, cdom, seed=0, depths=DEPTHS, distances=DISTANCES, gains=GAINS):
    M, sig = [], []
    for i, (d, r) in enumerate(zip(depths, distances)):
        c = chl[i] if np.ndim(chl) else chl
        s = forward.simulate_chart(c, cdom, d, r, seed=seed + i, noise=True)
        M.append(s.rgb * gains[i])
        sig.append(s.rgb_sigma * gains[i])
    return np.array(M), np.array(sig)


def test_joint_holds_the_truth_and_is_tighter_than_the_median_photo():
    M, sig = _dive(1.0, 0.1, seed=3)
    j = estimate_joint(M, depth=DEPTHS, distance=DISTANCES, sigma=sig, setup=SETUP,
                       path_models=("beam",))
    assert j.reliable, j.flags
    assert j.chl_ci[0] <= 1.0 <= j.chl_ci[1]
    assert j.cdom_ci[0] <= 0.1 <= j.cdom_ci[1]
    widths = []
    for i in range(len(DEPTHS)):
        e = sca.estimate(M[i], depth=DEPTHS[i], distance=DISTANCES[i], sigma=sig[i],
                         gain="free", path_models=("beam",))
        widths.append((e.chl_ci[1] - e.chl_ci[0], e.cdom_ci[1] - e.cdom_ci[0]))
    med = np.median(np.array(widths), axis=0)
    assert j.chl_ci[1] - j.chl_ci[0] < med[0]
    assert j.cdom_ci[1] - j.cdom_ci[0] < med[1]
    # every photo keeps its own exposure
    gains = np.array([p["gain"] for p in j.photos.values()])
    assert np.all(np.abs(gains / GAINS - 1) < 0.2)


def test_heterogeneity_names_the_photo_from_another_water():
    M, sig = _dive([1.0, 1.0, 8.0, 1.0], 0.1, seed=11)
    j = estimate_joint(M, depth=DEPTHS, distance=DISTANCES, sigma=sig, setup=SETUP,
                       uncertain={}, names=["a", "b", "c", "d"])
    assert not j.heterogeneity["one_water"]
    assert "heterogeneous" in j.flags and not j.reliable
    assert j.heterogeneity["disagree"] == ["c"]


def test_one_water_passes_the_heterogeneity_test():
    M, sig = _dive(1.0, 0.1, seed=21)
    j = estimate_joint(M, depth=DEPTHS, distance=DISTANCES, sigma=sig, setup=SETUP,
                       uncertain={})
    assert j.heterogeneity["one_water"], j.heterogeneity
    assert j.chl_ci[0] <= 1.0 <= j.chl_ci[1]


@pytest.mark.parametrize("uncertain", [{}, None])
def test_dive_bound_of_one_photo_is_the_single_photo_bound(uncertain):
    p1 = sca.precision(1.0, 0.1, depth=6.0, distance=1.5, gain="free", uncertain=uncertain)
    pd = sca.precision(1.0, 0.1, depth=[6.0], distance=[1.5], gain="free",
                       uncertain=uncertain, dive=True)
    assert pd.chl_sd == pytest.approx(p1.chl_sd, rel=1e-6)
    assert pd.cdom_sd == pytest.approx(p1.cdom_sd, rel=1e-6)


def test_dive_bound_shrinks_with_photos_and_depths():
    one = sca.precision(1.0, 0.1, depth=[6.0], distance=[1.5], gain="free", dive=True)
    same = sca.precision(1.0, 0.1, depth=[6.0] * 4, distance=[1.5] * 4, gain="free", dive=True)
    spread = sca.precision(1.0, 0.1, depth=DEPTHS, distance=DISTANCES, gain="free", dive=True)
    assert same.chl_sd < one.chl_sd
    assert spread.chl_sd < one.chl_sd
    # the budget's shared terms (chart, camera, water) do not average down: four photos at one
    # place are worth less than four independent photos would be (sd / 2)
    assert same.chl_sd > one.chl_sd / 2


def test_bad_input_names_the_argument():
    M, sig = _dive(1.0, 0.1)
    with pytest.raises(ValueError, match="sigma"):
        estimate_joint(M, depth=DEPTHS, distance=DISTANCES, sigma=sig[:, :, :5], setup=SETUP)
    with pytest.raises(ValueError, match="names"):
        estimate_joint(M, depth=DEPTHS, distance=DISTANCES, sigma=sig, setup=SETUP,
                       names=["a"])
    with pytest.raises(ValueError, match="depth"):
        estimate_joint(M, depth=[-1, 2, 3, 4], distance=DISTANCES, sigma=sig, setup=SETUP)
    with pytest.raises(ValueError, match="dive"):
        sca.precision([1.0, 2.0], 0.1, depth=[4, 6], distance=[1, 1], gain="free", dive=True)
    with pytest.raises(ValueError, match="records"):
        fit_joint([], setup=SETUP)


def _record(M, sig, depth, distance, name, flags=()):
    e = sca.estimate(M, depth=depth, distance=distance, sigma=sig, gain="free", uncertain={})
    return {"patches": {"rgb": M.tolist(), "sigma": sig.tolist(),
                        "clipped": np.zeros(M.shape).tolist()},
            "inputs": {"depth_m": depth, "distance_m": distance, "depth_sd": None,
                       "distance_sd": None, "uncertain": {}},
            "estimate": {"chl": e.chl, "cdom": e.cdom, "gain": e.gain,
                         "backscatter": e.backscatter.tolist(), "flags": list(flags)},
            "light_field": {"model": "none"}, "image": {"path": f"/dive/{name}"}}


def test_fit_joint_from_records_leaves_out_untrusted_photos():
    M, sig = _dive(1.0, 0.1, seed=5)
    recs = [_record(M[i], sig[i], DEPTHS[i], DISTANCES[i], f"IMG_{i}.dng") for i in range(3)]
    recs.append(_record(M[3], sig[3], DEPTHS[3], DISTANCES[3], "IMG_3.dng", flags=("misfit",)))
    j = fit_joint(recs, setup=SETUP)
    assert list(j.photos) == ["IMG_0.dng", "IMG_1.dng", "IMG_2.dng"]
    assert "IMG_3.dng" in j.excluded and "misfit" in j.excluded["IMG_3.dng"]
    assert j.chl_ci[0] <= 1.0 <= j.chl_ci[1]
    d = j.to_dict()
    for key in ("chl", "chl_ci", "cdom", "cdom_ci", "reliable", "flags", "heterogeneity"):
        assert key in d


def test_fit_joint_refuses_mixed_budgets_and_keeps_same_named_photos_apart():
    M, sig = _dive(1.0, 0.1, seed=5)
    recs = [_record(M[i], sig[i], DEPTHS[i], DISTANCES[i], "IMG_0.dng") for i in range(3)]
    for i, r in enumerate(recs):
        r["image"]["path"] = f"/dive{i}/IMG_0.dng"
    j = fit_joint(recs, setup=SETUP)
    assert len(j.photos) == 3
    # a depth sd on one photo only (a metadata row's depth_sd_m): each photo's own is used
    recs[1]["inputs"]["uncertain"] = {"depth": 0.5}
    recs[1]["inputs"]["depth_sd"] = 0.5
    assert len(fit_joint(recs, setup=SETUP).photos) == 3
    # a shared term that differs cannot be one water's: refused, naming the term
    recs[2]["inputs"]["uncertain"] = {"patch": 0.01}
    with pytest.raises(ValueError, match="records: .*shared term.*patch"):
        fit_joint(recs, setup=SETUP)
