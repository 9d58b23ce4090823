"""Chart detection (issue 18): measure.find_chart on whole rendered photographs (experiments.scene,
a renderer that shares no code with forward) and on a real underwater JPEG; measure.measure and
uw3p calibrate without corners."""

import csv
import io
import json
from pathlib import Path

import numpy as np
import pytest

import measure
from experiments.independent_world import render_calibration, render_chart
from experiments.scene import card_corners, render_scene, write_dng
from measure.chart import orientations
from measure.detect import ChartNotFound, find_chart

#: The frame of the rendered scenes (height, width), pixels
FRAME = (600, 900)
#: A patch centre found within this many pitches of the truth counts as right: the sampled
#: square (half a pitch, measure.chart.LAYOUTS) then stays inside its patch (0.9 pitch:
#: experiments.scene.PATCH_SIDE), which allows 0.2 pitch
CENTRE_PITCH = 0.15
#: The grid's corners, extrapolated half a pitch beyond the outer centres, within this
CORNER_PITCH = 0.25
REALDATA = Path(__file__).resolve().parents[1].parent / "shared" / "realdata"
REAL_JPEG = REALDATA / "underwater_chart_jpeg" / "andieich_test_photo.jpg"
#: ../shared/realdata/README.md: centres of patches 1, 6, 19, 24 (full-resolution pixels) and
#: the row pitch
REAL_CENTRES = {0: (1510, 1260), 5: (2300, 1670), 18: (1200, 1740), 23: (2060, 2160)}
REAL_PITCH = 178.0


@pytest.fixture(scope="module")
def patches():
    """Camera RGB of the 24 patches 8 m down in green-blue water (the second renderer)."""
    return render_chart(1.0, 0.1, 8.0, 1.5, noise=False, backscatter="single_scatter")["expected"]


def _photo(image):
    """A measure.Photo (linear RGB, 16-bit scale) of a rendered image."""
    scale = 65535.0
    return measure.Photo("scene", "rgb", (image * scale).astype(np.float32), None,
                         np.any(image >= 1.0, axis=-1),
                         np.full(3, scale), np.zeros(3))


def _scene(patches, width, rotation, perspective=(0.0, 0.0), mirrored=False, seed=0,
           exposure=0.06, **kw):
    corners = card_corners(FRAME, width_fraction=width, rotation_deg=rotation,
                           perspective=perspective, mirrored=mirrored, centre=(0.5, 0.52))
    return render_scene(patches, corners, size=FRAME, seed=seed, exposure=exposure,
                        glints=4, **kw)


#: name -> (width fraction, rotation deg, perspective, mirrored): 0/90/180/270° and oblique,
#: foreshortened, mirrored, 10 % and 60 % of the frame width
CASES = {"0°, 60 % of the frame": (0.6, 0.0, (0.0, 0.1)),
         "90°, foreshortened": (0.3, 90.0, (0.25, -0.1)),
         "180°, mirrored": (0.3, 180.0, (0.0, 0.0), True),
         "270°, 10 % of the frame": (0.1, 270.0, (0.1, 0.0)),
         "27°, foreshortened, mirrored": (0.35, 27.0, (-0.15, 0.25), True)}


@pytest.mark.parametrize("name", list(CASES))
def test_found_at_any_pose_on_a_dark_reef(patches, name):
    """Every pose on a dark (brightest patch 6 % of full scale), textured, colour-cast reef:
    the patch centres within CENTRE_PITCH and the grid's corners within CORNER_PITCH, in the
    project's order after the grey-row check (patch 1 corner first), with a reported orientation that matches the truth."""
    args = CASES[name]
    scene = _scene(patches, *args, seed=len(name))
    det = find_chart(_photo(scene["image"]))
    err = np.max(np.hypot(*(det.centres - scene["centres"]).T)) / scene["pitch"]
    assert err < CENTRE_PITCH, (name, err)
    err = np.max(np.hypot(*(det.corners - scene["grid_corners"]).T)) / scene["pitch"]
    assert err < CORNER_PITCH, (name, err)
    assert det.orientation["grey_row"] is True
    assert det.orientation["mirrored"] == (len(args) > 3 and args[3])
    assert 0.5 < det.confidence <= 1.0
    assert det.patches_found >= 8
    # measure's own orientation check keeps the order given
    assert orientations(_photo(scene["image"]), det.corners)["as given"][2]


