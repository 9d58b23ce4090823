"""Time one command, start to exit, and keep the time in a JSON file (BENCHMARKS.md reads it).

    python -m experiments.stopwatch [--json benchmarks/make_times.json] NAME -- COMMAND ...

The command runs as given (its output passes through; its exit status is this one's). Recorded
under ``NAME``: the command, wall-clock seconds, CPU seconds (user + system of the command and
everything it waited for: ``resource.RUSAGE_CHILDREN``) and so how many of the cores it kept
busy, its peak resident memory (the largest process), its exit status, the date, the commit
(:func:`experiments.common.commit_of`) and the machine's 1-minute load average when it
started (the machine may be shared: a load above the number of cores means the command had
less than the whole machine). ``make reproduce-figures`` times each of its steps with it.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

from forward.files import write_atomic

__all__ = ["DEFAULT_JSON", "main", "record", "stopwatch", "write_json"]

#: Where the times are kept by default.
DEFAULT_JSON = "benchmarks/make_times.json"


def stopwatch(argv) -> dict:
    """Run ``argv`` (a fresh process, output passed through) and measure it.

    Parameters
    ----------
    argv : sequence of str
        The command.

    Returns
    -------
    dict
        ``command`` (str), ``seconds`` (wall), ``cpu_seconds``, ``cores_busy`` (cpu / wall),
        ``peak_mb``, ``exit``, ``date``, ``load_at_start``, ``cores``.
    """
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    load = os.getloadavg()[0]
    t0 = time.perf_counter()
    code = subprocess.run(list(argv), check=False).returncode
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"command": " ".join(argv), "seconds": wall, "cpu_seconds": cpu,
            "cores_busy": cpu / wall if wall > 0 else float("nan"),
            "peak_mb": after.ru_maxrss / 1024.0, "exit": code,
            "date": time.strftime("%Y-%m-%d %H:%M:%S %Z"), "load_at_start": load,
            "cores": os.cpu_count()}


def write_json(path, data) -> None:
    """Write ``data`` as JSON to ``path`` whole or not at all (its folder created).

    Parameters
    ----------
    path : str or os.PathLike
    data : object
        Anything :func:`json.dumps` takes.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(path, json.dumps(data, indent=1, sort_keys=True))


def record(path, name: str, rec: dict) -> None:
    """Merge ``rec`` into the JSON file ``path`` under ``name`` (written whole or not at all;
    steps that finish at once, ``make -j2``, take turns by a lock beside the file)."""
    import fcntl

    from .common import commit_of

    path = Path(path)
    try:
        rec = dict(rec, commit=commit_of("WORKTREE"))
    except (OSError, subprocess.CalledProcessError):
        rec = dict(rec, commit=None)
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path.with_name(path.name + ".lock"), "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            data = json.loads(path.read_text())
        except (OSError, ValueError):
            data = {}
        data[name] = rec
        write_json(path, data)


def main(argv=None) -> int:
    """``python -m experiments.stopwatch NAME -- COMMAND ...``: exit with the command's
    status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if "--" not in argv:
        print("usage: python -m experiments.stopwatch [--json FILE] NAME -- COMMAND ...",
              file=sys.stderr)
        return 2
    cut = argv.index("--")
    p = argparse.ArgumentParser(prog="python -m experiments.stopwatch",
                                description=__doc__.splitlines()[0])
    p.add_argument("--json", default=DEFAULT_JSON)
    p.add_argument("name")
    args = p.parse_args(argv[:cut])
    command = argv[cut + 1:]
    if not command:
        p.error("no command after --")
    rec = stopwatch(command)
    record(args.json, args.name, rec)
    print(f"[stopwatch] {args.name}: {rec['seconds']:.1f} s wall, {rec['cpu_seconds']:.1f} s "
          f"CPU ({rec['cores_busy']:.2f} cores busy), peak {rec['peak_mb']:.0f} MB, exit "
          f"{rec['exit']} (load {rec['load_at_start']:.1f} at start)", file=sys.stderr)
    return rec["exit"]


if __name__ == "__main__":
    sys.exit(main())
