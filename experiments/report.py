"""Print the numbers of REPRODUCTION.md from the CSVs the figures were made from.

    python -m experiments.report [--figures figures]
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np


def _read(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(line for line in f if not line.startswith("#")))
    return rows


def report(figdir="figures") -> str:
    d = Path(figdir)
    out = []
    f9 = [l for l in (d / "fig09_attenuation.csv").read_text().splitlines() if l.startswith("#")]
    out.append(f9[0].lstrip("# "))
    f10 = _read(d / "fig10_rrmse.csv")
    means = np.array([float(r["rrmse_mean"]) for r in f10])
    out.append(f"Fig 10: mean RRMSE over all {len(f10)} depth x distance cells = {means.mean():.3g} "
               f"(min {means.min():.3g}, max {means.max():.3g}); converged "
               f"{sum(int(r['n_converged']) for r in f10)}/{sum(int(r['n']) for r in f10)}")
    for depth in sorted({float(r["depth_m"]) for r in f10}):
        m = [float(r["rrmse_mean"]) for r in f10 if float(r["depth_m"]) == depth]
        out.append(f"  depth {depth:g} m: mean over distances {np.mean(m):.3g}")
    for dist in sorted({float(r["distance_m"]) for r in f10}):
        m = [float(r["rrmse_mean"]) for r in f10 if float(r["distance_m"]) == dist]
        out.append(f"  distance {dist:g} m: mean over depths {np.mean(m):.3g}")
    for r in _read(d / "fig11_colour_correction.csv"):
        out.append(f"Fig 11: depth {r['depth_m']} m: mean CIEDE2000 captured {r['mean_de2000_captured']}"
                   f" -> corrected {r['mean_de2000_corrected']} (camera in air "
                   f"{r['mean_de2000_camera_in_air']})")
    for name, label in (("fig12_chlorophyll", "Fig 12 (C)"), ("fig13_cdom", "Fig 13 (CDOM)")):
        for r in _read(d / f"{name}.csv"):
            out.append(f"{label}: depth {r['depth_m']} m: Pearson r {r['pearson_r']} "
                       f"(on log10: {r['pearson_r_log10']}), n = {r['n']}")
    out.append("Noise study (illuminance lx: mean RRMSE +- SE; r(C), r(CDOM) at 20 m):")
    for r in _read(d / "noise_study.csv"):
        out.append(f"  {float(r['illuminance_lux']):g} lx: {float(r['rrmse_mean']):.3g} +- "
                   f"{float(r['rrmse_se']):.2g}; r(C) {r['pearson_r_chl_20m']}, r(CDOM) "
                   f"{r['pearson_r_cdom_20m']}; converged {r['n_converged']}/{r['n']}")
    return "\n".join(out)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--figures", default="figures")
    print(report(p.parse_args(argv).figures))


if __name__ == "__main__":
    main()