def test_colours_alone_orient_the_chart(patches):
    """On an RGB array (no grey-row check), the colours choose the right one of the eight
    orders, here for a chart upside down and mirrored."""
    scene = _scene(patches, 0.3, 180.0, mirrored=True, seed=5)
    det = find_chart(scene["image"])
    err = np.max(np.hypot(*(det.centres - scene["centres"]).T)) / scene["pitch"]
    assert err < CENTRE_PITCH
    assert det.orientation["grey_row"] is None
    assert det.colour_r2 > det.runner_up_r2


def test_card_layout_gives_the_card_corners(patches):
    scene = _scene(patches, 0.35, 30.0, exposure=0.3, seed=3)
    det = find_chart(scene["image"], layout="card")
    err = np.max(np.hypot(*(det.corners - scene["card_corners"]).T)) / scene["pitch"]
    assert err < CORNER_PITCH


def test_chartless_frame_is_not_a_chart(patches):
    scene = _scene(patches, 0.3, 0.0, seed=11, chart=False)
    with pytest.raises(ChartNotFound, match="no chart found"):
        find_chart(_photo(scene["image"]))


def test_flat_frame_and_bad_input():
    with pytest.raises(ChartNotFound, match="no chart found"):
        find_chart(np.full((200, 300, 3), 0.2, np.float32))
    with pytest.raises(ValueError, match="image"):
        find_chart(np.zeros((200, 300)))
    with pytest.raises(ValueError, match="layout"):
        find_chart(np.zeros((200, 300, 3)), layout="poster")


def test_real_underwater_jpeg():
    """The real photo (../shared/realdata): patch centres within 0.3 pitch of the README's, not
    mirrored, turned ~27° clockwise (colour-checker-detection issue #73: flipped)."""
    if not REAL_JPEG.is_file():
        pytest.skip(f"real data absent: {REAL_JPEG} (../shared/realdata beside the repository)")
    import colour
    import cv2

    decode = colour.cctf_decoding(np.arange(256) / 255, "sRGB").astype(np.float32)
    det = find_chart(decode[cv2.imread(str(REAL_JPEG), cv2.IMREAD_COLOR)[..., ::-1]])
    for j, xy in REAL_CENTRES.items():
        assert np.hypot(*(det.centres[j] - xy)) / REAL_PITCH < 0.3, j
    assert det.orientation["mirrored"] is False
    assert abs(det.orientation["rotation_deg"] - 27) < 5


@pytest.fixture(scope="module")
def dive(tmp_path_factory, patches):
    """A rendered RAW (DNG) of the chart underwater, and its true grid corners."""
    tmp = tmp_path_factory.mktemp("detect")
    corners = card_corners(FRAME, width_fraction=0.45, rotation_deg=160.0,
                           perspective=(0.15, 0.1), centre=(0.45, 0.5))
    scene = render_scene(patches, corners, size=FRAME, seed=7, exposure=0.5, glints=2)
    return write_dng(tmp / "uw.dng", scene["image"]), scene


def test_measure_without_corners_samples_as_with_true_ones(dive):
    """measure.measure(..., corners=None) on a RAW photo: the chart found, the same patch
    values as with the true corners (within the pixels' own noise), recorded in inputs."""
    path, scene = dive
    found = measure.measure(path, depth=8.0, distance=1.5, light_field="none")
    true = measure.measure(path, corners=scene["grid_corners"], depth=8.0, distance=1.5,
                           light_field="none")
    assert true.orientation == "as given"
    assert found.orientation.startswith("detected: rotated") and \
        found.orientation.endswith(", not mirrored")
    chart = found.inputs["chart"]
    assert chart["detected"] is True and chart["method"].startswith("grid")
    assert true.inputs["chart"]["detected"] is False
    se = np.hypot(found.sample.sigma, true.sample.sigma)
    assert np.all(np.abs(found.sample.rgb - true.sample.rgb) < 4 * se)
    assert np.max(np.abs(found.corners - true.corners)) / scene["pitch"] < CORNER_PITCH


def test_measure_chartless_raw_is_an_error(tmp_path, patches):
    scene = _scene(patches, 0.3, 0.0, seed=12, chart=False)
    path = write_dng(tmp_path / "empty.dng", scene["image"])
    with pytest.raises(ValueError, match="no chart found"):
        measure.measure(path, depth=5.0, distance=1.0)


