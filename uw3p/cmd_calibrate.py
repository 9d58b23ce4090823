"""``uw3p calibrate``: a camera's channel balance from a photograph of the chart in air.

    uw3p calibrate AIR.dng --out profile.json [--corners "x1,y1 x2,y2 x3,y3 x4,y4"]

Without ``--corners`` the chart is found in the photo (:func:`measure.find_chart`).

The profile written is what ``uw3p measure --profile`` reads. Exit status 0 when the profile
fits (reliable), 1 when it does not.
"""

from __future__ import annotations

import os

from forward.errors import InputError

from .common import (EXIT_NOT_RELIABLE, EXIT_OK, add_chart_option, add_photo_options, camera_note,
                     chart_from_args, check_spectra_args, read_photo, write_file)

__all__ = ["NAME", "BUFFERED", "add_parser", "profile_text", "run"]

#: The subcommand's name.
NAME = "calibrate"
#: Output is collected and written when the command ends (see ``uw3p.cli.main``).
BUFFERED = True


def add_parser(sub):
    """Register ``calibrate`` and its options.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``uw3p`` parser's subcommands.

    Returns
    -------
    argparse.ArgumentParser
        The subcommand's parser, its ``func`` default set to :func:`run`.
    """
    p = sub.add_parser(NAME, help="fit a camera's channel balance from a photo of the "
                                  "chart in air")
    p.add_argument("image", help="RAW (any LibRaw format) or linear 16-bit TIFF of the chart in air")
    p.add_argument("--out", required=True, help="the profile to write (JSON)")
    add_photo_options(p)
    add_chart_option(p)
    p.set_defaults(func=run)
    return p


def _corner_text(corners) -> str:
    """'x1,y1 x2,y2 x3,y3 x4,y4' (pixels, one decimal): what --corners takes."""
    return " ".join(f"{x:.1f},{y:.1f}" for x, y in corners)


def run(args, out, err) -> int:
    """Fit the channel balance of the camera from ``image`` and write the profile to ``--out``.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options: ``image``, ``out``, ``chart_reflectance`` (a measured chart's CSV,
        or None for the nominal chart) and the photo options (``corners`` in pixels or
        None to find the chart,
        ``layout``, ``camera``, ``quantal``, ``illuminant``, black and white levels in raw
        units).
    out : text stream
        The channel gains (largest 1), chi^2/dof and fit_rms per channel, and whether the
        profile is reliable.
    err : text stream
        ``wrote <profile>``; a note when the camera's curves stop inside 400-700 nm; the
        corners found when ``--corners`` is not given.

    Returns
    -------
    int
        ``EXIT_OK`` when the profile is reliable, else ``EXIT_NOT_RELIABLE``.

    Raises
    ------
    ValueError
        Bad input (an unreadable image, corners whose grey row does not fall from white to
        black, a chart found partly outside the frame, an unwritable ``--out``); the message
        names the argument or file;
        :class:`measure.ChartNotFound` (``no chart found``) when no chart is found.
    """
    import measure

    check_spectra_args(args)
    if args.out.endswith(("/", "\\")) or os.path.isdir(args.out):
        raise InputError("--out", f"{args.out} is a folder; give the profile's file name "
                         "(profile.json)")
    chart = chart_from_args(args)
    photo = read_photo(args, args.image)
    err.write(camera_note(args.camera))
    corners = args.corners
    if corners is None:
        found = measure.find_chart(photo, measure.LAYOUTS[args.layout])
        found.check_in_frame(photo.size)
        corners = found.corners
        err.write(f"chart found: corners {_corner_text(corners)} (confidence "
                  f"{found.confidence:.2f}; give --corners to override)\n")
    cands = measure.orientations(photo, corners, measure.LAYOUTS[args.layout])
    c, _, ok = cands["as given"]
    if not ok:
        passing = [k for k, v in cands.items() if v[2]]
        hint = f" (it does {passing[0]})" if len(passing) == 1 else ""
        which = "in the order given" if args.corners is not None else "of the chart found"
        raise InputError("corners", "the grey row (patches 19-24) does not fall from white to black "
                         f"{which}{hint}; give the corners next to patch 1, 6, 24, 19")
    sample = measure.sample_patches(photo, c, measure.LAYOUTS[args.layout])
    prof = measure.calibrate(sample, camera=args.camera, quantal=args.quantal,
                             illuminant=args.illuminant, image=photo.path,
                             chart_reflectance=chart)
    write_file(args.out, prof.to_json(), err)
    out.write(profile_text(prof))
    return EXIT_OK if prof.reliable else EXIT_NOT_RELIABLE


def profile_text(prof) -> str:
    """What ``uw3p calibrate`` prints of a profile (:class:`measure.Profile`): the gains, the
    per-patch systematic it measured and the limit that decides ``reliable``, the chi^2 per
    channel with that term in the noise and with photon noise alone, fit_rms."""
    from measure.camera import MIN_CALIBRATION_PATCHES, PATCH_SD_MAX

    def per_channel(values):
        return ", ".join(f"{v:.3g}" for v in values)
    lines = ["channel gains (largest 1): " + ", ".join(f"{g:.4g}" for g in prof.gains),
             f"per-patch systematic: {100 * prof.patch_sd:.2g} % of each patch beyond photon "
             f"noise (limit {100 * PATCH_SD_MAX:.0f} %: a chart's tolerance and the curves' "
             "error stay below it); it is in the gains' errors and sets the measurements' "
             "per-patch term (never below the budget's floor)"]
    if prof.chi2_dof_patch is not None:
        lines.append(f"chi2/dof per channel: {per_channel(prof.chi2_dof_patch)} with that term "
                     "in the noise (over the three channels 1 by its definition, below 1 where "
                     "photon noise explains the residuals); "
                     f"{per_channel(prof.chi2_dof)} with photon noise alone (large with "
                     "thousands of pixels per patch: it does not decide)")
    lines.append("fit_rms per channel: " + per_channel(prof.fit_rms))
    why = (f"flags: {', '.join(prof.flags)}" if prof.flags else
           f"the per-patch systematic is within {100 * PATCH_SD_MAX:.0f} % and every channel "
           f"has {MIN_CALIBRATION_PATCHES} patches or more")
    return "\n".join(lines) + f"\nreliable: {prof.reliable} ({why})\n"
