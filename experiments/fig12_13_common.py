"""Figs 12 and 13: estimated vs true C (Fig 12) or a_CDOM(440) (Fig 13) at 1 m distance.

As the captions describe: one panel per depth, points coloured by group (Fig 12: by a_CDOM;
Fig 13: by C), Pearson's r^2 per group in the legend and over all points in the title. The CSVs
give r and r^2 per depth (``<name>.csv``) and per depth and group (``<name>_groups.csv``).
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from . import sweep
from .common import figures_dir, save_figure, style, write_csv
from .estimation import fig12_conditions, fit_header, fit_row, resolve
from .grids import setting as get_setting

__all__ = ["make", "correlations", "group_r", "LABEL", "PLAIN", "ZERO"]

#: Estimates below this (mg m^-3 or m^-1; 1 % of the smallest true value of either grid) are
#: the solver's bound at 0 in all but name (values down to 1e-22 occur): they are drawn at ZERO
#: and left out of the log-log correlation (``pearson_r_log10``; ``n_log`` counts the rest).
ZERO = 1e-4

LABEL = {"chl": "C (mg m$^{-3}$)", "cdom": "a$_{CDOM}$(440) (m$^{-1}$)"}
PLAIN = {"chl": "C", "cdom": "a_CDOM(440)"}


def correlations(results, depth, quantity):
    """(Pearson r, Pearson r of log10 over estimates >= ZERO, n, n of the log r)."""
    sel = [x for x in results if x["depth"] == depth]
    t = np.array([x[quantity] for x in sel])
    e = np.array([x[quantity + "_hat"] for x in sel])
    pos = (t > 0) & (e >= ZERO)
    return (sweep.pearson(t, e), sweep.pearson(np.log10(t[pos]), np.log10(e[pos])), len(sel),
            int(pos.sum()))


def group_r(results, depth, quantity, colour_by):
    """{group value: (r, n)} at one depth: Pearson r of true vs estimated within each group."""
    out = {}
    sel = [x for x in results if x["depth"] == depth]
    for v in sorted({x[colour_by] for x in sel}):
        grp = [x for x in sel if x[colour_by] == v]
        out[v] = (sweep.pearson([x[quantity] for x in grp], [x[quantity + "_hat"] for x in grp]),
                  len(grp))
    return out


def make(quantity, name, colour_by, outdir=None, grid_name=None, cache_dir=None, workers=None,
         setting=None):
    g = resolve(grid_name)
    s = get_setting(setting)
    style()
    results, _ = sweep.run(fig12_conditions(g, illuminance_lux=s["illuminance_lux"],
                                            exposure=s["exposure"],
                                            estimation_step_nm=s["estimation_step_nm"]),
                           cache_dir=cache_dir, workers=workers, desc=name)
    depths = g["fig12_depths_m"]
    groups = sorted({x[colour_by] for x in results})
    colours = plt.get_cmap("viridis")(np.linspace(0, 0.9, len(groups)))
    fig, axes = plt.subplots(1, len(depths), figsize=(2.6 * len(depths) + 0.6, 4.6),
                             squeeze=False, constrained_layout=True)
    rows, group_rows = [], []
    for ax, d in zip(axes[0], depths):
        r, r_log, n, n_log = correlations(results, d, quantity)
        rows.append([d, g["fig12_distance_m"], f"{r:.4f}", f"{r * r:.4f}",
                     f"{r_log:.4f}" if np.isfinite(r_log) else "", n, n_log])
        per = group_r(results, d, quantity, colour_by)
        for v, col in zip(groups, colours):
            pts = [x for x in results if x["depth"] == d and x[colour_by] == v]
            t = np.array([x[quantity] for x in pts])
            e = np.array([x[quantity + "_hat"] for x in pts])
            rg, ng = per[v]
            group_rows.append([d, f"{v:g}", f"{rg:.4f}", f"{rg * rg:.4f}", ng])
            ax.scatter(t, np.maximum(e, ZERO), color=col, s=10,
                       label=f"{v:g}: r$^2$ = {rg * rg:.2f}")
        lo, hi = min(x[quantity] for x in results) / 2, max(x[quantity] for x in results) * 2
        ax.plot([lo, hi], [lo, hi], "k--", lw=0.8)
        ax.set(xscale="log", yscale="log", xlabel="true " + LABEL[quantity],
               ylabel="estimated " + LABEL[quantity])
        ax.set_title(f"depth {d:g} m: r$^2$ = {r * r:.3f} (r = {r:.3f})")
        ax.legend(title=LABEL[colour_by], fontsize=8, title_fontsize=8, loc="upper center",
                  bbox_to_anchor=(0.5, -0.2), ncol=2, handletextpad=0.2, borderpad=0.3,
                  labelspacing=0.2, columnspacing=0.8)
    fig.suptitle(f"{PLAIN[quantity]}: estimated vs true, distance {g['fig12_distance_m']:g} m, "
                 f"{s['illuminance_lux']:g} lx, estimator on a {s['estimation_step_nm']:g} nm grid "
                 f"(estimates below 10$^{{-4}}$ drawn at 10$^{{-4}}$)")
    save_figure(fig, name, outdir)
    plt.close(fig)
    write_csv(figures_dir(outdir) / f"{name}.csv",
              ["depth_m", "distance_m", "pearson_r", "r2", "pearson_r_log10", "n", "n_log"], rows,
              comment=f"{name} ({g['name']} grid, setting {s['name']}): Pearson r between true "
                      f"and estimated {quantity}, all points of a depth; pearson_r_log10 over the "
                      f"n_log estimates >= {ZERO:g} (below: the solver's bound at 0; empty where fewer "
                      "than two distinct values remain)")
    write_csv(figures_dir(outdir) / f"{name}_groups.csv",
              ["depth_m", colour_by, "pearson_r", "r2", "n"], group_rows,
              comment=f"{name}: Pearson r within each {colour_by} group (the captions' colours)")
    write_csv(figures_dir(outdir) / f"{name}_fits.csv", fit_header(),
              [fit_row(x) for x in results], comment=f"every fit behind {name}")
    return rows
