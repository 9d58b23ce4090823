"""Photographs in (issue 10): synthetic DNG files rendered with the forward model (Bayer mosaic,
black level per CFA position, Poisson and read noise, 14-bit clipping, a camera whose channel
balance differs from its published curves) are read back with rawpy, calibrated, measured and
corrected; wrong input is refused or flagged."""

import csv
import json

import numpy as np
import pytest

import forward
import measure
from measure.synthetic_photo import Scene, render_mosaic, write_dng
from forward.spectra import WHITE_PATCH
from uw3p.cli import main

#: the whole module is in the slow tier (make test-fast skips it)
pytestmark = pytest.mark.slow

#: the synthetic camera's true channel balance (the NPL curves are peak-normalised: 1, 1, 1)
TRUE_BALANCE = (0.55, 1.0, 0.7)
W, H = 360, 240
UW = dict(chl=2.0, cdom=0.1, depth=5.0, distance=1.5)


#: The photos and the profile are tests/conftest.py's :func:`chart_photos` (shared with other
#: modules), under this module's names.
@pytest.fixture(scope="module")
def true_setup(chart_photos):
    return chart_photos["setup"]


@pytest.fixture(scope="module")
def corners(chart_photos):
    return chart_photos["corners"]


def _corner_text(c):
    return " ".join(f"{x:.2f},{y:.2f}" for x, y in c)


def _dng(tmp, name, scene, corners, setup):
    return write_dng(render_mosaic(scene, corners, setup=setup), tmp / name, black=scene.black,
                     white=scene.white)


@pytest.fixture(scope="module")
def files(chart_photos):
    return chart_photos["dir"], chart_photos


@pytest.fixture(scope="module")
def profile(chart_photos):
    return chart_photos["profile"]


def _inside(ci, v):
    return ci[0] <= v <= ci[1]


def test_rawpy_reads_the_mosaic_black_levels_clip_and_exif(files):
    photo = measure.read_image(files[1]["uw"])
    assert photo.kind == "raw" and photo.size == (W, H)
    assert photo.channel[0, 0] == 0 and photo.channel[0, 1] == 1 and photo.channel[1, 0] == 1 \
        and photo.channel[1, 1] == 2
    # black 512/510/514/516 at the RGGB positions: green's two levels average to 512
    assert photo.black == pytest.approx([512, 512, 516])
    assert photo.white == pytest.approx([2 ** 14 - 1 - 512, 2 ** 14 - 1 - 512, 2 ** 14 - 1 - 516])
    assert photo.exposure == pytest.approx({"exposure_s": 1 / 125, "f_number": 5.6, "iso": 400})


def test_raw_mosaic_unpacked_in_one_pass_as_numpy_would():
    """The compiled one-pass unpack gives numpy's own float32 mosaic - black[colour], the
    channel lut[colour] and the clip test, value for value (black levels per colour index, a
    white level between the values)."""
    from measure.pixels import unpack as _unpack

    rng = np.random.default_rng(2)
    mosaic = rng.integers(0, 2 ** 14, (37, 52)).astype(np.uint16)
    colors = rng.integers(0, 4, mosaic.shape).astype(np.uint8)
    lut = np.array([0, 1, 2, 1], np.int8)
    blacks = np.array([512.25, 510.0, 514.5, 516.0])
    white = 12000.0
    data = np.empty(mosaic.shape, np.float32)
    channel = np.empty(mosaic.shape, np.int8)
    clipped = np.empty(mosaic.shape, bool)
    _unpack(mosaic, colors, lut, blacks.astype(np.float32), white, data, channel, clipped)
    want = mosaic.astype(np.float32)
    want -= blacks.astype(np.float32)[colors]
    np.testing.assert_array_equal(data, want)
    np.testing.assert_array_equal(channel, lut[colors])
    np.testing.assert_array_equal(clipped, mosaic >= white)
    assert clipped.any() and not clipped.all()


