"""``uw3p measure``: the water from a photograph of the chart underwater, and the photograph
colour-corrected; or a dive: a folder of photos, each with its own depth and distance.

    uw3p measure UW.dng --profile profile.json --depth 5 --distance 1.5 --corners "..." --out DIR
                 [--cdom-sample VALUE:SD] [--secchi DEPTH:SD] [--kd NM=VALUE:SD ...]
                 [--chart-reflectance FILE]
    uw3p measure DIVE_FOLDER/ --metadata dive.csv --profile profile.json [--joint] --out DIR

One photo: the estimate, and what the photo measures in words (measured, loosely measured,
only an upper bound, not constrained), printed and in the files (:mod:`measure.statements`).

A folder (:func:`measure.dive.measure_dive`): one output folder per photo, summary.csv (every
file of the folder: measured or why not), survey.nc, survey.png and, with ``--joint``,
joint.json; run on Dask (a local cluster, or ``--scheduler ADDRESS``); a rerun skips the photos
already complete with the same inputs and options, and a rerun with other options is refused
(``--overwrite``, or another ``--out``). Exit status 0 when every photo measured is reliable, 1
when one is not, 2 when one could not be measured (bad input) or none was, 130 interrupted
(Ctrl-C; the summary lists what was done). With ``--joint``, the frames in which no chart is
found are corrected with the dive's joint water at their depth along their range (metadata
columns ``range_m`` or ``range_map``; else ``distance_m``): status "corrected with the dive's
water", which leaves the exit status as the measured photos make it. ifdo.json holds the dive's
photometric fields of the iFDO standard.
"""

from __future__ import annotations

from pathlib import Path

from forward.errors import InputError

from . import __version__
from .common import (EXIT_INTERRUPTED, EXIT_NOT_RELIABLE, EXIT_OK, add_auxiliary_options,
                     add_budget_options, add_chart_option, add_photo_options, add_water_options,
                     auxiliary_from_args, camera_note, chart_from_args, check_spectra_args,
                     read_photo, uncertain_from_args, water_from_args)

__all__ = ["BUFFERED", "NAME", "add_parser", "run"]

#: The subcommand's name.
NAME = "measure"
#: Output is collected and written when the command ends (see ``uw3p.cli.main``).
BUFFERED = True


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
    p.add_argument("--metadata", default=None, metavar="CSV",
                   help="a folder's per-photo inputs: columns image,depth_m,distance_m and "
                        "optionally depth_sd_m,distance_sd_m,corners,range_m,range_map and the "
                        "water measured with each photo, each with its sd: "
                        "cdom_sample,cdom_sample_sd (m^-1), secchi_m,secchi_sd_m (m), "
                        "kd_<nm>,kd_<nm>_sd (m^-1), and the reference shots reference,reference_after "
                        "(PHOTO[:MINUTES], as --reference) (image names relative to the folder, "
                        "range maps and reference shots to the CSV's; a photo without a row is "
                        "not measured)")
    p.add_argument("--reference", default=None, action="append", metavar="PHOTO[:MINUTES]",
                   help="a photo of the chart in air at the site under the same sky (a reference "
                        "shot), MINUTES (default 10) before or after the dive: the daylight's "
                        "colour it measures replaces the budget's 30-mired prior (decision "
                        "0069-reference-shot); given twice, a shot before and one after the "
                        "dive, combined and checked against each other (decision "
                        "0074-reference-bracket)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace output folders that hold another photo's results (or results "
                        "of other inputs)")
    p.add_argument("--output-format", default="jpeg", choices=["jpeg", "tiff16"],
                   help="the corrected photo at full resolution in sRGB: corrected.jpg, 8-bit "
                        "(default), or corrected_srgb.tif, 16-bit (about 12 times larger)")
    p.add_argument("--linear", action="store_true",
                   help="also corrected.tiff: 16-bit linear camera RGB, corrected at the chart")
    p.add_argument("--tiff", default="compressed", choices=["compressed", "full", "none"],
                   help="the TIFFs asked for: lossless deflate (default) or uncompressed; none: "
                        "no TIFF (the preview corrected.png is always written)")
    p.add_argument("--method", default="matrix", choices=["matrix", "diagonal"],
                   help="the corrected photo: a 3x3 matrix per range (default) or the "
                        "per-channel (von Kries) correction alone; a dive's frames too")
    p.add_argument("--joint", action="store_true",
                   help="a folder: also fit all its photos as one water (joint.json) and "
                        "correct the frames without a chart with it")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="a folder: the Dask scheduler to run on (e.g. tcp://host:8786); default "
                        "a local cluster of one process per core; 'synchronous': no Dask")
    add_photo_options(p)
    add_chart_option(p)
    add_water_options(p)
    add_budget_options(p)
    add_auxiliary_options(p, folder=True)
    p.set_defaults(func=run)
    return p


