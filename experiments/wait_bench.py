"""Where users wait: whole-process times of ``uw3p measure``, ``uw3p estimate`` and quick exits.

    python -m experiments.wait_bench [--out FILE.json] [--repeats 3]

Every time is of a fresh process (``subprocess``), from its start to its exit -- imports, the
work, the outputs -- as a user at the shell sees it. The commands are run in turn, one after
another in each round, ``--repeats`` rounds, and each keeps its best time (the others are
recorded too), so the ratios compare runs made under the same load.

The fixture, written once in a temporary folder: a 24 MP (6000 x 4000) RGGB Bayer DNG of a
ColorChecker Classic on a reef (:mod:`experiments.scene`, the card at 30 % of the frame width;
its patch values from the second renderer, :mod:`experiments.independent_world`, 8 m down in
green-blue water), and one chart's patch file written by ``uw3p simulate``.

The commands:

* ``decode``: rawpy's own decode of the DNG to a 16-bit TIFF (``rawpy.imread(...).postprocess
  (output_bps=16)`` and ``tifffile.imwrite``) -- the reference of issue 21's target 1;
* ``measure``: ``uw3p measure DNG --depth 5 --distance 1.5 --out DIR --corners ...`` (default
  outputs), ``measure (detect)``: the same without ``--corners`` (the chart found
  automatically), and ``measure --tiff full``: with ``--corners``, corrected.tiff uncompressed
  like the decode's (what the rest of the pipeline costs beside the deflate);
* ``estimate``: ``uw3p estimate m.csv --depth 8 --distance 1.5`` (one chart);
* ``help``: ``uw3p --help``; ``measure --help``; ``bad input``: ``uw3p measure missing.dng
  ...`` (exit 2);
* ``library floor``: a process that imports numpy, scipy.special (the chi-square functions of
  every verdict) and numba and calls one trivial compiled function from numba's on-disk cache
  (written by the fixture): what ``uw3p estimate`` pays before its own work (the imports and
  numba's first load of a cached function), for issue 21's target 2.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from forward.files import write_atomic

__all__ = [
    "CARD_WIDTH",
    "DEPTH_M",
    "DISTANCE_M",
    "FRAME",
    "REPEATS",
    "TARGETS",
    "commands",
    "fixture",
    "main",
    "run",
    "table",
]

#: The photo's size (height, width), pixels: 24 MP
FRAME = (4000, 6000)
#: The card's width, fraction of the frame width (issue 21)
CARD_WIDTH = 0.3
#: The depth and distance given to ``uw3p measure`` (issue 21's command), m
DEPTH_M, DISTANCE_M = 5.0, 1.5
#: The water of the patch values: C (mg m^-3), a_CDOM(440) (m^-1), depth and distance (m)
WATER = (1.0, 0.1, 8.0, 1.5)
#: Rounds of the commands (each keeps its best)
REPEATS = 3
#: Issue 21's targets: command -> (reference command or None, the most seconds or the ratio)
TARGETS = {"measure": ("decode", 1.0), "measure (detect)": ("decode", None),
           "measure --tiff full": ("decode", None),
           "estimate": (None, 1.0), "help": (None, 0.3), "measure --help": (None, 0.3),
           "bad input": (None, 0.3), "library floor": (None, None)}
#: The ``library floor`` command's module: numpy, scipy.special and numba imported, one trivial
#: function in numba's on-disk cache called on an array
_FLOOR = ("import numpy as np\nimport numba\nimport scipy.special  # noqa: F401\n\n\n"
          "@numba.njit(cache=True)\ndef one(x):\n    return x + 1.0\n\n\none(np.ones(3))\n")

_DECODE = ("import sys, rawpy, tifffile\n"
           "with rawpy.imread(sys.argv[1]) as raw:\n"
           "    rgb = raw.postprocess(output_bps=16)\n"
           "tifffile.imwrite(sys.argv[2], rgb, photometric='rgb')\n")


def _uw3p() -> list:
    """The ``uw3p`` console script beside this Python, else ``python -m uw3p``."""
    script = Path(sys.executable).with_name("uw3p")
    return [str(script)] if script.exists() else [sys.executable, "-m", "uw3p"]


def fixture(folder, frame=FRAME, seed: int = 1, water=WATER) -> dict:
    """Write the 24 MP DNG and one chart's patch file into ``folder``.

    Parameters
    ----------
    folder : str or os.PathLike
        An existing folder (e.g. a temporary one).
    frame : tuple of int, optional
        The photo's (height, width), pixels (default :data:`FRAME`, 24 MP).
    seed : int, optional
        The scene's seed (the reef, the card's pose and glints; default 1).
    water : tuple of float, optional
        C, a_CDOM(440), depth and distance of the patch values (default :data:`WATER`).

    Returns
    -------
    dict
        ``dng``, ``patches`` and ``floor`` (paths, str: the ``library floor`` module, its
        function compiled into numba's cache) and ``corners`` (the patch grid's corners,
        pixels, the ``--corners`` text).
    """
    from .independent_world import render_chart
    from .scene import card_corners, render_scene, write_dng

    folder = Path(folder)
    chl, cdom, depth, distance = water
    rgb = render_chart(chl, cdom, depth, distance, noise=False,
                       backscatter="single_scatter")["expected"]
    scene = render_scene(rgb, card_corners(frame, width_fraction=CARD_WIDTH), size=frame,
                         seed=int(seed), exposure=0.5, glints=3)
    dng = write_dng(folder / "uw.dng", scene["image"])
    corners = " ".join(f"{x:.1f},{y:.1f}" for x, y in scene["grid_corners"])
    del scene
    patches = folder / "m.csv"
    subprocess.run([*_uw3p(), "simulate", "--chl", str(chl), "--cdom", str(cdom), "--depth",
                    str(depth), "--distance", str(distance), "--out", str(patches)],
                   check=True, capture_output=True)
    floor = folder / "library_floor.py"
    floor.write_text(_FLOOR)
    subprocess.run([sys.executable, str(floor)], check=True, capture_output=True)  # the cache
    return {"dng": str(dng), "patches": str(patches), "corners": corners, "floor": str(floor)}


def _fixture_in_child(folder, frame, seed: int = 1, water=WATER) -> dict:
    """:func:`fixture` in a child process (its ~2 GB of 24 MP render is freed when it ends, not
    kept by the caller's heap)."""
    code = ("import json, sys\nfrom experiments.wait_bench import fixture\n"
            "print(json.dumps(fixture(sys.argv[1], (int(sys.argv[2]), int(sys.argv[3])), "
            f"seed={int(seed)}, water={tuple(float(x) for x in water)!r})))")
    root = Path(__file__).resolve().parents[1]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(root)] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]))
    proc = subprocess.run([sys.executable, "-c", code, str(folder), str(frame[0]), str(frame[1])],
                          check=True, capture_output=True, text=True, cwd=root, env=env)
    return json.loads(proc.stdout.strip().splitlines()[-1])


