"""How long correcting a 24 MP photo with a range map takes, against rawpy's decode of it, and
its peak memory (issue 38).

    python -m experiments.correct_bench [--repeats 2] [--out FILE.json]

Whole processes, side by side, each timed from its start to its exit by ``/usr/bin/time``
(wall time and maximum resident set size):

* ``decode``: rawpy's decode of the DNG to a 16-bit TIFF (:data:`experiments.wait_bench._DECODE`,
  the reference of issue 21);
* ``correct (map)``: ``uw3p correct DNG --water measurement.json --range map.tif --out DIR``
  with a full-resolution float32 range map (default outputs: corrected.jpg with its ICC
  profile, correction.json; decision 0084-output-format);
* ``correct (map / 4)``: the same with a map of a quarter of the photo's width and height
  (resampled to the photo: what photogrammetry and depth networks usually give);
* ``correct (tiff16, linear)``: the full-resolution map with ``--output-format tiff16
  --linear`` (corrected_srgb.tif and corrected.tiff, deflated: what the defaults were);
* ``measure``: ``uw3p measure`` of the same photo (the chart's corners given; default outputs:
  corrected.jpg, the previews, measurement.json).

Each command's output folder is weighed (``sizes_mb``: every file and the total, MB = 10^6
bytes): what a photo takes on disk.

The fixture is wait_bench's (:func:`experiments.wait_bench.fixture`: a 6000 x 4000 RGGB DNG of
a chart on a reef); the water is the fixture's own measurement. Targets (issue 48): ``correct``
<= 1 x ``decode``, peak memory <= 1 GB, default outputs <= 40 MB. The machine's load average
is recorded beside the times (other processes share its cores).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from .wait_bench import _DECODE, FRAME, _fixture_in_child, _uw3p

__all__ = ["MEMORY_LIMIT_MB", "SIZE_LIMIT_MB", "folder_sizes", "run", "main"]

#: The peak memory target, MB
MEMORY_LIMIT_MB = 1024
#: The default outputs' target, MB (10^6 bytes) for a 24 MP photo
SIZE_LIMIT_MB = 40.0
#: Rounds (each command keeps its best time)
REPEATS = 2


def _timed(argv) -> tuple:
    """(wall seconds, max RSS MB, exit status, the last line of its own stderr) of one fresh
    process under /usr/bin/time."""
    proc = subprocess.run(["/usr/bin/time", "-f", "%e %M", *argv], capture_output=True,
                          text=True, check=False)
    lines = proc.stderr.strip().splitlines()
    last = lines[-1].split()
    return float(last[0]), float(last[1]) / 1024.0, proc.returncode, " ".join(lines[-2:-1])


def folder_sizes(folder) -> dict:
    """Every file's size in a folder and the ``total``, MB (10^6 bytes)."""
    sizes = {p.name: p.stat().st_size / 1e6 for p in sorted(Path(folder).iterdir())
             if p.is_file()}
    return sizes | {"total": sum(sizes.values())}


