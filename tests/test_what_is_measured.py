"""Issue 37 in the user's outputs: the attenuation coefficient of the light's path as a
measurement (m^-1, with its own interval) in every output, what is measured and what is not in
words, and the measurements a user makes besides the photos (a water sample's a_CDOM, a Secchi
depth, a radiometer's K_d, the chart's own spectra) as inputs of the command line, the Python
functions and the dive's metadata CSV.

The photographs are generated (:mod:`measure.synthetic_photo`), as in tests/test_measure.py
and tests/test_dive.py."""

import csv
import dataclasses
import io
import json
import math
from pathlib import Path

import numpy as np
import pytest

import forward
import measure
import sca
from measure.synthetic_photo import Scene, render_mosaic, write_dng
import measure.joint  # noqa: F401  (an import error fails, never skips)
from measure import dive
from measure.auxiliary import combine_readings, dive_auxiliary, merge_auxiliary, parse_kd
from measure.camera import read_chart_reflectance
from measure.statements import one_line, statements
from uw3p.cli import main

W, H = 360, 240
#: the water of the photos: a single photo leaves C only bounded above (with the default budget)
UW = dict(chl=2.0, cdom=0.1, depth=5.0, distance=1.5)


def run(argv):
    out, err = io.StringIO(), io.StringIO()
    code = main([str(a) for a in argv], out, err)
    return code, out.getvalue(), err.getvalue()


@pytest.fixture(scope="module")
def chart_csv(tmp_path_factory):
    """A simulated chart (C = 1.5, clear water at 3 m + 1 m) with its noise columns."""
    tmp = tmp_path_factory.mktemp("chart")
    f = tmp / "m.csv"
    assert run(["simulate", "--chl", 1.5, "--cdom", 0.1, "--depth", 3, "--distance", 1,
                "--seed", 0, "--out", f])[0] == 0
    return f


def _write_chart(path, refl, wl):
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["wavelength_nm"] + [f"patch_{j + 1}" for j in range(refl.shape[1])])
        w.writerows([[f"{x:g}"] + [repr(float(v)) for v in row] for x, row in zip(wl, refl)])
    return path


# --------------------------------------------------------------------------- inputs
def test_auxiliary_options_are_parsed_and_bad_ones_named(chart_csv):
    code, out, err = run(["estimate", chart_csv, "--depth", 3, "--distance", 1, "--secchi",
                          "8:x"])
    assert code == 2 and "--secchi: the sd is not a number" in err and out == ""
    for bad, word in ((["--cdom-sample", "0.1"], "--cdom-sample: expected VALUE:SD"),
                      (["--cdom-sample=-0.1:0.01"], "--cdom-sample: the value must be"),
                      (["--kd", "800=0.1:0.01"], "--kd: the band 800 nm lies outside"),
                      (["--kd", "490:0.1"], "--kd: expected NM=VALUE:SD"),
                      (["--kd", "490=0.1:0.01", "--kd", "490=0.2:0.01"], "--kd: the band 490 nm "
                                                                         "is given twice")):
        code, out, err = run(["estimate", chart_csv, "--depth", 3, "--distance", 1, *bad])
        assert code == 2 and word in err, (bad, err)
    assert parse_kd("--kd", "490.5=0.12:0.01") == (490.5, (0.12, 0.01))



def test_secchi_and_kd_readings_on_the_command_line_narrow_or_conflict(chart_csv):
    """A right --secchi or --kd (the model's own value at chart_csv's truth) keeps the estimate
    reliable and narrows C's interval, which still holds the truth; a wrong one (about three
    times the truth's attenuation) is flagged ``reading-conflict`` and exits 1."""
    from sca.auxiliary import planned

    truth = planned({"secchi": (1.0, 1.0), "kd": {490.0: (1.0, 0.01)}}, forward.Water(),
                    {"chl": np.array([1.5]), "cdom": np.array([0.1])})
    z, kd = float(truth["secchi"][0][0]), float(truth["kd"][490.0][0][0])

    def estimate(*extra):
        code, out, _ = run(["estimate", chart_csv, "--depth", 3, "--distance", 1, "--json",
                            *extra])
        return code, json.loads(out)
    code, bare = estimate()
    assert code == 0 and bare["reliable"]
    for option, right, wrong in (("--secchi", f"{z:.4g}:1", f"{z / 3:.4g}:0.5"),
                                 ("--kd", f"490={kd:.4g}:0.01", f"490={3 * kd:.4g}:0.02")):
        code, good = estimate(option, right)
        assert code == 0 and good["reliable"] and "reading-conflict" not in good["flags"], option
        assert good["chl_ci"][1] - good["chl_ci"][0] < bare["chl_ci"][1] - bare["chl_ci"][0]
        assert good["chl_ci"][0] <= 1.5 <= good["chl_ci"][1], option
        code, bad = estimate(option, wrong)
        assert code == 1 and not bad["reliable"] and "reading-conflict" in bad["flags"], option

