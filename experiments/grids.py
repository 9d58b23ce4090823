"""The sweep grids of Figs 9-13 and of the noise study, in one place.

``paper`` (default) is the full-size grid used for the published figures; ``reduced`` is a
small grid with the same structure, used by the test suite (seconds). Choose with
``python -m experiments --grid reduced`` or the environment variable ``UW3P_GRID``.
"""

from __future__ import annotations

import os

GRIDS = {
    "paper": {
        # Fig 10: RRMSE(k) vs depth and distance, averaged over C x CDOM x seeds
        "fig10_depths_m": (1.0, 2.0, 5.0, 10.0, 15.0, 20.0),
        "fig10_distances_m": (0.5, 1.0, 2.0, 5.0, 10.0),
        "fig10_chl": (0.1, 0.5, 1.0, 5.0, 10.0),
        "fig10_cdom": (0.01, 0.05, 0.1, 0.5),
        "fig10_seeds": 2,
        # Figs 12-13: estimated vs true C and CDOM at 1 m distance
        "fig12_depths_m": (5.0, 10.0, 20.0),
        "fig12_distance_m": 1.0,
        "fig12_chl": (0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0),
        "fig12_cdom": (0.01, 0.02, 0.05, 0.1, 0.2, 0.5),
        "fig12_seeds": 3,
        # noise study: the two headline numbers vs surface illuminance
        "noise_lux": (20000.0, 2000.0, 200.0, 20.0, 5.0),
        "noise_depths_m": (5.0, 10.0, 20.0),
        "noise_distances_m": (1.0, 5.0),
        "noise_chl": (0.1, 1.0, 5.0, 10.0),
        "noise_cdom": (0.01, 0.1, 0.5),
        "noise_seeds": 2,
    },
    "reduced": {
        "fig10_depths_m": (5.0, 20.0),
        "fig10_distances_m": (1.0, 5.0),
        "fig10_chl": (0.5, 5.0),
        "fig10_cdom": (0.05, 0.5),
        "fig10_seeds": 1,
        "fig12_depths_m": (5.0, 10.0, 20.0),
        "fig12_distance_m": 1.0,
        "fig12_chl": (0.1, 1.0, 10.0),
        "fig12_cdom": (0.02, 0.2),
        "fig12_seeds": 1,
        "noise_lux": (20000.0, 20.0),
        "noise_depths_m": (5.0, 20.0),
        "noise_distances_m": (1.0,),
        "noise_chl": (0.5, 5.0),
        "noise_cdom": (0.05,),
        "noise_seeds": 1,
    },
}

#: Fixed conditions of the single-chart figures.
FIG9 = dict(chl=1.0, cdom=0.1, depth=10.0, distance=5.0)
FIG11 = dict(chl=1.0, cdom=0.1, depths=(5.0, 20.0), distance=5.0)
#: Base of every noise seed (the seed of a condition is derived from it and the condition).
BASE_SEED = 2016


def grid(name=None) -> dict:
    name = name or os.environ.get("UW3P_GRID", "paper")
    if name not in GRIDS:
        raise ValueError(f"grid: unknown grid {name!r}; choose from {sorted(GRIDS)}")
    return dict(GRIDS[name], name=name)