def test_calibration_round_trip(profile):
    assert profile.reliable, profile.flags
    g = np.array(profile.gains)
    assert g == pytest.approx(np.array(TRUE_BALANCE) / max(TRUE_BALANCE), rel=3e-3)
    # within 4 standard errors of the truth
    assert np.all(np.abs(g - np.array(TRUE_BALANCE)) <= 4 * np.array(profile.gains_se) + 1e-12)


def test_underwater_round_trip_is_right_within_its_intervals(uw_measured):
    m = uw_measured
    e = m.estimate
    # 'path-model-span' is information: the intervals span the path models the data allow
    assert m.reliable and set(m.flags) <= {"path-model-span"} and m.orientation == "as given"
    assert _inside(e.chl_ci, UW["chl"]) and _inside(e.cdom_ci, UW["cdom"])
    assert _inside(e.gain_ci, 30000.0)
    assert 0.5 < e.chi2_dof < 2.0
    # the attenuation band holds the true k
    k = forward.attenuation(e.wavelengths, UW["chl"], UW["cdom"], UW["depth"], UW["distance"])
    assert np.all(m.attenuation_band[0] <= k * (1 + 1e-9)) and np.all(k <= m.attenuation_band[1] * (1 + 1e-9))


def test_correction_makes_the_white_patch_the_white_of_air(uw_measured, true_setup):
    m = uw_measured
    white = m.gains * (m.sample.rgb[:, WHITE_PATCH] - m.offset)
    air = true_setup.sensitivities.T @ (true_setup.illuminant * true_setup.reflectances[:, WHITE_PATCH])
    assert white / white[1] == pytest.approx(air / air[1], rel=0.02)
    img = measure.corrected_image(m)
    assert img.dtype == np.uint16 and img.shape == (H, W, 3)


@pytest.mark.parametrize("order,name", [((2, 3, 0, 1), "rotated 180°"),
                                        ((1, 0, 3, 2), "mirrored left-right"),
                                        ((3, 2, 1, 0), "mirrored top-bottom")])
def test_wrong_corner_order_is_found_and_corrected(files, corners, profile, uw_measured, order,
                                                   name):
    ref = uw_measured
    m = measure.measure(files[1]["uw"], corners=corners[list(order)], depth=UW["depth"],
                        distance=UW["distance"], profile=profile)
    assert m.orientation == name and "orientation-corrected" in m.flags
    assert m.estimate.chl == pytest.approx(ref.estimate.chl, rel=1e-9)
    assert m.notes and "wrong order" in m.notes[0]


def test_chart_turned_90_degrees_is_refused(files, corners, profile):
    with pytest.raises(ValueError, match="corners: the first side"):
        measure.measure(files[1]["uw"], corners=corners[[1, 2, 3, 0]], depth=5.0, distance=1.5,
                        profile=profile)


def test_clipped_patches_are_left_out_and_flagged(tmp_path, corners, true_setup, profile):
    scene = Scene(**UW, gain=60000, width=W, height=H, seed=4)
    path = _dng(tmp_path, "bright.dng", scene, corners, true_setup)
    m = measure.measure(path, corners=corners, depth=UW["depth"], distance=UW["distance"],
                        profile=profile)
    assert m.sample.clipped[1, WHITE_PATCH] > 0.5  # the white patch's green clips
    assert "clipped-patches" in m.flags
    # never a confident wrong answer: reliable only with the truth inside
    assert not m.reliable or (_inside(m.estimate.chl_ci, 2.0) and _inside(m.estimate.cdom_ci, 0.1))


def test_a_dark_photo_is_not_a_confident_answer(tmp_path, corners, true_setup, profile):
    scene = Scene(**UW, gain=40, width=W, height=H, seed=5)
    path = _dng(tmp_path, "dark.dng", scene, corners, true_setup)
    m = measure.measure(path, corners=corners, depth=UW["depth"], distance=UW["distance"],
                        profile=profile)
    e = m.estimate
    # 750x less light than the other photos: whatever the verdict (here unreliable: the grey row
    # cannot be verified in the dark), the intervals must be honest -- they hold the truth --
    # and say how little the photo tells: C's 95 % interval is wider than C itself (about
    # 0-5 mg m^-3 here, against ~0.4 wide for the well-exposed photo)
    assert _inside(e.chl_ci, UW["chl"]) and _inside(e.cdom_ci, UW["cdom"])
    assert e.chl_ci[1] - e.chl_ci[0] > UW["chl"]


