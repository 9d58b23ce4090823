"""``python -m experiments [--out DIR] [--grid paper|reduced] [--cache DIR] [names...]``:
regenerate the figures (PNG + PDF + the CSV behind each) into ``figures/``."""

from __future__ import annotations

import argparse
import importlib
import inspect
import sys
import time

#: Figure scripts, in order.
FIGURES = [
    "fig05_06_appearance_sites",
    "fig07_depth_distance",
    "fig08_chlorophyll",
    "fig09_attenuation",
    "fig10_rrmse",
    "fig11_colour_correction",
    "fig12_chlorophyll_estimates",
    "fig13_cdom_estimates",
    "noise_study",
]


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m experiments", description=__doc__)
    parser.add_argument("names", nargs="*", help=f"subset of {FIGURES}")
    parser.add_argument("--out", default=None, help="output folder (default figures/)")
    parser.add_argument("--grid", default=None, help="sweep grid: paper (default) or reduced")
    parser.add_argument("--cache", default=None, help="result cache folder (default cache/)")
    parser.add_argument("--workers", type=int, default=None, help="processes (default 2)")
    args = parser.parse_args(argv)
    names = args.names or FIGURES
    t_all = time.perf_counter()
    for name in names:
        if name not in FIGURES:
            parser.error(f"unknown figure {name!r}; choose from {FIGURES}")
        t0 = time.perf_counter()
        fn = importlib.import_module(f"experiments.{name}").main
        if "grid_name" in inspect.signature(fn).parameters:
            fn(args.out, grid_name=args.grid, cache_dir=args.cache, workers=args.workers)
        else:
            fn(args.out)
        print(f"{name}: {time.perf_counter() - t0:.1f} s", flush=True)
    print(f"all: {time.perf_counter() - t_all:.1f} s")


if __name__ == "__main__":
    try:
        main()
    except KeyboardInterrupt:  # finished fits are cached; a rerun resumes
        print("interrupted (finished fits are cached; rerun to resume)", file=sys.stderr)
        sys.exit(130)
