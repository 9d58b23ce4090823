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


def read_batch_csv(path):
    """Read a batch file: a header row with columns chart, patch, one column per channel, and
    optionally depth_m and distance_m; returns (charts ids, M (N, m, n), depth, distance)."""
    import csv as _csv
    from pathlib import Path

    p = Path(path)
    if not p.is_file():
        raise ValueError(f"--batch: file not found: {p}")
    with open(p, newline="", encoding="utf-8") as f:
        rows = [r for r in _csv.reader(line for line in f if not line.startswith("#")) if r]
    if not rows:
        raise ValueError(f"--batch: {p} is empty")
    header = [h.strip() for h in rows[0]]
    if header[:2] != ["chart", "patch"]:
        raise ValueError(f"--batch: {p} must start with the columns chart,patch,<channels>[,depth_m,distance_m]")
    extra = [h for h in ("depth_m", "distance_m") if h in header]
    channels = [h for h in header[2:] if h not in extra]
    try:
        data = [[float(x) for x in r] for r in rows[1:]]
    except ValueError as exc:
        raise ValueError(f"--batch: non-numeric value in {p}: {exc}") from None
    arr = np.array(data, dtype=float)
    if arr.ndim != 2 or arr.shape[1] != len(header):
        raise ValueError(f"--batch: every row of {p} needs {len(header)} values")
    charts = list(dict.fromkeys(arr[:, 0].tolist()))
    n = int(np.sum(arr[:, 0] == charts[0]))
    M = np.empty((len(charts), len(channels), n))
    depth = np.full(len(charts), np.nan)
    distance = np.full(len(charts), np.nan)
    for j, c in enumerate(charts):
        sel = arr[arr[:, 0] == c]
        if sel.shape[0] != n:
            raise ValueError(f"--batch: chart {c:g} has {sel.shape[0]} patches, chart {charts[0]:g} has {n}")
        sel = sel[np.argsort(sel[:, 1])]
        M[j] = sel[:, 2:2 + len(channels)].T
        if "depth_m" in header:
            depth[j] = sel[0, header.index("depth_m")]
        if "distance_m" in header:
            distance[j] = sel[0, header.index("distance_m")]
    return charts, M, depth, distance


def _estimate_batch(args, out, err):
    from sca import estimate_batch

    charts, M, depth, distance = read_batch_csv(args.batch)
    if np.isnan(depth).any():
        if args.depth is None:
            raise ValueError("--depth: required unless the batch file has a depth_m column")
        depth = np.where(np.isnan(depth), args.depth, depth)
    if np.isnan(distance).any():
        if args.distance is None:
            raise ValueError("--distance: required unless the batch file has a distance_m column")
        distance = np.where(np.isnan(distance), args.distance, distance)
    fix = {"backscatter": args.fix_backscatter} if args.fix_backscatter is not None else None
    if args.fix_cdom is not None:
        raise ValueError("--fix-cdom: not available with --batch")
    res = estimate_batch(M, depth=depth, distance=distance, camera=args.camera,
                         illuminant=args.illuminant, reflectances=args.reflectances,
                         wavelengths=args.grid(args), fix=fix, max_iter=args.max_iter)
    m = M.shape[1]
    out.write("chart,chl,cdom," + ",".join(f"backscatter_{j}" for j in range(m))
              + ",objective,converged,iterations,status\n")
    for j, c in enumerate(charts):
        out.write(f"{c:g},{res.chl[j]!r},{res.cdom[j]!r},"
                  + ",".join(repr(float(v)) for v in res.backscatter[j])
                  + f",{res.objective[j]!r},{bool(res.converged[j])},{res.iterations[j]},{res.status[j]}\n")
    err.write(f"{len(charts)} charts, {int(res.converged.sum())} converged, {res.elapsed_s:.3f} s\n")
    return 0 if res.converged.all() else 1


def _estimate(args, out, err):
    from sca import estimate

    if (args.batch is None) == (args.measurements is None):
        raise ValueError("measurements: give either a measurements CSV or --batch FILE")
    if args.batch is not None:
        return _estimate_batch(args, out, err)
    if args.depth is None or args.distance is None:
        raise ValueError("--depth, --distance: both are required")
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
        out.write(f"chl (C)          {res.chl:.6g} mg m^-3 (standard error {res.chl_se:.2g})\n")
        out.write(f"cdom a_CDOM(440) {res.cdom:.6g} m^-1 (standard error {res.cdom_se:.2g})\n")
        out.write("backscatter s    " + " ".join(f"{v:.6g}" for v in res.backscatter) + "\n")
        out.write(f"converged        {res.converged} ({res.status}; {res.iterations} iterations, "
                  f"mode {res.mode})\n")
        out.write("wavelength_nm,attenuation_k\n")
        for wl, k in zip(res.wavelengths, res.attenuation):
            out.write(f"{wl:g},{k:.8g}\n")
    return 0 if res.converged else 1


def add_estimate_parser(sub, add_common, grid):
    p = sub.add_parser("estimate", help="estimate C, CDOM and attenuation from patch values")
    p.add_argument("measurements", nargs="?", default=None,
                   help="CSV: patch, red, green, blue (one row per patch)")
    p.add_argument("--batch", default=None, metavar="FILE",
                   help="many charts at once (sca.estimate_batch): CSV with columns chart, patch, "
                        "red, green, blue [, depth_m, distance_m]; prints one CSV row per chart")
    p.add_argument("--depth", type=float, default=None, help="chart depth, m")
    p.add_argument("--distance", type=float, default=None, help="camera-to-chart distance, m")
    p.add_argument("--mode", default="safeguarded", choices=["safeguarded", "paper"])
    p.add_argument("--max-iter", type=int, default=100)
    p.add_argument("--fix-backscatter", type=float, default=None, help="hold s fixed (e.g. 0)")
    p.add_argument("--fix-cdom", type=float, default=None, help="hold a_CDOM(440) fixed, m^-1")
    p.add_argument("--json", action="store_true", help="print the whole result as JSON")
    add_common(p)
    p.set_defaults(func=_estimate, grid=grid)
