"""``python -m experiments [--out DIR] [names...]``: regenerate the figures."""

from __future__ import annotations

import argparse
import importlib
import time

#: Figure scripts, in order. Later issues append the estimation figures (9-13).
FIGURES = [
    "fig05_06_appearance_sites",
    "fig07_depth_distance",
    "fig08_chlorophyll",
]


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m experiments", description=__doc__)
    parser.add_argument("names", nargs="*", help=f"subset of {FIGURES}")
    parser.add_argument("--out", default=None, help="output folder (default figures/)")
    args = parser.parse_args(argv)
    names = args.names or FIGURES
    for name in names:
        if name not in FIGURES:
            parser.error(f"unknown figure {name!r}; choose from {FIGURES}")
        t0 = time.perf_counter()
        importlib.import_module(f"experiments.{name}").main(args.out)
        print(f"{name}: {time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
