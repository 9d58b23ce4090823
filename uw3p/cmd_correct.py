"""``uw3p correct``: a photo corrected pixel by pixel along each pixel's range, with a measured
water (measure.correct).

    uw3p correct PHOTO.dng --water RESULTS/DIVE_01/measurement.json --range 2.5 --out DIR
    uw3p correct PHOTO.dng --water RESULTS/joint.json --depth 8 --range PHOTO_range.tif --out DIR
    uw3p correct PHOTO.dng --water measurement.json --range plane:4,0,-3 --out DIR

Writes the corrected photo at full resolution in sRGB with its ICC profile -- corrected.jpg
(8-bit JPEG, the default) or, with --output-format tiff16, corrected_srgb.tif (16-bit TIFF) --,
corrected.tiff (linear camera RGB) only with --linear, and correction.json (the coefficients in
Sea-thru's form, the range, the cap, the water) into DIR, whole or not at all. DIR is replaced whole, so it may not hold the
photo, the --water file, the --range map or a measurement (a measurement.json of uw3p measure
or a dive's photo): that is refused, naming --out (exit 2), and nothing is written or removed. Exit status 0 when the water's measurement is
reliable, 1 when it is not, 2 bad input.
"""

from __future__ import annotations

from pathlib import Path

from forward.errors import InputError

from . import __version__
from .common import EXIT_NOT_RELIABLE, EXIT_OK, check_spectra_args, read_photo

__all__ = ["BUFFERED", "NAME", "add_parser", "run"]

#: The subcommand's name.
NAME = "correct"
#: Output is collected and written when the command ends (see ``uw3p.cli.main``).
BUFFERED = True


def add_parser(sub):
    """Register ``correct`` and its options.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``uw3p`` parser's subcommands.

    Returns
    -------
    argparse.ArgumentParser
        The subcommand's parser, its ``func`` default set to :func:`run`.
    """
    p = sub.add_parser(NAME, help="correct a photo pixel by pixel along each pixel's range with "
                                  "a measured water")
    p.add_argument("image", help="RAW or linear 16-bit TIFF")
    p.add_argument("--water", required=True, metavar="JSON",
                   help="measurement.json of uw3p measure, or joint.json of a dive")
    p.add_argument("--range", required=True, metavar="RANGE",
                   help="camera-to-object range: a distance in m, a range map (float TIFF in m, "
                        "16-bit PNG in mm, .npy in m; 0, NaN or < 0 unknown, +inf beyond the "
                        "cap; the photo's aspect, resampled to it) "
                        "or plane:A,B,C (A + B u + C v m, u and v across the photo in [-1, 1])")
    p.add_argument("--out", required=True,
                   help="output folder (created if missing; replaced whole, so it may not hold "
                        "the photo, the --water file, the --range map or a measurement.json: "
                        "refused)")
    p.add_argument("--depth", type=float, default=None,
                   help="the photo's depth, m (default the chart's)")
    p.add_argument("--photo", default=None,
                   help="joint.json: the dive photo whose veiling light and gain are used "
                        "(default the one nearest in depth)")
    p.add_argument("--exposure-ratio", type=float, default=None,
                   help="this photo's exposure over the chart photo's (t ISO / N^2); default "
                        "from both photos' EXIF where known, else 1")
    p.add_argument("--max-gain", type=float, default=None,
                   help="cap: the largest amplification of a channel's direct signal by the "
                        "range; farther ranges are corrected as at the cap (default "
                        "measure.correct.MAX_GAIN, 16)")
    p.add_argument("--max-range", type=float, default=None,
                   help="ranges beyond are corrected as at it, m")
    p.add_argument("--unknown", default="reference",
                   help="range (m) at which pixels without a range are corrected (default: "
                        "'reference', the chart's distance)")
    p.add_argument("--method", default="matrix", choices=["matrix", "diagonal"],
                   help="matrix (default): a 3x3 matrix per range, learned through the "
                        "measured water on 29 CIE/CQS test colours; diagonal: each channel "
                        "divided by the white's transmittance alone (von Kries)")
    p.add_argument("--white", type=float, default=1.0,
                   help="Y of a perfect white reflector in the sRGB image, 0-1 (default 1)")
    p.add_argument("--output-format", default="jpeg", choices=["jpeg", "tiff16"],
                   help="the corrected sRGB image: corrected.jpg, 8-bit (default), or "
                        "corrected_srgb.tif, 16-bit (about 12 times larger)")
    p.add_argument("--linear", action="store_true",
                   help="also corrected.tiff: 16-bit linear camera RGB in air")
    p.add_argument("--tiff", default="compressed", choices=["compressed", "full", "none"],
                   help="the TIFFs asked for: lossless deflate (default) or uncompressed; none: "
                        "no TIFF")
    p.add_argument("--uncertainty", action="store_true",
                   help="also the ΔE00 spread over the water's 95 %% intervals, and what a depth "
                        "outside the measured ones may cost (correction.json)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace an output folder that holds another photo's results")
    p.add_argument("--camera", default=None,
                   help="camera name or CSV (default: the water's recorded camera; a photo of "
                        "another camera (EXIF Make/Model) is refused without it)")
    p.add_argument("--quantal", action="store_true", help="the camera curves act on photons")
    p.add_argument("--profile", default=None,
                   help="camera profile from uw3p calibrate (default: the one the water was "
                        "measured with, at its recorded path)")
    p.add_argument("--illuminant", default=None,
                   help="surface illuminant (default the water's, D65)")
    p.add_argument("--black-level", type=float, default=None, help="override the file's, raw units")
    p.add_argument("--white-level", type=float, default=None, help="override the file's, raw units")
    p.set_defaults(func=run)
    return p


