"""``uw3p measure``: the water from a photograph of the chart underwater, and the photograph
colour-corrected.

    uw3p measure UW.dng --profile profile.json --depth 5 --distance 1.5 --corners "..." --out DIR
    uw3p measure DIVE_FOLDER/ ... --out DIR     (every image: one folder each and summary.csv)

Exit status 0 when every measurement is reliable, 1 when one is not, 2 when one could not be
measured (bad input).
"""

from __future__ import annotations

import os
from pathlib import Path

from . import __version__
from .common import (EXIT_BAD_INPUT, EXIT_NOT_RELIABLE, EXIT_OK, add_budget_options,
                     add_photo_options, add_water_options, atomic_open, budget_text, camera_note,
                     check_spectra_args, read_photo, uncertain_from_args, water_from_args)

__all__ = ["NAME", "BUFFERED", "SUMMARY_COLUMNS", "add_parser", "run"]

#: The subcommand's name.
NAME = "measure"
#: Output is collected and written when the command ends (see ``uw3p.cli.main``).
BUFFERED = True
#: Columns of a folder's ``summary.csv``, one row per file.
SUMMARY_COLUMNS = ("image", "chl", "chl_lo", "chl_hi", "cdom", "cdom_lo", "cdom_hi", "gain",
                   "fit_rms", "chi2_dof", "orientation", "reliable", "flags", "depth_m",
                   "depth_sd", "distance_m", "distance_sd", "chl_budget", "out", "error")


def add_parser(sub):
    """Register ``measure`` and its options.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``uw3p`` parser's subcommands.

    Returns
    -------
    argparse.ArgumentParser
        The subcommand's parser, its ``func`` default set to :func:`run`.
    """
    p = sub.add_parser(NAME, help="measure the water from a photo of the chart underwater "
                                  "and colour-correct it")
    p.add_argument("image", help="RAW or linear 16-bit TIFF, or a folder of them (a dive)")
    p.add_argument("--depth", type=float, default=None, help="chart depth, m")
    p.add_argument("--distance", type=float, default=None, help="camera-to-chart distance, m")
    p.add_argument("--profile", default=None, help="camera profile from uw3p calibrate")
    p.add_argument("--out", required=True, help="output folder (created if missing)")
    add_photo_options(p)
    add_water_options(p)
    add_budget_options(p)
    p.set_defaults(func=run)
    return p


def _measure_one(args, image, outdir):
    """Measure one image into ``outdir``; returns (exit code, summary row)."""
    import measure

    meas = measure.measure(read_photo(args, image), corners=args.corners, depth=args.depth,
                           distance=args.distance, camera=args.camera, quantal=args.quantal,
                           profile=args.profile, illuminant=args.illuminant,
                           layout=args.layout, water=water_from_args(args),
                           uncertain=_budget(args))
    meas.inputs["command"] = getattr(args, "command_line", "")
    measure.write_outputs(meas, outdir, version=__version__)
    e = meas.estimate
    row = dict(image=str(image), chl=e.chl, chl_lo=e.chl_ci[0], chl_hi=e.chl_ci[1], cdom=e.cdom,
               cdom_lo=e.cdom_ci[0], cdom_hi=e.cdom_ci[1], gain=e.gain, fit_rms=e.fit_rms,
               chi2_dof=e.chi2_dof, orientation=meas.orientation, reliable=meas.reliable,
               flags=" ".join(meas.flags), depth_m=args.depth,
               depth_sd=meas.inputs.get("depth_sd"), distance_m=args.distance,
               distance_sd=meas.inputs.get("distance_sd"),
               chl_budget=budget_text(e.budget, "chl"), out=str(outdir), error="")
    return (EXIT_OK if meas.reliable else EXIT_NOT_RELIABLE), row


def _budget(args):
    """The ``uncertain=`` of :func:`measure.measure`: None (the default budget with the
    profile's own numbers) unless a budget option was given; then those entries over it (over
    nothing with ``--exact``)."""
    if not (args.exact or args.depth_sd or args.distance_sd or args.uncertain):
        return None
    import measure

    given = uncertain_from_args(args)
    if args.exact:
        return given
    profile = measure.load_profile(args.profile) if args.profile else None
    base = measure.budget_for(None, profile)
    defaults = uncertain_from_args(type(args)(exact=False, depth_sd=None, distance_sd=None,
                                              uncertain=[]))
    return base | {k: v for k, v in given.items() if defaults.get(k) != v}


