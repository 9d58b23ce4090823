"""A dive, not a photo (issue 18): per-photo inputs from a metadata CSV and EXIF, every file of
the folder accounted for, distinct output folders, results written whole or not at all, reruns
that skip what is complete, Ctrl-C that leaves a summary, survey.nc with CF names, Dask; and
issue 35: a rerun that never replaces good results, the content as the key, names that cannot
collide, every metadata row accounted for, one run per output folder, paths for Dask workers."""

import csv
import dataclasses
import json
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest

import forward
import measure
from measure.synthetic_photo import Scene, default_corners, render_mosaic, write_dng
import measure.joint  # noqa: F401  (an import error fails, never skips)
from measure import dive
from measure.output import MARKER, TEMP_PREFIX, check_out
from uw3p.cli import main

W, H = 360, 240
#: fast fits: the exact model and no light-field search (what is tested here is the running)
FAST = {"uncertain": {}, "light_field": "none"}


@pytest.fixture(scope="module")
def shots(tmp_path_factory):
    """An air photo, a profile, an underwater DNG and the same as a linear TIFF."""
    import tifffile

    tmp = tmp_path_factory.mktemp("dive_src")
    setup = forward.chart_setup(channel_gains=(0.55, 1.0, 0.7))
    corners = default_corners(W, H)
    air = write_dng(render_mosaic(Scene(chl=0, cdom=0, depth=0, distance=0, gain=9000, width=W,
                                        height=H, seed=1), corners, setup=setup), tmp / "air.dng")
    uw = write_dng(render_mosaic(Scene(chl=2.0, cdom=0.1, depth=5.0, distance=1.5, gain=30000,
                                       width=W, height=H, seed=2), corners, setup=setup),
                   tmp / "uw.dng")
    profile = measure.calibrate(measure.sample_patches(measure.read_image(air), corners),
                                image=air)
    prof_path = tmp / "profile.json"
    prof_path.write_text(json.dumps(dataclasses.asdict(profile)))
    rgb = np.clip(np.rint(measure.demosaic(measure.read_image(uw))), 0, 65535).astype(np.uint16)
    tif = tmp / "uw.tif"
    tifffile.imwrite(tif, rgb, photometric="rgb")
    text = " ".join(f"{x:.2f},{y:.2f}" for x, y in corners)

    def render(path, depth, distance, seed=3):  # the same water at another depth and distance
        return write_dng(render_mosaic(Scene(chl=2.0, cdom=0.1, depth=depth, distance=distance,
                                             gain=30000, width=W, height=H, seed=seed),
                                       corners, setup=setup), path)

    return {"air": air, "uw": uw, "tif": tif, "profile": prof_path, "corners": text,
            "render": render}


def _folder(tmp_path, shots, names, rows=None):
    d = tmp_path / "dive"
    d.mkdir()
    for name in names:
        src = shots["tif"] if name.lower().endswith((".tif", ".tiff")) else shots["uw"]
        shutil.copy(src, d / name)
    if rows is not None:
        lines = ["image,depth_m,distance_m,depth_sd_m,corners"]
        lines += [f"{n},{d_},1.5,,\"{shots['corners']}\"" for n, d_ in rows.items()]
        (d / "dive.csv").write_text("\n".join(lines) + "\n")
    return d


def _run(d, out, shots, **kw):
    meta = d / "dive.csv"
    return dive.measure_dive(d, out=out, metadata=meta if meta.exists() else None,
                             profile=str(shots["profile"]), scheduler=kw.pop("scheduler",
                                                                             "synchronous"),
                             report=False, **{"figure": False} | FAST | kw)


def _csv(path):
    with open(path, encoding="utf-8", newline="") as fh:
        return list(csv.DictReader(fh))


def _mtimes(root):
    return {p: p.stat().st_mtime_ns for p in root.rglob("*") if p.is_file()
            and p.name not in ("summary.csv", "survey.nc", "survey.png", "ifdo.json")}


# --------------------------------------------------------------------------- inputs
def test_metadata_is_read_and_bad_files_are_refused_with_the_line(tmp_path):
    f = tmp_path / "m.csv"
    f.write_text("\ufeffimage,depth_m,distance_m,depth_sd_m,corners\n"
                 "a.dng,5,1.5,0.1,\"1,1 9,1 9,5 1,5\"\nb.dng,,2,,\n\n")
    rows = dive.read_metadata(f)
    assert rows["a.dng"]["depth_m"] == 5.0 and rows["a.dng"]["depth_sd_m"] == 0.1
    assert rows["a.dng"]["corners"] == "1,1 9,1 9,5 1,5" and rows["b.dng"]["depth_m"] is None
    for text, word in [("image,depth_m\na.dng,5\n", "missing column(s) distance_m"),
                       ("image,depth_m,distance_m,colour\n", "unknown column(s) colour"),
                       ("image,depth_m,distance_m\na.dng,five,1\n", "line 2: depth_m is not a"),
                       ("image,depth_m,distance_m\na.dng,5,0\n", "line 2: distance_m must be"),
                       ("image,depth_m,distance_m\na.dng,5,1\na.dng,6,1\n",
                        "line 3: image 'a.dng' repeats"),
                       ("image,depth_m,distance_m\n,5,1\n", "line 2: image is empty")]:
        f.write_text(text)
        with pytest.raises(ValueError, match="metadata: .*" + word.replace("(", r"\(")
                           .replace(")", r"\)")):
            dive.read_metadata(f)
    with pytest.raises(ValueError, match="metadata: file not found"):
        dive.read_metadata(tmp_path / "missing.csv")


