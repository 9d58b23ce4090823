"""The benchmark's chart set: a grid of waters and geometries rendered by :mod:`forward` in the
1 nm world, noise-free and with the sensor's noise (``make bench``, the batch profile and the
quadrature check use the same charts).
"""

from __future__ import annotations

import itertools

import numpy as np

import forward

__all__ = ["CDOMS", "CHLS", "DEPTHS", "DISTANCES", "GRID_STRIDE", "QUICK_GRID_STRIDE", "SEED",
           "chart_set"]

#: The grid: C (mg m^-3), a_CDOM(440) (m^-1), depth and distance (m)
CHLS = (1e-3, 0.05, 1.0, 20.0, 100.0)
CDOMS = (0.0, 0.05, 0.5, 2.0)
DEPTHS = (1.0, 10.0, 30.0)
DISTANCES = (0.5, 5.0)
#: Noise seeds of the chart set: SEED * 1000 + the chart's index
SEED = 7
#: Every GRID_STRIDE-th case of the chart grid is used (QUICK_GRID_STRIDE with --quick)
GRID_STRIDE = 4
QUICK_GRID_STRIDE = 8


def chart_set(quick=False):
    """(conditions, rgb, sigma) in the 1 nm world; every GRID_STRIDE-th grid case
    (QUICK_GRID_STRIDE if ``quick``), noise-free and noisy."""
    grid = list(itertools.product(CHLS, CDOMS, DEPTHS, DISTANCES))
    picked = grid[:: (QUICK_GRID_STRIDE if quick else GRID_STRIDE)]
    conds, rgbs, sigmas = [], [], []
    for noise in (False, True):
        for i, (c, a, d, r) in enumerate(picked):
            sim = forward.simulate_chart(c, a, d, r, noise=noise, seed=SEED * 1000 + i)
            conds.append(dict(chl=c, cdom=a, depth=d, distance=r, noise=noise))
            rgbs.append(sim.rgb)
            sigmas.append(sim.rgb_sigma)
    return conds, np.array(rgbs), np.array(sigmas)