def run(repeats: int = REPEATS, folder=None) -> dict:
    """The fixture, the measurement, the range maps and the timings."""
    import tifffile

    tmp = tempfile.TemporaryDirectory(prefix="uw3p-correct-bench-") if folder is None else None
    root = Path(folder or tmp.name)
    try:
        fx = _fixture_in_child(root, FRAME)
        uw3p = _uw3p()
        geometry = ["--depth", "8", "--distance", "1.5"]
        meas = root / "meas"
        first = subprocess.run([*uw3p, "measure", fx["dng"], *geometry, "--corners",
                                fx["corners"], "--out", str(meas), "--tiff", "none"],
                               check=False, capture_output=True, text=True)
        if not (meas / "measurement.json").exists():
            raise RuntimeError(f"the fixture's measurement failed: {first.stderr[-500:]}")
        H, W = FRAME
        v = np.linspace(-1, 1, H, dtype=np.float32)[:, None]
        u = np.linspace(-1, 1, W, dtype=np.float32)[None, :]
        full = (4.5 - 3.5 * v + 0.3 * u).astype(np.float32)  # a floor from 1 m to 8 m
        tifffile.imwrite(root / "range.tif", full)
        tifffile.imwrite(root / "range_small.tif", np.ascontiguousarray(full[::4, ::4]))
        del full
        water = str(meas / "measurement.json")
        cmds = {
            "decode": [sys.executable, "-c", _DECODE, fx["dng"], str(root / "decoded.tiff")],
            "correct (map)": [*uw3p, "correct", fx["dng"], "--water", water, "--range",
                              str(root / "range.tif"), "--out", str(root / "c1"), "--overwrite"],
            "correct (map / 4)": [*uw3p, "correct", fx["dng"], "--water", water, "--range",
                                  str(root / "range_small.tif"), "--out", str(root / "c2"),
                                  "--overwrite"],
            "correct (tiff16, linear)": [*uw3p, "correct", fx["dng"], "--water", water,
                                         "--range", str(root / "range.tif"), "--out",
                                         str(root / "c3"), "--overwrite", "--output-format",
                                         "tiff16", "--linear"],
            "measure": [*uw3p, "measure", fx["dng"], *geometry, "--corners", fx["corners"],
                        "--out", str(root / "m2"), "--overwrite"],
        }
        times = {k: [] for k in cmds}
        mem = {k: 0.0 for k in cmds}
        codes, said = {}, {}
        for _ in range(repeats):
            for name, argv in cmds.items():
                s, mb, code, text = _timed(argv)
                times[name].append(s)
                mem[name] = max(mem[name], mb)
                codes[name], said[name] = code, text
        best = {k: min(v) for k, v in times.items()}
        outs = {"correct (map)": "c1", "correct (map / 4)": "c2",
                "correct (tiff16, linear)": "c3", "measure": "m2"}
        sizes = {k: folder_sizes(root / d) for k, d in outs.items() if (root / d).is_dir()}
        return {"frame": list(FRAME), "best_s": best, "times_s": times, "peak_mb": mem,
                "sizes_mb": sizes, "load_average": os.getloadavg(),
                "exit": codes, "stderr": said, "ratio_to_decode": {k: best[k] / best["decode"] for k in best},
                "machine": {"cpus": os.cpu_count(), "python": platform.python_version(),
                            "platform": platform.platform()}}
    finally:
        if tmp is not None:
            tmp.cleanup()


def table(res: dict) -> str:
    """A Markdown table of the results."""
    lines = ["| command | best wall time (s) | x decode | peak memory (MB) | outputs (MB) | exit |",
             "|---|---|---|---|---|---|"]
    for k, s in res["best_s"].items():
        size = res["sizes_mb"].get(k, {}).get("total")
        lines.append(f"| {k} | {s:.2f} | {res['ratio_to_decode'][k]:.2f} | "
                     f"{res['peak_mb'][k]:.0f} | {'-' if size is None else f'{size:.1f}'} | "
                     f"{res['exit'][k]} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    """Run the benchmark and print its table (exit 1 when a target is missed)."""
    ap = argparse.ArgumentParser(prog="python -m experiments.correct_bench", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=REPEATS)
    ap.add_argument("--out", default=None, help="also write the results as JSON")
    args = ap.parse_args(argv)
    res = run(args.repeats)
    if args.out:
        Path(args.out).write_text(json.dumps(res, indent=1) + "\n", encoding="utf-8")
    print(table(res))
    ok = all(res["ratio_to_decode"][k] <= 1.0 and res["peak_mb"][k] <= MEMORY_LIMIT_MB
             and res["sizes_mb"][k]["total"] <= SIZE_LIMIT_MB
             for k in ("correct (map)", "correct (map / 4)"))
    return 0 if ok else 1


if __name__ == "__main__":  # pragma: no cover
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    sys.exit(main())