def test_a_measurement_needs_the_patches_noise(tmp_path, chart_csv):
    rows = list(csv.reader(chart_csv.open()))
    bare = tmp_path / "bare.csv"
    with open(bare, "w", newline="") as fh:
        csv.writer(fh).writerows([r[:4] for r in rows])
    code, out, err = run(["estimate", bare, "--depth", 3, "--distance", 1, "--cdom-sample",
                          "0.1:0.01"])
    assert code == 2 and "--cdom-sample: a measurement is weighed against" in err


def test_readings_of_one_water_are_combined_once_each():
    # the inverse-variance mean; equal readings: the sd of the mean
    assert combine_readings([(0.1, 0.02), (0.1, 0.02)]) == pytest.approx((0.1, 0.02 / 2 ** 0.5))
    # readings that disagree beyond their sds: widened by the Birge ratio
    v, sd = combine_readings([(0.1, 0.01), (0.2, 0.01)])
    assert v == pytest.approx(0.15) and sd == pytest.approx(0.01 / 2 ** 0.5 * 50 ** 0.5)

    def rec(*entries):
        return {"inputs": {"auxiliary": [dict(zip(("kind", "value", "sd", "source"), e))
                                         for e in entries]}}
    default = ("cdom", 0.1, 0.02, "the run's default")
    # the run's default in three photos is one reading; two metadata rows are two readings
    got = dive_auxiliary([rec(default), rec(default), rec(("cdom", 0.1, 0.02, "metadata line 3")),
                          rec(("secchi", 8.0, 0.5, "metadata line 3"))])
    assert got["cdom"] == pytest.approx((0.1, 0.02 / 2 ** 0.5)) and got["secchi"] == (8.0, 0.5)
    kd = {"kind": "kd", "band_nm": 490.0, "value": 0.12, "sd": 0.01, "source": "--kd"}
    assert dive_auxiliary([{"inputs": {"auxiliary": [kd]}}] * 2) == {"kd": {490.0: (0.12, 0.01)}}
    assert dive_auxiliary([{"inputs": {}}]) == {}
    # a photo's own reading over the run's, band by band
    assert merge_auxiliary({"cdom": (1, 1), "kd": {490: (1, 1), 555: (2, 1)}},
                           {"kd": {490.0: (3, 1)}}) == {"cdom": (1, 1),
                                                        "kd": {490.0: (3, 1), 555.0: (2, 1)}}


def test_metadata_columns_of_the_water_are_read_and_checked(tmp_path):
    f = tmp_path / "m.csv"
    f.write_text("image,depth_m,distance_m,cdom_sample,cdom_sample_sd,secchi_m,secchi_sd_m,"
                 "kd_490,kd_490_sd\n"
                 "a.dng,5,1.5,0.12,0.01,8,0.5,0.1,0.01\nb.dng,5,1.5,,,,,0.2,0.02\n")
    rows = dive.read_metadata(f)
    assert rows["a.dng"]["auxiliary"] == {"cdom": (0.12, 0.01), "secchi": (8.0, 0.5),
                                          "kd": {490.0: (0.1, 0.01)}}
    assert rows["b.dng"]["auxiliary"] == {"kd": {490.0: (0.2, 0.02)}}
    for text, word in [("image,depth_m,distance_m,secchi_m\n", "column secchi_m needs column "
                                                                "secchi_sd_m"),
                       ("image,depth_m,distance_m,kd_490_sd\n", "column kd_490_sd needs column "
                                                                 "kd_490"),
                       ("image,depth_m,distance_m,kd_900,kd_900_sd\n", "900 nm lies outside"),
                       ("image,depth_m,distance_m,cdom_sample,cdom_sample_sd\na.dng,5,1,0.1,\n",
                        "line 2: cdom_sample_sd is empty"),
                       ("image,depth_m,distance_m,secchi_m,secchi_sd_m\na.dng,5,1,x,1\n",
                        "line 2: secchi_m is not a number")]:
        f.write_text(text)
        with pytest.raises(ValueError, match="metadata: .*" + word):
            dive.read_metadata(f)


