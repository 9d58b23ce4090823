"""Issue 45 (items 3, 5, 7): a correction applies the water's own camera and calibration,
refuses another camera's photo, says when it extrapolates in depth (and refuses far beyond),
refuses a water it cannot read or that is implausible, each naming the option; a dive's
chartless frame carries the dive water's verdict."""

import dataclasses
import json

import numpy as np
import pytest

import forward
import measure
from measure.synthetic_photo import Scene, default_corners, render_mosaic, write_dng
from forward.errors import InputError
from measure.camera import camera_setup, load_profile, profile_digest
from measure.correctwater import DEPTH_EXTRAPOLATION_MAX_M, correction_water
from uw3p.cli import main

W, H = 480, 320
FAST = {"uncertain": {}, "light_field": "none"}
MAKE, MODEL = "NIKON CORPORATION", "NIKON D5100"


@pytest.fixture(scope="module")
def shot(tmp_path_factory):
    """A calibration in air, a photo of the chart at 5 m measured with it, and the same scene
    from another camera (other EXIF Make/Model)."""
    tmp = tmp_path_factory.mktemp("checks")
    setup = forward.chart_setup(channel_gains=(0.55, 1.0, 0.7))
    corners = default_corners(W, H)

    def render(path, depth=0.0, distance=0.0, chl=0.0, cdom=0.0, gain=9000, **exif):
        scene = Scene(chl=chl, cdom=cdom, depth=depth, distance=distance, gain=gain, width=W,
                      height=H, seed=2)
        return write_dng(render_mosaic(scene, corners, setup=setup), path,
                         **({"make": MAKE, "model": MODEL} | exif))
    air = render(tmp / "air.dng")
    prof = measure.calibrate(measure.sample_patches(measure.read_image(air), corners), image=air)
    prof_path = tmp / "profile.json"
    prof_path.write_text(json.dumps(dataclasses.asdict(prof)))
    uw = dict(depth=5.0, distance=1.5, chl=2.0, cdom=0.1, gain=30000)
    dng = render(tmp / "uw.dng", **uw)
    meas = measure.measure(dng, corners=corners, depth=5.0, distance=1.5,
                           profile=str(prof_path), **FAST)
    measure.write_outputs(meas, tmp / "m", report=False)
    other = render(tmp / "other.dng", make="Canon", model="Canon EOS R5", **uw)
    return {"tmp": tmp, "dng": dng, "other": other, "json": tmp / "m" / "measurement.json",
            "profile": prof_path, "meas": meas}


def _edit(shot, tmp_path, change) -> str:
    """measurement.json with ``change`` applied to its content, written in tmp_path."""
    rec = json.loads(shot["json"].read_text())
    change(rec)
    path = tmp_path / "water.json"
    path.write_text(json.dumps(rec))
    return str(path)


def _joint(shot, depths=(4.0, 8.0), camera=True) -> dict:
    """joint.json's content around the measurement: its water, photos at ``depths``."""
    rec = json.loads(shot["json"].read_text())
    e = rec["estimate"]
    photos = {f"p{d:g}.dng": {"gain": e["gain"], "backscatter": e["backscatter"], "depth": d,
                              "distance": 1.5} for d in depths}
    return {"chl": e["chl"], "cdom": e["cdom"], "chl_ci": e["chl_ci"], "cdom_ci": e["cdom_ci"],
            "path_model": e["path_model"], "nuisance": {}, "reliable": True, "flags": [],
            "photos": photos} | ({"camera": rec["camera"]} if camera else {})


def _correct(shot, tmp_path, water, *extra, image=None):
    out = tmp_path / "c"
    code = main(["correct", str(image or shot["dng"]), "--water", str(water), "--range", "1.5",
                 "--out", str(out), "--tiff", "none", *extra])
    rec = json.loads((out / "correction.json").read_text()) if code != 2 else None
    return code, rec


def test_a_measurement_records_its_camera_and_calibration(shot):
    """measurement.json names the photo's EXIF Make/Model, the curves and their digest, and
    the profile by path and digest."""
    cam = json.loads(shot["json"].read_text())["camera"]
    assert (cam["make"], cam["model"]) == (MAKE, MODEL)
    assert cam["name"] == forward.DEFAULT_CAMERA and len(cam["curves_sha256"]) == 64
    assert cam["profile"]["path"] == str(shot["profile"].resolve())
    assert cam["profile"]["sha256"] == profile_digest(load_profile(shot["profile"]))


