"""``uw3p bench``: speed against error of every estimator (what ``make bench`` runs).

    uw3p bench [--quick] [--out DIR]

Runs ``python -m experiments.benchmark`` in its own process with one BLAS thread, writing
BENCHMARKS.md, results.json and the speed-error figure into ``--out`` (default
``bench-results/``), never over the repository's record; ``make bench`` writes the record.
Exits with the benchmark's status. It runs from the repository (a checkout), not from the
installed wheel, which does not ship ``experiments`` (decision 0082-installed-packages).
"""

from __future__ import annotations

import os
import sys

from forward.errors import InputError

from .common import replication_root

__all__ = ["NAME", "BUFFERED", "add_parser", "run"]

#: The subcommand's name.
NAME = "bench"
#: Output goes straight to the terminal (the benchmark's own process writes it).
BUFFERED = False


def add_parser(sub):
    """Register ``bench`` and its options.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``uw3p`` parser's subcommands.

    Returns
    -------
    argparse.ArgumentParser
        The subcommand's parser, its ``func`` default set to :func:`run`.
    """
    p = sub.add_parser(NAME, help="speed against error of every estimator (make bench)")
    p.add_argument("--quick", action="store_true", help="reduced sizes (a check, not the record)")
    p.add_argument("--out", default="bench-results",
                   help="folder for BENCHMARKS.md, results.json and the figure (created; "
                        "default bench-results/)")
    p.set_defaults(func=run)
    return p


def run(args, out, err) -> int:
    """Run the benchmark in a child process and wait for it.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options: ``quick``, ``out`` (a folder).
    out, err : text streams
        Unused (the child writes to the process's own streams).

    Returns
    -------
    int
        The benchmark's exit status.

    Raises
    ------
    ValueError
        When ``--out`` is a file, or ``experiments`` is not there (the installed wheel).
    """
    import subprocess

    # one BLAS thread (see the Makefile); set before numpy is imported, so the
    # benchmark runs in its own process
    env = dict(os.environ)
    env.setdefault("OPENBLAS_NUM_THREADS", "1")
    root = str(replication_root(NAME))
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [root, env.get("PYTHONPATH")]))
    from pathlib import Path

    out_dir = Path(args.out)
    if out_dir.is_file():
        raise InputError("--out", f"{out_dir} is a file; give a folder")
    cmd = [sys.executable, "-m", "experiments.benchmark",
           "--out", str(out_dir / "results.json"), "--report", str(out_dir / "BENCHMARKS.md"),
           "--figure", str(out_dir / "benchmark_speed_error.png")] + (
        ["--quick"] if args.quick else [])
    proc = subprocess.Popen(cmd, env=env)
    try:
        return proc.wait()
    except KeyboardInterrupt:
        proc.wait()
        raise