def test_exif_water_depth_and_time_are_read(tmp_path):
    import tifffile

    img = np.zeros((8, 8, 3), np.uint16)
    tagged = tmp_path / "tagged.tif"
    # EXIF 2.31 WaterDepth (0x9403, signed rational, m) and DateTimeOriginal, here in IFD0
    tifffile.imwrite(tagged, img, photometric="rgb",
                     extratags=[(dive.WATER_DEPTH_TAG, 10, 1, (123, 10), True),
                                (dive.DATETIME_ORIGINAL_TAG, 2, 20, "2024:05:06 10:11:12",
                                 True)])
    info = dive.exif_info(tagged)
    assert info == {"depth_m": pytest.approx(12.3), "depth_tag": "WaterDepth",
                    "time": "2024-05-06T10:11:12"}
    plain = tmp_path / "plain.tif"
    tifffile.imwrite(plain, img, photometric="rgb")
    assert dive.exif_info(plain) == {}
    (tmp_path / "x.orf").write_text("not a tiff")
    assert dive.exif_info(tmp_path / "x.orf") == {}


def test_same_stem_files_get_distinct_folders(tmp_path):
    files = [tmp_path / n for n in ("IMG_1.dng", "IMG_1.TIF", "IMG_2.dng")]
    names = dive.output_names(files)
    assert names == {files[0]: "IMG_1_dng", files[1]: "IMG_1_TIF", files[2]: "IMG_2_dng"}


# --------------------------------------------------------------------------- a dive
def test_a_dive_every_file_accounted_for_then_a_rerun_redoes_nothing(tmp_path, shots):
    d = _folder(tmp_path, shots, ["a.dng", "b.dng", "IMG_1.dng", "IMG_1.tif"],
                rows={"a.dng": 5, "IMG_1.dng": 5, "IMG_1.tif": 5})
    (d / "notes.jpg").write_bytes(b"\xff\xd8 not measured")
    (d / ".DS_Store").write_text("hidden")
    out = tmp_path / "out"
    with pytest.warns(dive.DiveWarning, match="b.dng: no row"):
        res = _run(d, out, shots)
    by = {r["image"].split("/")[-1]: r for r in res.rows}
    # every file but the hidden one and the metadata CSV itself
    assert sorted(by) == ["IMG_1.dng", "IMG_1.tif", "a.dng", "b.dng", "notes.jpg"]
    assert by["b.dng"]["status"] == "not in metadata"
    assert "metadata: no row for b.dng" in by["b.dng"]["error"]
    assert by["notes.jpg"]["status"] == "not an image" and "not a RAW" in by["notes.jpg"]["error"]
    for name in ("a.dng", "IMG_1.dng", "IMG_1.tif"):
        assert by[name]["status"] == "measured", by[name]["error"]
        assert by[name]["depth_source"] == "metadata" and by[name]["corners_source"] == "metadata"
    assert by["a.dng"]["out"].endswith("/a_dng") and by["IMG_1.tif"]["out"].endswith("IMG_1_tif")
    assert json.loads((out / "IMG_1_tif" / "measurement.json").read_text())["image"]["path"] \
        .endswith("IMG_1.tif")
    # the photo without a row and the file that is not a photo do not make it bad input
    assert res.code == max(dive.summary.exit_code(by[n]) for n in ("a.dng", "IMG_1.dng",
                                                                  "IMG_1.tif"))
    assert not res.interrupted and not list(out.glob(TEMP_PREFIX + "*"))
    rows = _csv(res.summary)
    assert len(rows) == 5 and set(dive.SUMMARY_COLUMNS) == set(rows[0])
    assert {r["status"] for r in rows} == {"measured", "not in metadata", "not an image"}
    # the rerun: nothing complete is redone or rewritten
    before = _mtimes(out)
    calls = []
    res2 = _run(d, out, shots, progress=calls.append)
    assert calls == [] and _mtimes(out) == before
    assert [r["status"] for r in res2.rows] == [r["status"].replace("measured", "done earlier")
                                                for r in res.rows]
    assert [r.get("chl") for r in res2.rows] == [r.get("chl") for r in res.rows]
    # other inputs for a photo (its row edited), the same options: that photo is redone
    (d / "dive.csv").write_text((d / "dive.csv").read_text().replace("a.dng,5,", "a.dng,6,"))
    res3 = _run(d, out, shots)
    by3 = {r["image"].split("/")[-1]: r for r in res3.rows}
    assert by3["a.dng"]["status"] == "measured" and by3["a.dng"]["depth_m"] == 6.0
    assert by3["IMG_1.dng"]["status"] == "done earlier"
    assert json.loads((out / "a_dng" / "measurement.json").read_text())["inputs"]["depth_m"] == 6
    # results of another photo in a photo's folder: the run is refused, nothing written
    marker = json.loads((out / "a_dng" / MARKER).read_text())
    (out / "a_dng" / MARKER).write_text(json.dumps(marker | {"image": "/elsewhere/a.dng",
                                                             "key": "another photo's key"}))
    before = _snapshot(out)
    with pytest.raises(ValueError, match="^out: .*another photo.*--overwrite") as refused:
        _run(d, out, shots)
    assert refused.value.argument == "out"  # the command line says --out
    assert _snapshot(out) == before
    res4 = _run(d, out, shots, overwrite=True)
    assert {r["image"].split("/")[-1]: r["status"] for r in res4.rows}["a.dng"] == "measured"


