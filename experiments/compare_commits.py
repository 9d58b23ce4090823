"""Speed of two commits side by side: the same workload, alternating fresh processes.

    python -m experiments.compare_commits OLD_REV [NEW_REV] [--rounds 3] [--workload exact]
    python -m experiments.compare_commits ffa6454 WORKTREE --workload default \
        --batch 1000,120 --json benchmarks/compare_default.json

Each commit is exported with ``git archive`` into a folder of its own, kept between runs
(:func:`export_dir`: numba's on-disk cache beside its modules is then built once, not in every
run) and run from there with this environment's packages (``NEW_REV`` = ``WORKTREE``,
:data:`WORKTREE`: this working tree itself, uncommitted changes included, run in place); the
rounds alternate old, new, old, new, ... so that a machine whose speed drifts treats both
alike. Each round is a fresh process that first makes one untimed call of every estimator it
times (numba's and the quadrature's caches), then the timed calls. Reported: fits per second,
the best and the median round of each commit, and the speed-up new / old (above 1 where the new
commit is faster); the ``default`` workload also reports each process's CPU milliseconds per fit
(every thread of it): on a shared machine the work itself, where the wall time includes waiting
for a core.

Workloads (:data:`WORKLOADS`), on the 60 charts of ``make bench`` (every 4th case of its grid,
with the sensor's noise):

* ``exact`` (the default): one at a time through ``sca.estimate`` and
  ``sca.estimate_least_squares``, and tiled to ``--batch`` (default 20 000) through
  ``sca.estimate_batch`` with and without intervals, at 1 nm and 10 nm, all on the paper's exact
  model; only arguments every version since issue 10 accepts;
* ``default``: ``sca.estimate_batch(rgb, depth=, distance=, sigma=)`` with every other argument
  at the commit's own default (issue 36's "default configuration": the default uncertainty
  budget, every path model, intervals, the 1 nm grid -- on the certified quadrature where the
  commit has one), the charts tiled to each size of ``--batch`` (e.g. 1000,120).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from .common import WORKTREE, commit_of

__all__ = ["WORKLOAD", "WORKLOADS", "WORKLOAD_DEFAULT", "WORKTREE", "export", "export_dir",
           "main", "run_once"]

ROOT = Path(__file__).resolve().parents[1]
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

#: Issue 36's default configuration: the batch with nothing but the charts, their geometry and
#: the sensor's noise given; one size per entry of SIZES (after one untimed call on the 60);
#: fits per second (wall) and the process's CPU milliseconds per fit (every thread).
WORKLOAD_DEFAULT = r"""
import itertools, json, time
import numpy as np
import forward, sca
C = (0.001, 0.05, 1.0, 20.0, 100.0); A = (0.0, 0.05, 0.5, 2.0); D = (1.0, 10.0, 30.0)
R = (0.5, 5.0)
conds = list(itertools.product(C, A, D, R))[::4]
sims = [forward.simulate_chart(c, a, d, r, seed=i) for i, (c, a, d, r) in enumerate(conds)]
rgb0 = np.array([s.rgb for s in sims]); sig0 = np.array([s.rgb_sigma for s in sims])
d0 = np.array([c[2] for c in conds]); r0 = np.array([c[3] for c in conds])
sca.estimate_batch(rgb0, depth=d0, distance=r0, sigma=sig0)
out = {}
for n in SIZES:
    k = n // len(sims) + 1
    rgb, sig = np.tile(rgb0, (k, 1, 1))[:n], np.tile(sig0, (k, 1, 1))[:n]
    d, r = np.tile(d0, k)[:n], np.tile(r0, k)[:n]
    t, c = time.perf_counter(), time.process_time()
    b = sca.estimate_batch(rgb, depth=d, distance=r, sigma=sig)
    out[f"estimate_batch, defaults, {n} charts"] = n / (time.perf_counter() - t)
    out[f"CPU ms per fit: estimate_batch, defaults, {n} charts"] = (
        1e3 * (time.process_time() - c) / n)
