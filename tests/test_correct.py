"""Issue 38: every pixel corrected along its own range from the measured water (measure.correct),
its range inputs, outputs, uncertainty, the CLI, and a dive's chartless frames."""

import json
import shutil

import numpy as np
import pytest

import forward
import measure
from measure.synthetic_photo import Scene, default_corners, render_mosaic, write_dng
from measure.correct import (_white_response, correct_image, correction_table,
                             seathru_coefficients, srgb_encoding_lut)
from measure.correctwater import correction_water, exposure_ratio
from measure.rangemap import read_range
from uw3p.cli import main

W, H = 360, 240


@pytest.fixture(scope="module")
def shot(tmp_path_factory, fast_shot):
    """The measured photo (tests/conftest.py's fast_shot) and its measurement.json."""
    tmp = tmp_path_factory.mktemp("correct")
    out = tmp / "m"
    measure.write_outputs(fast_shot["meas"], out, report=False)
    return {"dng": fast_shot["dng"], "meas": fast_shot["meas"], "json": out / "measurement.json",
            "tmp": tmp, "corners": fast_shot["corners"]}


def test_at_the_chart_distance_it_is_the_von_kries_correction(shot):
    """A constant range r0 gives the paper's von Kries correction (measure.correction) up to
    one common factor (the diagonal method; the matrix method adds its cross-talk)."""
    m = shot["meas"]
    tab = correction_table(m, method="diagonal")
    J = tab.apply(m.sample.rgb.T, np.full(24, tab.reference))
    vk = m.gains * (m.sample.rgb.T - m.offset)
    ratio = J / vk
    assert ratio == pytest.approx(np.full_like(ratio, ratio.mean()), rel=1e-3)


def test_the_table_is_the_model_function(shot):
    """t_c(r) interpolated from the table equals the model's white response at that range, and
    a white reflector corrected from the model's raw values comes back white in air."""
    tab = correction_table(shot["meas"])
    w = tab.water
    r = np.array([0.3, 1.7, 4.2, 9.9])
    exact = _white_response(w, r) / w.setup.white_response
    interp = np.stack([np.interp(r, tab.ranges, tab.transmission[:, c]) for c in range(3)], -1)
    assert interp == pytest.approx(exact, rel=1e-4)
    veil = np.stack([np.interp(r, tab.ranges, tab.veil[:, c]) for c in range(3)], -1)
    raw = tab.gain * exact * w.setup.white_response + veil
    assert tab.apply(raw, r) == pytest.approx(np.broadcast_to(w.setup.white_response, (4, 3)),
                                              rel=1e-4)


def test_the_veil_is_anchored_to_the_fitted_one_and_grows_with_range(shot):
    tab = correction_table(shot["meas"])
    s0 = np.array([np.interp(tab.reference, tab.ranges, tab.veil[:, c]) for c in range(3)])
    assert s0 == pytest.approx(shot["meas"].estimate.backscatter, rel=1e-4)
    assert np.all(np.diff(tab.veil, axis=0) >= 0) and np.all(tab.veil[0] == 0)
    assert np.all(tab.veil_infinity >= tab.veil[-1])


def test_the_cap_follows_max_gain_and_max_range(shot):
    m = shot["meas"]
    t16, t4 = correction_table(m, max_gain=16), correction_table(m, max_gain=4)
    assert t4.cap < t16.cap and t4.cap_reason == "max_gain"
    rel = t4.transmission[-1] / t4.transmission[0]
    assert rel.min() == pytest.approx(1 / 4, rel=1e-3)
    assert correction_table(m, max_gain=np.inf, max_range=3.0).cap == pytest.approx(3.0)
    for bad in ({"max_gain": 1.0}, {"max_range": -1.0}, {"unknown": "far"}):
        with pytest.raises(ValueError, match=list(bad)[0]):
            correction_table(m, **bad)


