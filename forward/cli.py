"""The ``uw3p`` command line: ``uw3p simulate ...`` and ``uw3p estimate ...``.

Bad input prints the message on stderr and exits with status 2.
"""

from __future__ import annotations

import argparse
import csv
import io
import sys

import numpy as np


def _add_common(p):
    p.add_argument("--camera", default="Nikon 5100 (NPL)",
                   help="colour-science camera name or CSV file (default: %(default)s)")
    p.add_argument("--illuminant", default=None, help="colour-science illuminant name or CSV (default D65)")
    p.add_argument("--reflectances", default=None, help="chart name or CSV (default BabelColor Average)")
    p.add_argument("--step", type=float, default=None, help="wavelength step in nm (default 10)")
    p.add_argument("--wl-min", type=float, default=400.0, help="first wavelength, nm (default 400)")
    p.add_argument("--wl-max", type=float, default=700.0, help="last wavelength, nm (default 700)")


def _grid(args):
    if args.step is None and args.wl_min == 400.0 and args.wl_max == 700.0:
        return None
    step = 10.0 if args.step is None else args.step
    if not step > 0:
        raise ValueError(f"--step: must be > 0, got {step}")
    return np.arange(args.wl_min, args.wl_max + step / 2, step)


def _simulate(args, out, err):
    from . import simulate_chart

    sim = simulate_chart(args.chl, args.cdom, args.depth, args.distance, camera=args.camera,
                         illuminant=args.illuminant, reflectances=args.reflectances,
                         noise=not args.no_noise, seed=args.seed, wavelengths=_grid(args),
                         path_model=args.path_model)
    if args.out is None:
        out.write(_rgb_csv(sim.rgb))
        return 0
    if args.out.lower().endswith(".json"):
        text = sim.to_json()
    elif args.out.lower().endswith(".csv"):
        text = _rgb_csv(sim.rgb)
    else:
        raise ValueError(f"--out: must end in .json or .csv, got {args.out!r}")
    with open(args.out, "w", encoding="utf-8") as f:
        f.write(text)
    err.write(f"wrote {args.out}\n")
    return 0


def _rgb_csv(rgb) -> str:
    """Patch values as CSV: one row per patch, one column per channel."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    names = ["red", "green", "blue"] if rgb.shape[0] == 3 else [f"ch{j}" for j in range(rgb.shape[0])]
    w.writerow(["patch"] + names)
    for p in range(rgb.shape[1]):
        w.writerow([p + 1] + [repr(float(v)) for v in rgb[:, p]])
    return buf.getvalue()


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="uw3p", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("simulate", help="simulate the 24 patch values of a chart underwater")
    p.add_argument("--chl", type=float, required=True, help="chlorophyll C, mg m^-3")
    p.add_argument("--cdom", type=float, required=True, help="a_CDOM(440), m^-1")
    p.add_argument("--depth", type=float, required=True, help="chart depth, m")
    p.add_argument("--distance", type=float, required=True, help="camera-to-chart distance, m")
    p.add_argument("--no-noise", action="store_true", help="the exact expectation, no sensor noise")
    p.add_argument("--seed", type=int, default=None, help="noise seed")
    p.add_argument("--path-model", default="beam", choices=["beam", "absorption"])
    p.add_argument("--out", default=None, help="output file (.json: everything; .csv: patch values)")
    _add_common(p)
    p.set_defaults(func=_simulate)

    try:
        from sca.cli import add_estimate_parser
    except ImportError:  # pragma: no cover - sca is part of the same distribution
        pass
    else:
        add_estimate_parser(sub, _add_common, _grid)
    return parser


def main(argv=None, out=None, err=None) -> int:
    out = sys.stdout if out is None else out
    err = sys.stderr if err is None else err
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args, out, err) or 0)
    except ValueError as exc:
        err.write(f"uw3p {args.command}: error: {exc}\n")
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
