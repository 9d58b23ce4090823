"""Figs 12 and 13: estimated vs true C (Fig 12) or a_CDOM(440) (Fig 13).

As the captions describe: one panel per depth at 1 m distance, points coloured by group (Fig 12:
by a_CDOM; Fig 13: by C), r^2 per group in the legend and over all points in the title; and
(issue 39) one panel per distance at ``distance_depth_m`` (the paper: accuracy "decreases with
increasing depth and target distance").

Correlations are given on linear values (as the paper's r may have been) and on log10 values
(the grids span 0.05-10 mg m^-3 and 0.01-0.5 m^-1: on a linear scale C = 5 and 10 decide r);
estimates below :data:`ZERO` (the solver's bound at 0) count at :data:`ZERO` on the log scale,
as they are drawn. The CSVs: r and r^2 per depth (``<name>.csv``), per depth and group
(``<name>_groups.csv``), and the accuracy per group -- log r^2, the median factor error
exp(median |ln(est/true)|) and the bias (median est/true) -- by depth, C class, a_CDOM class and
distance (``<name>_accuracy.csv``).
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from . import sweep
from .common import figures_dir, save_figure, style, write_csv
from .estimation import condition_kw, distance_conditions, fig12_conditions, fit_header, fit_row, resolve
from .grids import setting as get_setting

__all__ = ["make", "group_r", "accuracy", "accuracy_rows", "LABEL", "PLAIN",
           "ZERO", "GROUPINGS"]

#: Estimates below this (mg m^-3 or m^-1; 1 % of the smallest true value of either grid) are
#: the solver's bound at 0 in all but name (values down to 1e-22 occur): they are drawn at ZERO
#: and count at ZERO on the log scale (log r, factor error).
ZERO = 1e-4

LABEL = {"chl": "C (mg m$^{-3}$)", "cdom": "a$_{CDOM}$(440) (m$^{-1}$)"}
PLAIN = {"chl": "C", "cdom": "a_CDOM(440)"}
#: The groupings of ``<name>_accuracy.csv``: name -> (the fits it uses, the variable)
GROUPINGS = {"depth": ("fig12", "depth"), "chl": ("fig12", "chl"), "cdom": ("fig12", "cdom"),
             "distance": ("distance", "distance")}


def _log(v):
    return np.log10(np.maximum(np.asarray(v, float), ZERO))


def accuracy(true, est) -> dict:
    """The accuracy of ``est`` against ``true`` (both > 0 where defined).

    Parameters
    ----------
    true, est : array_like
        True and estimated values (estimates below :data:`ZERO` count at it).

    Returns
    -------
    dict
        ``r`` and ``r2`` (Pearson, linear), ``r_log`` and ``r2_log`` (Pearson on log10),
        ``factor`` (median factor error exp(median |ln(est/true)|), >= 1), ``bias`` (median of
        est/true: 1 unbiased) and ``n``.
    """
    t = np.asarray(true, float)
    e = np.asarray(est, float)
    ratio = np.maximum(e, ZERO) / t
    r = sweep.pearson(t, e)
    r_log = sweep.pearson(_log(t), _log(e))
    return dict(r=r, r2=r * r, r_log=r_log, r2_log=r_log * r_log,
                factor=float(np.exp(np.median(np.abs(np.log(ratio))))) if t.size else float("nan"),
                bias=float(np.median(ratio)) if t.size else float("nan"), n=int(t.size))


def group_r(results, depth, quantity, colour_by):
    """{group value: accuracy dict} at one depth within each group (:func:`accuracy`)."""
    out = {}
    sel = [x for x in results if x["depth"] == depth]
    for v in sorted({x[colour_by] for x in sel}):
        grp = [x for x in sel if x[colour_by] == v]
        out[v] = accuracy([x[quantity] for x in grp], [x[quantity + "_hat"] for x in grp])
    return out


def accuracy_rows(fits: dict, quantity) -> list:
    """The accuracy of ``quantity`` per group of every grouping of :data:`GROUPINGS`.

    Parameters
    ----------
    fits : dict
        'fig12' (the Fig 12 grid's fits) and 'distance' (the distance study's).
    quantity : {'chl', 'cdom'}

    Returns
    -------
    list of dict
        ``grouping``, ``value`` and the keys of :func:`accuracy`.
    """
    rows = []
    for grouping, (which, var) in GROUPINGS.items():
        res = fits[which]
        for v in sorted({x[var] for x in res}):
            grp = [x for x in res if x[var] == v]
            rows.append(dict(grouping=grouping, value=v,
                             **accuracy([x[quantity] for x in grp],
                                        [x[quantity + "_hat"] for x in grp])))
    return rows


def _panels(results, panel_by, panels, quantity, colour_by, title):
    groups = sorted({x[colour_by] for x in results})
    colours = plt.get_cmap("viridis")(np.linspace(0, 0.9, len(groups)))
    fig, axes = plt.subplots(1, len(panels), figsize=(2.6 * len(panels) + 0.6, 4.6),
                             squeeze=False, constrained_layout=True)
    lo, hi = min(x[quantity] for x in results) / 2, max(x[quantity] for x in results) * 2
    for ax, p in zip(axes[0], panels):
        sel = [x for x in results if x[panel_by] == p]
        a = accuracy([x[quantity] for x in sel], [x[quantity + "_hat"] for x in sel])
        for v, col in zip(groups, colours):
            pts = [x for x in sel if x[colour_by] == v]
            t = np.array([x[quantity] for x in pts])
            e = np.array([x[quantity + "_hat"] for x in pts])
            g = accuracy(t, e)
            ax.scatter(t, np.maximum(e, ZERO), color=col, s=10,
                       label=f"{v:g}: r$^2$ {g['r2_log']:.2f}")
        ax.plot([lo, hi], [lo, hi], "k--", lw=0.8)
        ax.set(xscale="log", yscale="log", xlabel="true " + LABEL[quantity],
               ylabel="estimated " + LABEL[quantity])
        ax.set_title(f"{panel_by} {p:g} m: r$^2$ (log) {a['r2_log']:.3f}\n"
                     f"median factor error ×{a['factor']:.2f}")
        ax.legend(title=LABEL[colour_by] + ": r² (log)", fontsize=8, title_fontsize=8,
                  loc="upper center", bbox_to_anchor=(0.5, -0.2), ncol=2, handletextpad=0.2,
                  borderpad=0.3, labelspacing=0.2, columnspacing=0.8)
    fig.suptitle(title)
    return fig


def make(quantity, name, colour_by, outdir=None, grid_name=None, cache_dir=None, workers=None,
         setting=None):
    g = resolve(grid_name)
    s = get_setting(setting)
    style()
    kw = condition_kw(s)
    results, _ = sweep.run(fig12_conditions(g, **kw), cache_dir=cache_dir, workers=workers,
                           desc=name)
    dist_results, _ = sweep.run(distance_conditions(g, **kw), cache_dir=cache_dir,
                                workers=workers, desc=f"{name} (distance)")
    depths = g["fig12_depths_m"]
    world = "independent renderer" if s.get("world") == "independent" else "forward"
    where = (f"{s['illuminance_lux']:g} lx, charts by {world}, estimator on a "
             f"{s['estimation_step_nm']:g} nm grid (estimates below 10$^{{-4}}$ drawn at "
             "10$^{-4}$)")
    fig = _panels(results, "depth", depths, quantity, colour_by,
                  f"{PLAIN[quantity]}: estimated vs true, distance {g['fig12_distance_m']:g} m, "
                  + where)
    save_figure(fig, name, outdir)
    plt.close(fig)
    fig = _panels(dist_results, "distance", g["distance_study_m"], quantity, colour_by,
                  f"{PLAIN[quantity]}: estimated vs true, depth {g['distance_depth_m']:g} m, "
                  + where)
    save_figure(fig, f"{name}_distance", outdir)
    plt.close(fig)
    rows, group_rows = [], []
    for d in depths:
        sel = [x for x in results if x["depth"] == d]
        a = accuracy([x[quantity] for x in sel], [x[quantity + "_hat"] for x in sel])
        rows.append([d, g["fig12_distance_m"], f"{a['r']:.4f}", f"{a['r2']:.4f}",
                     f"{a['r_log']:.4f}", f"{a['r2_log']:.4f}", f"{a['factor']:.4g}",
                     f"{a['bias']:.4g}", a["n"],
                     sum(x[quantity + "_hat"] < ZERO for x in sel)])
        for v, ga in group_r(results, d, quantity, colour_by).items():
            group_rows.append([d, f"{v:g}", f"{ga['r']:.4f}", f"{ga['r2']:.4f}",
                               f"{ga['r_log']:.4f}", f"{ga['r2_log']:.4f}", f"{ga['factor']:.4g}",
                               f"{ga['bias']:.4g}", ga["n"]])
    write_csv(figures_dir(outdir) / f"{name}.csv",
              ["depth_m", "distance_m", "pearson_r", "r2", "pearson_r_log10", "r2_log10",
               "median_factor_error", "bias", "n", "n_at_zero"], rows,
              comment=f"{name} ({g['name']} grid, setting {s['name']}, charts by {world}): "
                      f"Pearson r between true and estimated {quantity} over all points of a "
                      f"depth, on linear and on log10 values (estimates below {ZERO:g}, the "
                      f"solver's bound at 0, counted at {ZERO:g}: n_at_zero of them); median "
                      "factor error exp(median |ln(est/true)|), bias median(est/true)")
    write_csv(figures_dir(outdir) / f"{name}_groups.csv",
              ["depth_m", colour_by, "pearson_r", "r2", "pearson_r_log10", "r2_log10",
               "median_factor_error", "bias", "n"], group_rows,
              comment=f"{name}: within each {colour_by} group (the captions' colours)")
    acc = accuracy_rows({"fig12": results, "distance": dist_results}, quantity)
    write_csv(figures_dir(outdir) / f"{name}_accuracy.csv",
              ["grouping", "value", "n", "r2_log10", "median_factor_error", "bias"],
              [[a["grouping"], f"{a['value']:g}", a["n"], f"{a['r2_log']:.4f}",
                f"{a['factor']:.4g}", f"{a['bias']:.4g}"] for a in acc],
              comment=f"{name}: accuracy of {quantity} per group: depth, chl and cdom over the "
                      f"figure's grid (distance {g['fig12_distance_m']:g} m), distance at depth "
                      f"{g['distance_depth_m']:g} m over the same C x a_CDOM x seeds; r2_log10 "
                      "(Pearson on log10), median factor error exp(median |ln(est/true)|), bias "
                      "median(est/true)")
    ident = lambda x: (x["chl"], x["cdom"], x["depth"], x["distance"], x["replicate"])  # noqa: E731
    seen = {ident(x) for x in results}
    extra = [x for x in dist_results if ident(x) not in seen]
    write_csv(figures_dir(outdir) / f"{name}_fits.csv", fit_header(),
              [fit_row(x) for x in results + extra],
              comment=f"every fit behind {name} (the figure's and the distance study's)")
    return rows
