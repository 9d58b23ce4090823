"""``uw3p estimate``: run the estimator on a CSV of patch values (as written by ``uw3p simulate``)."""

from __future__ import annotations

import json

import numpy as np


def read_patch_csv(path) -> np.ndarray:
    """Read patch values: one row per patch, one column per channel, optionally a first 'patch'
    column and a header row; returns (m, n)."""
    from forward.spectra import read_spectral_csv

    # read_spectral_csv treats the first column as the key column (patch number or wavelength)
    try:
        first, vals = read_spectral_csv(path, name="measurements")
    except ValueError as exc:
        if "strictly increasing" not in str(exc):
            raise
        raise ValueError("measurements: the first column must number the patches 1..n") from None
    if vals.shape[1] < 1:
        raise ValueError("measurements: need a patch column and one column per channel")
    return vals.T


def _estimate(args, out, err):
    from sca import estimate

    M = read_patch_csv(args.measurements)
    fix = {}
    if args.fix_backscatter is not None:
        fix["backscatter"] = args.fix_backscatter
    if args.fix_cdom is not None:
        fix["cdom"] = args.fix_cdom
    try:
        res = estimate(M, depth=args.depth, distance=args.distance, camera=args.camera,
                       illuminant=args.illuminant, reflectances=args.reflectances,
                       wavelengths=args.grid(args), mode=args.mode, fix=fix or None,
                       max_iter=args.max_iter)
    except ValueError as exc:
        msg = str(exc)
        if msg.startswith("rgb:"):  # name the file, in its orientation (rows = patches)
            raise ValueError(f"measurements: {args.measurements}: one row per patch and one column "
                             f"per channel expected; {msg[4:].strip()} (channels x patches)") from None
        raise
    if args.json:
        out.write(json.dumps(res.to_dict(), indent=1) + "\n")
    else:
        out.write(f"chl (C)          {res.chl:.6g} mg m^-3\n")
        out.write(f"cdom a_CDOM(440) {res.cdom:.6g} m^-1\n")
        out.write("backscatter s    " + " ".join(f"{v:.6g}" for v in res.backscatter) + "\n")
        out.write(f"converged        {res.converged} ({res.status}; {res.iterations} iterations, "
                  f"mode {res.mode})\n")
        out.write("wavelength_nm,attenuation_k\n")
        for wl, k in zip(res.wavelengths, res.attenuation):
            out.write(f"{wl:g},{k:.8g}\n")
    return 0 if res.converged else 1


def add_estimate_parser(sub, add_common, grid):
    p = sub.add_parser("estimate", help="estimate C, CDOM and attenuation from patch values")
    p.add_argument("measurements", help="CSV: patch, red, green, blue (one row per patch)")
    p.add_argument("--depth", type=float, required=True, help="chart depth, m")
    p.add_argument("--distance", type=float, required=True, help="camera-to-chart distance, m")
    p.add_argument("--mode", default="safeguarded", choices=["safeguarded", "paper"])
    p.add_argument("--max-iter", type=int, default=100)
    p.add_argument("--fix-backscatter", type=float, default=None, help="hold s fixed (e.g. 0)")
    p.add_argument("--fix-cdom", type=float, default=None, help="hold a_CDOM(440) fixed, m^-1")
    p.add_argument("--json", action="store_true", help="print the whole result as JSON")
    add_common(p)
    p.set_defaults(func=_estimate, grid=grid)
