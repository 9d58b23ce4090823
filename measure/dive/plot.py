"""survey.png: what the dive measures against depth (:func:`plot_survey`).

The path's attenuation coefficient c and its optical depth tau at the standard bands
(:data:`sca.derived.BANDS_NM`), each photo's with its 95 % interval and the joint fit's c as a
band, photos at one depth dodged apart; below, smaller, C and a_CDOM(440). Each point's marker
says its verdict (:data:`sca.derived.VERDICTS`: measured, loosely measured, upper bound, not
constrained; decision 0072-verdicts-loosely-measured).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .files import atomic
from .summary import to_float

__all__ = ["BAND_COLOURS", "DODGE_FRACTION", "SURVEY_LOG_SPAN", "VERDICT_MARKERS", "dodge",
           "plot_survey", "survey_figure"]

#: survey.png draws C and a_CDOM on a symmetric-log axis when the largest value (interval ends
#: included) exceeds its median by this factor.
SURVEY_LOG_SPAN = 30.0
#: Photos at one depth (and the bands of one photo) are set apart along the depth axis by
#: this fraction of the depths' span (at least 1 m) between neighbours.
DODGE_FRACTION = 0.012
#: The colour of each standard band (443, 490, 555, 670 nm)
BAND_COLOURS = ("#1f4e9c", "#17a2b8", "#2ca02c", "#d62728")
#: Marker and fill of each verdict, in the order of :data:`sca.derived.VERDICTS`; '' (an
#: earlier record without one) is drawn as not constrained.
VERDICT_MARKERS = {"measured": ("o", True), "loosely measured": ("o", False),
                   "upper bound": ("v", False), "not constrained": ("x", True)}


def dodge(x, slots: int = 1, step: float = 1.0) -> np.ndarray:
    """Offsets (N, slots) that set apart the points at one x: each point's ``slots`` (the
    bands of a photo) side by side, points of equal x next to each other, centred on x.

    Parameters
    ----------
    x : array_like, (N,)
        The positions (NaN allowed: offset 0).
    slots : int, optional
        Points drawn per position (one per band).
    step : float, optional
        The distance between neighbours.

    Returns
    -------
    numpy.ndarray, (N, slots)
    """
    x = np.asarray(x, float)
    rank = np.zeros(x.size)
    count = np.ones(x.size)
    for v in np.unique(x[np.isfinite(x)]):
        at = np.flatnonzero(x == v)
        rank[at], count[at] = np.arange(at.size), at.size
    slot = (rank[:, None] * slots + np.arange(slots)[None, :]).astype(float)
    return (slot - (count[:, None] * slots - 1) / 2) * step


def _points(a, x, y, bounds, verdicts, colour):
    """One errorbar per verdict: the 95 % intervals (an open end not drawn), the verdict's
    marker (:data:`VERDICT_MARKERS`)."""
    b = np.asarray(bounds, float)
    hi = np.where(np.isfinite(b[:, 1]), b[:, 1], np.nan)
    err = np.vstack([y - b[:, 0], hi - y])
    words = np.array([v if v in VERDICT_MARKERS else "not constrained" for v in verdicts])
    for word, (marker, filled) in VERDICT_MARKERS.items():
        sel = (words == word) & np.isfinite(y)
        if sel.any():
            a.errorbar(x[sel], y[sel], yerr=err[:, sel], fmt=marker, mec=colour, ecolor=colour,
                       color=colour, mfc=colour if filled else "none", capsize=2, ms=5)
    return hi


def _log_if_wide(a, y, hi):
    """A symmetric-log y axis where an open-ish upper end would flatten every other interval."""
    pos = np.concatenate([y[np.isfinite(y) & (y > 0)], hi[np.isfinite(hi) & (hi > 0)]])
    if pos.size and pos.max() > SURVEY_LOG_SPAN * max(np.median(pos), 1e-12):
        a.set_yscale("symlog", linthresh=max(float(np.median(pos)) / 10, 1e-6))
        a.set_ylim(bottom=0.0)


def _joint_band(a, joint, name, ci_name, colour, label=None):
    """The joint estimate as a line and its 95 % interval as a band (an open end: the axis')."""
    lo, up = (to_float(v) for v in joint[ci_name])
    a.axhspan(lo, up if math.isfinite(up) else a.get_ylim()[1], color=colour, alpha=0.15,
              label=label and f"{label} 95 %")
    a.axhline(to_float(joint[name]), color=colour, lw=1, ls="--", label=label)


def _band_panel(a, ds, x, prefix, step, joint):
    """c or tau at every standard band: each photo's, dodged; the joint fit's c as bands."""
    from sca.derived import BANDS_NM

    off = dodge(x, len(BANDS_NM), step)
    for k, band in enumerate(BANDS_NM):
        name = f"{prefix}_{band:.0f}"
        if name not in ds:
            continue
        _points(a, x + off[:, k], ds[name].values, ds[f"{name}_bounds"].values,
                ds[f"{name}_verdict"].values if f"{name}_verdict" in ds else [""] * x.size,
                BAND_COLOURS[k])
        if joint and name in (joint.get("quantities") or {}):
            _joint_band(a, {"v": joint["quantities"][name],
                            "ci": joint["quantity_intervals"][name]}, "v", "ci",
                        BAND_COLOURS[k])


def _parameter_panel(a, ds, x, name, step, joint):
    """C or a_CDOM: each photo's, dodged; the joint estimate as a band."""
    y = ds[name].values
    verdicts = ds[f"{name}_verdict"].values if f"{name}_verdict" in ds else [""] * x.size
    hi = _points(a, x + dodge(x, 1, 3 * step)[:, 0], y, ds[f"{name}_bounds"].values, verdicts, "k")
    _log_if_wide(a, y, hi)
    if joint and joint.get(name) is not None:
        _joint_band(a, joint, name, f"{name}_ci", "C1", "joint")
        a.legend(fontsize=7, loc="upper right")


def _legend(a):
    """The bands' colours and the verdicts' markers."""
    from matplotlib.lines import Line2D

    from sca.derived import BANDS_NM

    handles = [Line2D([], [], color=c, lw=2, label=f"{b:.0f} nm")
               for b, c in zip(BANDS_NM, BAND_COLOURS)]
    handles += [Line2D([], [], ls="", marker=m, color="0.3", mfc="0.3" if f else "none",
                       label=word) for word, (m, f) in VERDICT_MARKERS.items()]
    handles.append(Line2D([], [], color="0.3", ls="--", label="joint fit, 95 % band"))
    a.legend(handles=handles, fontsize=7, ncol=2, loc="best")


def survey_figure(ds, joint=None):
    """The survey figure (a matplotlib Figure): c and tau at the standard bands against depth,
    then C and a_CDOM(440) (:func:`plot_survey`)."""
    # matplotlib's object interface: no pyplot (its global figures and backend)
    from matplotlib.figure import Figure

    x = np.asarray(ds["depth"].values, float)
    finite = x[np.isfinite(x)]
    step = DODGE_FRACTION * max(float(np.ptp(finite)) if finite.size else 0.0, 1.0)
    fig = Figure(figsize=(8, 10), dpi=90)
    grid = fig.add_gridspec(3, 2, height_ratios=(3, 3, 2))
    c_ax = fig.add_subplot(grid[0, :])
    tau_ax = fig.add_subplot(grid[1, :], sharex=c_ax)
    _band_panel(c_ax, ds, x, "c", step, joint)
    _band_panel(tau_ax, ds, x, "tau", step, None)
    c_ax.set_ylabel("c, the path's attenuation (m⁻¹)")
    tau_ax.set_ylabel("τ, the path's optical depth")
    _legend(c_ax)
    for j, (name, label) in enumerate((("chl", "C (mg m⁻³)"), ("cdom", "a_CDOM(440) (m⁻¹)"))):
        a = fig.add_subplot(grid[2, j], sharex=c_ax)
        _parameter_panel(a, ds, x, name, step, joint)
        a.set_ylabel(label, fontsize=8)
        a.set_xlabel("depth (m)")
    tau_ax.set_xlabel("depth (m)")
    fig.suptitle("what the dive measures: each photo's 95 % interval (photos at one depth set "
                 "apart), the marker its verdict", fontsize=9)
    fig.subplots_adjust(left=0.1, right=0.97, bottom=0.06, top=0.94, hspace=0.35, wspace=0.3)
    return fig


def plot_survey(ds, path, joint=None):
    """survey.png: what the dive measures against depth. The path's attenuation c and optical
    depth tau at 443, 490, 555 and 670 nm, each photo's with its 95 % interval and a marker
    for its verdict (:data:`VERDICT_MARKERS`), photos at one depth dodged apart
    (:func:`dodge`), the joint fit's c as a band per band; below, C and a_CDOM(440) with
    the joint estimate.

    Parameters
    ----------
    ds : xarray.Dataset
        :func:`survey_dataset`'s.
    path : str or os.PathLike
        The PNG to write (whole or not at all).
    joint : dict, optional
        joint.json's content (``chl``, ``chl_ci``, ``cdom``, ``cdom_ci``, ``quantities``,
        ``quantity_intervals``; the joint fit reports no tau).

    Returns
    -------
    pathlib.Path
        The file written.
    """
    fig = survey_figure(ds, joint)
    p = Path(path)
    with atomic(p) as tmp:
        fig.savefig(tmp, format="png")
    return p