def test_survey_nc_has_cf_names_bounds_and_the_spectrum(tmp_path, shots):
    import xarray as xr

    d = _folder(tmp_path, shots, ["a.dng", "b.tif", "c.dng"], rows={"a.dng": 5, "b.tif": 5})
    out = tmp_path / "out"
    res = _run(d, out, shots, figure=True)
    with xr.open_dataset(res.survey, engine=dive.netcdf_engine()) as ds:
        assert ds.attrs["Conventions"] == "CF-1.8" and ds.sizes["photo"] == 3
        assert ds["chl"].attrs["standard_name"] == dive.CF_CHL[0]
        assert ds["chl"].attrs["units"] == "mg m-3" and ds["chl"].attrs["bounds"] == "chl_bounds"
        assert ds["cdom"].attrs["standard_name"] == dive.CF_CDOM[0] == (
            "volume_absorption_coefficient_of_radiative_flux_in_sea_water_due_to_dissolved_"
            "organic_matter")
        assert ds["cdom"].attrs["units"] == "m-1"
        assert ds["chl_bounds"].dims == ("photo", "nv") and ds.sizes["nv"] == 2
        assert ds["transmittance"].dims == ("photo", "wavelength")
        assert ds["wavelength"].attrs["units"] == "nm"
        ok = ds["status"].values == "measured"
        assert ok.sum() == 2 and np.isnan(ds["chl"].values[~ok]).all()
        b = ds["chl_bounds"].values[ok]
        assert np.all(b[:, 0] <= ds["chl"].values[ok]) and np.all(ds["chl"].values[ok] <= b[:, 1])
        assert np.all((ds["transmittance"].values[ok] > 0) & (ds["transmittance"].values[ok] < 1))
        assert list(ds["depth"].values[ok]) == [5.0, 5.0] and ds["depth"].attrs["units"] == "m"
        rows = {r["image"]: r for r in res.rows}
        assert [rows[i]["chl"] for i in ds["image"].values[ok]] == list(ds["chl"].values[ok])
    assert res.figure is not None and res.figure.stat().st_size > 0
    with xr.open_dataset(res.survey, engine=dive.netcdf_engine()) as ds:
        band = dive.plot_survey(ds, tmp_path / "band.png", joint={
            "chl": 2.0, "chl_ci": [1.5, "inf"], "cdom": 0.1, "cdom_ci": [0.08, 0.12]})
    assert band.stat().st_size > 0


def test_ctrl_c_writes_the_summary_and_the_rerun_completes_the_rest(tmp_path, shots):
    d = _folder(tmp_path, shots, ["a.dng", "b.dng", "c.dng"],
                rows={"a.dng": 5, "b.dng": 5, "c.dng": 5})
    out = tmp_path / "out"

    def interrupt(row):
        raise KeyboardInterrupt

    res = _run(d, out, shots, progress=interrupt)
    assert res.interrupted and res.code == 130
    assert [r["status"] for r in res.rows] == ["measured", "interrupted", "interrupted"]
    rows = _csv(out / "summary.csv")
    assert [r["status"] for r in rows] == ["measured", "interrupted", "interrupted"]
    # only complete folders look complete: a's, with its marker; nothing half-written
    assert sorted(p.name for p in out.iterdir() if p.is_dir()) == ["a_dng"]
    assert (out / "a_dng" / MARKER).exists()
    before = _mtimes(out)
    calls = []
    res2 = _run(d, out, shots, progress=calls.append)
    assert [r["status"] for r in res2.rows] == ["done earlier", "measured", "measured"]
    assert len(calls) == 2 and all(before[p] == p.stat().st_mtime_ns for p in before)


def test_cli_ctrl_c_exits_130_with_a_summary(tmp_path, shots, monkeypatch, capsys):
    d = _folder(tmp_path, shots, ["a.dng", "b.dng"], rows={"a.dng": 5, "b.dng": 5})
    def job(j):  # Ctrl-C while the first photo is measured
        raise KeyboardInterrupt

    monkeypatch.setattr(dive.worker, "run_job", job)
    out = tmp_path / "out"
    code = main(["measure", str(d), "--metadata", str(d / "dive.csv"), "--profile",
                 str(shots["profile"]), "--exact", "--scheduler", "synchronous", "--tiff",
                 "none", "--out", str(out)])
    assert code == 130 and "interrupted" in capsys.readouterr().err
    rows = _csv(out / "summary.csv")
    assert [r["status"] for r in rows] == ["interrupted", "interrupted"]
    assert (out / "survey.nc").exists() and not [p for p in out.iterdir() if p.is_dir()]


def test_cli_folder_without_depth_gives_error_rows(tmp_path, shots):
    d = _folder(tmp_path, shots, ["a.dng"])
    out = tmp_path / "out"
    code = main(["measure", str(d), "--distance", "1.5", "--corners", shots["corners"],
                 "--scheduler", "synchronous", "--out", str(out)])
    rows = _csv(out / "summary.csv")
    assert code == 2 and rows[0]["status"] == "error" and rows[0]["error"].startswith("depth:")