@pytest.mark.parametrize("vignetting,gradient", [(0.3, 0.0), (0.0, 0.1), (0.3, 0.1)])
def test_uneven_light_is_measured_right_or_flagged(tmp_path, corners, true_setup, profile,
                                                   vignetting, gradient):
    scene = Scene(**UW, gain=30000, width=W, height=H, seed=6, vignetting=vignetting,
                  gradient=gradient)
    path = _dng(tmp_path, "uneven.dng", scene, corners, true_setup)
    m = measure.measure(path, corners=corners, depth=UW["depth"], distance=UW["distance"],
                        profile=profile)
    e = m.estimate
    assert not m.reliable or (_inside(e.chl_ci, 2.0) and _inside(e.cdom_ci, 0.1))
    if vignetting == 0.0:  # a gradient over the chart is modelled (the nested test picks it)
        assert m.light_field["model"] != "none" and "light-field" in m.flags
        assert m.reliable and _inside(e.chl_ci, 2.0) and _inside(e.cdom_ci, 0.1)
    else:  # vignetting is not modelled: docs/howto/photo.md promises `misfit`, not reliable
        assert "misfit" in m.flags and not m.reliable, m.flags


def test_even_light_gets_no_light_field(uw_measured):
    m = uw_measured
    assert m.light_field["model"] == "none" and m.light_field["tests"]["plane"]["p_value"] > 0.01


def test_photos_at_other_depths_and_distances_build_no_quadrature_rule(tmp_path, monkeypatch,
                                                                     files, corners, profile,
                                                                     true_setup):
    """Issue 46 item 5: with one profile, a photo at another depth and distance (its light
    field another gradient) builds no spectral quadrature rule (one built, one file in the disk
    cache); its estimates are those of a first measurement with an empty cache."""
    from sca import quadrature as Q

    deeper = _dng(tmp_path, "deeper.dng", Scene(chl=2.0, cdom=0.1, depth=9.0, distance=2.5,
                                                gain=30000, width=W, height=H, seed=7,
                                                gradient=0.1), corners, true_setup)
    photos = [(files[1]["uw"], UW["depth"], UW["distance"]), (deeper, 9.0, 2.5)]
    builds = []
    real = Q._build
    monkeypatch.setattr(Q, "_build", lambda *a: builds.append(a) or real(*a))

    def measured(path, depth, distance, cache):
        monkeypatch.setenv(Q.CACHE_ENV, str(tmp_path / cache))
        return measure.measure(path, corners=corners, depth=depth, distance=distance,
                               profile=profile).estimate

    Q._rule.cache_clear()
    Q._scaled.cache_clear()
    reused = [measured(*p, "dive") for p in photos]
    assert len(builds) == 1
    assert len(list((tmp_path / "dive" / "quadrature").glob("*.npz"))) == 1  # one rule on disk
    Q._rule.cache_clear()
    Q._scaled.cache_clear()
    fresh = measured(*photos[1], "fresh")
    assert len(builds) == 2
    for name in ("chl", "cdom", "chl_ci", "cdom_ci", "gain"):
        np.testing.assert_allclose(getattr(reused[1], name), getattr(fresh, name), rtol=1e-9)


