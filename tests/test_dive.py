"""A dive, not a photo (issue 18): per-photo inputs from a metadata CSV and EXIF, every file of
the folder accounted for, distinct output folders, results written whole or not at all, reruns
that skip what is complete, Ctrl-C that leaves a summary, survey.nc with CF names, Dask."""

import csv
import dataclasses
import json
import shutil
import warnings

import numpy as np
import pytest

import forward
import measure
from experiments.synthetic_photo import Scene, default_corners, render_mosaic, write_dng
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
    return {"air": air, "uw": uw, "tif": tif, "profile": prof_path, "corners": text}


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
            and p.name not in ("summary.csv", "survey.nc", "survey.png")}


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
    with pytest.raises(ValueError, match="metadata: cannot read"):
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
    res = _run(d, out, shots)
    by = {r["image"].split("/")[-1]: r for r in res.rows}
    # every file but the hidden one and the metadata CSV itself
    assert sorted(by) == ["IMG_1.dng", "IMG_1.tif", "a.dng", "b.dng", "notes.jpg"]
    assert by["b.dng"]["status"] == "error" and "metadata: no row for b.dng" in by["b.dng"]["error"]
    assert by["notes.jpg"]["status"] == "not an image" and "not a RAW" in by["notes.jpg"]["error"]
    for name in ("a.dng", "IMG_1.dng", "IMG_1.tif"):
        assert by[name]["status"] == "measured", by[name]["error"]
        assert by[name]["depth_source"] == "metadata" and by[name]["corners_source"] == "metadata"
    assert by["a.dng"]["out"].endswith("/a_dng") and by["IMG_1.tif"]["out"].endswith("IMG_1_tif")
    assert json.loads((out / "IMG_1_tif" / "measurement.json").read_text())["image"]["path"] \
        .endswith("IMG_1.tif")
    assert res.code == 2 and not res.interrupted and not list(out.glob(TEMP_PREFIX + "*"))
    rows = _csv(res.summary)
    assert len(rows) == 5 and set(dive.SUMMARY_COLUMNS) == set(rows[0])
    assert {r["status"] for r in rows} == {"measured", "error", "not an image"}
    # the rerun: nothing complete is redone or rewritten
    before = _mtimes(out)
    calls = []
    res2 = _run(d, out, shots, progress=calls.append)
    assert calls == [] and _mtimes(out) == before
    assert [r["status"] for r in res2.rows] == [r["status"].replace("measured", "done earlier")
                                                for r in res.rows]
    assert [r.get("chl") for r in res2.rows] == [r.get("chl") for r in res.rows]
    # other inputs for a photo: its folder is not replaced without overwrite
    (d / "dive.csv").write_text((d / "dive.csv").read_text().replace("a.dng,5,", "a.dng,6,"))
    res3 = _run(d, out, shots)
    a3 = next(r for r in res3.rows if r["image"].endswith("a.dng"))
    assert a3["status"] == "error" and "--overwrite" in a3["error"]
    assert json.loads((out / "a_dng" / "measurement.json").read_text())["inputs"]["depth_m"] == 5
    res4 = _run(d, out, shots, overwrite=True)
    a4 = next(r for r in res4.rows if r["image"].endswith("a.dng"))
    assert a4["status"] == "measured" and a4["depth_m"] == 6.0
    assert json.loads((out / "a_dng" / "measurement.json").read_text())["inputs"]["depth_m"] == 6


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
        assert ds["attenuation"].dims == ("photo", "wavelength")
        assert ds["wavelength"].attrs["units"] == "nm"
        ok = ds["status"].values == "measured"
        assert ok.sum() == 2 and np.isnan(ds["chl"].values[~ok]).all()
        b = ds["chl_bounds"].values[ok]
        assert np.all(b[:, 0] <= ds["chl"].values[ok]) and np.all(ds["chl"].values[ok] <= b[:, 1])
        assert np.all((ds["attenuation"].values[ok] > 0) & (ds["attenuation"].values[ok] < 1))
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
        measure.write_outputs(meas, folder)
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["res"]
    assert set(first) == set(before)


def test_compressed_tiff_is_smaller_and_reads_back_equal(tmp_path, meas):
    import tifffile

    full = measure.write_outputs(meas, tmp_path / "full", report=False, tiff="full")
    small = measure.write_outputs(meas, tmp_path / "small", report=False)
    none = measure.write_outputs(meas, tmp_path / "none", report=False, tiff="none")
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
    pytest.importorskip("measure.joint")
    d = _folder(tmp_path, shots, ["a.dng", "b.dng"], rows={"a.dng": 5, "b.dng": 4})
    res = _run(d, tmp_path / "out", shots, joint=True)
    assert res.joint is not None, res.joint_error
    data = json.loads(res.joint.read_text())
    for key in ("chl", "chl_ci", "cdom", "cdom_ci", "reliable", "flags"):
        assert key in data


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
