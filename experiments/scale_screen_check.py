"""The known gain's test with and without its screen (decision 0071-scale-test-screened): the
same charts fitted by ``sca.estimate_batch`` (its defaults, gain known, the sensor's noise) with
every chart refitted with the gain free (``sca.batch.SCALE_SCREEN_STAT`` = 0) and with only the
charts the screen passes refitted; per world (the charts' values times a factor: 1 = in the
units the fit is told), the charts flagged ``scale-mismatch`` each way, those flagged by one
only, and the seconds of each fit.

    python -m experiments.scale_screen_check [--n 150]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import forward
import sca
import sca.batch

__all__ = ["FACTORS", "SEED", "main", "run"]

#: The worlds: every value times this factor (a camera's values in other units, read as the
#: model's).
FACTORS = (1.0, 0.4, 0.7, 0.85, 1.15, 1.5)
#: The draw's seed.
SEED = 0


def _charts(rng, n, factor):
    """n charts of forward's world: C log-uniform 0.01-30, a_CDOM 0.005-2, depth 1-20 m,
    distance 0.5-4 m, with the sensor's noise, times ``factor``."""
    C = np.exp(rng.uniform(np.log(0.01), np.log(30.0), n))
    A = np.exp(rng.uniform(np.log(0.005), np.log(2.0), n))
    D, R = rng.uniform(1.0, 20.0, n), rng.uniform(0.5, 4.0, n)
    sims = [forward.simulate_chart(c, a, d, r, seed=int(rng.integers(2 ** 31)))
            for c, a, d, r in zip(C, A, D, R)]
    return (np.array([s.rgb for s in sims]) * factor,
            np.array([s.rgb_sigma for s in sims]) * factor, D, R)


def _flagged(rgb, sig, D, R, screen: float):
    keep = sca.batch.SCALE_SCREEN_STAT
    sca.batch.SCALE_SCREEN_STAT = screen
    try:
        t = time.perf_counter()
        b = sca.estimate_batch(rgb, depth=D, distance=R, sigma=sig)
        return np.array(["scale-mismatch" in f for f in b.flags]), time.perf_counter() - t
    finally:
        sca.batch.SCALE_SCREEN_STAT = keep


def run(n: int = 150, seed: int = SEED) -> list:
    """One row per factor: n, flagged with every chart refitted, flagged with the screen,
    flagged by one way only, and the seconds of each."""
    rng = np.random.default_rng(seed)
    rows = []
    for factor in FACTORS:
        rgb, sig, D, R = _charts(rng, n, factor)
        full, t_full = _flagged(rgb, sig, D, R, 0.0)
        screened, t_screen = _flagged(rgb, sig, D, R, sca.batch.SCALE_SCREEN_STAT)
        rows.append({"factor": factor, "n": n, "flagged_all_refitted": int(full.sum()),
                     "flagged_screened": int(screened.sum()),
                     "differ": int(np.sum(full != screened)),
                     "seconds_all_refitted": t_full, "seconds_screened": t_screen})
    return rows


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--n", type=int, default=150)
    a = p.parse_args(argv)
    print("| values x | charts | flagged, every chart refitted | flagged, screened | differ "
          "| s, every chart refitted | s, screened |")
    print("|---:|---:|---:|---:|---:|---:|---:|")
    for r in run(a.n):
        print(f"| {r['factor']:g} | {r['n']} | {r['flagged_all_refitted']} | "
              f"{r['flagged_screened']} | {r['differ']} | {r['seconds_all_refitted']:.2f} | "
              f"{r['seconds_screened']:.2f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