# --------------------------------------------------------------------------- one photo's files
@pytest.fixture(scope="module")
def meas(shots):
    return measure.measure(shots["uw"], corners=shots["corners"], depth=5.0, distance=1.5,
                           profile=str(shots["profile"]), **FAST)


def test_a_photos_files_load_neither_colour_science_nor_pyplot(tmp_path, shots):
    """The previews read colour-science's sRGB from the package data and the report draws on a
    matplotlib Figure: writing a photo's files (report included) imports neither colour-science
    (about 1 s) nor pyplot (its global figures and backend)."""
    import subprocess
    import sys

    code = (f"import measure, sys\n"
            f"m = measure.measure({str(shots['uw'])!r}, corners={shots['corners']!r}, depth=5.0, "
            f"distance=1.5, profile={str(shots['profile'])!r}, **{FAST!r})\n"
            f"measure.write_outputs(m, {str(tmp_path / 'out')!r})\n"
            "print(sorted(n for n in sys.modules if n.split('.')[0] == 'colour' "
            "or n == 'matplotlib.pyplot'))")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert res.stdout.strip().splitlines()[-1] == "[]"
    assert (tmp_path / "out" / "report.png").exists()


def test_a_failed_tiff_leaves_the_old_results_whole(tmp_path, meas, monkeypatch):
    """corrected.tiff is written beside the previews; its failure is the writer's error (naming
    ``out``), and the folder keeps the results it had, with no temporary folder left."""
    import tifffile

    folder = tmp_path / "res"
    first = measure.write_outputs(meas, folder, report=False, tiff="none")
    before = {p.name: p.read_bytes() for p in folder.iterdir()}

    def broken(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(tifffile, "imwrite", broken)
    with pytest.raises(ValueError, match="out: cannot write"):
        measure.write_outputs(meas, folder, linear=True)
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["res"]
    assert set(first) == set(before)


def test_compressed_tiff_is_smaller_and_reads_back_equal(tmp_path, meas):
    import tifffile

    full = measure.write_outputs(meas, tmp_path / "full", report=False, tiff="full", linear=True)
    small = measure.write_outputs(meas, tmp_path / "small", report=False, linear=True)
    none = measure.write_outputs(meas, tmp_path / "none", report=False, tiff="none")
    # by default one full-resolution sRGB image, the JPEG (decision 0084-output-format)
    plain = measure.write_outputs(meas, tmp_path / "plain", report=False)
    assert sorted(plain) == ["complete.json", "corrected.jpg", "corrected.png",
                             "measurement.json"]
    tif = measure.write_outputs(meas, tmp_path / "tif", report=False, output_format="tiff16")
    assert "corrected_srgb.tif" in tif and "corrected.jpg" not in tif
    with pytest.raises(ValueError, match="^tiff: 'none' writes no TIFF"):
        measure.write_outputs(meas, tmp_path / "y", tiff="none", linear=True)
    a, b = tifffile.imread(full["corrected.tiff"]), tifffile.imread(small["corrected.tiff"])
    assert np.array_equal(a, b) and a.dtype == np.uint16
    assert (tmp_path / "small" / "corrected.tiff").stat().st_size < \
        0.9 * (tmp_path / "full" / "corrected.tiff").stat().st_size
    assert "corrected.tiff" not in none and (tmp_path / "none" / "corrected.png").exists()
    with pytest.raises(ValueError, match="tiff: must be one of"):
        measure.write_outputs(meas, tmp_path / "x", tiff="lzw")


def test_another_photos_results_are_not_replaced_without_overwrite(tmp_path, meas, shots):
    folder = tmp_path / "res"
    measure.write_outputs(meas, folder, report=False, tiff="none")
    measure.write_outputs(meas, folder, report=False, tiff="none")  # the same photo: replaced
    other = dataclasses.replace(meas, photo=dataclasses.replace(meas.photo, path="other.dng"))
    with pytest.raises(ValueError, match="out: .*another photo.*--overwrite"):
        measure.write_outputs(other, folder, report=False, tiff="none")
    assert json.loads((folder / MARKER).read_text())["image"] == meas.photo.path
    measure.write_outputs(other, folder, report=False, tiff="none", overwrite=True)
    assert json.loads((folder / MARKER).read_text())["image"] == "other.dng"
    assert not list(tmp_path.glob(TEMP_PREFIX + "*"))
    junk = tmp_path / "junk"
    junk.mkdir()
    (junk / "thesis.docx").write_text("mine")
    with pytest.raises(ValueError, match="not uw3p results"):
        check_out(junk, meas.photo.path, overwrite=True)
    # the command refuses before measuring
    code = main(["measure", str(shots["tif"]), "--depth", "5", "--distance", "1.5",
                 "--corners", shots["corners"], "--out", str(folder)])
    assert code == 2


# --------------------------------------------------------------------------- Dask
@pytest.mark.slow
def test_a_dive_on_a_dask_local_cluster_without_fork_warnings(tmp_path, shots, capfd):
    # one photo: one worker process (spawned, so no fork), which takes seconds to start
    d = _folder(tmp_path, shots, ["a.dng"], rows={"a.dng": 5})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = _run(d, tmp_path / "out", shots, scheduler=None)
    assert [r["status"] for r in res.rows] == ["measured"], res.rows
    assert (tmp_path / "out" / "a_dng" / MARKER).exists()
    err = capfd.readouterr().err
    assert "fork" not in err.lower() and not [w for w in caught if "fork" in str(w.message)]


def test_joint_fit_of_a_dive(tmp_path, shots):
    d = _folder(tmp_path, shots, ["a.dng", "b.dng"], rows={"a.dng": 5, "b.dng": 4})
    res = _run(d, tmp_path / "out", shots, joint=True)
    assert res.joint is not None, res.joint_error
    data = json.loads(res.joint.read_text())
    for key in ("chl", "chl_ci", "cdom", "cdom_ci", "reliable", "flags"):
        assert key in data
    # the joint interval holds the water the photos were rendered in (C 2, a_CDOM 0.1)
    assert data["chl_ci"][0] <= 2.0 <= data["chl_ci"][1], data
    assert data["cdom_ci"][0] <= 0.1 <= data["cdom_ci"][1], data


def test_a_frame_without_a_chart_is_not_bad_input(tmp_path, shots):
    import tifffile

    d = _folder(tmp_path, shots, ["a.dng"], rows={"a.dng": 5})
    rng = np.random.default_rng(0)
    tifffile.imwrite(d / "blank.tif", rng.integers(9000, 11000, (H, W, 3), dtype=np.uint16),
                     photometric="rgb")
    with open(d / "dive.csv", "a", encoding="utf-8") as fh:
        fh.write("blank.tif,5,1.5,,\n")  # no corners: the chart is to be found
    res = _run(d, tmp_path / "out", shots)
    by = {r["image"].split("/")[-1]: r for r in res.rows}
    assert by["a.dng"]["status"] == "measured"
    assert by["blank.tif"]["status"] == "no chart" and "no chart" in by["blank.tif"]["error"]
    assert by["blank.tif"]["corners_source"] == "detected"
    # the frame's inputs are kept (to colour-correct it with the dive's water later)
    assert by["blank.tif"]["depth_m"] == 5.0 and by["blank.tif"]["distance_m"] == 1.5
    assert res.code == dive.summary.exit_code(by["a.dng"]) != 2
    assert [r["status"] for r in _csv(res.summary)] == ["measured", "no chart"]
    assert not [p for p in (tmp_path / "out").iterdir() if p.name.startswith("blank")]


# --------------------------------------------------------------------------- issue 35
def _snapshot(root):
    """Every file under ``root``: its bytes (what a refused run must leave as it was)."""
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file()}