def _camera_options(args) -> dict:
    """The camera options given (None: the water's recorded camera and calibration)."""
    return {"camera": args.camera, "quantal": True if args.quantal else None,
            "illuminant": args.illuminant, "profile": args.profile}


def _exposure(args, photo, water_path):
    """--exposure-ratio, or the ratio of the EXIF exposures (this photo's over the chart
    photo's, from measurement.json) where both are known."""
    if args.exposure_ratio is not None:
        return args.exposure_ratio
    import json

    from measure.correctwater import exposure_ratio

    try:
        rec = json.loads(Path(water_path).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    chart = (rec.get("image") or {}).get("exposure") if isinstance(rec, dict) else None
    return exposure_ratio(photo.exposure, chart) if chart else None


def run(args, out, err) -> int:
    """Correct one photo.

    Parameters
    ----------
    args : argparse.Namespace
    out : text stream
        What was written, the range and the cap.
    err : text stream

    Returns
    -------
    int
        ``EXIT_OK`` when the water's measurement is reliable, ``EXIT_NOT_RELIABLE`` otherwise.

    Raises
    ------
    ValueError
        Bad input, naming the option (``--water``, ``--range``, ``--out``, ...).
    """
    from measure.correct import MAX_GAIN, applied, correct_image, seathru_coefficients
    from measure.correct_output import NOT_MODELLED, write_corrected
    from measure.imagefiles import SRGB_BITS

    check_spectra_args(args)
    src = Path(args.image)
    if not src.is_file():
        raise InputError("image", f"file not found: {src}")
    if not Path(args.water).is_file():
        raise InputError("water", f"file not found: {args.water}")
    if Path(args.out).is_file():
        raise InputError("out", f"{args.out} is a file; give a folder (created if missing)")
    from measure.correct_output import check_correct_out
    from measure.output import image_options

    image_options(args.output_format, args.linear, args.tiff, args.method)  # before the work
    inputs = (args.water, args.range)
    check_correct_out(args.out, src, inputs, args.overwrite)  # a refusal before the work
    photo = read_photo(args, src)
    corr = correct_image(photo, args.water, args.range, max_gain=MAX_GAIN if args.max_gain is None else args.max_gain,
                         max_range=args.max_range, unknown=args.unknown, white=args.white,
                         method=args.method, linear=args.linear,
                         srgb_bits=SRGB_BITS[args.output_format], depth=args.depth, photo=args.photo,
                         exposure_ratio=_exposure(args, photo, args.water), **_camera_options(args))
    record = {"image": str(src), "range": {"given": str(args.range)} | corr.ranges,
              "seathru": seathru_coefficients(corr.table), "notes": corr.notes,
              "not_modelled": list(NOT_MODELLED), "white_Y": args.white,
              "command": getattr(args, "command_line", ""), "version": __version__}
    record.update(applied(corr.table, args.water))
    if args.uncertainty:
        from measure.correct_uncertainty import correction_spread, extrapolation_spread

        record["uncertainty"] = correction_spread(corr.table.water, method=args.method) | {
            "extrapolation": extrapolation_spread(corr.table.water)}
    written = write_corrected(corr, args.out, record=record, version=__version__,
                              tiff=args.tiff, output_format=args.output_format,
                              overwrite=args.overwrite,
                              inputs=inputs)
    r = corr.ranges
    span = "no finite range" if r["min_m"] is None else f"{r['min_m']:.3g}-{r['max_m']:.3g} m"
    out.write(f"range            {r['kind']}: {span}"
              + (f", {100 * r['unknown_fraction']:.1f} % unknown" if r["unknown_fraction"] else "")
              + f"; capped at {r['cap_m']:.3g} m ({r['cap_reason']})"
              + (f", {100 * r['capped_fraction']:.1f} % beyond" if r["capped_fraction"] else "")
              + "\n"
              f"water            C {corr.table.water.chl:.4g} mg m^-3, a_CDOM(440) "
              f"{corr.table.water.cdom:.4g} m^-1, depth {corr.table.water.depth:.3g} m "
              f"({corr.table.water.source})\n")
    for note in corr.notes:
        out.write(f"note             {note}\n")
    out.write("wrote            " + ", ".join(written.values()) + "\n")
    return EXIT_OK if corr.table.water.reliable else EXIT_NOT_RELIABLE