def _measure_worker(job):
    """One image of a folder, in a worker process: bad input becomes a summary row."""
    args, image, outdir = job
    try:
        return _measure_one(args, image, outdir)
    except ValueError as exc:
        return EXIT_BAD_INPUT, dict(image=str(image), error=str(exc), out=str(outdir))


def run(args, out, err) -> int:
    """Measure one photograph, or every RAW/TIFF file of a folder.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options: ``image`` (a file or a folder), ``depth`` (m), ``distance`` (m),
        ``profile``, ``out`` (a folder), the photo options and the water options.
    out : text stream
        One image: the estimate (C in mg m^-3, a_CDOM(440) in m^-1, the gain, the fit) and the
        files written. A folder: a one-line count and the summary's path.
    err : text stream
        A folder's progress bar; a note when the camera's curves stop inside 400-700 nm.

    Returns
    -------
    int
        The worst status: ``EXIT_OK`` when every measurement is reliable,
        ``EXIT_NOT_RELIABLE`` when one is not, ``EXIT_BAD_INPUT`` when a folder's file could not
        be measured.

    Raises
    ------
    ValueError
        Bad input (missing ``--depth``/``--distance``, an unreadable image, a folder without
        images, an output folder that cannot be created); the message names the argument or file.
    """
    if args.depth is None or args.distance is None:
        raise ValueError("--depth, --distance: both are required")
    check_spectra_args(args)
    src = Path(args.image)
    if not src.exists():
        raise ValueError(f"image: file not found: {src}")
    if Path(args.out).is_file():
        raise ValueError(f"--out: {args.out} is a file; give a folder (created if missing)")
    err.write(camera_note(args.camera))
    if src.is_dir():
        return _measure_folder(args, src, out, err)
    outdir = Path(args.out)
    code, row = _measure_one(args, src, outdir)
    e = row
    out.write(f"chl (C)          {e['chl']:.6g} mg m^-3, 95 % interval [{e['chl_lo']:.4g}, "
              f"{e['chl_hi']:.4g}]\n"
              f"cdom a_CDOM(440) {e['cdom']:.6g} m^-1, 95 % interval [{e['cdom_lo']:.4g}, "
              f"{e['cdom_hi']:.4g}]\n"
              f"gain             {e['gain']:.6g} raw units per model unit\n"
              f"fit              fit_rms {e['fit_rms']:.3g}, chi2/dof {e['chi2_dof']:.3g}\n"
              f"orientation      {e['orientation']}\n"
              f"reliable         {e['reliable']}" + (f" (flags: {e['flags']})" if e["flags"] else "")
              + f"\nwrote            {outdir / 'measurement.json'}, corrected.tiff, "
                "corrected.png, report.png\n")
    return code


def _measure_folder(args, src, out, err):
    """Every image of a folder (a dive's photos): one output folder each, summary.csv, a
    progress bar, all cores. Files that are not images are listed in the summary with their
    error."""
    import csv
    from concurrent.futures import ProcessPoolExecutor

    from tqdm import tqdm

    from measure.image import RAW_EXTENSIONS, TIFF_EXTENSIONS

    files = sorted(p for p in src.iterdir() if p.is_file() and not p.name.startswith(".")
                   and p.suffix.lower() in RAW_EXTENSIONS + TIFF_EXTENSIONS)
    if not files:
        raise ValueError(f"image: folder {src} has no RAW or TIFF files "
                         f"({', '.join(RAW_EXTENSIONS + TIFF_EXTENSIONS)})")
    root = Path(args.out)
    try:
        root.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"--out: cannot create {root}: {exc.strerror}") from None
    jobs = [(args, f, root / f.stem) for f in files]
    workers = max(1, min(len(jobs), os.cpu_count() or 1))
    with ProcessPoolExecutor(workers) as pool:
        results = list(tqdm(pool.map(_measure_worker, jobs), total=len(jobs), file=err,
                            desc="measuring", unit="image"))
    with atomic_open(root / "summary.csv", "--out") as fh:
        w = csv.DictWriter(fh, fieldnames=SUMMARY_COLUMNS)
        w.writeheader()
        for _, row in results:
            w.writerow({k: row.get(k, "") for k in SUMMARY_COLUMNS})
    codes = [c for c, _ in results]
    n_ok = codes.count(EXIT_OK)
    out.write(f"{len(files)} files: {n_ok} reliable, {codes.count(EXIT_NOT_RELIABLE)} not "
              f"reliable, {codes.count(EXIT_BAD_INPUT)} not measurable; {root / 'summary.csv'}\n")
    return max(codes)