def test_linear_tiff_input(tmp_path, files, corners, profile):
    import tifffile

    photo = measure.read_image(files[1]["uw"])
    rgb = np.clip(np.rint(measure.demosaic(photo)), 0, 65535).astype(np.uint16)
    path = tmp_path / "uw.tiff"
    tifffile.imwrite(path, rgb, photometric="rgb")
    m = measure.measure(path, corners=corners, depth=UW["depth"], distance=UW["distance"],
                        profile=profile)
    assert m.photo.kind == "rgb"
    # demosaiced pixels are correlated, so the standard errors from the pixel spread are
    # optimistic: the fit's chi^2 says so, and the photo is not called reliable (never a
    # confident answer on standard errors that are too small)
    assert not m.reliable and "misfit" in m.flags, m.flags
    # with the exact model (photon noise only) the point estimate is close too
    x = measure.measure(path, corners=corners, depth=UW["depth"], distance=UW["distance"],
                        profile=profile, uncertain={}).estimate
    assert abs(x.chl - 2.0) < 0.15 and abs(x.cdom - 0.1) < 0.01


def test_bad_input_is_refused_with_the_argument_named(tmp_path, files, corners):
    junk = tmp_path / "notes.dng"
    junk.write_text("not an image")
    with pytest.raises(ValueError, match="image: .*notes.dng"):
        measure.read_image(junk)
    with pytest.raises(ValueError, match="image: .*no such file"):
        measure.read_image(tmp_path / "missing.dng")
    photo = measure.read_image(files[1]["uw"])
    with pytest.raises(ValueError, match="corners: corner"):
        measure.sample_patches(photo, "1,1 900,1 900,500 1,500")
    with pytest.raises(ValueError, match="corners: expected"):
        measure.parse_corners("1,2 3,4")
    with pytest.raises(ValueError, match="profile"):
        measure.load_profile(junk)


def test_cli_calibrate_then_measure(files, corners, tmp_path, capsys):
    tmp, f = files
    ct = _corner_text(corners)
    prof = tmp_path / "profile.json"
    assert main(["calibrate", f["air"], "--corners", ct, "--out", str(prof)]) == 0
    out = tmp_path / "m"
    code = main(["measure", f["uw"], "--corners", ct, "--profile", str(prof), "--depth", "5",
                 "--distance", "1.5", "--out", str(out)])
    assert code == 0
    data = json.loads((out / "measurement.json").read_text())
    printed = capsys.readouterr().out
    # the flag path-model-span explained under the reliable line and in the notes (issue 48)
    assert "path-model-span" in data["estimate"]["flags"]
    assert "\n  path-model-span: the path models " in printed
    assert any(n.startswith("path-model-span: the path models ") for n in data["notes"])
    for key in ("chl", "cdom", "chl_ci", "cdom_ci", "gain", "transmittance", "wavelengths",
                "backscatter", "reliable", "flags", "fit_rms", "chi2_dof", "beam_attenuation",
                "beam_attenuation_ci", "quantities", "quantity_intervals", "verdicts",
                "statements"):
        assert key in data["estimate"], key
    assert np.shape(data["patches"]["rgb"]) == (3, 24) and np.shape(data["patches"]["sigma"]) == (3, 24)
    for key in ("n_pixels", "clipped"):
        assert key in data["patches"]
    assert data["orientation"] == "as given" and len(data["correction"]["gains"]) == 3
    assert {"path", "size", "exposure"} <= set(data["image"]) and data["version"]
    for name in ("corrected.jpg", "corrected.png", "report.png"):  # corrected.tiff: --linear
        assert (out / name).stat().st_size > 0
    assert not (out / "corrected.tiff").exists()
    # without the profile: measured, the camera flagged, not reliable (exit 1; here, not in a
    # test of its own, which measured the same photo the same way again); a non-image: exit 2
    assert main(["measure", f["uw"], "--corners", ct, "--depth", "5", "--distance", "1.5",
                 "--out", str(tmp_path / "n")]) == 1
    flagged = json.loads((tmp_path / "n" / "measurement.json").read_text())["estimate"]
    assert "uncalibrated-camera" in flagged["flags"] and not flagged["reliable"]
    junk = tmp_path / "x.dng"
    junk.write_text("no")
    assert main(["measure", str(junk), "--corners", ct, "--depth", "5", "--distance", "1.5",
                 "--out", str(tmp_path / "j")]) == 2
    assert main(["measure", f["uw"], "--corners", "1,1 2,2", "--depth", "5", "--distance",
                 "1.5", "--out", str(tmp_path / "j")]) == 2