def test_a_measured_chart_file_is_read_and_checked(tmp_path):
    wl = np.arange(400.0, 701.0, 10.0)
    nominal = forward.chart_reflectances(wavelengths=wl)
    f = _write_chart(tmp_path / "chart.csv", nominal, wl)
    np.testing.assert_allclose(read_chart_reflectance(f, wl), nominal, rtol=1e-12)
    assert read_chart_reflectance(f).shape == (301, 24)
    for name, data, word in (("few.csv", nominal[:, :23], "has 23 reflectance columns"),
                             ("pct.csv", 100 * nominal, "looks like percent"),
                             ("order.csv", nominal[:, ::-1], "grey row"),
                             ("short.csv", nominal[wl >= 420], "")):
        g = _write_chart(tmp_path / name, data, wl[wl >= 420] if name == "short.csv" else wl)
        with pytest.raises(ValueError, match="--chart-reflectance: " + ".*" + word):
            read_chart_reflectance(g, name="--chart-reflectance")
    code, out, err = run(["calibrate", tmp_path / "no.dng", "--chart-reflectance",
                          tmp_path / "pct.csv", "--out", tmp_path / "p.json"])
    assert code == 2 and "--chart-reflectance:" in err and "percent" in err


def test_a_measured_chart_leaves_a_smaller_per_patch_term():
    from sca.budget_defaults import MEASURED_CHART_PATCH

    assert measure.budget_for(None, None)["patch"] == sca.DEFAULT_UNCERTAIN["patch"]
    assert measure.budget_for(None, None, measured_chart=True)["patch"] == MEASURED_CHART_PATCH
    assert MEASURED_CHART_PATCH < sca.DEFAULT_UNCERTAIN["patch"]
    prof = measure.Profile("Nikon 5100 (NPL)", False, "D65", [1, 1, 1], [0, 0, 0], [1, 1, 1],
                           [1, 1, 1], [0, 0, 0], True, patch_sd=0.002)
    assert measure.budget_for(None, prof, measured_chart=True)["patch"] == 0.002  # measured


# --------------------------------------------------------------------------- uw3p estimate
def test_estimate_says_what_is_measured_and_what_is_not(tmp_path, chart_csv):
    code, out, err = run(["estimate", chart_csv, "--depth", 3, "--distance", 1, "--json",
                          "--spectrum", tmp_path / "c.csv"])
    assert code == 0, err
    res = json.loads(out)
    assert set(res["quantities"]) == set(sca.derived.QUANTITIES)
    for k, (lo, hi) in res["quantity_intervals"].items():
        assert lo < res["quantities"][k] < hi and res["verdicts"][k] == "measured", k
    # C is not measured by one chart (the default budget): said so, with what would narrow it
    assert res["verdicts"]["chl"] != "measured"
    assert res["statements"][0].startswith("C: ") and "--cdom-sample" in res["statements"][0]
    assert any(s.startswith("c(490): measured") for s in res["statements"])
    rows = list(csv.reader((tmp_path / "c.csv").open()))
    assert rows[0] == ["wavelength_nm", "c_per_m", "c_lo_per_m", "c_hi_per_m", "transmittance"]
    spec = np.array(rows[1:], float)
    np.testing.assert_allclose(spec[:, 1], res["beam_attenuation"], rtol=1e-15)
    np.testing.assert_allclose(spec[:, 4], res["attenuation"], rtol=1e-15)
    assert np.all((spec[:, 2] < spec[:, 1]) & (spec[:, 1] < spec[:, 3]))
    # the transmittance is exp(-(depth + distance) c), the path's length the fit's
    L = res["nuisance"]["depth"] + res["nuisance"]["distance"]
    assert abs(L - 4.0) < 0.1
    np.testing.assert_allclose(spec[:, 4], np.exp(-L * spec[:, 1]), rtol=1e-9)
    code, text, err = run(["estimate", chart_csv, "--depth", 3, "--distance", 1])
    assert "what this chart measures" in text and "c(443): measured, " in text
    assert res["statements"][0] in text and "--spectrum FILE" in text
    # a measured a_CDOM is fused: C's interval narrows, and it is no longer suggested
    code, text2, err = run(["estimate", chart_csv, "--depth", 3, "--distance", 1, "--json",
                            "--cdom-sample", "0.1:0.01"])
    with_cdom = json.loads(text2)
    width = [r["chl_ci"][1] - r["chl_ci"][0] for r in (res, with_cdom)]
    assert width[1] < 0.75 * width[0] and with_cdom["verdicts"]["cdom"] == "measured"
    assert not any("--cdom-sample" in s for s in with_cdom["statements"])


