"""Issue 48 item 1: the spectral colour correction (a 3 x 3 matrix per range,
measure.correct_matrix) against the diagonal with the same water; its training set held out
from the scored chart; the report's grey-world mapped to the camera's white. No photo is
measured: the water is given (fast)."""

import numpy as np
import pytest

import forward
from experiments.correct_range import camera_white, grey_world
from forward.errors import InputError
from measure.correct import correct_image, correction_table
from measure.correct_matrix import check_held_out, model_response, training_reflectances
from measure.correctwater import CorrectionWater


@pytest.fixture(scope="module")
def water():
    """Coastal water (C = 2 mg m^-3, a_CDOM(440) = 0.1 m^-1) at 5 m, the chart measured at 1 m."""
    return CorrectionWater(chl=2.0, cdom=0.1, chl_ci=(1.5, 2.5), cdom_ci=(0.05, 0.15),
                           water=forward.Water(), nuisance={}, depth=5.0, distance=1.0,
                           backscatter=np.array([300.0, 600.0, 700.0]), gain=30000.0,
                           setup=forward.chart_setup())


def _chart_de00(table, cw, r) -> float:
    """Median ΔE00 of the ColorChecker (not in the training set) seen at range r through the
    model and corrected by ``table``, against its appearance in air."""
    from skimage.color import deltaE_ciede2000, xyz2lab

    setup = cw.setup
    veil = np.array([np.interp(r, table.ranges, table.veil[:, c]) for c in range(3)])
    raw = cw.gain * model_response(cw, [r], setup.reflectances)[0].T + veil  # (24, 3)
    air = (setup.sensitivities.T @ (setup.illuminant[:, None] * setup.reflectances)).T
    to_xyz = forward.camera_to_xyz_matrix(setup)
    lab = [xyz2lab(v @ to_xyz.T, illuminant="D65", observer="2", channel_axis=-1)
           for v in (table.apply(raw, np.full(24, r)), air)]
    return float(np.median(deltaE_ciede2000(*lab, channel_axis=-1)))


def test_the_matrix_beats_the_diagonal_on_a_held_out_chart_far_away(water):
    """At 5-7 m the matrix's median ΔE00 on the ColorChecker is below the diagonal's with the
    same water (the diagonal's floor: each reflectance's spectrum changes what a channel
    loses), and a white still comes back white (the matrix preserves it)."""
    matrix = correction_table(water)
    diagonal = correction_table(water, method="diagonal")
    assert matrix.method == "matrix" and diagonal.method == "diagonal"
    for r in (5.0, 7.0):
        m, d = _chart_de00(matrix, water, r), _chart_de00(diagonal, water, r)
        assert m < d - 1.0, (r, m, d)
    ranges = np.array([0.5, 3.0, 6.5])
    white = water.gain * model_response(water, ranges, np.ones((301, 1)))[:, :, 0]
    veil = np.stack([np.interp(ranges, matrix.ranges, matrix.veil[:, c]) for c in range(3)], -1)
    assert matrix.apply(white + veil, ranges) == pytest.approx(
        np.broadcast_to(water.setup.white_response, (3, 3)), rel=1e-4)  # the table's 1e-4


def test_the_training_set_shares_no_sample_with_the_chart():
    """The 29 CIE 1995 / NIST CQS 9.0 samples exclude every ColorChecker patch; a chart that
    holds one of them is refused, naming the argument."""
    setup = forward.chart_setup()
    names, train = training_reflectances(setup.wavelengths)
    assert train.shape == (setup.wavelengths.size, 29) and len(set(names)) == 29
    check_held_out(setup.reflectances, train)  # no error
    mixed = np.column_stack([setup.reflectances[:, :5], train[:, 7]])
    with pytest.raises(InputError, match="chart"):
        check_held_out(mixed, train, "chart")


def test_grey_world_of_a_neutral_world_maps_to_the_cameras_white(water):
    """A frame of a neutral grey seen through the water comes out, after grey-world, with the
    colour of the camera's white in air (P^T i, about 0.58, 1, 0.85), not (1, 1, 1)."""
    setup = water.setup
    through = model_response(water, np.linspace(1.0, 6.0, 8), np.full((301, 1), 0.18))[:, :, 0]
    img = np.broadcast_to(through[None], (4, 8, 3))
    white = camera_white(setup)
    assert white == pytest.approx([0.58, 1.0, 0.85], abs=0.01)
    out = grey_world(img, white).reshape(-1, 3)
    assert out.mean(axis=0) == pytest.approx(white, rel=1e-9)


def test_a_bad_method_is_refused_naming_it(water):
    with pytest.raises(InputError, match="method"):
        correction_table(water, method="vonkries")
    with pytest.raises(InputError, match="method"):
        correct_image("missing.dng", water, 2.0, method="matrices")


def test_readme_picture_shows_the_frame_as_shot_with_the_daylight_balance(tmp_path):
    """The README's before/after (experiments.correct_range._figure): 'before' is the camera's
    own colours (white-balanced for daylight in air), not balanced on the chart underwater, so
    a blue-green frame stays blue-green while the corrected one shows its own colours."""
    from PIL import Image

    from experiments.correct_range import _figure

    setup = forward.chart_setup()
    white = camera_white(setup)
    tint = white * np.array([0.15, 0.6, 0.5])  # the water took the red
    shot = np.broadcast_to(tint, (40, 60, 3)).astype(np.float32)
    near = {"air": np.tile(0.9 * white[:, None], (1, 24)),
            "boxes": np.tile([0.0, 0.0, 60.0, 40.0], (24, 1))}
    path = tmp_path / "ba.jpg"
    _figure(path, setup, near, {"as shot": shot, "corrected": shot / tint * white},
            {"as shot": [20.0], "corrected": [2.0]}, [1.5])
    img = np.asarray(Image.open(path).convert("RGB"), float)
    before, after = img[5:35, 5:55].mean(axis=(0, 1)), img[5:35, 73:123].mean(axis=(0, 1))
    assert before[1] > before[0] + 60 and before[2] > before[0] + 40  # blue-green as shot
    assert np.ptp(after) < 15  # the corrected grey is grey
    assert img.shape[0] == 40 + 44  # the numbers' two lines under the pictures
