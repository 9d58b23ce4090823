"""survey.png shows what the dive measures (issue 48 item 5): the path's c and tau at the
standard bands per photo with their intervals and verdict markers, the joint fit's c, photos
at one depth dodged apart, C and a_CDOM below."""

import numpy as np
import xarray as xr

from measure.dive.plot import VERDICT_MARKERS, dodge, plot_survey, survey_figure
from sca.derived import BANDS_NM, VERDICTS


def _dataset():
    """Three photos, two of them at 5 m: c and tau at every band, C and a_CDOM, verdicts."""
    depth = np.array([5.0, 5.0, 12.0])
    n = depth.size
    var = {"depth": ("photo", depth), "reliable": ("photo", np.ones(n, np.int8))}
    for k, band in enumerate(BANDS_NM):
        c = np.full(n, 0.2 + 0.1 * k)
        for name, v in ((f"c_{band:.0f}", c), (f"tau_{band:.0f}", c * (depth + 1.5))):
            var[name] = ("photo", v)
            var[f"{name}_bounds"] = (("photo", "nv"), np.column_stack([0.9 * v, 1.1 * v]))
            var[f"{name}_verdict"] = ("photo", np.array(["measured"] * n, dtype=object))
    for name, v, hi, word in (("chl", 1.0, np.inf, "not constrained"),
                              ("cdom", 0.1, 0.3, "loosely measured")):
        var[name] = ("photo", np.full(n, v))
        var[f"{name}_bounds"] = (("photo", "nv"), np.tile([v / 4, hi], (n, 1)))
        var[f"{name}_verdict"] = ("photo", np.array([word, "upper bound", word], dtype=object))
    return xr.Dataset(var, coords={"image": ("photo", ["a.dng", "b.dng", "c.dng"])})


def test_dodge_sets_apart_photos_at_one_depth_and_keeps_the_others():
    off = dodge([5.0, 5.0, 12.0, np.nan], slots=4, step=0.1)
    assert off.shape == (4, 4)
    at5 = (5.0 + off[:2]).ravel()
    assert np.unique(at5).size == 8 and np.isclose(at5.mean(), 5.0)
    assert np.isclose(off[2].mean(), 0.0) and np.unique(off[2]).size == 4


def test_survey_figure_draws_c_and_tau_per_photo_with_verdicts_and_the_joint(tmp_path):
    ds = _dataset()
    joint = {"chl": 1.0, "chl_ci": [0.5, "inf"], "cdom": 0.1, "cdom_ci": [0.05, 0.2],
             "quantities": {"c_443": 0.2}, "quantity_intervals": {"c_443": [0.18, 0.22]}}
    fig = survey_figure(ds, joint)
    c_ax, tau_ax = fig.axes[:2]
    assert "c, the path's attenuation" in c_ax.get_ylabel() and "τ" in tau_ax.get_ylabel()
    assert c_ax.get_xlabel() == "" and tau_ax.get_xlabel() == "depth (m)"
    for a, prefix in ((c_ax, "c"), (tau_ax, "tau")):
        xy = np.vstack([line.get_xydata() for line in a.lines if line.get_marker() == "o"])
        # every photo at every band, the photos at 5 m never on top of each other
        assert len(xy) == 3 * len(BANDS_NM) and len({tuple(p) for p in xy}) == len(xy)
        want = np.concatenate([ds[f"{prefix}_{b:.0f}"].values for b in BANDS_NM])
        np.testing.assert_allclose(np.sort(xy[:, 1]), np.sort(want))
        assert np.unique(np.round(xy[xy[:, 0] < 8, 0], 9)).size == 2 * len(BANDS_NM)
    legend = [t.get_text() for t in c_ax.get_legend().get_texts()]
    assert set(VERDICTS) <= set(legend) and set(VERDICT_MARKERS) == set(VERDICTS)
    # the joint fit's c(443) as a line; C and a_CDOM below, each with its verdicts' markers
    assert any(np.allclose(line.get_ydata(), 0.2) for line in c_ax.lines
               if line.get_linestyle() == "--")
    markers = {line.get_marker() for a in fig.axes[2:] for line in a.lines}
    assert {"x", "v", "o"} <= markers
    path = plot_survey(ds, tmp_path / "survey.png", joint)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