def _options(args) -> dict:
    """The keyword arguments of :func:`measure.measure` given by the options (the
    measurements of the water and the measured chart only where given: a dive's run.json
    keeps the options of earlier runs)."""
    extra = {"auxiliary": auxiliary_from_args(args), "chart_reflectance": chart_from_args(args)}
    return {"camera": args.camera, "quantal": args.quantal, "profile": args.profile,
            "illuminant": args.illuminant, "layout": args.layout, "water": water_from_args(args),
            "black_level": args.black_level, "white_level": args.white_level,
            "uncertain": _with_reference(args, _budget(args))} | {
                k: v for k, v in extra.items() if v}


def _with_reference(args, uncertain):
    """``uncertain`` with the daylight measured by ``--reference`` (one shot, or two
    bracketing the dive: :func:`measure.reference.reference_budget`; as given without it)."""
    refs = getattr(args, "reference", None) or []
    if not refs or uncertain == {}:
        return uncertain
    import measure
    from measure.reference import parse_reference, reference_budget

    shots = [parse_reference(r) for r in refs]
    profile = measure.load_profile(args.profile) if args.profile else None
    base = uncertain if uncertain is not None else measure.budget_for(
        None, profile, measured_chart=args.chart_reflectance is not None)
    return reference_budget(base, shots, lambda photo: read_photo(args, photo),
                            _reference_setup(args, profile), args.layout)


def _reference_setup(args, profile):
    """The camera set-up a reference shot is fitted with: the profile's gains, the options'
    camera, illuminant and chart."""
    import measure
    from measure.camera import read_chart_reflectance

    return measure.camera_setup(args.camera, quantal=args.quantal, illuminant=args.illuminant,
                                gains=None if profile is None else profile.gains,
                                reflectances=None if args.chart_reflectance is None else
                                read_chart_reflectance(args.chart_reflectance))


def daylight_line(uncertain) -> str:
    """What the fit took of the daylight's colour, in words."""
    from sca.budget import DEFAULT_UNCERTAIN

    day = (DEFAULT_UNCERTAIN if uncertain is None else uncertain).get("daylight", 0.0)
    if isinstance(day, dict) and "shots" in day:
        return (f"daylight: measured at the site by two shots, {day['centre']:+.1f} +- "
                f"{day['sd']:.1f} mired (before/after "
                + " / ".join(f"{s['centre']:+.1f}" for s in day["shots"])
                + f", chi2 {day['chi2']:.3g}, p {day['p']:.2g}"
                + ("; THE SHOTS DISAGREE: the sky changed beyond its sd (reference-conflict)"
                   if day.get("conflict") else "") + ")")
    if isinstance(day, dict):
        return (f"daylight: measured at the site, {day['centre']:+.1f} +- {day['sd']:.1f} mired "
                f"(fit {day.get('sd_fit', float('nan')):.1f}, sky's change "
                f"{day.get('sd_sky', float('nan')):.1f} over {day.get('minutes', float('nan')):g}"
                " min)")
    return f"daylight: prior {float(day):g} mired" if float(day) > 0 else "daylight: as given"


def _images(args) -> dict:
    """The images asked for (:func:`measure.output.image_options`, checked)."""
    from measure.output import image_options

    return image_options(args.output_format, args.linear, args.tiff, args.method)


