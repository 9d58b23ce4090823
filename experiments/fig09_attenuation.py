"""Fig 9: estimated vs true attenuation k(lambda) at depth 10 m, distance 5 m, C = 1, CDOM 0.1,
with sensor noise (one fixed seed)."""

from __future__ import annotations

import matplotlib.pyplot as plt

from . import sweep
from .common import figures_dir, save_figure, write_csv
from .grids import FIG9


def main(outdir=None, grid_name=None, cache_dir=None, workers=None):
    cond = sweep.condition(FIG9["chl"], FIG9["cdom"], FIG9["depth"], FIG9["distance"], 0)
    (res,), _ = sweep.run([cond], cache_dir=cache_dir, workers=1, progress=False, desc="fig09")
    wl, k, k_hat = res["wavelengths"], res["attenuation"], res["attenuation_hat"]
    fig, ax = plt.subplots(figsize=(4.5, 3.2))
    ax.plot(wl, k, "k-", lw=2, label="ground truth")
    ax.plot(wl, k_hat, "o", ms=4, mfc="none", color="tab:red", label="estimate")
    ax.set_xlabel("wavelength (nm)")
    ax.set_ylabel("attenuation k")
    ax.set_title(f"depth 10 m, distance 5 m, C = 1, CDOM = 0.1\nRRMSE = {res['rrmse_k']:.2e}",
                 fontsize=8)
    ax.legend(fontsize=8)
    save_figure(fig, "fig09_attenuation", outdir)
    plt.close(fig)
    write_csv(figures_dir(outdir) / "fig09_attenuation.csv", ["wavelength_nm", "k_true", "k_est"],
              [[w, f"{a:.10g}", f"{b:.10g}"] for w, a, b in zip(wl, k, k_hat)],
              comment=(f"Fig 9: seed {res['seed']}, C_hat {res['chl_hat']:.6g}, "
                       f"CDOM_hat {res['cdom_hat']:.6g}, RRMSE (eq 19) {res['rrmse_k']:.6g}, "
                       f"converged {res['converged']} ({res['status']})"))
    return res


if __name__ == "__main__":
    main()