print(json.dumps(out))
"""
#: Results whose name starts so are costs (lower is better); the others are fits per second.
LOWER_IS_BETTER = "CPU ms"
#: name -> (workload source, its default batch sizes)
WORKLOADS = {"exact": (WORKLOAD, (BATCH_CHARTS,)), "default": (WORKLOAD_DEFAULT, (1000, 120))}


def export_dir() -> Path:
    """Where exported commits are kept (``$UW3P_CACHE_DIR/commits``, else
    ``$XDG_CACHE_HOME/uw3p/commits`` or ``~/.cache/uw3p/commits``)."""
    given = os.environ.get("UW3P_CACHE_DIR")
    if given:
        return Path(given) / "commits"
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "uw3p" / "commits"


def export(rev: str, dest: Path | None = None) -> Path:
    """``git archive`` of ``rev`` unpacked into ``dest`` (default :func:`export_dir` / its
    full hash, reused when a complete export is there); returns the folder (:data:`ROOT`
    itself, nothing exported, for :data:`WORKTREE`)."""
    if rev == WORKTREE:
        return ROOT
    if dest is None:
        dest = export_dir() / commit_of(rev)
    done = dest / ".exported"
    if done.is_file():
        return dest
    dest.mkdir(parents=True, exist_ok=True)
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", rev], check=True,
                             capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(dest)], input=archive, check=True)
    done.write_text(rev + "\n")
    return dest


def run_once(tree: Path, n_batch=BATCH_CHARTS, workload: str = "exact") -> dict:
    """The workload in a fresh process with ``tree`` first on the import path (``n_batch``:
    the batch size, or the sizes of the ``default`` workload)."""
    env = dict(os.environ, PYTHONPATH=str(tree), OPENBLAS_NUM_THREADS="1")
    if workload == "default":
        sizes = (n_batch,) if np.isscalar(n_batch) else tuple(n_batch)
        code = WORKLOAD_DEFAULT.replace("SIZES", repr(tuple(int(n) for n in sizes)))
    else:
        n = n_batch if np.isscalar(n_batch) else n_batch[0]
        code = WORKLOAD.replace("N_BATCH", str(int(n)))
    res = subprocess.run([sys.executable, "-c", code], cwd=tree, env=env, check=True,
                         capture_output=True, text=True)
    return json.loads(res.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    """Run both commits alternately and print a Markdown table (best and median rounds);
    ``--json`` also writes every round."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("old")
    p.add_argument("new", nargs="?", default="HEAD",
                   help=f"a revision, or {WORKTREE} for this working tree as it is")
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--workload", choices=sorted(WORKLOADS), default="exact")
    p.add_argument("--batch", default=None,
                   help="batch size(s), comma-separated (default: the workload's)")
    p.add_argument("--json", default=None, metavar="FILE", help="write the rounds here")
    args = p.parse_args(argv)
    sizes = WORKLOADS[args.workload][1] if args.batch is None else tuple(
        int(x) for x in str(args.batch).split(","))
    revs = (args.old, args.new)
    rounds = {rev: [] for rev in revs}
    t0, load, date = time.perf_counter(), _load(), time.strftime("%Y-%m-%d %H:%M:%S %Z")
    trees = {rev: export(rev) for rev in revs}
    for _ in range(args.rounds):
        for rev in revs:
            rounds[rev].append(run_once(trees[rev], sizes, args.workload))
    keys = list(dict.fromkeys(k for rev in revs for r in rounds[rev] for k in r))

    def stat(rev, key, fn):
        vals = [r[key] for r in rounds[rev] if key in r]
        return float(fn(vals)) if vals else float("nan")
    rows = []
    for key in keys:
        lower = key.startswith(LOWER_IS_BETTER)
        row = {"workload": key, "lower_is_better": lower}
        for i, rev in enumerate(revs):
            row[f"best_{i}"] = stat(rev, key, min if lower else max)
            row[f"median_{i}"] = stat(rev, key, np.median)
        for w in ("best", "median"):  # > 1: the new commit is faster
            a, b = row[f"{w}_0"], row[f"{w}_1"]
            row[f"ratio_{w}"] = a / b if lower else b / a
        rows.append(row)
    print(f"best and median of {args.rounds} alternating rounds (speed-up: > 1 where the new "
          "commit is faster)\n")
    print(f"| workload | {args.old} best / median | {args.new} best / median | speed-up "
          "(best) |\n|---|---|---|---|")
    for r in rows:
        print(f"| {r['workload']} | {r['best_0']:.4g} / {r['median_0']:.4g} | "
              f"{r['best_1']:.4g} / {r['median_1']:.4g} | {r['ratio_best']:.2f}x |")
    if args.json:
        out = {"command": "python -m experiments.compare_commits " + " ".join(
                   argv if argv is not None else sys.argv[1:]),
               "old": args.old, "new": args.new, "old_commit": commit_of(args.old),
               "new_commit": commit_of(args.new), "workload": args.workload,
               "sizes": list(sizes), "rounds": args.rounds, "results": rounds, "rows": rows,
               "seconds": time.perf_counter() - t0,
               "date": date,
               "machine": {"platform": platform.platform(), "cores": os.cpu_count(),
                           "load_at_start": load}}
        from .stopwatch import write_json

        write_json(args.json, out)
    return 0


def _load():
    """The 1-minute load average (None where unknown)."""
    try:
        return os.getloadavg()[0]
    except OSError:
        return None


if __name__ == "__main__":
    sys.exit(main())