@pytest.mark.slow
def test_the_batch_rows_carry_the_quantities_and_verdicts(tmp_path, chart_csv):
    from uw3p.cmd_estimate import BATCH_COLUMNS, QUANTITY_NAMES

    assert QUANTITY_NAMES == tuple(sca.derived.QUANTITIES)
    rows = list(csv.DictReader(chart_csv.open()))
    b = tmp_path / "b.csv"
    with open(b, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=["chart"] + list(rows[0]))
        w.writeheader()
        for chart in ("x", "y"):
            w.writerows({"chart": chart} | r for r in rows)
    code, out, err = run(["estimate", "--batch", b, "--depth", 3, "--distance", 1,
                          "--spectrum", tmp_path / "s.csv"])
    assert code == 0, err
    got = list(csv.DictReader(io.StringIO(out)))
    assert list(got[0]) == [c for c in BATCH_COLUMNS if c != "backscatter_*"][:11] + [
        "backscatter_0", "backscatter_1", "backscatter_2"] + [
        c for c in BATCH_COLUMNS if c != "backscatter_*"][11:]
    for r in got:
        assert float(r["c_490_lo"]) < float(r["c_490"]) < float(r["c_490_hi"])
        assert r["c_490_verdict"] == "measured" and r["chl_verdict"] in sca.derived.VERDICTS
    spec = list(csv.reader((tmp_path / "s.csv").open()))
    assert spec[0][:2] == ["chart", "c_400"] and len(spec[0]) == 1 + 4 * 301
    code, out, err = run(["estimate", "--batch", b, "--depth", 3, "--distance", 1, "--json"])
    rec = json.loads(out)["charts"][0]
    assert set(rec["verdicts"]) == {"chl", "cdom", *sca.derived.QUANTITIES}
    assert len(rec["beam_attenuation"]) == 301 and np.shape(rec["beam_attenuation_ci"]) == (301, 2)


def test_statements_group_by_verdict():
    est = {"chl": 1.0, "chl_ci": [0.0, 5.0], "cdom": 0.1, "cdom_ci": [0.05, "inf"],
           "quantities": {"c_490": 0.2}, "quantity_intervals": {"c_490": [0.19, 0.21]}}
    said = statements(est, "dive")
    assert said[0].startswith("C: only an upper bound from this dive: at most 5")
    assert "cdom_sample column" in said[0]
    assert said[1].startswith("a_CDOM(440): not constrained by this dive")
    assert said[2] == "c(490): measured, 0.2 m^-1 (95 %: 0.19-0.21)"
    assert one_line(est) == ("measured: c(490) 0.2 [0.19, 0.21] m^-1; loosely measured: -; "
                             "only an upper bound: C <= 5 mg m^-3; not constrained: a_CDOM(440) "
                             ">= 0.05 m^-1")
    with pytest.raises(ValueError, match="where: "):
        statements(est, "lake")


