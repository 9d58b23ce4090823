"""Fig 10: RRMSE(k) (eq 19) vs depth and distance; each point the mean over C x CDOM x seeds,
with its standard error."""

from __future__ import annotations

import matplotlib.pyplot as plt

from . import sweep
from .common import figures_dir, save_figure, write_csv
from .estimation import fig10_conditions, fit_header, fit_row, mean_se, resolve


def summarise(results, g):
    rows = []
    for d in g["fig10_depths_m"]:
        for r in g["fig10_distances_m"]:
            sel = [x for x in results if x["depth"] == d and x["distance"] == r]
            m, se = mean_se([x["rrmse_k"] for x in sel])
            conv = sum(x["converged"] for x in sel)
            rows.append(dict(depth=d, distance=r, mean=m, se=se, n=len(sel), converged=conv))
    return rows


def main(outdir=None, grid_name=None, cache_dir=None, workers=None):
    g = resolve(grid_name)
    results, _ = sweep.run(fig10_conditions(g), cache_dir=cache_dir, workers=workers, desc="fig10")
    rows = summarise(results, g)
    fig, ax = plt.subplots(figsize=(5, 3.5))
    for r in g["fig10_distances_m"]:
        sel = [x for x in rows if x["distance"] == r]
        ax.errorbar([x["depth"] for x in sel], [x["mean"] for x in sel],
                    yerr=[x["se"] for x in sel], marker="o", ms=3, capsize=2,
                    label=f"distance {r:g} m")
    ax.set_xlabel("depth (m)")
    ax.set_ylabel("RRMSE of k (eq 19, 31 bands)")
    ax.set_yscale("log")
    ax.legend(fontsize=7)
    ax.set_title(f"mean over {len(g['fig10_chl'])} C x {len(g['fig10_cdom'])} CDOM x "
                 f"{g['fig10_seeds']} seeds ({g['name']} grid)", fontsize=8)
    save_figure(fig, "fig10_rrmse", outdir)
    plt.close(fig)
    write_csv(figures_dir(outdir) / "fig10_rrmse.csv",
              ["depth_m", "distance_m", "rrmse_mean", "rrmse_se", "n", "n_converged"],
              [[x["depth"], x["distance"], f"{x['mean']:.6g}", f"{x['se']:.3g}", x["n"],
                x["converged"]] for x in rows],
              comment=f"Fig 10 ({g['name']} grid): C {g['fig10_chl']}, CDOM {g['fig10_cdom']}, "
                      f"{g['fig10_seeds']} seeds per condition, default sensor; charts in the 1 nm "
                      "world, fitted at the estimator's default (1 nm); RRMSE (eq 19) on the 31 "
                      "bands of 10 nm (experiments.sweep.RRMSE_BANDS_NM)")
    write_csv(figures_dir(outdir) / "fig10_fits.csv", fit_header(), [fit_row(x) for x in results],
              comment="every fit behind Fig 10")
    return rows


if __name__ == "__main__":
    main()