def test_a_rerun_with_other_options_is_refused_before_anything_is_written(tmp_path, shots):
    d = _folder(tmp_path, shots, ["a.dng", "b.dng"], rows={"a.dng": 5, "b.dng": 5})
    out = tmp_path / "out"
    first = _run(d, out, shots, figure=True, joint=True)
    assert [r["status"] for r in first.rows] == ["measured", "measured"]
    before = _snapshot(out)
    with pytest.raises(ValueError, match=r"^out: .*tiff.*--overwrite.*--out"):
        _run(d, out, shots, tiff="none")
    assert _snapshot(out) == before  # nothing written, nothing removed
    with pytest.raises(ValueError, match=r"^out: .*uncertain"):
        _run(d, out, shots, uncertain={"patch": 0.01})
    assert _snapshot(out) == before
    with pytest.raises(ValueError, match=r"^out: .*method"):  # run.json records the method
        _run(d, out, shots, method="diagonal")
    assert _snapshot(out) == before
    again = _run(d, out, shots, tiff="none", overwrite=True)
    assert [r["status"] for r in again.rows] == ["measured", "measured"]
    assert not any((out / r["out"]).joinpath("corrected.tiff").exists() for r in again.rows)


def test_summary_survey_joint_and_figure_describe_one_run(tmp_path, shots):
    d = _folder(tmp_path, shots, ["a.dng", "b.dng"], rows={"a.dng": 5, "b.dng": 4})
    out = tmp_path / "out"
    res = _run(d, out, shots, figure=True, joint=True)
    assert res.joint is not None and res.figure is not None, res.joint_error
    # the same run without --joint and without the figure: no joint.json or survey.png of
    # the earlier run is left beside this run's summary
    res2 = _run(d, out, shots)
    assert res2.joint is None and res2.figure is None
    assert not (out / "joint.json").exists() and not (out / "survey.png").exists()


def test_the_resume_key_is_the_content(tmp_path, shots):
    import os

    d = _folder(tmp_path, shots, ["a.dng", "b.dng"], rows={"a.dng": 5, "b.dng": 5})
    out = tmp_path / "out"
    _run(d, out, shots)
    # another photo copied over a.dng with the same size and modification time (cp -p)
    st = (d / "a.dng").stat()
    data = bytearray((d / "a.dng").read_bytes())
    mid = len(data) // 2
    data[mid:mid + 64] = bytes(64)  # pixels of another photo
    (d / "a.dng").write_bytes(bytes(data))
    os.utime(d / "a.dng", ns=(st.st_atime_ns, st.st_mtime_ns))
    assert (d / "a.dng").stat().st_size == st.st_size
    res = _run(d, out, shots)
    assert [r["status"] for r in res.rows] == ["measured", "done earlier"]