# --------------------------------------------------------------------------- survey.nc
def _record(path_model, models):
    wl = [400.0, 550.0, 700.0]
    q = {k: 0.2 for k in sca.derived.QUANTITIES}
    return {"estimate": {"wavelengths": wl, "transmittance": [0.5, 0.6, 0.1],
                         "beam_attenuation": [0.3, 0.2, 0.6],
                         "beam_attenuation_ci": [[0.25, 0.35], [0.18, 0.22], [0.5, "inf"]],
                         "quantities": q, "quantity_intervals": {k: [0.1, 0.3] for k in q},
                         "verdicts": {"chl": "upper bound", "cdom": "measured",
                                      **{k: "measured" for k in q}},
                         "path_model": path_model, "path_models": models}}


def test_survey_names_the_coefficient_by_its_path_model():
    import xarray as xr  # noqa: F401 - survey_dataset's

    rows = [{"image": "a", "chl": 1.0, "status": "measured", "reliable": True},
            {"image": "b", "chl": 1.0, "status": "measured", "reliable": True}]
    beam = dive.survey_dataset(rows, {"a": _record("beam", ["beam"]),
                                      "b": _record("beam", ["beam"])})
    cf = sca.derived.PATH_CF["beam"]
    assert beam["attenuation_coefficient"].attrs["standard_name"] == cf
    assert beam["c_490"].attrs["standard_name"] == cf and beam["c_490"].attrs["units"] == "m-1"
    assert "kd_490" not in beam  # not published (decision 0067-kd-not-published)
    assert "standard_name" not in beam["a_nw_440"].attrs
    assert beam["attenuation_coefficient_bounds"].dims == ("photo", "wavelength", "nv")
    assert np.isinf(beam["attenuation_coefficient_bounds"].values[0, 2, 1])
    # photos whose path models differ (or span two): no one CF name; the comment says why
    mixed = dive.survey_dataset(rows, {"a": _record("beam", ["beam"]),
                                       "b": _record("absorption", ["absorption", "beam"])})
    assert "standard_name" not in mixed["attenuation_coefficient"].attrs
    assert "absorption, beam" in mixed["attenuation_coefficient"].attrs["comment"]
    assert list(mixed["path_model"].values) == ["beam", "absorption"]
    assert dive.path_standard_name(["absorption"]) == sca.derived.PATH_CF["absorption"]


# --------------------------------------------------------------------------- photographs
@pytest.fixture(scope="module")
def shots(chart_photos, tmp_path_factory):
    """A camera profile and an underwater photo of a known water (the session's
    ``chart_photos``); and a chart whose patches are off the nominal by 3 % (its spectra in a
    CSV), photographed in air and underwater by the same camera."""
    tmp = tmp_path_factory.mktemp("shots37")
    corners = chart_photos["corners"]
    rng = np.random.default_rng(5)
    chart = forward.chart_reflectances() * (1 + 0.03 * rng.standard_normal(24))[None, :]
    setup = forward.chart_setup(channel_gains=(0.55, 1.0, 0.7), reflectances=chart)
    out = {"corners": corners, "chart": _write_chart(tmp / "chart.csv", chart,
                                                     forward.wavelength_grid()),
           "uw": chart_photos["uw"],
           "profile": chart_photos["profile"]}
    out["worn_air"] = write_dng(render_mosaic(Scene(
        chl=0, cdom=0, depth=0, distance=0, gain=9000, width=W, height=H, seed=1), corners,
        setup=setup), tmp / "worn_air.dng")
    out["worn_uw"] = write_dng(render_mosaic(Scene(
        **UW, gain=30000, width=W, height=H, seed=2), corners, setup=setup), tmp / "worn_uw.dng")
    return out


@pytest.fixture(scope="module")
def photo(shots):
    """The photo measured with the default budget, without and with a water sample's
    a_CDOM(440) = 0.1 +- 0.005 m^-1 (the truth: 0.1)."""
    kw = dict(corners=shots["corners"], depth=UW["depth"], distance=UW["distance"],
              profile=shots["profile"], light_field="none")
    return (measure.measure(shots["uw"], **kw),
            measure.measure(shots["uw"], auxiliary={"cdom": (0.1, 0.005)}, **kw))