def test_cli_measures_a_folder(files, corners, tmp_path):
    tmp, f = files
    dive = tmp_path / "dive"
    dive.mkdir()
    for name in ("a.dng", "b.dng"):
        (dive / name).write_bytes(open(f["uw"], "rb").read())
    (dive / "c.dng").write_text("broken")
    (dive / "notes.txt").write_text("ignored")
    prof = tmp_path / "p.json"
    ct = _corner_text(corners)
    assert main(["calibrate", f["air"], "--corners", ct, "--out", str(prof)]) == 0
    code = main(["measure", str(dive), "--corners", ct, "--profile", str(prof), "--depth", "5",
                 "--distance", "1.5", "--scheduler", "synchronous", "--out",
                 str(tmp_path / "out")])
    rows = list(csv.DictReader(open(tmp_path / "out" / "summary.csv")))
    # every file is listed (issue 18): notes.txt with its reason (Dask: tests/test_dive.py)
    assert [r["image"].split("/")[-1] for r in rows] == ["a.dng", "b.dng", "c.dng", "notes.txt"]
    assert rows[3]["status"] == "not an image"
    assert rows[0]["reliable"] == "True" and rows[2]["error"].startswith("image:")
    assert code == 2 and (tmp_path / "out" / "a_dng" / "measurement.json").exists()


def test_calibrate_says_why_a_large_chi2_is_reliable():
    """`uw3p calibrate` prints the per-patch systematic it measured and the chi^2 with it in
    the noise (1 pooled, by its definition) beside the photon-noise chi^2 (issue 48)."""
    from measure.camera import PATCH_SD_MAX
    from measure.chart import PatchSample
    from uw3p.cmd_calibrate import profile_text

    setup = forward.chart_setup(channel_gains=TRUE_BALANCE)
    model = setup.sensitivities.T @ (setup.illuminant[:, None] * setup.reflectances)
    rng = np.random.default_rng(4)
    rgb = 20000 * model / model.max() * (1 + 0.012 * rng.standard_normal(model.shape))
    sample = PatchSample(rgb=rgb, sigma=np.sqrt(rgb) / 30, n_pixels=np.full((3, 24), 900),
                         clipped=np.zeros((3, 24)), boxes=np.zeros((24, 4, 2)))
    prof = measure.calibrate(sample)
    assert prof.reliable and 0.006 < prof.patch_sd < PATCH_SD_MAX
    assert min(prof.chi2_dof) > 10  # photon noise alone: far above 1
    pooled = np.sum(np.multiply(prof.chi2_dof_patch, 23)) / 69
    assert pooled == pytest.approx(1.0, rel=1e-3)
    text = profile_text(prof)
    assert f"per-patch systematic: {100 * prof.patch_sd:.2g} %" in text
    assert ", ".join(f"{v:.3g}" for v in prof.chi2_dof_patch) + " with that term" in text
    assert ", ".join(f"{v:.3g}" for v in prof.chi2_dof) + " with photon noise alone" in text
    assert text.splitlines()[-1].startswith("reliable: True (the per-patch systematic is within")


def test_path_model_span_is_explained_where_it_appears(uw_measured):
    """The informational flag path-model-span comes with its sentence in the notes, naming the
    supported path models (decision 0078-path-model-span-explained)."""
    from sca.assess import BLOCKING
    from sca.pathmodels import SPAN_FLAG, span_note

    m = uw_measured
    assert SPAN_FLAG in m.flags and SPAN_FLAG not in BLOCKING and m.reliable
    note = span_note(m.flags, m.estimate.path_models)
    assert note in m.notes and " and ".join(m.estimate.path_models) in note
    assert span_note(("misfit",), ("beam",)) == ""
    # a joint estimate's candidates with their objectives: the supported ones only
    joint = span_note([SPAN_FLAG], {"beam": 10.0, "absorption": 12.0, "split": 30.0})
    assert "beam and absorption fit" in joint and "split" not in joint
