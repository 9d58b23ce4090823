"""Coverage and width of every derived quantity among the charts whose C sits at its bound 0,
and among the others, in one of HONESTY.md's worlds (the independent renderer).

    python -m experiments.bound_check [--n 200] [--world priors]

Decision 0066-derived-intervals-at-the-bounds cites its output.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import sca

from . import honesty

__all__ = ["NAMES", "main", "run"]

#: The quantities checked.
NAMES = ("c_443", "c_490", "c_555", "c_670", "a_nw_440")


def run(n: int = 200, world: str = "priors", seed: int = honesty.SEED) -> list:
    """Lines: the fit's time and counts, then per quantity and group the charts covered and
    the median half-width (hi - lo) / 2 / estimate."""
    root = np.random.default_rng(seed)
    cond_rng, render_root = root.spawn(2)
    cond = honesty.draw_conditions(cond_rng, n)
    every = {w.name: w for w in honesty.worlds()}
    streams = dict(zip(every, render_root.spawn(len(every)), strict=True))
    w = every[world]
    r = honesty.render_set(w, cond, streams[world])
    t0 = time.perf_counter()
    est = sca.estimate_batch(np.maximum(r["rgb"], 0.0), depth=r["depth"],
                             distance=r["distance"], sigma=r["sigma"], gain="free",
                             uncertain=w.uncertain)
    rel, at = est.reliable, est.chl <= 0.0
    lines = [f"{world}: {n} charts fitted in {time.perf_counter() - t0:.1f} s; {rel.sum()} "
             f"reliable, {(rel & at).sum()} of them with C at 0"]
    for k in NAMES:
        ci, truth, value = est.quantity_intervals[k], np.asarray(r["truth"][k]), est.quantities[k]
        cov = (ci[:, 0] <= truth) & (truth <= ci[:, 1])
        with np.errstate(divide="ignore", invalid="ignore"):
            half = (ci[:, 1] - ci[:, 0]) / 2 / value
        for label, m in (("all", rel), ("C = 0", rel & at), ("C > 0", rel & ~at)):
            lines.append(f"  {k} {label}: covered {cov[m].sum()}/{m.sum()}, median half-width "
                         f"{100 * np.median(half[m]):.1f} %")
    return lines


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--n", type=int, default=200, help="charts (default 200)")
    p.add_argument("--world", default="priors", help="HONESTY.md's world (default priors)")
    args = p.parse_args(argv)
    for line in run(args.n, args.world):
        print(line, flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