@pytest.mark.slow
def test_a_measured_cdom_narrows_c_where_one_photo_measures_it_loosely(photo):
    """C's interval spans a factor ~8 above a clear lower end: loosely measured (decision
    0072-verdicts-loosely-measured; it was called an upper bound)."""
    alone, with_cdom = photo
    e0, e1 = alone.estimate, with_cdom.estimate
    assert e0.verdicts["chl"] == "loosely measured" and e0.verdicts["cdom"] != "measured"
    assert e1.verdicts["cdom"] == "measured" and e1.cdom_ci[1] - e1.cdom_ci[0] < 0.025
    ratio = [e.chl_ci[1] / max(e.chl_ci[0], 1e-300) for e in (e0, e1)]
    assert ratio[1] < ratio[0] / 1.5  # a factor ~8 -> ~4.6
    for e in (e0, e1):
        assert e.chl_ci[0] <= UW["chl"] <= e.chl_ci[1]
    rec = with_cdom.to_dict()
    assert rec["inputs"]["auxiliary"] == [{"kind": "cdom", "value": 0.1, "sd": 0.005,
                                           "units": "m^-1", "source": "given"}]
    assert not any("--cdom-sample" in s for s in rec["estimate"]["statements"])
    assert "--cdom-sample" in alone.to_dict()["estimate"]["statements"][0]


@pytest.mark.slow
def test_measurement_json_holds_the_coefficient_its_interval_and_the_verdicts(photo):
    m = photo[0]
    rec = json.loads(json.dumps(measure.output.strict_json(m.to_dict())))
    e = rec["estimate"]
    assert "attenuation" not in e and "attenuation_band" not in e  # a transmittance's names
    c, ci = np.array(e["beam_attenuation"]), np.array(e["beam_attenuation_ci"], float)
    k, band = np.array(e["transmittance"]), np.array(e["transmittance_band"])
    assert c.shape == k.shape == (301,) and ci.shape == (301, 2) and band.shape == (2, 301)
    assert np.all((ci[:, 0] < c) & (c < ci[:, 1])) and np.all((band[0] < k) & (k < band[1]))
    # the transmittance's band is the coefficient's, not the (C, a_CDOM) box's: at 450 nm the
    # coefficient is known to a few tens of percent while C is not measured
    i = e["wavelengths"].index(450.0)
    assert ci[i, 1] / ci[i, 0] < 2 and e["verdicts"]["chl"] != "measured"
    assert e["verdicts"]["c_490"] == "measured" and e["units"]["beam_attenuation"].startswith("m^-1")
    assert set(e["quantities"]) == set(sca.derived.QUANTITIES)
    assert len(e["statements"]) == 2 + len(sca.derived.QUANTITIES)
    assert e["path_model"] in e["path_models"]


@pytest.mark.slow
def test_the_report_draws_the_coefficient_and_says_what_chi2_says(photo):
    m = photo[0]
    preview = np.zeros((120, 180, 3), np.uint8)
    fig = measure.output.report_figure(m, preview)
    photo_ax, resid, coef, words = fig.axes[:4]
    assert "chi²/dof" in resid.get_title() and "per patch" in resid.get_title()
    # the profile's measured term, as in chi^2
    assert f"{100 * m.estimate.uncertain['patch']:.2g} % per patch" in resid.get_title()
    assert m.patch_term == m.estimate.uncertain["patch"] > 0
    assert coef.get_ylabel() == "attenuation coefficient c (m⁻¹)"
    assert "m⁻¹" in coef.get_title() and "attenuation" not in photo_ax.get_title()
    assert len(coef.collections) >= 1  # the coefficient's own band
    text = "".join(t.get_text() for t in words.texts).replace("\n  ", " ").replace("\n", " ")
    assert m.to_dict()["estimate"]["statements"][0] in text
    assert "c(490): measured" in text
    # the residuals in the units chi^2 uses: their mean square is chi^2's data part
    z = (m.sample.rgb - m.fitted) / m.residual_sd
    assert 0.3 < float(np.mean(z ** 2)) < 3 and np.abs(z).max() < 5


