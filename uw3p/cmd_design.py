"""``uw3p design``: how precisely can this camera measure C and CDOM here?

    uw3p design --depth 15 --distance 1 --chl 1 --cdom 0.1 [--lux 20000] [--gain free]
                [--camera ...]

The Cramer-Rao bound of the chart model (``sca.precision``), said in words with a verdict.
Exit status 0 when C is measurable to +-30 % at 95 % (:data:`DESIGN_GOOD`), 1 when it is not.
"""

from __future__ import annotations

import math

from .common import (EXIT_NOT_RELIABLE, EXIT_OK, add_budget_options, add_setup_options,
                     budget_text, uncertain_from_args, water_from_args, wavelengths_from_args)

__all__ = ["NAME", "BUFFERED", "DESIGN_GOOD", "DESIGN_COARSE", "add_parser", "run"]

#: The subcommand's name.
NAME = "design"
#: Output is collected and written when the command ends (see ``uw3p.cli.main``).
BUFFERED = True
#: A measurement is "reliable" to the design tool when the 95 % half-width of C is at most
#: this fraction of C, and "coarse" up to DESIGN_COARSE.
DESIGN_GOOD, DESIGN_COARSE = 0.30, 1.00


def add_parser(sub):
    """Register ``design`` and its options.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``uw3p`` parser's subcommands.

    Returns
    -------
    argparse.ArgumentParser
        The subcommand's parser, its ``func`` default set to :func:`run`.
    """
    p = sub.add_parser(NAME, help="how precisely can this camera measure C and CDOM here? "
                                  "(the Cramer-Rao bound, sca.precision)")
    p.add_argument("--chl", type=float, required=True, help="expected chlorophyll C, mg m^-3")
    p.add_argument("--cdom", type=float, required=True, help="expected a_CDOM(440), m^-1")
    p.add_argument("--depth", type=float, required=True, help="chart depth, m")
    p.add_argument("--distance", type=float, required=True, help="camera-to-chart distance, m")
    p.add_argument("--lux", type=float, default=20000.0, help="surface illuminance, lx (default 20000)")
    p.add_argument("--exposure", default="capped", choices=["capped", "iset"],
                   help="auto-exposure model (default capped at 1/30 s)")
    p.add_argument("--gain", default="free", choices=["known", "free", "channels"],
                   help="exposure known, unknown (default: a photograph), or unknown per channel "
                        "(uncalibrated camera)")
    add_setup_options(p)
    add_budget_options(p)
    p.set_defaults(func=run)
    return p


def _pm(rel):
    return "not bounded" if not math.isfinite(rel) else f"±{100 * rel:.0f} %"


def run(args, out, err) -> int:
    """Say how precisely C and a_CDOM(440) can be measured, and what would help.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options: ``chl`` (mg m^-3), ``cdom`` (m^-1), ``depth`` (m), ``distance`` (m),
        ``lux`` (surface illuminance, lx), ``exposure``, ``gain`` and the setup options.
    out : text stream
        The 95 % precision of C and a_CDOM(440), the expected RRMSE of k, what fixing a_CDOM or
        knowing the exposure buys, and a verdict.
    err : text stream
        Unused.

    Returns
    -------
    int
        ``EXIT_OK`` when the 95 % half-width of C is at most :data:`DESIGN_GOOD` of C, else
        ``EXIT_NOT_RELIABLE``.

    Raises
    ------
    ValueError
        Bad input; the message names the argument.
    """
    import forward
    from sca import precision

    sensor = forward.SensorSettings(illuminance_lux=args.lux, exposure_mode=args.exposure)
    kw = dict(camera=args.camera, illuminant=args.illuminant, reflectances=args.reflectances,
              wavelengths=wavelengths_from_args(args), water=water_from_args(args), sensor=sensor,
              uncertain=uncertain_from_args(args))
    cond = dict(chl=args.chl, cdom=args.cdom, depth=args.depth, distance=args.distance)
    p = precision(**cond, gain=args.gain, **kw)
    fixed = precision(**cond, gain=args.gain, fix={"cdom": None}, **kw)
    known = precision(**cond, gain="known", **kw) if args.gain != "known" else p
    rel, rel_fix = float(p.chl_rel95), float(fixed.chl_rel95)
    gains = {"known": "exposure known (data in model units)",
             "free": "exposure unknown, camera's channel balance calibrated",
             "channels": "exposure and channel balance unknown (uncalibrated camera)"}
    lines = [f"camera {args.camera}, {args.lux:g} lx at the surface, chart at {args.depth:g} m "
             f"seen from {args.distance:g} m; C = {args.chl:g} mg m^-3, a_CDOM(440) = "
             f"{args.cdom:g} m^-1; {gains[args.gain]}",
             f"C                {_pm(rel)} (95 %; sd {p.chl_sd:.3g} mg m^-3)",
             f"a_CDOM(440)      {_pm(float(p.cdom_rel95))} (95 %; sd {p.cdom_sd:.3g} m^-1)",
             f"attenuation k    expected RRMSE (eq 19) {p.rrmse:.2g}"]
    corr = float(p.correlation)
    if abs(corr) > 0.95:
        lines.append(f"C and a_CDOM are hard to separate here (correlation {corr:+.2f}): the "
                     "chart fixes a combination of them better than either.")
    lines.append(f"with a_CDOM measured separately, C to {_pm(rel_fix)}")
    if args.gain != "known":
        lines.append(f"with the exposure known, C to {_pm(float(known.chl_rel95))}")
    if p.budget:
        lines.append(f"budget of C      {budget_text(p.budget, 'chl')} of the variance; "
                     f"{p.limiting} limits the instrument here")
        camera_only = precision(**cond, gain=args.gain, **{**kw, "uncertain": {}})
        lines.append(f"the camera alone (photon and read noise only, --exact): C to "
                     f"{_pm(float(camera_only.chl_rel95))}")
    if p.flags:
        lines.append("caveats: " + ", ".join(p.flags) + " (the bound may not be attained)")
    at = f"at {args.depth:g} m with this camera"
    if rel <= DESIGN_GOOD:
        verdict = f"{at}, C is measurable to {_pm(rel)}: a reliable measurement is possible."
    elif rel_fix <= DESIGN_GOOD:
        verdict = (f"{at}, C is measurable to {_pm(rel)}; fix a_CDOM (measure it separately) to "
                   f"reach {_pm(rel_fix)}.")
    elif rel <= DESIGN_COARSE:
        verdict = (f"{at}, C is measurable only coarsely ({_pm(rel)}); move closer, shoot "
                   "shallower or in brighter light.")
    else:
        verdict = f"{at}, C cannot be measured ({_pm(rel)}): the chart does not constrain it."
    lines.append("verdict          " + verdict)
    out.write("\n".join(lines) + "\n")
    return EXIT_OK if rel <= DESIGN_GOOD else EXIT_NOT_RELIABLE
