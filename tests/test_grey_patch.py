"""A real camera's grey patch against depth (experiments/grey_patch.py, GREYPATCH.md).

The tests on the data need ``../shared/realdata/grey_patch_vs_depth`` and skip without it: the
observed slopes, the retrieval, the camera check and the report's verdicts computed from the
data. Without the data the command exits 2 and writes nothing.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from experiments import grey_patch as gp

REALDATA = Path(__file__).resolve().parents[1].parent / "shared" / "realdata"
needs_data = pytest.mark.skipif(
    not (REALDATA / gp.DATA_FILE).is_file() or not (REALDATA / gp.CAMERAS_DIR).is_dir(),
    reason="../shared/realdata/grey_patch_vs_depth (a real camera's grey patch against depth) "
           "or its camera curves are absent")


@pytest.fixture(scope="module")
def data():
    depth, rgb = gp.load_grey_patch()
    return depth, gp.log_ratios(rgb)


@pytest.fixture(scope="module")
def numbers(tmp_path_factory):
    """One run with few resamples (the report's numbers, not its precision)."""
    out = tmp_path_factory.mktemp("grey_patch")
    return out, gp.run(out, n_boot=300, n_boot_fit=3)


@needs_data
def test_observed_slopes_are_the_least_squares_slopes_and_exclude_zero(data):
    depth, y = data
    s = gp.slope(depth, y)
    for k in range(2):
        np.testing.assert_allclose(s[k], np.polyfit(depth, y[:, k], 1)[0], rtol=1e-10)
    lo, hi = np.percentile(gp.bootstrap_slopes(depth, y, 500), [2.5, 97.5], axis=0)
    assert np.all((lo < s) & (s < hi))
    assert hi[0] < 0.0 < lo[1]  # red falls and blue rises against green with depth


@needs_data
def test_the_retrieved_water_fits_better_than_every_plausible_water(data):
    """The least squares reached its optimum: no plausible water, each with its own best
    constants, leaves smaller residuals."""
    depth, y = data
    model = gp.grey_model()
    fit = gp.fit_water(depth, y, model)
    cost = np.sum((y - fit["fitted"]) ** 2)
    for chl in gp.PLAUSIBLE_CHL:
        for cdom in gp.PLAUSIBLE_CDOM:
            pred = gp.model_log_ratios(model, chl, cdom, depth, gp.DISTANCE_M)
            assert cost <= np.sum((y - pred - np.mean(y - pred, axis=0)) ** 2), (chl, cdom)


@needs_data
def test_a_measured_camera_reproduces_both_observed_slopes(numbers):
    """The model with the water retrieved for some real camera reproduces the observed slopes
    within their intervals, and the cameras' slopes bracket the observed ones."""
    _, n = numbers
    lo, hi = np.array(n["observed"]["interval"]).T
    cams = n["cameras"]
    assert len(cams["cameras"]) == 49
    inside = [c for c in cams["cameras"].values() if c["inside"]]
    assert len(inside) == cams["n_inside"] >= 1
    for c in inside:
        assert np.all((lo <= c["model_slope"]) & (np.array(c["model_slope"]) <= hi))
    smin, smax = np.array(cams["range"])
    assert np.all((smin < n["observed"]["slope"]) & (n["observed"]["slope"] < smax))


@needs_data
def test_the_report_states_what_the_numbers_say(numbers):
    out, n = numbers
    text = gp.report(n, 1.0)
    model_slope = np.array(n["retrieved"]["model_slope"])
    lo, hi = np.array(n["observed"]["interval"]).T
    agrees = (lo <= model_slope) & (model_slope <= hi)
    assert n["agrees"]["retrieved"] == agrees.tolist()
    row = next(line for line in text.splitlines() if line.startswith("| model, retrieved"))
    assert [cell.endswith("**inside**") for cell in row.split(" | ")[1:3]] == agrees.tolist()
    assert ("does not reproduce" in text) == (not agrees.all())
    assert f"with {n['cameras']['n_inside']} of them" in text
    for name in ("grey_patch.png", "grey_patch.pdf", "grey_patch_residuals.csv"):
        assert (out / name).stat().st_size > 100
    json.dumps(n, default=float)  # JSON-ready


def test_command_exits_2_without_data_and_writes_nothing(monkeypatch, tmp_path):
    monkeypatch.setattr(gp, "realdata_dir", lambda: tmp_path / "absent")
    report = tmp_path / "GREYPATCH.md"
    assert gp.main(["--out", str(tmp_path / "out"), "--report", str(report)]) == 2
    assert not report.exists() and not (tmp_path / "out").exists()
