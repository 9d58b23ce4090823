"""Fig 10: RRMSE(k) (eq 19) vs depth and distance; each point the mean over C x CDOM x seeds,
with its standard error (the paper: "Each point represents the average RRMSE and the
corresponding standard error across different phytoplankton concentrations C and CDOM
absorptions")."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from . import sweep
from .common import figures_dir, percent_axis, save_figure, style, write_csv
from .estimation import condition_kw, fig10_conditions, fit_header, fit_row, mean_se, resolve
from .grids import setting as get_setting

__all__ = ["summarise", "by_medium", "main", "SQRT_Q"]

#: sqrt(q) of eq 19 for the 1 nm estimator (its 31 nodes at 10 nm); a coarser estimator's is
#: ``sqrt(sweep.q_eq19(step))``
SQRT_Q = float(np.sqrt(sweep.RRMSE_BANDS_NM.size))



def summarise(results, g):
    rows = []
    for d in g["fig10_depths_m"]:
        for r in g["fig10_distances_m"]:
            sel = [x for x in results if x["depth"] == d and x["distance"] == r]
            m, se = mean_se([x["rrmse_k"] for x in sel])
            conv = sum(x["converged"] for x in sel)
            rows.append(dict(depth=d, distance=r, mean=m, se=se, n=len(sel), converged=conv))
    return rows


def by_medium(results, g):
    """The RRMSE by medium (the paper: "the high quality of the estimate does not depend on the
    specific medium characteristics"): per C class and per a_CDOM class, the mean over every
    depth, distance, other constituent and seed.

    Parameters
    ----------
    results : list of dict
        The Fig 10 fits (:func:`experiments.sweep.run`).
    g : dict
        The grid.

    Returns
    -------
    list of dict
        ``group`` ('chl' or 'cdom'), ``value``, ``mean``, ``se``, ``n``.
    """
    rows = []
    for group, values in (("chl", g["fig10_chl"]), ("cdom", g["fig10_cdom"])):
        for v in values:
            m, se = mean_se([x["rrmse_k"] for x in results if x[group] == v])
            rows.append(dict(group=group, value=v, mean=m, se=se,
                             n=sum(x[group] == v for x in results)))
    return rows


def main(outdir=None, grid_name=None, cache_dir=None, workers=None, setting=None):
    g = resolve(grid_name)
    s = get_setting(setting)
    style()
    step = s["estimation_step_nm"]
    results, _ = sweep.run(fig10_conditions(g, **condition_kw(s)), cache_dir=cache_dir,
                           workers=workers, desc="fig10")
    rows = summarise(results, g)
    q = sweep.q_eq19(step)
    sqrt_q = float(np.sqrt(q))
    factor = sqrt_q if s["rrmse_reading"] != "eq19" else 1.0
    fig, ax = plt.subplots(figsize=(4.8, 3.6), constrained_layout=True)
    for r in g["fig10_distances_m"]:
        sel = [x for x in rows if x["distance"] == r]
        ax.errorbar([x["depth"] for x in sel], [factor * x["mean"] for x in sel],
                    yerr=[factor * x["se"] for x in sel], marker="o", ms=3, capsize=2,
                    label=f"distance {r:g} m")
    ax.set_xlabel("depth (m)")
    ax.set_xticks(g["fig10_depths_m"])
    reading = f"eq 19, q = {q}" if factor == 1.0 else f"eq 19 without √q (q = {q})"
    ax.set_ylabel(f"RRMSE of k ({reading})")
    ax.set_yscale("log")
    percent_axis(ax)
    ax.legend(fontsize=8)
    ax.set_title(f"mean ± SE over {len(g['fig10_chl'])} C × {len(g['fig10_cdom'])} a$_{{CDOM}}$ × "
                 f"{g['fig10_seeds']} seeds\n{s['illuminance_lux']:g} lx, estimator on a "
                 f"{step:g} nm grid")
    save_figure(fig, "fig10_rrmse", outdir)
    plt.close(fig)
    write_csv(figures_dir(outdir) / "fig10_rrmse.csv",
              ["depth_m", "distance_m", "rrmse_mean", "rrmse_se", "rrmse_mean_without_sqrt_q",
               "n", "n_converged"],
              [[x["depth"], x["distance"], f"{x['mean']:.6g}", f"{x['se']:.3g}",
                f"{x['mean'] * sqrt_q:.6g}", x["n"], x["converged"]] for x in rows],
              comment=f"Fig 10 ({g['name']} grid, setting {s['name']}: {s['illuminance_lux']:g} lx, "
                      f"{s['exposure']} exposure): C {g['fig10_chl']}, CDOM {g['fig10_cdom']}, "
                      f"{g['fig10_seeds']} seeds per condition; charts by "
                      f"{'the independent renderer (0.5 nm)' if s.get('world') == 'independent' else 'forward (1 nm)'}, fitted "
                      f"on a {step:g} nm grid; RRMSE (eq 19) on the estimator's q = {q} nodes "
                      "at 10 nm (experiments.sweep.rrmse_on_grid), and without eq 19's 1/sqrt(q)")
    write_csv(figures_dir(outdir) / "fig10_by_medium.csv",
              ["group", "value", "rrmse_mean", "rrmse_se", "rrmse_mean_without_sqrt_q", "n"],
              [[x["group"], f"{x['value']:g}", f"{x['mean']:.6g}", f"{x['se']:.3g}",
                f"{x['mean'] * sqrt_q:.6g}", x["n"]] for x in by_medium(results, g)],
              comment="Fig 10 by medium: RRMSE (eq 19) per C class (group chl, mg m^-3) and per "
                      "a_CDOM(440) class (group cdom, m^-1), each the mean over every depth, "
                      "distance, other constituent and seed")
    write_csv(figures_dir(outdir) / "fig10_fits.csv", fit_header(), [fit_row(x) for x in results],
              comment="every fit behind Fig 10")
    return rows


if __name__ == "__main__":
    main()