def test_a_joint_water_applies_the_recorded_calibration(shot, tmp_path):
    """The README's command with a joint.json: the profile the dive was measured with is
    applied (before: the default camera's own balance) and correction.json says which water,
    camera and calibration."""
    path = tmp_path / "joint.json"
    path.write_text(json.dumps(_joint(shot)))
    w = correction_water(str(path), depth=5.0)
    calibrated = camera_setup(gains=load_profile(shot["profile"]).gains)
    assert w.setup.sensitivities == pytest.approx(calibrated.sensitivities)
    assert not np.allclose(w.setup.sensitivities, camera_setup().sensitivities, rtol=1e-3)
    code, rec = _correct(shot, tmp_path, path, "--depth", "5")
    assert code in (0, 1)
    assert rec["water_file"]["sha256"] == measure.camera.file_digest(path)
    assert rec["camera"]["profile"]["sha256"] == profile_digest(load_profile(shot["profile"]))
    assert rec["camera"]["recorded"]["model"] == MODEL


def test_a_recorded_profile_that_is_gone_is_refused_naming_profile(shot, tmp_path, capsys):
    def gone(rec):
        rec["camera"]["profile"]["path"] = str(tmp_path / "moved.json")
    water = _edit(shot, tmp_path, gone)
    code, _ = _correct(shot, tmp_path, water)
    err = capsys.readouterr().err
    assert code == 2 and err.startswith("uw3p correct: error: --profile:") and err.count("\n") == 1
    assert not (tmp_path / "c").exists()
    code, rec = _correct(shot, tmp_path, water, "--profile", str(shot["profile"]))
    assert code in (0, 1) and rec["camera"]["profile"]["path"] == str(shot["profile"].resolve())


def test_another_cameras_photo_is_refused_naming_camera(shot, tmp_path, capsys):
    code, _ = _correct(shot, tmp_path, shot["json"], image=shot["other"])
    err = capsys.readouterr().err
    assert code == 2 and err.startswith("uw3p correct: error: --camera:")
    assert "Canon EOS R5" in err and MODEL in err and err.count("\n") == 1
    code, rec = _correct(shot, tmp_path, shot["json"], "--camera", forward.DEFAULT_CAMERA,
                         image=shot["other"])
    assert code in (0, 1) and any("Canon EOS R5" in n for n in rec["notes"])


def test_an_older_measurement_keeps_working_with_a_note(shot, tmp_path):
    """A measurement.json written before the camera was recorded: corrected with its recorded
    gains, a note that the camera could not be checked."""
    def old(rec):
        cam = rec["camera"]
        for k in ("make", "model", "curves_sha256"):
            del cam[k]
        cam["profile"] = {k: cam["profile"][k] for k in ("gains", "illuminant", "image")}
    code, rec = _correct(shot, tmp_path, _edit(shot, tmp_path, old))
    assert code in (0, 1)
    assert any("could not be checked" in n for n in rec["notes"])
    assert rec["camera"]["profile"]["gains"] == pytest.approx(
        load_profile(shot["profile"]).gains)


def test_a_depth_outside_the_measured_ones_is_noted_and_far_outside_refused(shot, tmp_path):
    """A dive measured at 4-8 m: 9 m is corrected with a note, ``extrapolated`` and its cost in
    the uncertainty; 16 m is refused naming depth. A single photo at 5 m likewise."""
    from measure.correct_uncertainty import extrapolation_spread

    joint = _joint(shot)
    assert correction_water(joint, depth=6.0).extrapolated is None
    w = correction_water(joint, depth=9.0)
    assert w.extrapolated["outside_m"] == pytest.approx(1.0)
    assert any(n.startswith("extrapolated") for n in w.notes)
    cost = extrapolation_spread(w)
    assert cost["measured_depth_m"] == 8.0 and max(g["de00"] for g in cost["grey_de00"]) > 0
    with pytest.raises(InputError, match="depth") as exc:
        correction_water(joint, depth=8.0 + DEPTH_EXTRAPOLATION_MAX_M + 0.5)
    assert exc.value.argument == "depth"
    code, rec = _correct(shot, tmp_path, shot["json"], "--depth", "6", "--uncertainty")
    assert code in (0, 1) and rec["extrapolated"]["span_m"] == [5.0, 5.0]
    assert rec["uncertainty"]["extrapolation"]["grey_de00"]
    code, _ = _correct(shot, tmp_path, shot["json"], "--depth", "25")
    assert code == 2