def commands(fx: dict, folder) -> dict:
    """The benchmarked commands: name -> argv (fresh processes).

    Parameters
    ----------
    fx : dict
        :func:`fixture`'s result.
    folder : str or os.PathLike
        Where the commands write (each its own sub-folder or file, replaced every round).

    Returns
    -------
    dict
        Name -> list of str, in the order they are run.
    """
    folder = Path(folder)
    uw3p = _uw3p()
    geometry = ["--depth", str(DEPTH_M), "--distance", str(DISTANCE_M)]
    return {
        "decode": [sys.executable, "-c", _DECODE, fx["dng"], str(folder / "decoded.tiff")],
        "measure": [*uw3p, "measure", fx["dng"], *geometry, "--corners", fx["corners"],
                    "--out", str(folder / "out_corners"), "--overwrite"],
        "measure (detect)": [*uw3p, "measure", fx["dng"], *geometry,
                             "--out", str(folder / "out_detect"), "--overwrite"],
        "measure --tiff full": [*uw3p, "measure", fx["dng"], *geometry, "--corners",
                                fx["corners"], "--tiff", "full", "--out",
                                str(folder / "out_full"), "--overwrite"],
        "estimate": [*uw3p, "estimate", fx["patches"], "--depth", str(WATER[2]),
                     "--distance", str(WATER[3])],
        "help": [*uw3p, "--help"],
        "measure --help": [*uw3p, "measure", "--help"],
        "bad input": [*uw3p, "measure", str(folder / "missing.dng"), *geometry,
                      "--out", str(folder / "x")],
        "library floor": [sys.executable, fx["floor"]],
    }


