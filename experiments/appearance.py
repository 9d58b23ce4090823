"""Shared code of the appearance figures (Figs 5-8): simulate, render, plot a panel grid, save."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import forward  # noqa: E402

from .common import figures_dir, save_figure, write_csv  # noqa: E402

#: Noise seed of all appearance figures (fixed: reruns give identical images).
SEED = 2016


def render_conditions(conditions, name, title, outdir=None, ncols=None, seed=SEED):
    """Simulate each condition dict (chl, cdom, depth, distance, label) and draw the charts.

    Writes ``name``.png/.pdf and ``name``_patches.csv (sRGB of every patch) into the figures
    folder; returns the list of (condition, patch sRGB (24, 3)).
    """
    ncols = ncols or len(conditions)
    nrows = -(-len(conditions) // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(2.6 * ncols, 2.1 * nrows), squeeze=False)
    results, rows = [], []
    for ax, cond in zip(axes.flat, conditions):
        sim = forward.simulate_chart(cond["chl"], cond["cdom"], cond["depth"], cond["distance"],
                                     seed=seed)
        srgb = forward.patch_srgb(sim)
        ax.imshow(forward.chart_image(sim))
        ax.set_title(cond["label"], fontsize=8)
        ax.set_axis_off()
        results.append((cond, srgb))
        for p, (r, g, b) in enumerate(srgb):
            rows.append([cond["chl"], cond["cdom"], cond["depth"], cond["distance"], p + 1,
                         f"{r:.6f}", f"{g:.6f}", f"{b:.6f}", f"{sim.exposure_s:.6g}"])
    for ax in list(axes.flat)[len(conditions):]:
        ax.set_axis_off()
    fig.suptitle(title, fontsize=9)
    save_figure(fig, name, outdir)
    plt.close(fig)
    write_csv(figures_dir(outdir) / f"{name}_patches.csv",
              ["chl_mg_m3", "cdom_440_per_m", "depth_m", "distance_m", "patch", "srgb_r",
               "srgb_g", "srgb_b", "exposure_s"], rows,
              comment=f"{title}\nsimulated with forward.simulate_chart(..., seed={seed}); "
                      "sRGB (gamma-encoded) of the raw camera codes, forward.patch_srgb")
    return results