@pytest.mark.parametrize("change", [
    lambda rec: rec["estimate"].pop("backscatter"),
    lambda rec: rec["estimate"].update(gain="abc"),
    lambda rec: rec["estimate"].update(cdom=1e6),
    lambda rec: rec["estimate"].update(chl=-1.0),
], ids=["no-backscatter", "gain-abc", "cdom-1e6", "chl-negative"])
def test_a_broken_or_implausible_water_is_refused_naming_water(shot, tmp_path, capsys, change):
    code, _ = _correct(shot, tmp_path, _edit(shot, tmp_path, change))
    err = capsys.readouterr().err
    assert code == 2 and err.startswith("uw3p correct: error: --water:")
    assert err.count("\n") == 1 and "Traceback" not in err


def test_a_chartless_frame_carries_the_dive_waters_verdict(shot, tmp_path):
    """A chartless frame corrected with an unreliable joint water: its row says so (reliable
    False, the water's flags); a frame beyond the measured depths is flagged ``extrapolated``,
    one far beyond is not corrected and says why."""
    import tifffile

    from measure.dive.chartless import correct_frames

    joint = _joint(shot) | {"reliable": False, "flags": ["two-waters"]}
    rng = np.random.default_rng(0)
    rows = []
    for name, depth in (("near.tif", 6.0), ("deeper.tif", 9.0), ("far.tif", 25.0)):
        tifffile.imwrite(tmp_path / name, rng.integers(2000, 4000, (H, W, 3), dtype=np.uint16),
                         photometric="rgb")
        rows.append({"image": str(tmp_path / name), "status": "no chart", "error": "",
                     "out": str(tmp_path / name.replace(".", "_")), "depth_m": depth,
                     "distance_m": 1.5, "range_m": None, "range_map": None})
    correct_frames(rows, {}, {}, joint, shot["meas"].setup)
    near, deeper, far = rows
    assert near["status"] == deeper["status"] == "corrected with the dive's water"
    assert near["reliable"] is False and near["flags"] == "two-waters"
    assert deeper["flags"] == "two-waters extrapolated"
    assert far["status"] == "no chart" and "depth" in far["error"]


def test_a_dives_joint_json_records_the_camera_that_correct_applies(shot, tmp_path):
    """joint.json of a dive names the photos' camera and calibration as measurement.json does;
    correcting with it applies that calibration."""
    import shutil

    from measure import dive

    d = tmp_path / "dive"
    d.mkdir()
    shutil.copy(shot["dng"], d / "a.dng")
    text = " ".join(f"{x:.2f},{y:.2f}" for x, y in default_corners(W, H))
    res = dive.measure_dive(d, out=tmp_path / "out", depth=5.0, distance=1.5, corners=text,
                            profile=str(shot["profile"]), scheduler="synchronous", joint=True,
                            report=False, figure=False, **FAST)
    assert res.joint is not None, res.joint_error
    cam = json.loads(res.joint.read_text())["camera"]
    assert (cam["make"], cam["model"]) == (MAKE, MODEL)
    assert cam["profile"]["sha256"] == profile_digest(load_profile(shot["profile"]))
    w = correction_water(str(res.joint))
    assert w.camera.profile["sha256"] == cam["profile"]["sha256"]


def test_a_light_given_as_spectra_is_recorded_so_and_asked_for_again():
    """measurement.json's camera record names the light a set-up was built with: a file's path
    as given, 'custom' for spectra in memory (it was 'D65'), and a correction refuses to guess
    'custom' (naming --illuminant)."""
    from pathlib import Path

    import numpy as np

    from forward.spectra import DEFAULT_CAMERA
    from measure.camera import camera_record
    from measure.correctcamera import correction_setup

    assert camera_record(DEFAULT_CAMERA, illuminant=Path("sky.csv"))["illuminant"] == "sky.csv"
    rec = camera_record(DEFAULT_CAMERA, illuminant=np.ones(301))
    assert rec["illuminant"] == "custom"
    with pytest.raises(ValueError, match="^illuminant: .*--illuminant"):
        correction_setup(rec)