@pytest.mark.slow
def test_a_measured_chart_replaces_the_nominal_in_calibrate_and_measure(tmp_path, shots):
    corners = " ".join(f"{x:.2f},{y:.2f}" for x, y in shots["corners"])
    nominal = measure.calibrate(measure.sample_patches(measure.read_image(shots["worn_air"]),
                                                       shots["corners"]))
    prof = tmp_path / "p.json"
    code, out, err = run(["calibrate", shots["worn_air"], "--corners", corners,
                          "--chart-reflectance", shots["chart"], "--out", prof])
    assert code == 0, err
    measured = measure.load_profile(prof)
    assert measured.patch_sd < 0.2 * nominal.patch_sd  # the chart's 3 % is no longer an error
    assert measured.chart == measure.camera.chart_digest(shots["chart"])
    res = tmp_path / "m"
    code, out, err = run(["measure", shots["worn_uw"], "--corners", corners, "--profile", prof,
                          "--chart-reflectance", shots["chart"], "--depth", UW["depth"],
                          "--distance", UW["distance"], "--cdom-sample", "0.1:0.005",
                          "--out", res])
    assert code in (0, 1), err
    assert "what this photo measures" in out and "c(490): measured" in out
    rec = json.loads((res / "measurement.json").read_text())
    assert rec["inputs"]["chart_reflectance"]["sha256"] == measured.chart
    assert rec["inputs"]["auxiliary"][0]["source"] == "--cdom-sample"
    assert rec["inputs"]["uncertain"]["patch"] == pytest.approx(measured.patch_sd)
    worn = measure.measure(shots["worn_uw"], corners=shots["corners"], depth=UW["depth"],
                           distance=UW["distance"], profile=nominal,
                           auxiliary={"cdom": (0.1, 0.005)}).estimate
    lo, hi = rec["estimate"]["chl_ci"]
    assert lo <= UW["chl"] <= hi and (hi - lo) < 0.7 * (worn.chl_ci[1] - worn.chl_ci[0])


