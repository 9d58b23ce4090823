"""Fig 9: estimated vs true attenuation k(lambda) at depth 10 m, distance 5 m, C = 1, CDOM 0.1,
with sensor noise (one fixed seed) -- the chart of Fig 11's first row (the paper: "The
attenuation curve in Fig. 9 was derived from the top left image in Fig. 11"). The CSV holds
the estimator's grid (the truth sampled there)."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from . import sweep
from .common import figures_dir, save_figure, style, write_csv
from .estimation import condition_kw
from .grids import FIG9
from .grids import setting as get_setting

__all__ = ["main"]


def main(outdir=None, grid_name=None, cache_dir=None, workers=None, setting=None):
    s = get_setting(setting)
    style()
    step = s["estimation_step_nm"]
    cond = sweep.condition(FIG9["chl"], FIG9["cdom"], FIG9["depth"], FIG9["distance"], 0,
                           **condition_kw(s))
    (res,), _ = sweep.run([cond], cache_dir=cache_dir, workers=1, progress=False, desc="fig09")
    wl, k = np.asarray(res["wavelengths"]), np.asarray(res["attenuation"])
    wl_hat, k_hat = np.asarray(res["wavelengths_hat"]), np.asarray(res["attenuation_hat"])
    q = sweep.q_eq19(step)
    factor = np.sqrt(q) if s["rrmse_reading"] != "eq19" else 1.0
    rr = res["rrmse_k"] * factor
    fig, ax = plt.subplots(figsize=(4.5, 3.3), constrained_layout=True)
    world = "independent renderer" if s.get("world") == "independent" else "forward"
    ax.plot(wl, k, "k-", lw=2, label=f"ground truth ({world}, {wl[1] - wl[0]:g} nm)")
    nodes = np.isin(wl_hat, sweep.RRMSE_BANDS_NM)
    ax.plot(wl_hat[nodes], k_hat[nodes], "o", ms=4, mfc="none", color="tab:red",
            label=f"estimate ({step:g} nm grid; every {max(step, 10.0):g} nm)")
    ax.set_xlabel("wavelength (nm)")
    ax.set_ylabel("attenuation k = exp(−c L)  (dimensionless)")
    reading = f"eq 19, q = {q}" if factor == 1.0 else f"eq 19 without √q, q = {q}"
    ax.set_title(f"depth 10 m, distance 5 m, C = 1 mg m$^{{-3}}$, a$_{{CDOM}}$ = 0.1 m$^{{-1}}$\n"
                 f"RRMSE ({reading}) = {100 * rr:.2g} %; {s['illuminance_lux']:g} lx")
    ax.set_xlim(400, 700)
    ax.legend()
    save_figure(fig, "fig09_attenuation", outdir)
    plt.close(fig)
    k_true_hat = np.interp(wl_hat, wl, k)
    write_csv(figures_dir(outdir) / "fig09_attenuation.csv", ["wavelength_nm", "k_true", "k_est"],
              [[f"{w:g}", f"{a:.10g}", f"{b:.10g}"] for w, a, b in zip(wl_hat, k_true_hat, k_hat)],
              comment=(f"Fig 9 ({s['name']}: charts by {world}, {s['illuminance_lux']:g} lx, "
                       f"{s['exposure']} exposure, "
                       f"estimator on a {step:g} nm grid): "
                       f"seed {res['seed']}, C_hat {res['chl_hat']:.6g}, CDOM_hat "
                       f"{res['cdom_hat']:.6g}, RRMSE (eq 19, q = {q}) {res['rrmse_k']:.6g}, "
                       "without sqrt(q) "
                       f"{res['rrmse_k'] * np.sqrt(q):.6g}, converged "
                       f"{res['converged']} ({res['status']})"))
    return res


if __name__ == "__main__":
    main()
