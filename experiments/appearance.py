"""Shared code of the appearance figures (Figs 5-8): simulate, render, plot a panel grid, save."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import forward  # noqa: E402

from .common import figures_dir, save_figure, style, write_csv  # noqa: E402
from .grids import setting as get_setting  # noqa: E402

__all__ = ["SEED", "sensor_of", "simulate", "render_conditions", "chromaticity_spread"]

#: Noise seed of all appearance figures (fixed: reruns give identical images).
SEED = 2016


def sensor_of(setting_name=None) -> forward.SensorSettings:
    s = get_setting(setting_name)
    return forward.SensorSettings(illuminance_lux=s["illuminance_lux"], exposure_mode=s["exposure"])


def simulate(conditions, setting_name=None, seed=SEED):
    sensor = sensor_of(setting_name)
    return [forward.simulate_chart(c["chl"], c["cdom"], c["depth"], c["distance"], seed=seed,
                                   sensor=sensor) for c in conditions]


def render_conditions(conditions, name, title, outdir=None, ncols=None, seed=SEED,
                      setting_name=None, rows_of=None, normalised_row=False):
    """Simulate each condition dict (chl, cdom, depth, distance, label) and draw the charts as
    the camera recorded them (raw codes over full scale, gamma-encoded sRGB). With
    ``normalised_row`` a second row shows each chart scaled to its brightest patch (what the
    exposure hides: the hue).

    Writes ``name``.png/.pdf and ``name``_patches.csv (sRGB of every patch) into the figures
    folder; returns the list of (condition, patch sRGB (24, 3), simulation).
    """
    style()
    ncols = ncols or len(conditions)
    nrows = -(-len(conditions) // ncols) * (2 if normalised_row else 1)
    fig, axes = plt.subplots(nrows, ncols, figsize=(max(4.8, 1.55 * ncols), 1.45 * nrows + 0.5),
                             squeeze=False, constrained_layout=True)
    sims = simulate(conditions, setting_name, seed)
    results, rows = [], []
    for j, (cond, sim) in enumerate(zip(conditions, sims)):
        srgb = forward.patch_srgb(sim)
        r, c = divmod(j, ncols)
        ax = axes[r * (2 if normalised_row else 1), c]
        ax.imshow(forward.chart_image(sim))
        ax.set_title(cond["label"], fontsize=8)
        if normalised_row:
            axn = axes[r * 2 + 1, c]
            axn.imshow(forward.chart_image(sim, normalise="max"))
            axn.set_title("scaled to its brightest patch", fontsize=8)
        results.append((cond, srgb, sim))
        for p, (rr, gg, bb) in enumerate(srgb):
            rows.append([cond["chl"], cond["cdom"], cond["depth"], cond["distance"], p + 1,
                         f"{rr:.6f}", f"{gg:.6f}", f"{bb:.6f}", f"{sim.exposure_s:.6g}"])
    for ax in axes.flat:
        ax.set_axis_off()
    fig.suptitle(title)
    save_figure(fig, name, outdir)
    plt.close(fig)
    s = get_setting(setting_name)
    write_csv(figures_dir(outdir) / f"{name}_patches.csv",
              ["chl_mg_m3", "cdom_440_per_m", "depth_m", "distance_m", "patch", "srgb_r",
               "srgb_g", "srgb_b", "exposure_s"], rows,
              comment=f"{title}\nsimulated with forward.simulate_chart(..., seed={seed}) at "
                      f"{s['illuminance_lux']:g} lx, {s['exposure']} exposure; sRGB "
                      "(gamma-encoded) of the raw camera codes, forward.patch_srgb")
    return results


def chromaticity_spread(rgb) -> float:
    """How colourful a chart is: the summed standard deviation over patches of the camera's
    chromaticities r/(r+g+b), g/(..), b/(..) (0 for a grey chart)."""
    rgb = np.asarray(rgb, float)
    return float((rgb / rgb.sum(0)).std(1).sum())