def test_per_pixel_correction_of_a_map_matches_the_table(shot):
    """The compiled pass (demosaic + range interpolation) agrees with the table applied to the
    demosaiced image; unknown ranges are corrected at the chart's distance."""
    m = shot["meas"]
    rmap = np.tile(np.linspace(1.0, 6.0, W, dtype=np.float32), (H, 1))
    rmap[:20] = np.nan
    out = correct_image(m.photo, m, rmap, float_output=True)
    rgb = measure.demosaic(m.photo)
    want = out.table.apply(rgb[::17, ::13], rmap[::17, ::13])
    assert out.values[::17, ::13] == pytest.approx(want, rel=1e-4, abs=1e-6)
    assert out.ranges["unknown_fraction"] == pytest.approx(20 / H)
    assert out.linear.dtype == np.uint16 and out.srgb.dtype == np.uint16


def test_the_kernel_makes_the_jpegs_codes_and_the_range_summary_in_its_one_pass(shot):
    """srgb_bits=8: the 16-bit image's codes rounded to 8 bits (measure.imagefiles.to_8bit),
    made by the kernel; the kernel's per-row counts give the map's summary (unknown, beyond
    the cap, the finite span) as the map itself does. A preview's demosaic at a step is the
    full one's pixels there."""
    from measure.imagefiles import to_8bit

    m = shot["meas"]
    rmap = np.tile(np.linspace(1.0, 6.0, W, dtype=np.float32), (H, 1))
    rmap[:7], rmap[-5:] = np.nan, np.inf
    full = correct_image(m.photo, m, rmap, linear=False)
    small = correct_image(m.photo, m, rmap, linear=False, srgb_bits=8)
    assert small.srgb.dtype == np.uint8 and np.array_equal(small.srgb, to_8bit(full.srgb))
    assert small.ranges == full.ranges
    r = full.ranges
    assert r["unknown_fraction"] == pytest.approx(7 / H) and r["capped_fraction"] == \
        pytest.approx(5 / H)
    assert (r["min_m"], r["max_m"]) == (1.0, pytest.approx(6.0))
    with pytest.raises(ValueError, match="^srgb_bits"):
        correct_image(m.photo, m, 2.0, srgb_bits=12)
    for step in (1, 3, 7):
        np.testing.assert_array_equal(measure.demosaic(m.photo, m.gains, m.offset, uint16=True,
                                                       step=step),
                                      measure.demosaic(m.photo, m.gains, m.offset,
                                                       uint16=True)[::step, ::step])


def test_range_inputs(tmp_path):
    import tifffile
    from PIL import Image

    size = (40, 30)  # (width, height)
    assert read_range(2.5, size) == 2.5 and read_range("2.5", size) == 2.5
    plane = read_range("plane:4,0,-3", size)
    assert plane[0, 0] == pytest.approx(7.0) and plane[-1, 0] == pytest.approx(1.0)
    small = np.full((15, 20), 3.0, np.float32)
    small[0, 0] = 0.0
    tifffile.imwrite(tmp_path / "r.tif", small)
    got = read_range(tmp_path / "r.tif", size)
    assert got.shape == (30, 40) and np.isnan(got[0, 0]) and got[-1, -1] == pytest.approx(3.0)
    Image.fromarray(np.full((30, 40), 2500, np.uint16)).save(tmp_path / "r.png")
    assert np.nanmax(read_range(tmp_path / "r.png", size)) == pytest.approx(2.5)
    np.save(tmp_path / "r.npy", np.full((30, 40), 1.25, np.float32))
    assert read_range(tmp_path / "r.npy", size)[5, 5] == pytest.approx(1.25)
    for bad, why in (("plane:1,2", "plane"), ("-1", "> 0"), (tmp_path / "none.tif", "no such"),
                     ("x.jpg", "range map")):
        with pytest.raises(ValueError, match=f"range: .*{why}"):
            read_range(bad, size)
    np.save(tmp_path / "z.npy", np.zeros((30, 40), np.float32))
    with pytest.raises(ValueError, match="no known range"):
        read_range(tmp_path / "z.npy", size)
    tifffile.imwrite(tmp_path / "i.tif", np.ones((30, 40), np.uint16))
    with pytest.raises(ValueError, match="floats in metres"):
        read_range(tmp_path / "i.tif", size)


