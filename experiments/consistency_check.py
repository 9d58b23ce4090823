"""False alarms of the readings' and priors' tests (:mod:`sca.consistency`) on HONESTY.md's
worlds (the independent renderer): per world, the charts flagged ``nuisance-pulled``, and on
``clean`` and ``priors`` with a right water sample on every chart (the truth plus its sd times
a normal draw) the charts flagged ``reading-conflict`` and a_CDOM's coverage.

    python -m experiments.consistency_check [--n 200]

Decision 0062-readings-tested-against-the-photos cites its output.
"""

from __future__ import annotations

import argparse

import numpy as np

import sca

from . import honesty

__all__ = ["WORLDS", "SAMPLE_SD", "main", "run"]

#: The worlds checked (HONESTY.md's names).
WORLDS = ("clean", "priors", "cdom_slope_0.019", "depth_told_+0.3m", "distance_told_x1.10",
          "yellowing_0.03", "path_split", "balance_1%")
#: The water sample's sd, m^-1 (issue 47: a realistic sample).
SAMPLE_SD = 0.02


def _fit(world, r, auxiliary=None):
    return sca.estimate_batch(np.maximum(r["rgb"], 0.0), depth=r["depth"],
                              distance=r["distance"], sigma=r["sigma"], gain="free",
                              uncertain=world.uncertain, auxiliary=auxiliary)


def _count(est, flag) -> int:
    return int(sum(flag in f for f in est.flags))


def run(n: int = 200, seed: int = honesty.SEED) -> list:
    """One line per world (see the module's text)."""
    root = np.random.default_rng(seed)
    cond_rng, render_root = root.spawn(2)
    cond = honesty.draw_conditions(cond_rng, n)
    every = {w.name: w for w in honesty.worlds()}
    streams = dict(zip(every, render_root.spawn(len(every)), strict=True))
    lines = []
    for name in WORLDS:
        world = every[name]
        r = honesty.render_set(world, cond, streams[name])
        est = _fit(world, r)
        line = f"{name}: {_count(est, 'nuisance-pulled')} of {n} charts nuisance-pulled"
        if name in ("clean", "priors"):
            truth = np.asarray(cond["cdom"], float)
            draw = np.random.default_rng(seed + 1).standard_normal(n)
            value = np.maximum(truth + SAMPLE_SD * draw, 1e-4)
            e2 = _fit(world, r, {"cdom": (value, np.full(n, SAMPLE_SD))})
            cov = np.mean((e2.cdom_ci[:, 0] <= truth) & (truth <= e2.cdom_ci[:, 1]))
            line += (f"; with a right water sample: {_count(e2, 'reading-conflict')} "
                     f"reading-conflict, {_count(e2, 'nuisance-pulled')} nuisance-pulled, "
                     f"a_CDOM covered {100 * cov:.1f} %")
        lines.append(line)
    return lines


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--n", type=int, default=200, help="charts per world (default 200)")
    args = p.parse_args(argv)
    for line in run(args.n):
        print(line, flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