def _measure_one(args, image, outdir):
    """Measure one image into ``outdir``; returns (exit code, summary of the estimate)."""
    import measure
    from measure.auxiliary import auxiliary_record, option_sources
    from measure.output import check_out
    from measure.statements import statements
    from sca.pathmodels import span_note

    check_out(outdir, image, args.overwrite)  # a refusal before the work
    _images(args)
    opts = _options(args)
    opts.pop("black_level"), opts.pop("white_level")
    meas = measure.measure(read_photo(args, image), corners=args.corners, depth=args.depth,
                           distance=args.distance, **opts)
    meas.inputs["command"] = getattr(args, "command_line", "")
    aux = opts.get("auxiliary")
    meas.inputs["auxiliary"] = auxiliary_record(aux, option_sources(aux))
    written = measure.write_outputs(meas, outdir, version=__version__, overwrite=args.overwrite,
                                    **_images(args))
    e = meas.estimate
    row = {"chl": e.chl, "chl_lo": e.chl_ci[0], "chl_hi": e.chl_ci[1], "cdom": e.cdom,
           "cdom_lo": e.cdom_ci[0], "cdom_hi": e.cdom_ci[1], "gain": e.gain,
           "fit_rms": e.fit_rms, "chi2_dof": e.chi2_dof, "orientation": meas.orientation,
           "reliable": meas.reliable, "flags": " ".join(meas.flags), "written": written,
           "statements": statements(e, "photo", meas.auxiliary_kinds),
           "daylight": daylight_line(e.uncertain or {}),
           "span": span_note(meas.flags, e.path_models)}
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
    base = measure.budget_for(None, profile, measured_chart=args.chart_reflectance is not None)
    defaults = uncertain_from_args(type(args)(exact=False, depth_sd=None, distance_sd=None,
                                              uncertain=[]))
    return base | {k: v for k, v in given.items() if defaults.get(k) != v}


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
        ``EXIT_NOT_RELIABLE`` when one is not, ``EXIT_BAD_INPUT`` when a folder's photo could
        not be measured, ``EXIT_INTERRUPTED`` when a folder's run was interrupted (Ctrl-C).

    Raises
    ------
    ValueError
        Bad input (missing ``--depth``/``--distance`` for one photo, an unreadable image, a
        folder without images, a bad ``--metadata`` file, an output folder that cannot be
        created or holds another photo's results without ``--overwrite``); the message names
        the argument or file.
    """
    check_spectra_args(args)
    if not args.out:
        raise InputError("--out", "empty (an unset shell variable?); give the output folder "
                         "(created if missing)")
    src = Path(args.image)
    if not src.exists():
        raise InputError("image", f"file not found: {src}")
    if Path(args.out).is_file():
        raise InputError("--out", f"{args.out} is a file; give a folder (created if missing)")
    if args.metadata is not None and not src.is_dir():
        raise InputError("--metadata", "applies to a folder of photos; for one photo give "
                         "--depth and --distance")
    err.write(camera_note(args.camera))
    if src.is_dir():
        return _measure_folder(args, src, out, err)
    if args.depth is None or args.distance is None:
        raise InputError("--depth, --distance", "both are required")
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
              f"light            {e['daylight']}\n"
              f"reliable         {e['reliable']}" + (f" (flags: {e['flags']})" if e["flags"] else "")
              + (f"\n  {e['span']}" if e["span"] else "")
              + "\nwhat this photo measures (95 % intervals):\n"
              + "".join(f"  {x}\n" for x in e["statements"])
              + "wrote            " + ", ".join(
                  [str(outdir / "measurement.json")]
                  + [k for k in e["written"] if k != "measurement.json"]) + "\n")
    return code


def _measure_folder(args, src, out, err):
    """Every photo of a folder (a dive): :func:`measure.dive.measure_dive` on Dask, a progress
    bar on ``err``; a count and the outputs' paths on ``out``."""
    import warnings

    from measure.dive import DiveWarning, measure_dive
    from measure.dive.summary import CORRECTED

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DiveWarning)  # written below, in the command's words
        res = measure_dive(src, out=args.out, metadata=args.metadata, depth=args.depth,
                           distance=args.distance, corners=args.corners,
                           overwrite=args.overwrite, joint=args.joint, **_images(args),
                           scheduler=args.scheduler, bar=err, version=__version__,
                           command=getattr(args, "command_line", ""), **_options(args))
    for text in res.warnings:
        err.write(f"uw3p measure: warning: {text}\n")
    c = res.counts
    n = len(res.rows)
    out.write(f"{n} rows: {c['measured'] + c['done earlier']} measured ({c['done earlier']} "
              f"complete from an earlier run), {sum(r.get('reliable') is True for r in res.rows)} "
              f"reliable; {c['error']} not measurable, {c['no chart']} without a chart, "
              f"{c[CORRECTED]} without a chart corrected with the dive's water, "
              f"{c['not in metadata']} without a metadata row, {c['no such photo']} metadata "
              f"rows naming no photo, {c['not an image']} not photos, {c['interrupted']} "
              "interrupted\n")
    for path in (res.summary, res.survey, res.figure, res.joint, res.ifdo):
        if path is not None:
            out.write(f"wrote {path}\n")
    if args.joint and res.joint is None:
        out.write(f"joint: {res.joint_error}\n")
    elif res.joint_estimate is not None:
        out.write(_joint_line(res.joint_estimate))
    if res.interrupted:
        err.write(f"uw3p measure: interrupted; {res.summary} lists what was done (a rerun "
                  "completes the rest)\n")
        return EXIT_INTERRUPTED
    return res.code


def _joint_line(j) -> str:
    """The joint estimate (:class:`sca.joint.JointEstimate`) on one line."""
    from measure.statements import one_line
    from sca.pathmodels import span_note

    def end(v):  # inf, -inf and nan as Python writes them
        return f"{float(v):.4g}"
    v = j.verdicts or {}
    return (f"joint: C {j.chl:.4g} mg m^-3 [{end(j.chl_ci[0])}, {end(j.chl_ci[1])}] "
            f"({v.get('chl', '?')}), a_CDOM(440) {j.cdom:.4g} m^-1 "
            f"[{end(j.cdom_ci[0])}, {end(j.cdom_ci[1])}] ({v.get('cdom', '?')}); "
            f"what the dive measures: {one_line(j, j.quantities or ())}; reliable {j.reliable}"
            + (f" (flags: {' '.join(j.flags)})" if j.flags else "")
            + ("" if j.heterogeneity["one_water"] else
               "; not one water: " + (", ".join(j.heterogeneity["disagree"]) or "?")) + "\n"
            + "".join(f"  {n}\n" for n in (span_note(j.flags, j.path_models),) if n))