def _time(argv, env=None) -> tuple:
    """(seconds, exit status, the last line of stderr, CPU seconds) of one fresh process (its
    CPU time: user + system of it and its children, ``resource.RUSAGE_CHILDREN``); ``env``:
    its environment (default this one's)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(argv, check=False, capture_output=True, text=True, env=env)
    seconds = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    last = (proc.stderr.strip().splitlines() or [""])[-1]
    return seconds, proc.returncode, last, cpu


def run(repeats=REPEATS, folder=None, names=None, frame=FRAME) -> dict:
    """Write the fixture and time every command, in turn, ``repeats`` rounds.

    Parameters
    ----------
    repeats : int, optional
        Rounds (default :data:`REPEATS`); each command keeps its best time.
    folder : str or os.PathLike, optional
        Where to write the fixture and outputs (default a temporary folder, removed after).
    names : sequence of str, optional
        The commands (names of :func:`commands`) to time, in :func:`commands`' order (default all; a
        command's target reference is timed too).
    frame : tuple of int, optional
        The photo's (height, width), pixels (default :data:`FRAME`).

    Returns
    -------
    dict
        ``commands`` name -> {``argv``, ``seconds`` and ``cpu_seconds`` (every round; CPU:
        the process and its children), ``best``, ``cpu_best``, ``exit`` (statuses of the
        rounds), ``stderr`` (the last line of the last round)};
        ``fixture_seconds``; ``machine`` (platform, cores); ``repeats``.

    Raises
    ------
    ValueError
        If ``repeats`` is not a positive integer.
    """
    if int(repeats) != repeats or repeats < 1:
        raise ValueError(f"repeats: a positive integer, got {repeats!r}")
    with tempfile.TemporaryDirectory(prefix="uw3p_wait_") as tmp:
        folder = Path(tmp if folder is None else folder)
        t0 = time.perf_counter()
        fx = _fixture_in_child(folder, frame)
        fixture_seconds = time.perf_counter() - t0
        cmds = commands(fx, folder)
        if names is not None:
            unknown = set(names) - set(cmds)
            if unknown:
                raise ValueError(f"names: unknown commands {sorted(unknown)}; choose from "
                                 f"{list(cmds)}")
            wanted = set(names) | {TARGETS[n][0] for n in names if TARGETS.get(n, (None,))[0]}
            cmds = {n: argv for n, argv in cmds.items() if n in wanted}
        res = {name: {"argv": argv, "seconds": [], "cpu_seconds": [], "exit": [], "stderr": ""}
               for name, argv in cmds.items()}
        for _ in range(int(repeats)):
            for name, argv in cmds.items():
                seconds, code, last, cpu = _time(argv)
                res[name]["seconds"].append(seconds)
                res[name]["cpu_seconds"].append(cpu)
                res[name]["exit"].append(code)
                res[name]["stderr"] = last
    for r in res.values():
        r["best"] = min(r["seconds"])
        r["cpu_best"] = min(r["cpu_seconds"])
    return {"commands": res, "fixture_seconds": fixture_seconds, "repeats": int(repeats),
            "frame": list(frame),
            "machine": {"platform": platform.platform(), "python": platform.python_version(),
                        "cores": os.cpu_count()}}


def table(results) -> str:
    """The results as a markdown table: best and median time, exit status, the target.

    Parameters
    ----------
    results : dict
        :func:`run`'s result.

    Returns
    -------
    str
        A markdown table, one row per command.
    """
    cmds = results["commands"]
    lines = ["| command | best (s) | median (s) | CPU, best (s) | exit | target | met |",
             "|---|---:|---:|---:|---:|---|---|"]
    for name, r in cmds.items():
        ref, limit = TARGETS.get(name, (None, None))
        target, met = "", ""
        if ref is not None:
            ratio = r["best"] / cmds[ref]["best"]
            target = f"{ratio:.2f}x {ref}" + (f" (<= {limit:g}x)" if limit else "")
            met = "" if limit is None else ("yes" if ratio <= limit else "no")
        elif limit is not None:
            target, met = f"<= {limit:g} s", "yes" if r["best"] <= limit else "no"
        exits = ",".join(str(c) for c in sorted(set(r["exit"])))
        cpu = f"{r['cpu_best']:.2f}" if "cpu_best" in r else ""
        lines.append(f"| `{name}` | {r['best']:.2f} | {float(np.median(r['seconds'])):.2f} | "
                     f"{cpu} | {exits} | {target} | {met} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    """``python -m experiments.wait_bench``: run, print the table, optionally write JSON."""
    ap = argparse.ArgumentParser(prog="python -m experiments.wait_bench",
                                 description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=None, metavar="FILE.json", help="write the results here")
    ap.add_argument("--repeats", type=int, default=REPEATS, help="rounds (default 3)")
    args = ap.parse_args(argv)
    results = run(args.repeats)
    print(table(results))
    if args.out:
        write_atomic(args.out, json.dumps(results, indent=1))
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
