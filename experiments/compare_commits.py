"""Speed of two commits side by side: the same workload, alternating fresh processes.

    python -m experiments.compare_commits OLD_REV [NEW_REV] [--rounds 3]

Each commit is exported with ``git archive`` into a temporary folder and run from there with
this environment's packages (``NEW_REV`` = ``WORKTREE``, :data:`WORKTREE`: this working tree
itself, uncommitted changes included, run in place); the rounds alternate old, new, old, new, ... so that a machine
whose speed drifts treats both alike, and the best round of each is reported (fits per
second; higher is better). The workload: the 60 charts of ``make bench`` (every 4th case of
its grid, noisy), one at a time through ``sca.estimate`` and ``sca.estimate_least_squares``,
and tiled to 20 000 through ``sca.estimate_batch`` with and without intervals, at 1 nm and
10 nm. It uses only arguments every version since issue 10 accepts.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

__all__ = ["WORKLOAD", "WORKTREE", "export", "main", "run_once"]

ROOT = Path(__file__).resolve().parents[1]
#: The revision name that stands for this working tree as it is (not exported).
WORKTREE = "WORKTREE"
#: Charts in the batch rows (the 60 tiled).
BATCH_CHARTS = 20000

WORKLOAD = r"""
import itertools, json, time
import numpy as np
import inspect
import forward, sca
# the paper's exact model where the commit has an uncertainty budget (its default since issue 17)
EX = {"uncertain": {}} if "uncertain" in inspect.signature(sca.estimate).parameters else {}
C = (0.001, 0.05, 1.0, 20.0, 100.0); A = (0.0, 0.05, 0.5, 2.0); D = (1.0, 10.0, 30.0)
R = (0.5, 5.0)
conds = list(itertools.product(C, A, D, R))[::4]
sims = [forward.simulate_chart(c, a, d, r, seed=i) for i, (c, a, d, r) in enumerate(conds)]
out = {}
for step in (1.0, 10.0):
    setup = forward.chart_setup(wavelengths=np.arange(400.0, 701.0, step))
    for name, fn in (("sca.estimate", sca.estimate),
                     ("estimate_least_squares", sca.estimate_least_squares)):
        fn(sims[0].rgb, depth=conds[0][2], distance=conds[0][3], sigma=sims[0].rgb_sigma,
           setup=setup, **EX)
        t = time.perf_counter()
        for s, c in zip(sims, conds):
            fn(s.rgb, depth=c[2], distance=c[3], sigma=s.rgb_sigma, setup=setup, **EX)
        out[f"{name}, {step:g} nm"] = len(sims) / (time.perf_counter() - t)
    n = N_BATCH
    k = n // len(sims) + 1
    rgb = np.tile(np.array([s.rgb for s in sims]), (k, 1, 1))[:n]
    sig = np.tile(np.array([s.rgb_sigma for s in sims]), (k, 1, 1))[:n]
    d = np.tile(np.array([c[2] for c in conds]), k)[:n]
    r = np.tile(np.array([c[3] for c in conds]), k)[:n]
    sca.estimate_batch(rgb[:60], depth=d[:60], distance=r[:60], sigma=sig[:60], setup=setup,
                       **EX)
    for iv in (False, True):
        t = time.perf_counter()
        sca.estimate_batch(rgb, depth=d, distance=r, sigma=sig, setup=setup, intervals=iv,
                           **EX)
        key = "estimate_batch" + ("" if iv else " (no intervals)")
        out[f"{key}, {step:g} nm"] = n / (time.perf_counter() - t)
print(json.dumps(out))
"""


def export(rev: str, dest: Path) -> Path:
    """``git archive`` of ``rev`` unpacked into ``dest``; returns ``dest`` (:data:`ROOT`
    itself, nothing exported, for :data:`WORKTREE`)."""
    if rev == WORKTREE:
        return ROOT
    dest.mkdir(parents=True, exist_ok=True)
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", rev], check=True,
                             capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(dest)], input=archive, check=True)
    return dest


def run_once(tree: Path, n_batch: int = BATCH_CHARTS) -> dict:
    """The workload in a fresh process with ``tree`` first on the import path."""
    env = dict(os.environ, PYTHONPATH=str(tree), OPENBLAS_NUM_THREADS="1")
    code = WORKLOAD.replace("N_BATCH", str(int(n_batch)))
    res = subprocess.run([sys.executable, "-c", code], cwd=tree, env=env, check=True,
                         capture_output=True, text=True)
    return json.loads(res.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    """Run both commits alternately and print a Markdown table of the best rounds."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("old")
    p.add_argument("new", nargs="?", default="HEAD",
                   help=f"a revision, or {WORKTREE} for this working tree as it is")
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--batch", type=int, default=BATCH_CHARTS)
    args = p.parse_args(argv)
    best = {args.old: {}, args.new: {}}
    with tempfile.TemporaryDirectory() as tmp:
        trees = {rev: export(rev, Path(tmp) / f"rev{i}") for i, rev in
                 enumerate((args.old, args.new))}
        for _ in range(args.rounds):
            for rev in (args.old, args.new):
                for key, val in run_once(trees[rev], args.batch).items():
                    best[rev][key] = max(best[rev].get(key, 0.0), val)
    print(f"fits per second, best of {args.rounds} alternating rounds\n")
    print(f"| workload | {args.old} | {args.new} | change |\n|---|---|---|---|")
    for key in best[args.old]:
        a, b = best[args.old][key], best[args.new].get(key, float("nan"))
        print(f"| {key} | {a:.4g} | {b:.4g} | {100 * (b / a - 1):+.0f} % |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
