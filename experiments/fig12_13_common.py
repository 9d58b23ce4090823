"""Figs 12 and 13: estimated vs true C (Fig 12) or a_CDOM(440) (Fig 13) at 1 m distance."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from . import sweep
from .common import figures_dir, save_figure, write_csv
from .estimation import fig12_conditions, fit_header, fit_row, resolve


def correlations(results, depth, quantity):
    sel = [x for x in results if x["depth"] == depth]
    t = np.array([x[quantity] for x in sel])
    e = np.array([x[quantity + "_hat"] for x in sel])
    pos = (t > 0) & (e > 0)
    return (sweep.pearson(t, e), sweep.pearson(np.log10(t[pos]), np.log10(e[pos])), len(sel))


def make(quantity, name, colour_by, outdir=None, grid_name=None, cache_dir=None, workers=None):
    g = resolve(grid_name)
    results, _ = sweep.run(fig12_conditions(g), cache_dir=cache_dir, workers=workers, desc=name)
    depths = g["fig12_depths_m"]
    fig, axes = plt.subplots(1, len(depths), figsize=(3.3 * len(depths), 3.2), squeeze=False)
    label = {"chl": "C (mg m$^{-3}$)", "cdom": "a$_{CDOM}$(440) (m$^{-1}$)"}
    rows = []
    for ax, d in zip(axes[0], depths):
        sel = [x for x in results if x["depth"] == d]
        t = np.array([x[quantity] for x in sel])
        e = np.array([x[quantity + "_hat"] for x in sel])
        cval = np.array([x[colour_by] for x in sel])
        sc = ax.scatter(t, np.maximum(e, 1e-4), c=np.log10(cval), cmap="viridis", s=12)
        lo, hi = t.min() / 2, t.max() * 2
        ax.plot([lo, hi], [lo, hi], "k--", lw=0.8)
        ax.set_xscale("log")
        ax.set_yscale("log")
        r, r_log, n = correlations(results, d, quantity)
        rows.append([d, g["fig12_distance_m"], f"{r:.4f}", f"{r_log:.4f}", n])
        ax.set_title(f"depth {d:g} m: r = {r:.3f} (log r = {r_log:.3f})", fontsize=8)
        ax.set_xlabel("true " + label[quantity])
        ax.set_ylabel("estimated " + label[quantity])
        cb = fig.colorbar(sc, ax=ax)
        cb.set_label("log10 " + label[colour_by], fontsize=7)
    fig.tight_layout()
    save_figure(fig, name, outdir)
    plt.close(fig)
    write_csv(figures_dir(outdir) / f"{name}.csv",
              ["depth_m", "distance_m", "pearson_r", "pearson_r_log10", "n"], rows,
              comment=f"{name} ({g['name']} grid): Pearson r between true and estimated {quantity}")
    write_csv(figures_dir(outdir) / f"{name}_fits.csv", fit_header(),
              [fit_row(x) for x in results], comment=f"every fit behind {name}")
    return rows
