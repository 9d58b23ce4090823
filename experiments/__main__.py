"""``python -m experiments [--out DIR] [--grid paper|reduced] [--setting NAME] [names...]``:
regenerate Figs 5-13 (PNG + PDF + the CSV behind each) at each sensor setting of
:data:`experiments.grids.SETTINGS` into ``DIR/<setting>/``; Figs 3-4 (which no sensor setting
changes), the paper-like search and the instrument study into ``DIR/``; and the generated tables
of REPRODUCTION.md and INSTRUMENT.md (``--report``)."""

from __future__ import annotations

import argparse
import importlib
import inspect
import os
import sys
import time
from pathlib import Path

from .grids import SETTINGS

__all__ = ["main", "FIGURES", "STUDIES", "APPEARANCE"]

#: Figure scripts, in order (made at every setting).
FIGURES = [
    "fig05_06_appearance_sites",
    "fig07_depth_distance",
    "fig08_chlorophyll",
    "fig09_attenuation",
    "fig10_rrmse",
    "fig11_colour_correction",
    "fig12_chlorophyll_estimates",
    "fig13_cdom_estimates",
]
#: The appearance figures (Figs 5-8): noise-free ``forward`` charts and the sensor's light, the
#: same at the default and same-code settings, so not made again at a machinery check (the
#: report reads the default setting's)
APPEARANCE = ["fig05_06_appearance_sites", "fig07_depth_distance", "fig08_chlorophyll"]
#: Made once (into DIR itself), after the figures (instrument reads Fig 12's CSV): Figs 3-4
#: (the constituents' spectra, the same at every setting), the paper-like search, the
#: instrument study and the real camera (``DIR/realcamera/``: the G7X charts, issue 39).
STUDIES = ["fig03_04_spectra", "paper_like", "instrument", "realcamera"]


def _call(name, outdir, args, setting=None):
    fn = importlib.import_module(f"experiments.{name}").main
    params = inspect.signature(fn).parameters
    kw = {}
    if "doc_path" in params and args.report:  # INSTRUMENT.md beside REPRODUCTION.md
        kw["doc_path"] = str(Path(args.report).with_name("INSTRUMENT.md"))
    if "grid_name" in params:
        kw.update(grid_name=args.grid, cache_dir=args.cache, workers=args.workers)
    if "setting" in params and setting is not None:
        kw["setting"] = setting
    return fn(str(outdir), **kw)


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m experiments", description=__doc__)
    parser.add_argument("names", nargs="*", help=f"a subset of {FIGURES + STUDIES}")
    parser.add_argument("--out", default="figures", help="output folder (default figures/)")
    parser.add_argument("--grid", default=None, help="sweep grid: paper (default) or reduced")
    parser.add_argument("--cache", default=None, help="result cache folder (default cache/)")
    parser.add_argument("--workers", type=int, default=None, help="processes (default 2)")
    parser.add_argument("--setting", default=None, choices=sorted(SETTINGS),
                        help="one sensor setting (default: all)")
    parser.add_argument("--report", default=None, metavar="FILE",
                        help="rewrite the generated tables of FILE (REPRODUCTION.md)")
    args = parser.parse_args(argv)
    names = args.names or FIGURES + STUDIES
    for name in names:
        if name not in FIGURES + STUDIES:
            parser.error(f"unknown figure {name!r}; choose from {FIGURES + STUDIES}")
    settings = [args.setting] if args.setting else list(SETTINGS)
    out = Path(args.out)
    t_all = time.perf_counter()
    for name in names:
        t0 = time.perf_counter()
        if name in STUDIES:
            _call(name, out, args)
        else:
            for s in settings:
                if name in APPEARANCE and SETTINGS[s].get("machinery_check"):
                    continue
                _call(name, out / s, args, s)
        print(f"{name}: {time.perf_counter() - t0:.1f} s", flush=True)
    if args.report:
        from .report import write_report

        write_report(out, args.report)
        print(f"wrote the generated tables of {args.report}")
    print(f"all: {time.perf_counter() - t_all:.1f} s")


if __name__ == "__main__":
    try:
        main()
    except KeyboardInterrupt:  # finished fits are cached; a rerun resumes
        print("interrupted (finished fits are cached; rerun to resume)", file=sys.stderr)
        sys.stderr.flush()
        sys.stdout.flush()
        # at once: the pool's workers are already terminated, and the interpreter's exit would
        # wait on the executor's management thread (a worker caught while starting up can keep
        # it waiting); every output is written atomically, so nothing is left half-done
        os._exit(130)
