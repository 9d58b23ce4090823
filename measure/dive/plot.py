"""survey.png: the dive's estimates against depth and time (:func:`plot_survey`)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .files import atomic
from .summary import to_float

__all__ = ["SURVEY_LOG_SPAN", "plot_survey"]

#: survey.png draws a quantity on a symmetric-log axis when its largest value (interval ends
#: included) exceeds its median by this factor.
SURVEY_LOG_SPAN = 30.0


def plot_survey(ds, path, joint=None):
    """survey.png: C and a_CDOM with their 95 % intervals against depth (and against time where
    the EXIF has it), reliable estimates filled; the joint estimate of the dive as a band.

    Parameters
    ----------
    ds : xarray.Dataset
        :func:`survey_dataset`'s.
    path : str or os.PathLike
        The PNG to write (whole or not at all).
    joint : dict, optional
        joint.json's content (``chl``, ``chl_ci``, ``cdom``, ``cdom_ci``).

    Returns
    -------
    pathlib.Path
        The file written.
    """
    # matplotlib's object interface: no pyplot (its global figures and backend)
    from matplotlib.figure import Figure

    has_time = bool(np.any(~np.isnat(ds["time"].values)))
    xs = [("depth", "depth (m)")] + ([("time", "time (EXIF)")] if has_time else [])
    fig = Figure(figsize=(5.5 * len(xs), 7), dpi=90)
    ax = fig.subplots(2, len(xs), squeeze=False)
    ok = ds["reliable"].values == 1
    for i, (name, label, unit) in enumerate((("chl", "C", "mg m⁻³"),
                                             ("cdom", "a_CDOM(440)", "m⁻¹"))):
        y = ds[name].values
        b = ds[f"{name}_bounds"].values
        hi = np.where(np.isfinite(b[:, 1]), b[:, 1], np.nan)
        err = np.vstack([y - b[:, 0], hi - y])
        for j, (xname, xlabel) in enumerate(xs):
            a = ax[i, j]
            x = ds[xname].values
            for sel, fill in ((ok, "C0"), (~ok, "none")):
                if sel.any():
                    a.errorbar(x[sel], y[sel], yerr=err[:, sel], fmt="o", mfc=fill, mec="C0",
                               ecolor="C0", capsize=3,
                               label="reliable" if fill == "C0" else "not reliable")
            if joint and joint.get(name) is not None:
                lo, up = (to_float(v) for v in joint[f"{name}_ci"])
                a.axhspan(lo, up if math.isfinite(up) else np.nanmax(y, initial=lo), color="C1",
                          alpha=0.25, label="joint 95 %")
                a.axhline(to_float(joint[name]), color="C1", label="joint estimate")
            a.set_xlabel(xlabel)
            a.set_ylabel(f"{label} ({unit})")
            pos = np.concatenate([y[np.isfinite(y) & (y > 0)], hi[np.isfinite(hi) & (hi > 0)]])
            if pos.size and pos.max() > SURVEY_LOG_SPAN * max(np.median(pos), 1e-12):
                # an open-ish upper end would flatten every other interval: log-like axis
                a.set_yscale("symlog", linthresh=max(float(np.median(pos)) / 10, 1e-6))
                a.set_ylim(bottom=0.0)
            if i == 0 and j == 0:
                a.legend(fontsize=8)
    fig.suptitle("dive survey: per-photo estimates, 95 % intervals", fontsize=10)
    fig.subplots_adjust(left=0.14 / len(xs), right=0.97, bottom=0.08, top=0.92, wspace=0.3,
                        hspace=0.3)
    p = Path(path)
    with atomic(p) as tmp:
        fig.savefig(tmp, format="png")
    return p