def test_srgb_encoding_is_colour_sciences():
    colour = pytest.importorskip("colour")
    lut = srgb_encoding_lut()
    x = np.linspace(0, 1, lut.size)[:: 4099]
    want = np.rint(colour.cctf_encoding(x, function="sRGB") * 65535)
    assert np.abs(lut[:: 4099].astype(int) - want).max() <= 1


def test_ciede2000_is_colour_sciences():
    colour = pytest.importorskip("colour")
    from measure.correct_uncertainty import _de

    rng = np.random.default_rng(1)
    a = rng.uniform([0, -60, -60], [100, 60, 60], (20, 3))
    b = a + rng.normal(0, 5, (20, 3))
    assert _de(a, b) == pytest.approx(colour.delta_E(a, b, method="CIE 2000"), rel=1e-9)


def _uncorrected_de00(meas):
    """Median CIEDE2000 of the chart as photographed against the chart corrected (the white's
    luminance matched), both by measure.correct_uncertainty's colour conversion."""
    from forward.spectra import WHITE_PATCH
    from measure.correct_uncertainty import _de, _lab

    w = correction_water(meas)
    chart = np.asarray(meas.sample.rgb, float).T
    corrected = correction_table(w).apply(chart, np.full(24, w.distance))
    to_xyz = forward.camera_to_xyz_matrix(w.setup)
    k = (to_xyz @ corrected[WHITE_PATCH])[1] / (to_xyz @ chart[WHITE_PATCH])[1]
    return float(np.median(_de(_lab(w.setup, k * chart), _lab(w.setup, corrected))))

def test_uncertainty_in_measurement_json_grows_with_range(shot):
    data = json.loads(shot["json"].read_text())
    u = data["correction"]["uncertainty"]
    # the water's intervals have a width, so the correction moves (> 0), and by less than the
    # correction itself moves the chart: the uncorrected chart (its white at the corrected
    # white's luminance) against the corrected one
    assert 0 < u["chart_de00"]["median"] < _uncorrected_de00(shot["meas"])
    de = [g["de00"] for g in u["grey_de00"]]
    assert all(np.isfinite(de)) and de[-1] >= de[0]
    assert len(u["samples"]) == 4


def test_open_intervals_give_an_unbounded_spread(shot):
    from measure.correct_uncertainty import correction_spread

    w = correction_water(shot["meas"])
    w.chl_ci = (0.0, np.inf)
    out = correction_spread(w)
    assert out["chart_de00"] is None and "open" in out["notes"][0]


def test_seathru_coefficients(shot):
    tab = correction_table(shot["meas"])
    s = seathru_coefficients(tab)
    # red is attenuated fastest; the fitted exponentials describe the table
    assert s["beta_D"][0] > s["beta_D"][1] and min(s["beta_B"]) > 0
    assert max(s["rms_log"]["beta_D"]) < 0.2
    assert s["B_inf"] == pytest.approx(tab.veil_infinity.tolist())


def test_water_from_joint_json_and_exposure_ratio(shot):
    m = shot["meas"]
    joint = {"chl": m.estimate.chl, "cdom": m.estimate.cdom, "chl_ci": [0, 5], "cdom_ci": [0, 1],
             "path_model": "beam", "nuisance": {}, "reliable": True,
             "photos": {"a.dng": {"gain": 100.0, "backscatter": [1, 2, 3], "depth": 5.0,
                                  "distance": 1.5},
                        "b.dng": {"gain": 200.0, "backscatter": [2, 4, 6], "depth": 10.0,
                                  "distance": 2.0}}}
    w = correction_water(joint, depth=9.0, exposure_ratio=2.0, setup=m.setup)
    assert w.gain == 400.0 and w.backscatter.tolist() == [4, 8, 12] and w.depth == 9.0
    assert w.distance == 2.0
    assert exposure_ratio({"exposure_s": 0.02, "f_number": 4, "iso": 200},
                          {"exposure_s": 0.01, "f_number": 4, "iso": 200}) == pytest.approx(2)
    assert exposure_ratio({}, {"exposure_s": 1}) is None
    with pytest.raises(ValueError, match="photo"):
        correction_water(joint, photo="c.dng")
    with pytest.raises(ValueError, match="water"):
        correction_water({"x": 1})