def test_an_edited_camera_csv_is_noticed(tmp_path, shots):
    import os

    wl = forward.wavelength_grid()
    cam = forward.spectra.camera_sensitivities(wavelengths=wl)
    csv_path = tmp_path / "camera.csv"

    def write(scale):
        csv_path.write_text("wavelength,r,g,b\n" + "".join(
            f"{w:.1f},{r * scale:.6f},{g:.6f},{b:.6f}\n" for w, (r, g, b) in zip(wl, cam)))

    write(1.0)
    d = _folder(tmp_path, shots, ["a.dng"], rows={"a.dng": 5})
    out = tmp_path / "out"
    def run():  # no profile: the profile is of the built-in camera
        return dive.measure_dive(d, out=out, metadata=d / "dive.csv", camera=str(csv_path),
                                 scheduler="synchronous", report=False, figure=False, **FAST)

    row = run().rows[0]
    assert row["status"] == "measured", row["error"]
    st = csv_path.stat()
    write(0.999999)  # the same size: one digit changed
    os.utime(csv_path, ns=(st.st_atime_ns, st.st_mtime_ns))
    assert csv_path.stat().st_size == st.st_size
    with pytest.raises(ValueError, match="^out: .*camera: the file's content changed"):
        run()


def test_output_names_cannot_collide_and_name_their_photo(tmp_path):
    names = ["A.dng", "A.nef", "A_dng.dng", "a.DNG", "x.b.dng", "x_b.dng", "summary.csv.dng",
             "survey.nc.tif", "joint.json.dng", "run.json.dng", "survey.png.tif"]
    files = [tmp_path / n for n in names]
    got = dive.output_names(files)
    folded = [v.lower() for v in got.values()]
    assert len(set(folded)) == len(files), got
    reserved = {n.lower() for n in dive.RUN_FILES}
    assert not reserved & set(folded) and not any(v.startswith(".") for v in folded)
    for f in files:  # the folder says which photo it holds
        assert got[f].lower().startswith(f.stem.replace(".", "_").lower()), (f, got[f])
    # the names depend on the photo, not on what else is in the folder
    assert dive.output_names([files[0]])[files[0]] == dive.output_names(files[:2])[files[0]] \
        or len({f.name.lower() for f in files[:2]}) < 2


def test_photos_named_like_the_runs_files_are_measured(tmp_path, shots):
    d = _folder(tmp_path, shots, ["summary.csv.dng", "survey.nc.tif", "joint.json.dng"])
    out = tmp_path / "out"
    res = _run(d, out, shots, depth=5, distance=1.5, corners=shots["corners"], joint=True,
               figure=True)
    assert [r["status"] for r in res.rows] == ["measured"] * 3
    assert (out / "summary.csv").is_file() and (out / "survey.nc").is_file()
    assert (out / "joint.json").is_file()
    assert len({r["out"] for r in res.rows}) == 3


def test_summary_csv_cells_cannot_run(tmp_path):
    from measure.dive.summary import write_summary

    path = write_summary([{"image": "=HYPERLINK(\"http://x\")", "chl": -1.5, "error": "-x",
                           "corners": "@1", "flags": "+y", "status": "measured"}],
                         tmp_path / "summary.csv")
    row = _csv(path)[0]
    assert row["image"] == "'=HYPERLINK(\"http://x\")" and row["chl"] == "-1.5"
    assert row["error"] == "'-x" and row["corners"] == "'@1" and row["flags"] == "'+y"


def test_every_metadata_row_is_accounted_for(tmp_path, shots, capsys):
    import os

    d = _folder(tmp_path, shots, ["a.dng", "b.dng"],
                rows={"a.dng": 5, "typo.dng": 5, "sub/c.dng": 5, "gone.dng": 5})
    (d / "sub").mkdir()
    shutil.copy(shots["uw"], d / "sub" / "c.dng")
    os.symlink(tmp_path / "missing.dng", d / "gone.dng")
    out = tmp_path / "out"
    with pytest.warns(UserWarning) as caught:
        res = _run(d, out, shots)
    by = {r["image"].replace(str(d) + "/", ""): r for r in res.rows}
    assert by["a.dng"]["status"] == "measured"
    for name in ("typo.dng", "sub/c.dng", "gone.dng"):
        assert by[name]["status"] == "no such photo", by[name]
        assert by[name]["error"] and by[name]["depth_m"] == 5.0
    assert by["b.dng"]["status"] == "not in metadata" and "no row" in by["b.dng"]["error"]
    text = " ".join(str(w.message) for w in caught)
    for name in ("typo.dng", "sub/c.dng", "gone.dng", "b.dng"):
        assert name in text
    assert sorted(res.warnings) and res.code != 2  # a.dng was measured: not bad input
    rows = {r["image"]: r["status"] for r in _csv(res.summary)}
    assert sorted(rows.values()).count("no such photo") == 3
    # the command line: a warning on stderr, the exit status of what was measured
    out2 = tmp_path / "out2"
    code = main(["measure", str(d), "--metadata", str(d / "dive.csv"), "--profile",
                 str(shots["profile"]), "--exact", "--scheduler", "synchronous", "--tiff",
                 "none", "--out", str(out2)])
    err = capsys.readouterr().err
    assert code in (0, 1) and "warning" in err and "typo.dng" in err and "b.dng" in err