def test_chart_partly_outside_the_frame_is_said_so(tmp_path, patches):
    """A chart cut by the frame's right edge, no --corners given: the detector's corners lie
    beyond the image; the error names the image and the cause (issue 35: it blamed --corners,
    which the user had not given), in measure.measure, uw3p measure and uw3p calibrate."""
    from uw3p.cli import main

    size = (300, 450)
    corners = card_corners(size, width_fraction=0.45, centre=(0.85, 0.5))
    scene = render_scene(patches, corners, size=size, seed=7, exposure=0.5)
    assert scene["grid_corners"][:, 0].max() > size[1]  # the patch grid itself is cut
    path = write_dng(tmp_path / "cut.dng", scene["image"])
    with pytest.raises(ValueError, match=r"^image: the chart found lies partly outside the "
                                         r"frame .*next to patch 6, 24") as exc:
        measure.measure(path, depth=8.0, distance=1.5, light_field="none", uncertain={})
    assert "--corners" not in str(exc.value) and "whole chart" in str(exc.value)
    for argv in (["measure", path, "--depth", "8", "--distance", "1.5", "--exact", "--out",
                  str(tmp_path / "m")], ["calibrate", path, "--out", str(tmp_path / "p.json")]):
        out, err = io.StringIO(), io.StringIO()
        assert main(argv, out, err) == 2
        assert err.getvalue().startswith(f"uw3p {argv[0]}: error: image: the chart found lies "
                                         "partly outside the frame"), err.getvalue()


def test_detected_chart_rotated_and_mirrored_is_reported_so(tmp_path, patches):
    """A chart turned 177° and seen in a mirror, no --corners: the detector finds it, and the
    orientation reported (Measurement, measurement.json, the command's print, summary.csv)
    says so; 'as given' is for corners given and used as given (issue 35)."""
    from uw3p.cli import main

    size = (300, 450)
    corners = card_corners(size, width_fraction=0.5, rotation_deg=177.0, mirrored=True)
    scene = render_scene(patches, corners, size=size, seed=7, exposure=0.5)
    path = write_dng(tmp_path / "turned.dng", scene["image"])
    said = "detected: rotated 177° clockwise, mirrored"
    m = measure.measure(path, depth=8.0, distance=1.5, light_field="none", uncertain={})
    assert np.max(np.hypot(*(m.corners - scene["grid_corners"]).T)) / scene["pitch"] < CORNER_PITCH
    assert m.orientation == said
    assert m.inputs["chart"]["orientation"]["mirrored"] is True
    assert abs(m.inputs["chart"]["orientation"]["rotation_deg"] - 177) < 1
    given = measure.measure(path, corners=scene["grid_corners"], depth=8.0, distance=1.5,
                            light_field="none", uncertain={})
    assert given.orientation == "as given"
    out, err = io.StringIO(), io.StringIO()
    assert main(["measure", path, "--depth", "8", "--distance", "1.5", "--exact", "--tiff",
                 "none", "--out", str(tmp_path / "m")], out, err) in (0, 1), err.getvalue()
    assert f"orientation      {said}\n" in out.getvalue()
    assert json.loads((tmp_path / "m" / "measurement.json").read_text())["orientation"] == said
    folder = tmp_path / "dive"
    folder.mkdir()
    (folder / "turned.dng").write_bytes(Path(path).read_bytes())
    res = measure.measure_dive(folder, out=tmp_path / "d", depth=8.0, distance=1.5,
                               scheduler="synchronous", light_field="none", uncertain={})
    with open(res.summary, newline="", encoding="utf-8") as f:
        assert [r["orientation"] for r in csv.DictReader(f)] == [said]


def test_calibrate_cli_without_corners(tmp_path):
    """uw3p calibrate finds the chart in air and reports the corners it used."""
    from uw3p.cli import main

    air = render_calibration(noise=False)["expected"]
    scene = render_scene(air, card_corners(FRAME, width_fraction=0.4, rotation_deg=-90.0),
                         size=FRAME, seed=4, exposure=0.7, cast=(1.0, 1.0, 1.0),
                         background_level=0.3)
    path = write_dng(tmp_path / "air.dng", scene["image"])
    out, err = io.StringIO(), io.StringIO()
    code = main(["calibrate", path, "--out", str(tmp_path / "p.json")], out, err)
    assert code in (0, 1), err.getvalue()
    assert "chart found: corners" in err.getvalue()
    assert (tmp_path / "p.json").is_file()