def test_cli_correct_writes_whole_outputs_with_an_icc_profile(shot, tmp_path, capsys):
    import tifffile
    from PIL import Image

    out = tmp_path / "c"
    code = main(["correct", str(shot["dng"]), "--water", str(shot["json"]), "--range",
                 "plane:3,0,-2", "--out", str(out), "--uncertainty"])
    assert code in (0, 1)
    names = sorted(p.name for p in out.iterdir())
    # by default one sRGB image, the JPEG, with its profile; complete.json records the sizes
    assert names == ["complete.json", "corrected.jpg", "correction.json"]
    with Image.open(out / "corrected.jpg") as im:
        assert im.size == (W, H) and im.info.get("icc_profile")
        jpeg = np.asarray(im)
    done = json.loads((out / "complete.json").read_text())
    assert done["sizes"] == {n: (out / n).stat().st_size for n in names if n != "complete.json"}
    rec = json.loads((out / "correction.json").read_text())
    tiffs = tmp_path / "t"
    assert main(["correct", str(shot["dng"]), "--water", str(shot["json"]), "--range",
                 "plane:3,0,-2", "--out", str(tiffs), "--output-format", "tiff16",
                 "--linear"]) in (0, 1)
    assert sorted(p.name for p in tiffs.iterdir()) == [
        "complete.json", "corrected.tiff", "corrected_srgb.tif", "correction.json"]
    with tifffile.TiffFile(tiffs / "corrected_srgb.tif") as tf:
        page = tf.pages[0]
        assert page.dtype == np.uint16 and page.shape == (H, W, 3)
        assert page.compression != 1 and 34675 in page.tags
        from measure.imagefiles import to_8bit

        # the same image (the JPEG's loss is noise-like: its channel means within 0.5 code)
        np.testing.assert_allclose(to_8bit(page.asarray()).mean(axis=(0, 1)),
                                   jpeg.mean(axis=(0, 1)), atol=0.5)
    assert main(["correct", str(shot["dng"]), "--water", str(shot["json"]), "--range", "2",
                 "--out", str(tmp_path / "n"), "--tiff", "none", "--linear"]) == 2
    assert "error: --tiff:" in capsys.readouterr().err and not (tmp_path / "n").exists()
    assert set(rec["seathru"]) >= {"beta_D", "beta_B", "B_inf", "white_balance"}
    assert rec["uncertainty"]["grey_de00"]
    assert rec["range"]["kind"] == "map"


def test_cli_bad_range_names_the_option(shot, tmp_path, capsys):
    code = main(["correct", str(shot["dng"]), "--water", str(shot["json"]), "--range",
                 "plane:1", "--out", str(tmp_path / "c")])
    assert code == 2
    assert "uw3p correct: error: --range:" in capsys.readouterr().err
    assert not (tmp_path / "c").exists()


def test_a_failed_write_leaves_the_old_folder_whole(shot, tmp_path, monkeypatch):
    from measure import imagefiles

    out = tmp_path / "c"
    args = ["correct", str(shot["dng"]), "--water", str(shot["json"]), "--range", "2",
            "--out", str(out)]
    main(args)
    before = {p.name: p.read_bytes() for p in out.iterdir()}

    def fail(*a, **k):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(imagefiles, "write_jpeg", fail)
    assert main(args) == 2
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before


