"""How the two headline numbers move with the noise level (surface illuminance).

Headline 1: mean RRMSE(k) over the noise grid (depths x distances x C x CDOM x seeds).
Headline 2: Pearson r between true and estimated C and CDOM at 20 m depth, 1 m distance, over
the Fig 12 grid. The paper does not publish its ISET settings; this shows which light level
gives its "about 2 %" RRMSE. Everything else stays at the sensor defaults.
"""

from __future__ import annotations

import matplotlib.pyplot as plt

from . import sweep
from .common import figures_dir, save_figure, write_csv
from .estimation import fig12_conditions, mean_se, noise_conditions, resolve
from .fig12_13_common import correlations


def main(outdir=None, grid_name=None, cache_dir=None, workers=None):
    g = resolve(grid_name)
    conds, tags = [], []
    for lux in g["noise_lux"]:
        a = noise_conditions(g, lux)
        b = fig12_conditions(g, depths=(20.0,), illuminance_lux=lux)
        conds += a + b
        tags += [("rrmse", lux)] * len(a) + [("r20", lux)] * len(b)
    results, _ = sweep.run(conds, cache_dir=cache_dir, workers=workers, desc="noise study")
    rows = []
    for lux in g["noise_lux"]:
        rr = [x for x, t in zip(results, tags) if t == ("rrmse", lux)]
        r20 = [x for x, t in zip(results, tags) if t == ("r20", lux)]
        m, se = mean_se([x["rrmse_k"] for x in rr])
        r_chl, r_chl_log, _ = correlations(r20, 20.0, "chl")
        r_cdom, r_cdom_log, _ = correlations(r20, 20.0, "cdom")
        conv = sum(x["converged"] for x in rr + r20)
        rows.append([lux, f"{m:.6g}", f"{se:.3g}", f"{r_chl:.4f}", f"{r_cdom:.4f}",
                     f"{r_chl_log:.4f}", f"{r_cdom_log:.4f}", conv, len(rr) + len(r20)])
    fig, (a0, a1) = plt.subplots(1, 2, figsize=(8, 3.2))
    lux = [r[0] for r in rows]
    a0.errorbar(lux, [float(r[1]) for r in rows], yerr=[float(r[2]) for r in rows], marker="o",
                capsize=2)
    a0.axhline(0.02, color="grey", ls="--", lw=0.8, label="paper: about 2 %")
    a0.set_xscale("log")
    a0.set_yscale("log")
    a0.set_xlabel("surface illuminance (lx)")
    a0.set_ylabel("mean RRMSE of k (eq 19)")
    a0.legend(fontsize=7)
    a1.plot(lux, [float(r[3]) for r in rows], "o-", label="C")
    a1.plot(lux, [float(r[4]) for r in rows], "s-", label="CDOM")
    a1.axhline(0.7, color="grey", ls="--", lw=0.8, label="paper: > 0.7")
    a1.set_xscale("log")
    a1.set_xlabel("surface illuminance (lx)")
    a1.set_ylabel("Pearson r at 20 m depth")
    a1.legend(fontsize=7)
    fig.tight_layout()
    save_figure(fig, "noise_study", outdir)
    plt.close(fig)
    write_csv(figures_dir(outdir) / "noise_study.csv",
              ["illuminance_lux", "rrmse_mean", "rrmse_se", "pearson_r_chl_20m",
               "pearson_r_cdom_20m", "pearson_r_log_chl_20m", "pearson_r_log_cdom_20m",
               "n_converged", "n"], rows,
              comment=f"noise study ({g['name']} grid); all other sensor settings at defaults")
    return rows


if __name__ == "__main__":
    main()
