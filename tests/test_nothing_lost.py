"""Issue 45 ("Nothing lost, nothing silently wrong"): a correction never deletes what it reads
or a measurement; a plan never overwrites a file; ifdo.json's exposure factor is one quantity;
outputs follow the user's umask; unclear inputs are one-line errors naming the option."""

import io
import json
import os
import stat
from pathlib import Path

import pytest

import measure
from uw3p.cli import main


@pytest.fixture(scope="module")
def shot(tmp_path_factory, fast_shot):
    """One chart photo measured (tests/conftest.py's fast_shot), its results in tmp/R
    (measurement.json, ...)."""
    tmp = tmp_path_factory.mktemp("nothing_lost")
    measure.write_outputs(fast_shot["meas"], tmp / "R", report=False)
    return {"dng": fast_shot["dng"], "meas": fast_shot["meas"], "R": tmp / "R", "tmp": tmp}


def _run(argv):
    """``uw3p`` in-process: (exit status, stdout, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    code = main(argv, out, err)
    return code, out.getvalue(), err.getvalue()


def _contents(folder):
    return {p.name: p.read_bytes() for p in folder.iterdir()}


def test_correct_refuses_the_measurement_folder_that_holds_its_water(shot):
    """`uw3p correct A.dng --water R/measurement.json --out R` deleted R's measurement.json,
    corrected.png ... (the folder counted as the same photo's results): now exit 2, one line
    naming --out, and R byte for byte as it was."""
    before = _contents(shot["R"])
    code, _, err = _run(["correct", str(shot["dng"]), "--water",
                         str(shot["R"] / "measurement.json"), "--range", "1.5",
                         "--out", str(shot["R"])])
    assert code == 2
    assert err.count("\n") == 1 and "--out" in err and "input" in err
    assert _contents(shot["R"]) == before


def test_correct_refuses_a_measurement_folder_of_the_same_photo(shot, tmp_path):
    """A measurement's folder (a measurement.json of the same photo) is never replaced by a
    correction, even when the --water file lies elsewhere."""
    water = tmp_path / "water.json"
    water.write_bytes((shot["R"] / "measurement.json").read_bytes())
    before = _contents(shot["R"])
    code, _, err = _run(["correct", str(shot["dng"]), "--water", str(water), "--range", "1.5",
                         "--out", str(shot["R"])])
    assert code == 2
    assert err.count("\n") == 1 and "--out" in err and "measurement" in err
    assert _contents(shot["R"]) == before


def test_write_corrected_refuses_a_folder_holding_its_range_map(shot, tmp_path):
    """The library refuses too: a range map inside the output folder survives."""
    import numpy as np

    from forward.errors import InputError

    out = tmp_path / "C"
    out.mkdir()
    rmap = out / "range.npy"
    np.save(rmap, np.full((24, 36), 1.5, np.float32))
    corr = measure.correct_image(shot["meas"].photo, shot["meas"], rmap, linear=False)
    with pytest.raises(InputError) as exc:
        measure.write_corrected(corr, out, record={}, tiff="none", inputs=[rmap])
    assert exc.value.argument == "out"
    assert sorted(p.name for p in out.iterdir()) == ["range.npy"]


def test_ifdo_exposure_factor_is_one_quantity_for_measured_and_chartless_rows(shot, tmp_path):
    """ifdo.json's photometric-exposure-factor-RGB held the von Kries gains (~10) for a measured
    photo and model units per raw unit (~0.001) for a chartless frame: now both are corrected.tiff
    units per raw unit at the chart's distance. The same photo as both kinds of row (same
    exposure, same water, same range) gives factors that agree to within the white they
    normalise (the white patch, a perfect white)."""
    import numpy as np

    from measure.correct import seathru_coefficients
    from measure.dive.ifdo import ifdo_fields
    from measure.dive.summary import CORRECTED, MEASURED

    meas = shot["meas"]
    corr = measure.correct_image(meas.photo, meas, 1.5, linear=False)
    measure.write_corrected(corr, tmp_path / "frame", record={
        "seathru": seathru_coefficients(corr.table)}, tiff="none")
    rows = [{"image": "/d/A.dng", "status": sorted(MEASURED)[0]},
            {"image": "/d/frame.dng", "status": CORRECTED, "out": str(tmp_path / "frame")}]
    items = ifdo_fields(rows, {"/d/A.dng": meas.to_dict()})["image-set-items"]
    key = "photometric-exposure-factor-RGB"
    measured = np.array(items["A.dng"]["image-photometric-calibration"][key])
    chartless = np.array(items["frame.dng"]["image-photometric-calibration"][key])
    assert measured == pytest.approx(meas.gains)
    ratio = chartless / measured
    assert np.all((ratio > 0.7) & (ratio < 1.3)), ratio
    assert ratio == pytest.approx(np.full(3, ratio.mean()), rel=1e-3)  # one common factor


def test_result_folders_and_run_files_follow_the_umask(shot, tmp_path):
    """Under umask 022 a photo's result folder was 0700 and a dive's summary.csv, ifdo.json,
    run.json ... 0600 (tempfile's private modes kept by the rename): now 0755 and 0644, from
    the writers themselves (measure.write_outputs, the dive's atomic files, the CLI's)."""
    from measure.dive.files import atomic
    from uw3p.common import write_atomic

    old = os.umask(0o022)
    try:
        measure.write_outputs(shot["meas"], tmp_path / "m", report=False, tiff="none")
        with atomic(tmp_path / "summary.csv") as tmp:
            tmp.write_text("image\n", encoding="utf-8")
        write_atomic(tmp_path / "plan.csv", lambda fh: fh.write("image\n"))
    finally:
        os.umask(old)

    def mode(p):
        return stat.S_IMODE(p.stat().st_mode)
    assert mode(tmp_path / "m") == 0o755
    files = [*(tmp_path / "m").iterdir(), tmp_path / "summary.csv", tmp_path / "plan.csv"]
    assert {p.name: mode(p) for p in files} == {p.name: 0o644 for p in files}


DESIGN = ["design", "--chl", "1", "--cdom", "0.1", "--camera-only", "--target", "C=20%"]


def test_a_plan_never_overwrites_the_dives_metadata(tmp_path):
    """`uw3p design --plan dive.csv` over a dive.csv with real depths replaced it with
    placeholder rows without a word: now refused (exit 2, --plan named, the file as it was);
    --overwrite replaces it and says what it wrote (the path and the number of rows)."""
    plan = tmp_path / "dive.csv"
    plan.write_text("image,depth_m,distance_m\nIMG_0101.ORF,4.8,1.2\n", encoding="utf-8")
    before = plan.read_bytes()
    argv = DESIGN + ["--depth", "5", "--distance", "1", "--plan", str(plan)]
    code, out, err = _run(argv)
    assert code == 2 and err.count("\n") == 1
    assert err.startswith("uw3p design: error: --plan: ") and "--overwrite" in err
    assert plan.read_bytes() == before and out == ""
    code, out, err = _run(argv + ["--overwrite"])
    assert code == 0, err
    rows = plan.read_text(encoding="utf-8").splitlines()
    assert rows[1:] == ["PHOTO_01.dng,5,1"]
    assert f"wrote {plan}: {len(rows) - 1} row(s)" in out


@pytest.mark.parametrize("distance", [["0"], ["-1"], ["0", "2"]])
def test_design_refuses_a_distance_not_above_zero(distance):
    """`--distance 0` planned photos "from 0 m" (the light crossing no water to the chart)."""
    code, out, err = _run(DESIGN + ["--depth", "5", "--distance", *distance])
    assert code == 2 and out == "" and err.count("\n") == 1
    assert err.startswith("uw3p design: error: --distance: ") and "> 0" in err


def test_design_refuses_depths_beyond_daylights_reach():
    """`--depth 2 500` recommended photos at 251-500 m: refused, naming --depth and the limit
    (cmd_design.daylight_depth of the guessed water); a depth within it is still designed."""
    from forward import Water
    from uw3p.cmd_design import daylight_depth

    reach = daylight_depth(1.0, 0.1, Water())
    assert 15 < reach < 500
    code, out, err = _run(DESIGN + ["--depth", "2", "500", "--distance", "1"])
    assert code == 2 and out == "" and err.count("\n") == 1
    assert err.startswith("uw3p design: error: --depth: 500 m is beyond daylight's reach")
    assert f"{reach:.0f} m" in err
    assert _run(DESIGN + ["--depth", "2", f"{0.9 * reach:.1f}", "--distance", "1"])[0] in (0, 1)


def test_metadata_with_two_columns_of_one_kd_band_is_refused(shot, tmp_path):
    """kd_490 and kd_490.0 name the same quantity; one was silently kept. Now one line naming
    --metadata and both columns, nothing measured."""
    dive = tmp_path / "dive"
    dive.mkdir()
    (dive / "A.dng").write_bytes(Path(shot["dng"]).read_bytes())
    meta = tmp_path / "dive.csv"
    meta.write_text("image,depth_m,distance_m,kd_490,kd_490_sd,kd_490.0,kd_490.0_sd\n"
                    "A.dng,5,1.5,0.1,0.01,0.3,0.01\n", encoding="utf-8")
    code, _, err = _run(["measure", str(dive), "--metadata", str(meta),
                         "--out", str(tmp_path / "out")])
    assert code == 2 and err.count("\n") == 1
    assert "--metadata" in err and "kd_490 " in err and "kd_490.0" in err
    assert not (tmp_path / "out" / "A_dng").exists()
