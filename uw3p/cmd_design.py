"""``uw3p design``: how precisely can this camera measure C and CDOM here?

    uw3p design --depth 15 --distance 1 --chl 1 --cdom 0.1 [--lux 20000] [--gain free]
                [--camera ...]

The Cramer-Rao bound of the chart model (``sca.precision``), said in words with a verdict.
Exit status 0 when C is measurable to +-30 % at 95 % (:data:`DESIGN_GOOD`), 1 when it is not.
"""

from __future__ import annotations

import math

from .common import (EXIT_NOT_RELIABLE, EXIT_OK, add_budget_options, add_setup_options,
                     budget_text, camera_note, check_spectra_args, uncertain_from_args,
                     water_from_args, wavelengths_from_args)

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
    p.add_argument("--chl", type=float, required=True,
                   help="expected chlorophyll C, mg m^-3 (> 0: the precision is relative to it)")
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


#: Relative precisions above this are said as "more than" it (digits there mean nothing).
SAY_MAX = 10.0


def _pm(rel):
    """A relative 95 % half-width in words: '±12 %', 'more than ±1000 %', 'not bounded'."""
    if not math.isfinite(rel):
        return "not bounded"
    return f"more than ±{100 * SAY_MAX:.0f} %" if rel > SAY_MAX else f"±{100 * rel:.0f} %"


def _c_to(rel):
    """'C to ±12 %' or 'C is still not bounded'."""
    return f"C to {_pm(rel)}" if math.isfinite(rel) else "C is still not bounded"


def _rel95(p, name):
    """The relative 95 % half-width of C or a_CDOM, or None at a true value of 0."""
    value = float(getattr(p, name))
    return None if value == 0 else float(getattr(p, f"{name}_rel95"))


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
        A note when the camera's curves stop inside the grid.

    Returns
    -------
    int
        ``EXIT_OK`` when the 95 % half-width of C is at most :data:`DESIGN_GOOD` of C, else
        ``EXIT_NOT_RELIABLE``.

    Raises
    ------
    ValueError
        Bad input (``--chl`` not > 0, ``--lux`` not > 0, ...); the message names the option.
    """
    import forward
    from sca import precision

    if not args.chl > 0:
        raise ValueError(f"--chl: must be > 0 (the precision is relative to C; give the "
                         f"smallest C you need to measure), got {args.chl:g}")
    check_spectra_args(args)
    try:
        sensor = forward.SensorSettings(illuminance_lux=args.lux, exposure_mode=args.exposure)
    except ValueError as exc:
        raise ValueError(str(exc).replace("illuminance_lux", "--lux", 1)) from None
    wl = wavelengths_from_args(args)
    err.write(camera_note(args.camera, wl))
    kw = dict(camera=args.camera, illuminant=args.illuminant, reflectances=args.reflectances,
              wavelengths=wl, water=water_from_args(args), sensor=sensor,
              uncertain=uncertain_from_args(args))
    cond = dict(chl=args.chl, cdom=args.cdom, depth=args.depth, distance=args.distance)
    p = precision(**cond, gain=args.gain, **kw)
    fixed = precision(**cond, gain=args.gain, fix={"cdom": None}, **kw)
    known = precision(**cond, gain="known", **kw) if args.gain != "known" else p
    rel, rel_fix = _rel95(p, "chl"), _rel95(fixed, "chl")
    cdom_rel = _rel95(p, "cdom")
    gains = {"known": "exposure known (data in model units)",
             "free": "exposure unknown, camera's channel balance calibrated",
             "channels": "exposure and channel balance unknown (uncalibrated camera)"}
    cdom_text = (f"±{1.96 * float(p.cdom_sd):.3g} m^-1 (95 %, absolute: a_CDOM(440) = 0)"
                 if cdom_rel is None else f"{_pm(cdom_rel)} (95 %; sd {p.cdom_sd:.3g} m^-1)")
    rrmse = float(p.rrmse)
    lines = [f"camera {args.camera}, {args.lux:g} lx at the surface, chart at {args.depth:g} m "
             f"seen from {args.distance:g} m; C = {args.chl:g} mg m^-3, a_CDOM(440) = "
             f"{args.cdom:g} m^-1; {gains[args.gain]}",
             f"C                {_pm(rel)} (95 %; sd {p.chl_sd:.3g} mg m^-3)",
             f"a_CDOM(440)      {cdom_text}",
             "attenuation k    " + (f"expected RRMSE (eq 19) {rrmse:.2g}" if math.isfinite(rrmse)
                                    else "expected RRMSE (eq 19) not defined: the chart does "
                                         "not bound C and a_CDOM here")]
    if args.depth + args.distance == 0:
        lines.append("the light crosses no water (depth and distance 0): the chart cannot "
                     "tell anything about the water")
    corr = float(p.correlation)
    if abs(corr) > 0.95:
        lines.append(f"C and a_CDOM are hard to separate here (correlation {corr:+.2f}): the "
                     "chart fixes a combination of them better than either.")
    lines.append(f"with a_CDOM measured separately, {_c_to(rel_fix)}")
    if args.gain != "known":
        lines.append(f"with the exposure known, {_c_to(_rel95(known, 'chl'))}")
    if p.budget:
        shares = budget_text(p.budget, "chl")
        lines.append(f"budget of C      {shares} of the variance; {p.limiting} limits the "
                     "instrument here" if shares else
                     "budget of C      not defined: C is not bounded here")
        budget = kw["uncertain"]
        if p.limiting in budget and p.limiting != "patch":
            better = dict(budget)
            sd = budget[p.limiting]
            better[p.limiting] = (f"{float(str(sd).rstrip('%')) / 4:g}%" if isinstance(sd, str)
                                  else sd / 4)
            q = precision(**cond, gain=args.gain, **{**kw, "uncertain": better})
            lines.append(f"with {p.limiting} known 4x better (sd {better[p.limiting]}), C to "
                         f"{_pm(float(q.chl_rel95))}")
        elif p.limiting == "patch":
            lines.append("a calibration photo in air (uw3p calibrate) measures the per-patch "
                         "term of this camera and chart; --uncertain patch=SD uses it")
        camera_only = precision(**cond, gain=args.gain, **{**kw, "uncertain": {}})
        lines.append(f"the camera alone (photon and read noise only, --exact): "
                     f"{_c_to(_rel95(camera_only, 'chl'))}")
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
    elif math.isfinite(rel):
        verdict = f"{at}, C cannot be measured ({_pm(rel)}): the chart does not constrain it."
    else:
        verdict = f"{at}, C cannot be measured: the chart does not bound it."
    lines.append("verdict          " + verdict)
    out.write("\n".join(lines) + "\n")
    return EXIT_OK if rel <= DESIGN_GOOD else EXIT_NOT_RELIABLE