@pytest.mark.slow
def test_a_dive_with_chartless_frames_gives_every_frame_a_corrected_srgb_image(tmp_path):
    """One chart photo, chartless frames with ranges in the metadata (a range_m, a range map):
    every frame gets a corrected sRGB image, the exit status is 0 (the measured photo is
    reliable), ifdo.json has the photometric fields, a rerun redoes nothing."""
    import dataclasses

    import tifffile

    from measure import dive

    setup = forward.chart_setup(channel_gains=(0.55, 1.0, 0.7))
    corners = default_corners(W, H)
    air = write_dng(render_mosaic(Scene(chl=0, cdom=0, depth=0, distance=0, gain=9000, width=W,
                                        height=H, seed=1), corners, setup=setup),
                    tmp_path / "air.dng")
    prof = measure.calibrate(measure.sample_patches(measure.read_image(air), corners), image=air)
    (tmp_path / "profile.json").write_text(json.dumps(dataclasses.asdict(prof)))
    d = tmp_path / "dive"
    d.mkdir()
    write_dng(render_mosaic(Scene(chl=2, cdom=0.1, depth=5, distance=1.5, gain=30000, width=W,
                                  height=H, seed=2), corners, setup=setup), d / "chart.dng")
    rng = np.random.default_rng(0)
    for name in ("reef1.tif", "reef2.tif"):
        tifffile.imwrite(d / name, rng.integers(2000, 4000, (H, W, 3), dtype=np.uint16),
                         photometric="rgb")
    np.save(tmp_path / "reef2_range.npy", np.linspace(1, 6, 60 * 90, dtype=np.float32)
            .reshape(60, 90))
    text = " ".join(f"{x:.2f},{y:.2f}" for x, y in corners)
    (d / "dive.csv").write_text(
        "image,depth_m,distance_m,corners,range_m,range_map\n"
        f'chart.dng,5,1.5,"{text}",,\nreef1.tif,6,1.5,,3.0,\nreef2.tif,5,1.5,,,../reef2_range.npy\n')
    kw = dict(out=tmp_path / "out", metadata=d / "dive.csv", profile=str(tmp_path / "profile.json"),
              scheduler="synchronous", joint=True, report=False, figure=False,
              light_field="none", method="diagonal")
    res = dive.measure_dive(d, **kw)
    by = {r["image"].split("/")[-1]: r for r in res.rows}
    assert by["chart.dng"]["status"] == "measured"
    for name in ("reef1.tif", "reef2.tif"):
        assert by[name]["status"] == "corrected with the dive's water", by[name]["error"]
        folder = tmp_path / "out" / name.replace(".", "_")
        assert sorted(p.name for p in folder.iterdir()) == [
            "complete.json", "corrected.jpg", "correction.json"]  # the default: the JPEG
        assert json.loads((folder / "correction.json").read_text())["method"] == "diagonal"
    assert (tmp_path / "out" / "chart_dng" / "corrected.jpg").exists()
    assert json.loads((tmp_path / "out" / "chart_dng" / "complete.json").read_text())[
        "correction_method"] == "diagonal"  # --method through the dive path, both kinds
    assert res.code == (0 if by["chart.dng"]["reliable"] in (True, "True") else 1)
    rec = json.loads((tmp_path / "out" / "reef2_tif" / "correction.json").read_text())
    assert rec["range"]["kind"] == "map" and rec["range"]["max_m"] == pytest.approx(6.0)
    ifdo = json.loads((tmp_path / "out" / "ifdo.json").read_text())
    header = ifdo["image-set-header"]["image-photometric-calibration"]
    assert "photometric-water-properties-description" in header
    assert set(ifdo["image-set-items"]) == {"chart.dng", "reef1.tif", "reef2.tif"}
    mtimes = {p: p.stat().st_mtime_ns for p in (tmp_path / "out").rglob("*")
              if p.is_file() and p.parent != tmp_path / "out"}
    again = dive.measure_dive(d, **kw)
    assert {r["image"].split("/")[-1]: r["status"] for r in again.rows} == {
        "chart.dng": "done earlier", "reef1.tif": "corrected with the dive's water",
        "reef2.tif": "corrected with the dive's water"}
    assert {p: p.stat().st_mtime_ns for p in mtimes} == mtimes
    shutil.rmtree(tmp_path / "out")