def test_metadata_quoted_newlines_and_a_trailing_comma(tmp_path):
    f = tmp_path / "m.csv"
    f.write_text('image,depth_m,distance_m,corners,\n'
                 'a.dng,5,1.5,"1,1 9,1\n9,5 1,5",\n'
                 'b.dng,6,1.5,,\n', encoding="utf-8")
    rows = dive.read_metadata(f)
    assert sorted(rows) == ["a.dng", "b.dng"]
    assert rows["a.dng"]["corners"] == "1,1 9,1\n9,5 1,5" and rows["b.dng"]["depth_m"] == 6.0
    assert rows["b.dng"]["line"] == 4  # the line the row starts on
    f.write_text("image,depth_m,distance_m,,colour\n")
    with pytest.raises(ValueError, match=r"unknown column\(s\) colour$"):
        dive.read_metadata(f)
    f.write_text("image,depth_m,distance_m,\na.dng,5,1.5,oops\n")
    with pytest.raises(ValueError, match="line 2: .*no column name"):
        dive.read_metadata(f)


@pytest.mark.slow
def test_the_readmes_dive_csv_gives_a_joint_estimate(tmp_path, shots, capsys):
    """README's dive.csv as written (file names: generated DNGs; the corners of the
    generated photo), a depth_sd_m on one row only, with --joint: the default budget and light
    field, as the README's command (25 s; the budget rule alone: test_joint.py)."""
    d = tmp_path / "DIVE"
    d.mkdir()
    for i, (n, depth, distance) in enumerate((("IMG_0101.dng", 4.8, 1.2),
                                              ("IMG_0102.dng", 6.1, 1.5),
                                              ("IMG_0103.dng", 5.0, 1.4))):
        shots["render"](d / n, depth, distance, seed=10 + i)
    (d / "dive.csv").write_text(
        "image,depth_m,distance_m,depth_sd_m,distance_sd_m,corners\n"
        "IMG_0101.dng,4.8,1.2,0.1,,\n"
        "IMG_0102.dng,6.1,1.5,,,\n"
        f"IMG_0103.dng,,1.4,,,\"{shots['corners']}\"\n")
    out = tmp_path / "results"
    code = main(["measure", str(d), "--metadata", str(d / "dive.csv"), "--profile",
                 str(shots["profile"]), "--joint", "--out", str(out), "--depth", "5",
                 "--corners", shots["corners"], "--scheduler", "synchronous", "--tiff",
                 "none"])
    text = capsys.readouterr().out
    # exit 0: the README's photos are clean, told their geometry, of the profile's camera, so
    # every one is reliable (README: "Exit status 0: reliable; 1: measured but not reliable")
    assert code == 0 and (out / "joint.json").exists(), text
    assert "joint: C" in text and "what the dive measures: measured: c(443)" in text
    rows = {Path(r["image"]).name: r for r in _csv(out / "summary.csv")}
    assert [r["reliable"] for r in rows.values()] == ["True"] * 3, rows
    assert float(rows["IMG_0101.dng"]["depth_sd"]) == 0.1


def test_joint_budgets_may_differ_in_per_photo_sds_only(meas):
    from measure.joint import fit_joint

    rec = meas.to_dict()
    other = json.loads(json.dumps(rec, default=float))
    other["inputs"]["uncertain"] = dict(rec["inputs"]["uncertain"]) | {"patch": 0.05}
    with pytest.raises(ValueError, match=r"records: .*patch.*same"):
        fit_joint([rec, other], setup=meas.setup)


def test_dask_jobs_carry_absolute_paths(tmp_path, shots, monkeypatch):
    import os

    from measure.dive import run as run_mod

    _folder(tmp_path, shots, ["a.dng"], rows={"a.dng": 5})
    shutil.copy(shots["profile"], tmp_path / "profile.json")
    seen = []

    def capture(jobs, scheduler, on_result):
        seen.extend(jobs)
        return {job["key"] for job in jobs}  # as if interrupted before running them

    monkeypatch.setattr(run_mod, "execute", capture)
    monkeypatch.setattr(run_mod, "check_scheduler", lambda s: None)  # never connected to
    monkeypatch.chdir(tmp_path)
    dive.measure_dive("dive", out="out", metadata="dive/dive.csv", profile="profile.json",
                      scheduler="tcp://127.0.0.1:1", report=False, figure=False, **FAST)
    assert len(seen) == 1
    job = seen[0]
    for path in (job["image"], job["out"], job["options"]["profile"]):
        assert os.path.isabs(path), path


@pytest.mark.slow
def test_a_real_scheduler_from_another_cwd_measures_relative_paths(tmp_path, shots,
                                                                   monkeypatch):
    import os

    from distributed import Client, LocalCluster

    _folder(tmp_path, shots, ["a.dng"], rows={"a.dng": 5})
    shutil.copy(shots["profile"], tmp_path / "profile.json")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                      dashboard_address=":0") as cluster, Client(cluster) as client:
        client.run(os.chdir, str(elsewhere))  # the workers run in another folder
        monkeypatch.chdir(tmp_path)
        res = dive.measure_dive("dive", out="out", metadata="dive/dive.csv",
                                profile="profile.json", scheduler=cluster.scheduler_address,
                                report=False, figure=False, **FAST)
    assert [r["status"] for r in res.rows] == ["measured"], res.rows


