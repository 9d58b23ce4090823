"""The first ``uw3p measure`` after an install against the second: issue 36's target (the
first within 1.5x the second).

    python -m experiments.cold_start [--json benchmarks/cold_start.json]

A fresh install has no compiled code in numba's on-disk cache and no quadrature rule in
uw3p's: each scenario below gives every process of it a new, empty ``NUMBA_CACHE_DIR`` and
``UW3P_CACHE_DIR`` (numba then reads and writes its cache only there, so nothing compiled
earlier on this machine is found), and times fresh processes, start to exit:

* ``no warm``: ``uw3p measure`` of the 24 MP DNG of :mod:`experiments.wait_bench` (its
  ``measure`` command: ``--corners`` given, default outputs), twice, then the same command on
  another photo (another reef, card pose and water: :data:`OTHER_PHOTO`);
* ``after warm``: ``python -m uw3p.warm`` (what ``make install`` runs after pip), then the same
  three measurements.

The ratio first / second of each scenario is the target's (``after warm`` is what a user who
ran ``make install`` meets); the other photo says what a second photo costs, as opposed to the
same photo again (what the caches keyed on a photo's content, such as the quadrature rules of
its light field, :mod:`sca.quadrature`, do not hold for a new one). Python's own byte-code
caches are not cleared (pip writes them at install).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

__all__ = ["OTHER_PHOTO", "TARGET_RATIO", "main", "run"]

#: Issue 36: the first ``uw3p measure`` after install within this factor of the second.
TARGET_RATIO = 1.5
#: The other photo: the scene's seed and its water (C, a_CDOM(440), depth, distance)
OTHER_PHOTO = (2, (0.5, 0.3, 6.0, 1.2))


def _timed(argv, env) -> dict:
    """:func:`experiments.wait_bench._time` as a dict."""
    from .wait_bench import _time

    seconds, code, last, cpu = _time(argv, env)
    return {"seconds": seconds, "exit": code, "cpu_seconds": cpu, "stderr": last}


def run(frame=None) -> dict:
    """Both scenarios on the 24 MP DNG (:func:`experiments.wait_bench.fixture`).

    Parameters
    ----------
    frame : tuple of int, optional
        The photo's (height, width) (default :data:`experiments.wait_bench.FRAME`, 24 MP).

    Returns
    -------
    dict
        ``scenarios``: name -> {'warm' (the warm step's time, or None), 'first', 'second',
        'other photo' (each {'seconds', 'cpu_seconds', 'exit', 'stderr'}), 'ratio' (first /
        second, wall), 'cpu_ratio' (the same of CPU time)}; ``frame``;
        ``command`` (the measure command's arguments after ``uw3p``).
    """
    from . import wait_bench

    frame = tuple(frame or wait_bench.FRAME)
    out = {"frame": list(frame), "scenarios": {}}
    with tempfile.TemporaryDirectory(prefix="uw3p_cold_") as tmp:
        tmp = Path(tmp)
        fx = wait_bench._fixture_in_child(tmp, frame)
        argv = wait_bench.commands(fx, tmp)["measure"]
        (tmp / "other").mkdir()
        fx2 = wait_bench._fixture_in_child(tmp / "other", frame, *OTHER_PHOTO)
        argv2 = wait_bench.commands(fx2, tmp / "other")["measure"]
        out["command"] = ["uw3p"] + argv[argv.index("measure"):]
        for name, warm in (("no warm", False), ("after warm", True)):
            caches = tmp / name.replace(" ", "_")
            env = dict(os.environ, NUMBA_CACHE_DIR=str(caches / "numba"),
                       UW3P_CACHE_DIR=str(caches / "uw3p"), OPENBLAS_NUM_THREADS="1")
            rec = {"warm": None}
            if warm:
                rec["warm"] = _timed([sys.executable, "-m", "uw3p.warm"], env)
            rec["first"] = _timed(argv, env)
            rec["second"] = _timed(argv, env)
            rec["other photo"] = _timed(argv2, env)
            rec["ratio"] = rec["first"]["seconds"] / rec["second"]["seconds"]
            rec["cpu_ratio"] = rec["first"]["cpu_seconds"] / rec["second"]["cpu_seconds"]
            out["scenarios"][name] = rec
    return out


def main(argv=None) -> int:
    """``python -m experiments.cold_start``: print both scenarios (and write JSON)."""
    from .common import commit_of

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--json", default=None)
    args = p.parse_args(argv)
    t0, load, date = time.perf_counter(), os.getloadavg()[0], time.strftime("%Y-%m-%d %H:%M:%S %Z")
    res = run()
    res.update(command_run="python -m experiments.cold_start" + (
        f" --json {args.json}" if args.json else ""), commit=commit_of("WORKTREE"),
        date=date, seconds=time.perf_counter() - t0,
        load_at_start=load, target_ratio=TARGET_RATIO)
    for name, r in res["scenarios"].items():
        warm = "" if r["warm"] is None else f"warm {r['warm']['seconds']:.1f} s, "
        print(f"{name}: {warm}first {r['first']['seconds']:.1f} s (exit {r['first']['exit']}), "
              f"second {r['second']['seconds']:.1f} s: {r['ratio']:.2f}x (CPU {r['cpu_ratio']:.2f}x); "
              f"another photo {r['other photo']['seconds']:.1f} s")
    if args.json:
        from .stopwatch import write_json

        write_json(args.json, res)
    return 0


if __name__ == "__main__":
    sys.exit(main())