@pytest.mark.slow
def test_a_dives_metadata_readings_reach_each_photo_and_the_joint_fit(tmp_path, shots):
    import xarray as xr

    d = tmp_path / "dive"
    d.mkdir()
    corners = " ".join(f"{x:.2f},{y:.2f}" for x, y in shots["corners"])
    for name in ("a.dng", "b.dng"):
        (d / name).write_bytes(Path(shots["uw"]).read_bytes())
    (d / "dive.csv").write_text(
        "image,depth_m,distance_m,corners,cdom_sample,cdom_sample_sd,secchi_m,secchi_sd_m\n"
        f"a.dng,5,1.5,\"{corners}\",0.1,0.001,,\n"
        f"b.dng,5,1.5,\"{corners}\",0.1,0.001,12,1\n")
    res = dive.measure_dive(d, out=tmp_path / "out", metadata=d / "dive.csv",
                            profile=shots["profile"], scheduler="synchronous", report=False,
                            figure=False, joint=True, uncertain={}, light_field="none",
                            auxiliary={"kd": {490.0: (0.18, 0.02)}})
    assert res.joint is not None, res.joint_error
    recs = {n: json.loads((tmp_path / "out" / f"{n}_dng" / "measurement.json").read_text())
            for n in ("a", "b")}
    assert [r["kind"] for r in recs["a"]["inputs"]["auxiliary"]] == ["cdom", "kd"]
    assert [r["source"] for r in recs["b"]["inputs"]["auxiliary"]] == [
        "metadata line 3", "metadata line 3", "the run's default"]
    for r in recs.values():  # each photo's fit took its row's a_CDOM
        lo, hi = r["estimate"]["cdom_ci"]
        assert hi - lo < 0.005
    # the joint fit: the two rows' a_CDOM as one reading (their mean, sd / sqrt 2), the run's
    # K_d once, the Secchi depth of row b
    joint = json.loads(res.joint.read_text())
    fused = {a["kind"]: a for a in joint["auxiliary"]}
    assert fused["cdom"]["value"] == pytest.approx(0.1)
    assert fused["cdom"]["sd"] == pytest.approx(0.001 / 2 ** 0.5)
    assert fused["kd"]["sd"] == 0.02 and fused["secchi"]["value"] == 12.0
    # the run fitted the photos it measured as the typed objects its workers made (no
    # measurement.json read back); from their measurement.json the same photos give the same
    setup = measure.camera_setup(gains=shots["profile"].gains)
    assert res.joint_estimate is not None
    again = measure.fit_joint(list(recs.values()), setup=setup)
    assert again.chl == pytest.approx(res.joint_estimate.chl, rel=1e-9)
    assert again.cdom_ci == pytest.approx(res.joint_estimate.cdom_ci, rel=1e-9)
    assert joint["chl"] == pytest.approx(res.joint_estimate.chl, rel=1e-12)
    alone = measure.fit_joint(list(recs.values()), setup=setup, auxiliary={})
    width = [joint["cdom_ci"][1] - joint["cdom_ci"][0], alone.cdom_ci[1] - alone.cdom_ci[0]]
    assert width[0] < 0.5 * width[1]
    # summary.csv and survey.nc: the quantities with their bounds and verdicts, per photo and
    # for the joint fit, under the CF name of the path model (the exact model: 'beam')
    rows = list(csv.DictReader(open(tmp_path / "out" / "summary.csv")))
    assert rows[0]["c_490_verdict"] == "measured" and json.loads(rows[0]["auxiliary"])
    with xr.open_dataset(res.survey, engine=dive.netcdf_engine()) as ds:
        cf = sca.derived.PATH_CF["beam"]
        assert ds["attenuation_coefficient"].dims == ("photo", "wavelength")
        assert ds["attenuation_coefficient"].attrs["units"] == "m-1"
        assert ds["attenuation_coefficient"].attrs["standard_name"] == cf
        b = ds["attenuation_coefficient_bounds"].values
        c = ds["attenuation_coefficient"].values
        assert b.shape == c.shape + (2,) and np.all((b[..., 0] < c) & (c < b[..., 1]))
        assert ds["joint_attenuation_coefficient"].dims == ("wavelength",)
        assert ds["joint_attenuation_coefficient"].attrs["standard_name"] == cf
        assert ds["joint_attenuation_coefficient_bounds"].dims == ("wavelength", "nv")
        assert ds["joint_c_490"].attrs["units"] == "m-1"
        assert float(ds["joint_cdom"]) == pytest.approx(joint["cdom"])
        assert "kd_490" not in ds and "joint_kd_490" not in ds  # decision 0067-kd-not-published
        assert ds["transmittance"].attrs["units"] == "1"
        assert str(ds["c_490_verdict"].values[0]) == "measured"
        assert math.isclose(float(ds["c_490_wavelength"]), 490.0)


def test_a_measurement_and_its_json_are_the_same_joint_photo(photo):
    """The joint fit's photo made from the Measurement equals the one read from its
    measurement.json, field by field; a Measurement, its JointPhoto and its JSON fit alike."""
    from measure.joint import JointPhoto, joint_photo
    from measure.output import strict_json

    meas = photo[1]
    typed = JointPhoto.from_measurement(meas)
    text = json.loads(json.dumps(strict_json(meas.to_dict()), allow_nan=False))
    read = JointPhoto.from_record(text)
    for f in dataclasses.fields(JointPhoto):
        a, b = getattr(typed, f.name), getattr(read, f.name)
        if f.name == "start":
            assert a.keys() == b.keys()
            for k in a:
                np.testing.assert_array_equal(np.asarray(a[k], float), np.asarray(b[k], float))
        elif f.name == "budget":
            assert strict_json(a) == b
        elif isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
            np.testing.assert_array_equal(a, b)
        else:
            assert a == b, f.name
    assert typed.auxiliary and typed.depth_sd > 0 and np.isinf(typed.sigma).sum() == \
        np.isinf(read.sigma).sum()
    assert joint_photo(typed) is typed and joint_photo(text).name == typed.name
    with pytest.raises(ValueError, match="^records: each must be"):
        joint_photo(3.0)
