"""Noise-free round trip of both estimator modes over the grid of the estimator's tests.

    python -m experiments.estimator_grid [--out figures]

Grid: C in 5 log-spaced values 0.01-20 mg m^-3, a_CDOM(440) in 4 log-spaced values 0.01-1 m^-1,
depth in {1, 5, 10, 20} m, distance in {0.5, 1, 5, 10} m (320 charts). A fit succeeds when it
reports ``converged`` and recovers C and a_CDOM to 1e-4 relative and k to RRMSE < 1e-6.
Prints the success rate and median iterations per mode and writes estimator_grid.csv.
"""

from __future__ import annotations

import argparse
import itertools

import numpy as np

import forward
import sca

from .common import figures_dir, write_csv

__all__ = ["run", "main", "CHLS", "CDOMS", "DEPTHS", "DISTANCES"]

CHLS = np.logspace(-2, np.log10(20), 5)
CDOMS = np.logspace(-2, 0, 4)
DEPTHS = (1.0, 5.0, 10.0, 20.0)
DISTANCES = (0.5, 1.0, 5.0, 10.0)


def run(outdir=None):
    rows, summary = [], {}
    for mode in sca.MODES:
        ok, iters = 0, []
        for chl, cdom, depth, distance in itertools.product(CHLS, CDOMS, DEPTHS, DISTANCES):
            sim = forward.simulate_chart(chl, cdom, depth, distance, noise=False)
            est = sca.estimate(sim.rgb, depth=depth, distance=distance, mode=mode, uncertain={})
            err_k = sca.rrmse(est.attenuation, sim.attenuation)
            good = (est.converged and abs(est.chl / chl - 1) < 1e-4
                    and abs(est.cdom / cdom - 1) < 1e-4 and err_k < 1e-6)
            ok += good
            iters.append(est.iterations)
            rows.append([mode, chl, cdom, depth, distance, est.chl, est.cdom, err_k,
                         est.converged, good, est.iterations, est.status])
        n = len(iters)
        summary[mode] = (ok, n, float(np.median(iters)))
        print(f"{mode:12s} success {ok}/{n} = {ok / n:.1%}, median iterations {np.median(iters):g}")
    write_csv(figures_dir(outdir) / "estimator_grid.csv",
              ["mode", "chl", "cdom", "depth_m", "distance_m", "chl_hat", "cdom_hat", "rrmse_k",
               "converged", "success", "iterations", "status"], rows,
              comment="python -m experiments.estimator_grid: noise-free round trips")
    return summary


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=None)
    run(parser.parse_args(argv).out)


if __name__ == "__main__":
    main()