def test_ctrl_c_while_the_local_cluster_starts_stops_the_run(tmp_path, shots, monkeypatch):
    import os
    import signal

    import distributed

    d = _folder(tmp_path, shots, ["a.dng", "b.dng"], rows={"a.dng": 5, "b.dng": 5})
    closed = []

    class Starting:  # Ctrl-C arrives while the cluster starts
        def __init__(self, *args, **kwargs):
            os.kill(os.getpid(), signal.SIGINT)

        def close(self, *args, **kwargs):
            closed.append(True)

    def no_client(*args, **kwargs):
        raise AssertionError("the run went on after Ctrl-C")

    monkeypatch.setattr(distributed, "LocalCluster", Starting)
    monkeypatch.setattr(distributed, "Client", no_client)
    handler = signal.getsignal(signal.SIGINT)
    res = _run(d, tmp_path / "out", shots, scheduler=None)
    assert res.interrupted and res.code == 130 and closed
    assert [r["status"] for r in _csv(res.summary)] == ["interrupted", "interrupted"]
    assert signal.getsignal(signal.SIGINT) is handler


def test_the_worker_start_up_ignores_ctrl_c():
    import signal

    from measure.dive import worker

    old = signal.getsignal(signal.SIGINT)
    try:
        worker.dask_setup(None)
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGINT, old)


def test_a_killed_runs_temporary_files_are_removed(tmp_path, shots):
    d = _folder(tmp_path, shots, ["a.dng"], rows={"a.dng": 5})
    out = tmp_path / "out"
    out.mkdir()
    left = [out / ".survey.nc.k2j3h4g5.tmp", out / ".summary.csv.abc_1234.tmp",
            out / ".joint.json.zz9y8x7w.tmp", out / ".survey.png.q1w2e3r4.tmp"]
    mine = [out / ".notes.tmp", out / ".survey.nc.keep", out / "x.survey.nc.a.tmp"]
    for p in left + mine:
        p.write_text("half")
    _run(d, out, shots)
    assert not [p for p in left if p.exists()] and all(p.exists() for p in mine)


def test_a_second_run_into_the_same_out_is_refused(tmp_path, shots):
    d = _folder(tmp_path, shots, ["a.dng", "b.dng"], rows={"a.dng": 5, "b.dng": 5})
    out = tmp_path / "out"
    out.mkdir()
    (out / ".uw3p.lock").write_text("")  # a killed run's lock file: no holder, no block
    refused = []

    def second_run(row):  # while the first run writes into out
        with pytest.raises(ValueError, match="^out: another uw3p run is writing") as exc:
            _run(d, out, shots)
        refused.append(str(exc.value))

    res = _run(d, out, shots, progress=second_run)
    assert len(refused) == 2 and [r["status"] for r in res.rows] == ["measured", "measured"]
    assert [r["status"] for r in _run(d, out, shots).rows] == ["done earlier"] * 2
    assert not (out / ".uw3p.lock").exists()  # a clean run leaves no lock file


def test_the_lock_file_goes_with_the_run_and_a_removed_one_is_not_shared(tmp_path):
    """No .uw3p.lock is left after a run; a run whose opened lock file was removed by a run
    that ended (it locks a file no longer in the folder) is refused, not let in beside a
    third run that locks the new file."""
    import os

    from measure.dive.files import locked

    out = tmp_path / "out"
    with locked(out):
        assert (out / ".uw3p.lock").exists()
    assert not (out / ".uw3p.lock").exists()
    real_open = os.open

    def open_then_removed(path, *a, **k):  # the previous run removes the file after our open
        fd = real_open(path, *a, **k)
        os.unlink(path)
        return fd

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(os, "open", open_then_removed)
        with pytest.raises(ValueError, match="^out: another uw3p run is writing"):
            with locked(out):
                pass


def test_an_out_that_cannot_be_written_is_bad_input(tmp_path, shots, monkeypatch, capsys):
    import errno
    import os

    d = _folder(tmp_path, shots, ["a.dng"], rows={"a.dng": 5})
    ro = tmp_path / "ro"
    ro.mkdir()
    if os.geteuid() == 0:  # root writes anywhere: a read-only file system simulated
        real_open, real_mkdir = os.open, os.mkdir

        def refuse(real):
            def call(path, *args, **kwargs):
                if str(os.fspath(path)).startswith(str(ro)):
                    raise PermissionError(errno.EROFS, "Read-only file system", str(path))
                return real(path, *args, **kwargs)
            return call

        monkeypatch.setattr(os, "open", refuse(real_open))
        monkeypatch.setattr(os, "mkdir", refuse(real_mkdir))
    else:
        ro.chmod(0o555)
    try:
        for out in (ro, ro / "results"):
            code = main(["measure", str(d), "--metadata", str(d / "dive.csv"), "--profile",
                         str(shots["profile"]), "--exact", "--scheduler", "synchronous",
                         "--tiff", "none", "--out", str(out)])
            err = capsys.readouterr().err
            assert code == 2 and "uw3p measure: error: --out: " in err, err
            assert "Traceback" not in err
    finally:
        ro.chmod(0o755)
