"""``uw3p design``: which dive measures the water to the precision I need?

    uw3p design --chl 1 --cdom 0.1 --depth 2 15 --distance 1 3 [--target C=30%]
                [--target a_CDOM=10%] [--target c=5%] [--lux 20000] [--camera ...]
                [--sample-sd 0.015] [--secchi-sd M] [--no-auxiliary] [--max-photos 12]
                [--reference-shot [MINUTES]] [--camera-only] [--plan plan.csv [--overwrite]]

A thin wrapper of :func:`sca.design` (:mod:`sca.protocols`): for a guessed water and the depths
and distances a dive can use, the cheapest protocol (photos x depths x distances, with or
without a water sample's a_CDOM(440) or a Secchi depth) whose predicted 95 % half-widths meet
every target, what one photo gives, and where none does, the best protocol and what limits it.
Predictions use the default uncertainty budget; ``--camera-only`` gives the camera's own limit
(photon and read noise only), labelled as such. The advice ends with how to follow it: what to
photograph and measure on the dive and the ``uw3p measure`` command that fits it (a dive: its
folder, the metadata CSV ``--plan`` writes, ``--joint``; the auxiliary measurement as
``--cdom-sample`` or ``--secchi``). ``--reference-shot`` adds a chart photographed in air at
the site to every protocol (the daylight's prior a reference shot measures, decision
0075-design-reference-shot) and prints the design with and without it side by side. ``--plan`` never replaces an existing file (a dive's
metadata with real depths) unless ``--overwrite`` is given.

Refused before any work (exit 2, naming the option): a ``--distance`` not > 0, a ``--depth``
beyond daylight's reach in the guessed water (:func:`daylight_depth`, decision
0064-daylight-reach), an existing ``--plan`` file without ``--overwrite``.

Exit status: 0 when a protocol meets every target, 1 when none does, 2 for bad input (the
message names the option).
"""

from __future__ import annotations

import math

from forward.errors import InputError

from .common import (EXIT_NOT_RELIABLE, EXIT_OK, add_budget_options, add_setup_options, budget_text,
                     camera_note, check_spectra_args, uncertain_from_args,
                     water_from_args, wavelengths_from_args)

__all__ = ["NAME", "BUFFERED", "DAYLIGHT_FLOOR", "DEFAULT_TARGET", "PLAN_COLUMNS", "SAY_MAX",
           "TARGET_NAMES", "add_parser", "check_dive", "daylight_depth", "follow", "parse_target",
           "run", "write_plan"]

#: The subcommand's name.
NAME = "design"
#: Output is collected and written when the command ends (see ``uw3p.cli.main``).
BUFFERED = True
#: The target without ``--target``: C to +-30 % at 95 % (decision 0012-precision-bound).
DEFAULT_TARGET = "C=30%"
#: Relative precisions above this are said as "more than" it (digits there mean nothing).
SAY_MAX = 10.0
#: ``--target`` names -> :data:`sca.protocols.TARGETS` names ('C' is C, 'c' the attenuation
#: coefficient; the others in any case; the Python names are accepted too).
TARGET_NAMES = {"c": "c", "chl": "chl", "a_cdom": "cdom", "cdom": "cdom",
                "c443": "c_443", "c490": "c_490", "c555": "c_555", "c670": "c_670",
                "a_nw440": "a_nw_440", "a_nw": "a_nw_440"}
#: The deepest chart a design considers is where the downwelling daylight at the most
#: penetrating wavelength falls to this fraction of the surface's (decision 0064-daylight-reach)
DAYLIGHT_FLOOR = 1e-4
#: Columns of the metadata CSV ``--plan`` writes (:data:`measure.dive.metadata.METADATA_COLUMNS`).
PLAN_COLUMNS = ("image", "depth_m", "distance_m")
#: How each target is named in the output.
LABELS = {"chl": "C", "cdom": "a_CDOM(440)", "c": "c (443-670 nm)", "c_443": "c(443)",
          "c_490": "c(490)", "c_555": "c(555)", "c_670": "c(670)", "a_nw_440": "a_nw(440)"}


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
    p = sub.add_parser(NAME, help="which dive measures the water to the precision I need? "
                                  "(photos x depths x distances, with or without a water "
                                  "sample or a Secchi depth; sca.design)")
    p.add_argument("--chl", type=float, required=True,
                   help="expected chlorophyll C, mg m^-3 (> 0: the targets are relative to it)")
    p.add_argument("--cdom", type=float, required=True,
                   help="expected a_CDOM(440), m^-1 (> 0)")
    p.add_argument("--depth", type=float, nargs="+", required=True, metavar="M",
                   help="the chart depth, or the shallowest and deepest the dive can use, m")
    p.add_argument("--distance", type=float, nargs="+", required=True, metavar="M",
                   help="the camera-to-chart distance, or two distances the dive can use, m")
    p.add_argument("--target", action="append", default=[], metavar="NAME=PCT",
                   help="a 95 %% half-width to reach, in %% of the value: C, a_CDOM, c (the "
                        "path's attenuation coefficient at 443, 490, 555 and 670 nm), c443, "
                        "c490, c555, c670, a_nw440; repeatable (default "
                        f"{DEFAULT_TARGET.replace('%', '%%')})")
    p.add_argument("--max-photos", type=int, default=12, metavar="N",
                   help="most photos of a protocol (default 12)")
    p.add_argument("--sample-sd", type=float, default=None, metavar="SD",
                   help="sd of a water sample's a_CDOM(440), m^-1 (default 0.015)")
    p.add_argument("--reference-shot", nargs="?", type=float, default=None,
                   const=float("nan"), metavar="MINUTES",
                   help="with a reference shot (the chart in air at the site, MINUTES from the "
                        "dive, default 10): the daylight measured; prints the design with and "
                        "without it")
    p.add_argument("--secchi-sd", type=float, default=None, metavar="SD",
                   help="sd of a Secchi reading, m (default 10 %% of the depth the water "
                        "predicts; the relation's own 20 %% scatter is added)")
    p.add_argument("--no-auxiliary", action="store_true",
                   help="photos only: no water sample, no Secchi depth")
    p.add_argument("--camera-only", action="store_true",
                   help="the camera's own limit: photon and read noise only, nothing else "
                        "uncertain (the same as --exact; not what a real dive gets)")
    p.add_argument("--lux", type=float, default=20000.0,
                   help="surface illuminance, lx (default 20000)")
    p.add_argument("--exposure", default="capped", choices=["capped", "iset"],
                   help="auto-exposure model (default capped at 1/30 s)")
    p.add_argument("--gain", default="free", choices=["known", "free", "channels"],
                   help="a single photo's exposure: unknown (default: a photograph), known, or "
                        "unknown per channel (uncalibrated camera); a dive's photos each have "
                        "their own unknown exposure")
    p.add_argument("--plan", default=None, metavar="CSV",
                   help="write the protocol's photos as a dive's metadata CSV (image, depth_m, "
                        "distance_m; the image names are placeholders to replace with the "
                        "photos' file names) for uw3p measure --metadata; an existing file is "
                        "refused unless --overwrite")
    p.add_argument("--overwrite", action="store_true",
                   help="let --plan replace an existing file")
    add_setup_options(p)
    add_budget_options(p)
    p.set_defaults(func=run, option_names={"chl": "--chl", "cdom": "--cdom",
                                           "depth": "--depth", "distance": "--distance",
                                           "max_photos": "--max-photos",
                                           "sample_sd": "--sample-sd",
                                           "minutes": "--reference-shot",
                                           "secchi_sd": "--secchi-sd", "targets": "--target",
                                           "plan": "--plan"})
    return p


def parse_target(text: str) -> tuple:
    """One ``--target`` as (name, relative half-width).

    Parameters
    ----------
    text : str
        ``NAME=PCT``, e.g. ``C=30%`` or ``a_CDOM=10`` (per cent, the sign optional).

    Returns
    -------
    tuple
        (a name of :data:`sca.protocols.TARGETS`, fraction).

    Raises
    ------
    ValueError
        Naming ``--target`` for a malformed entry, an unknown name or a value not > 0.
    """
    name, sep, value = text.partition("=")
    key = name.strip()
    if not sep or not key:
        raise InputError("--target", f"expected NAME=PCT such as C=30%, got {text!r}")
    key = {"C": "chl", "c": "c"}.get(key, key.lower())  # C is chlorophyll, c attenuation
    if key not in TARGET_NAMES and key not in LABELS:
        raise InputError("--target", f"unknown name {name.strip()!r}; choose from C, a_CDOM, c, "
                         "c443, c490, c555, c670, a_nw440 (K_d(490) is not published: "
                         "decision 0067-kd-not-published)")
    try:
        pct = float(value.strip().rstrip("%").strip())
    except ValueError:
        raise InputError("--target", f"{name.strip()}'s value must be a percentage like 30%, "
                         f"got {value!r}") from None
    if not (math.isfinite(pct) and pct > 0):
        raise InputError("--target", f"{name.strip()}'s value must be > 0 %, got {value!r}")
    return TARGET_NAMES.get(key, key), pct / 100.0


def _pm(rel):
    """A relative 95 % half-width in words: '±12 %', 'more than ±1000 %', 'not bounded'."""
    if not math.isfinite(rel):
        return "not bounded"
    if rel > SAY_MAX:
        return f"more than ±{100 * SAY_MAX:.0f} %"
    return f"±{100 * rel:.0f} %" if rel >= 0.095 else f"±{100 * rel:.2g} %"


def _gives(pred, targets) -> str:
    """'C ±21 %, a_CDOM(440) ±5 %, c (443-670 nm) ±4 %': the targets first, then C, a_CDOM and
    c if not targets."""
    names = list(targets) + [k for k in ("chl", "cdom", "c") if k not in targets]
    return ", ".join(f"{LABELS[k]} {_pm(pred.rel95[k])}" for k in names)


def _span(pred) -> str:
    if len(pred.span) < 2:
        return ""
    return (" (the intervals span the path models " + " and ".join(pred.span) +
            ": the photos cannot tell them apart; the bound alone: "
            f"C {_pm(pred.bound_rel95['chl'])})")


def _minutes(value):
    """The minutes of ``--reference-shot [MINUTES]`` (None: the default)."""
    return None if value is None or math.isnan(value) else value


def _with_and_without(d, targets) -> list:
    """What the reference shot buys: the design's protocol (or best) and the one photo's
    prediction, with the shot and without it, side by side."""
    w = d.without_reference
    day = d.uncertain.get("daylight", {})
    out = [f"reference shot   the daylight measured at the site: prior +-"
           f"{day.get('sd', float('nan')):.1f} mired ({day.get('minutes', float('nan')):g} min "
           f"from the dive) in place of +-{float(w.uncertain.get('daylight', 0.0)):g}"]
    for name, x in (("  with it", d), ("  without it", w)):
        p = x.protocol if x.meets else x.best
        out.append(f"{name:<17}{p.protocol.describe()}: {_gives(p, targets)}"
                   f"{'' if x.meets else ' (best; no protocol meets the targets)'}; one photo "
                   f"{_gives(x.one_photo, targets)}")
    return out


def _aux_text(d) -> str:
    return (f"a water sample's a_CDOM(440) sd {d.auxiliary_sd['sample']:.3g} m^-1, "
            f"a Secchi depth sd {d.auxiliary_sd['secchi']:.2g} m")


def follow(protocol, auxiliary_sd: dict, plan: str | None = None, reference=False) -> list:
    """How to follow a protocol: what to do on the dive and the ``uw3p measure`` command that
    measures it as the design predicted (the joint fit of a dive with the auxiliary
    measurement fused).

    Parameters
    ----------
    protocol : sca.protocols.Protocol
        The protocol to follow.
    auxiliary_sd : dict
        'sample' (m^-1) and 'secchi' (m): the sds the design assumed (:class:`sca.Design`).
    plan : str, optional
        The metadata CSV's name in the command (default ``dive.csv``).
    reference : False, None or float, optional
        With a reference shot: its minutes from the dive (None: the default); False: none.

    Returns
    -------
    list of str
        Output lines ('follow it ...'); the command's placeholders (DIVE/, PHOTO.dng, A, Z)
        are explained on the last line.
    """
    import shlex

    photos = ", ".join(f"{d:g} m from {r:g} m" for d, r in protocol.photos)
    todo = [f"photograph the chart at {photos}"]
    opts, said = "", []
    if "sample" in protocol.auxiliary:
        sd = auxiliary_sd["sample"]
        todo.append(f"measure a water sample's a_CDOM(440) (sd {sd:.2g} m^-1 or better)")
        opts += f" --cdom-sample A:{sd:.2g}"
        said.append("A the sample's a_CDOM(440) in m^-1")
    if "secchi" in protocol.auxiliary:
        sd = auxiliary_sd["secchi"]
        todo.append(f"read a Secchi depth (sd {sd:.2g} m or better)")
        opts += f" --secchi Z:{sd:.2g}"
        said.append("Z the Secchi depth in m")
    if reference is not False:
        from sca.reference import REFERENCE_MINUTES

        t = REFERENCE_MINUTES if reference is None else reference
        todo.append(f"photograph the chart in air at the site, under the dive's sky, {t:g} min "
                    "from the dive (a second one on the other side of the dive is checked "
                    "against it)")
        opts += f" --reference AIR.dng:{t:g}"
        said.append("AIR.dng the reference shot")
    if protocol.n_photos == 1:
        (d, r), = protocol.photos
        cmd = (f"uw3p measure PHOTO.dng --profile profile.json --depth {d:g} --distance {r:g}"
               f"{opts} --out results/")
        said.insert(0, "PHOTO.dng the photo")
    else:
        cmd = (f"uw3p measure DIVE/ --metadata {shlex.quote(plan or 'dive.csv')} "
               f"--profile profile.json --joint{opts} --out results/")
        said.insert(0, f"DIVE/ the photos' folder, {plan or 'dive.csv'} one row per photo: "
                       f"{','.join(PLAN_COLUMNS)}" + ("" if plan else " (--plan writes it)"))
    return [f"follow it        on the dive: {'; '.join(todo)}",
            f"  then           {cmd}",
            f"  where          {'; '.join(said)}; profile.json from uw3p calibrate"]


def write_plan(path: str, protocol) -> int:
    """Write ``protocol``'s photos as a dive's metadata CSV (:data:`PLAN_COLUMNS`; the image
    names PHOTO_01.dng, ... are placeholders for the photos' file names), whole or not at all.

    Parameters
    ----------
    path : str
        The CSV file to write (replaced if it exists: :func:`run` refuses that without
        ``--overwrite``).
    protocol : sca.protocols.Protocol

    Returns
    -------
    int
        The number of rows (photos) written.

    Raises
    ------
    forward.errors.InputError
        Naming ``--plan`` when the file cannot be written.
    """
    import csv

    from .common import write_atomic

    def rows(fh):
        w = csv.writer(fh)
        w.writerow(PLAN_COLUMNS)
        for i, (d, r) in enumerate(protocol.photos, 1):
            w.writerow([f"PHOTO_{i:02d}.dng", f"{d:g}", f"{r:g}"])
    write_atomic(path, rows, "--plan")
    return len(protocol.photos)


def daylight_depth(chl, cdom, water, wavelengths=None) -> float:
    """The depth at which the downwelling daylight at the most penetrating wavelength falls to
    :data:`DAYLIGHT_FLOOR` of the surface's: ln(1 / floor) / min K_d, K_d = (a + b_b) / mu_d
    of the guessed water (whatever the path model: daylight goes down diffusely).

    Parameters
    ----------
    chl, cdom : float
        The guessed water, mg m^-3 and m^-1.
    water : forward.Water
    wavelengths : array_like, optional
        nm (default 400-700 nm).

    Returns
    -------
    float
        m.
    """
    from forward.spectra import wavelength_grid
    from forward.water import DIFFUSE_TERMS

    kd = water.on_grid(wavelength_grid(wavelengths)).path_coefficient(
        chl, cdom, terms=DIFFUSE_TERMS)[0]
    return math.log(1.0 / DAYLIGHT_FLOOR) / float(kd.min())


def check_dive(args, water, wavelengths) -> None:
    """Refuse what the design cannot answer, before its work: a ``--distance`` not > 0, a
    ``--depth`` beyond :func:`daylight_depth`, an existing ``--plan`` without ``--overwrite``.

    Raises
    ------
    forward.errors.InputError
        Naming ``--distance``, ``--depth`` or ``--plan``.
    """
    from pathlib import Path

    if not all(r > 0 for r in args.distance):
        raise InputError("--distance", "the camera-to-chart distance must be > 0 m (the light "
                         f"must cross water to the chart), got {' '.join(map(str, args.distance))}")
    if args.cdom >= 0 and all(math.isfinite(d) for d in args.depth):
        reach = daylight_depth(args.chl, args.cdom, water, wavelengths)
        if max(args.depth) > reach:
            raise InputError("--depth", f"{max(args.depth):g} m is beyond daylight's reach in "
                             f"the guessed water: below {reach:.0f} m under "
                             f"{100 * DAYLIGHT_FLOOR:g} % of the surface light is left at any "
                             "wavelength (decision 0064-daylight-reach); give depths up to "
                             f"{reach:.0f} m")
    if args.plan and Path(args.plan).exists() and not args.overwrite:
        raise InputError("--plan", f"{args.plan} exists (a dive's metadata?); give a new file "
                         "name, or --overwrite to replace it")


def run(args, out, err) -> int:
    """Say which protocol reaches the targets, what one photo gives, and what limits it.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options: ``chl`` (mg m^-3), ``cdom`` (m^-1), ``depth`` and ``distance`` (one or
        two values, m), ``target`` (``NAME=PCT`` strings), ``max_photos``, ``sample_sd``,
        ``secchi_sd``, ``no_auxiliary``, ``camera_only``, ``plan`` (a CSV path or None),
        ``overwrite``,
        ``lux``, ``exposure``, ``gain`` and the setup and budget options.
    out : text stream
        The budget, the targets, what one photo gives, the protocol (or the best one and its
        limit), the camera's own limit for contrast, a verdict and, where a protocol meets the
        targets, how to follow it (:func:`follow`).
    err : text stream
        A note when the camera's curves stop inside the grid.

    Returns
    -------
    int
        ``EXIT_OK`` when a protocol meets every target, else ``EXIT_NOT_RELIABLE``.

    Raises
    ------
    ValueError
        Bad input (``--chl`` not > 0, ``--lux`` not > 0, a malformed ``--target``, three
        depths, :func:`check_dive`'s refusals, ...); the message names the option.
    """
    import forward
    from sca import design
    from sca.protocols import AUXILIARY_OPTIONS, SAMPLE_SD

    for opt, values in (("--depth", args.depth), ("--distance", args.distance)):
        if len(values) > 2:
            raise InputError(opt, f"give one value or two (m), got {len(values)}")
    if not args.chl > 0:
        raise InputError("--chl", f"must be > 0 (the precision is relative to C; give the "
                         f"smallest C you need to measure), got {args.chl:g}")
    targets = dict(parse_target(t) for t in (args.target or [DEFAULT_TARGET]))
    check_spectra_args(args)
    sensor = forward.SensorSettings(illuminance_lux=args.lux, exposure_mode=args.exposure)
    wl = wavelengths_from_args(args)
    water = water_from_args(args)
    check_dive(args, water, wl)
    err.write(camera_note(args.camera, wl))
    uncertain = {} if args.camera_only else uncertain_from_args(args)
    kw = dict(camera=args.camera, illuminant=args.illuminant, reflectances=args.reflectances,
              wavelengths=wl, water=water, sensor=sensor)
    depth = args.depth[0] if len(args.depth) == 1 else tuple(args.depth)
    distance = args.distance[0] if len(args.distance) == 1 else tuple(args.distance)
    d = design(args.chl, args.cdom, depth=depth, distance=distance, targets=targets,
               max_photos=args.max_photos,
               auxiliary=("none",) if args.no_auxiliary else AUXILIARY_OPTIONS,
               sample_sd=SAMPLE_SD if args.sample_sd is None else args.sample_sd,
               secchi_sd=args.secchi_sd, gain=args.gain, uncertain=uncertain,
               reference_shot=args.reference_shot is not None,
               reference_minutes=_minutes(args.reference_shot), **kw)
    lo, hi = d.depth_range
    depths = f"{lo:g} m" if lo == hi else f"{lo:g}-{hi:g} m"
    gains = {"known": "one photo's exposure known", "free": "each photo's exposure unknown",
             "channels": "one photo's exposure and channel balance unknown"}
    lines = [f"water guessed    C = {args.chl:g} mg m^-3, a_CDOM(440) = {args.cdom:g} m^-1",
             f"dive             depths {depths}, distances "
             + ", ".join(f"{r:g}" for r in d.distances) + f" m; camera {args.camera}, "
             f"{args.lux:g} lx at the surface; {gains[args.gain]}",
             "budget           " + ("camera only: photon and read noise, nothing else "
                                    "uncertain (--camera-only; a real dive does worse)"
                                    if d.camera_only else
                                    "the default uncertainty budget" +
                                    (" (as changed by the options)" if uncertain != _default()
                                     else "")),
             "target           " + ", ".join(f"{LABELS[k]} ±{100 * v:g} %"
                                             for k, v in targets.items()) + " (95 %)"]
    if hi + max(d.distances) == 0:
        lines.append("the light crosses no water (depth and distance 0): the chart cannot "
                     "tell anything about the water")
    one = d.one_photo
    depth1, dist1 = one.protocol.photos[0]
    lines.append(f"one photo        at {depth1:g} m from {dist1:g} m: {_gives(one, targets)}"
                 + _span(one))
    single = d.one_photo_budget
    if single is not None and single.budget:
        shares = budget_text(single.budget, "chl")
        lines.append(f"budget of C      {shares} of the variance; {single.limiting} limits the "
                     "instrument here" if shares and math.isfinite(single.chl_sd) else
                     "budget of C      not defined: C is not bounded here")
    if not d.camera_only:
        from sca import precision

        alone = precision(args.chl, args.cdom, depth=depth1, distance=dist1, gain=args.gain,
                          uncertain={}, **kw)
        lines.append(f"the camera alone (photon and read noise only, --camera-only): one photo, "
                     f"C {_pm(float(alone.chl_rel95))}")
    searched = (f"{d.bounds} bounds over up to {args.max_photos} photos, "
                + ("photos only" if args.no_auxiliary else _aux_text(d)))
    if d.meets:
        p = d.protocol
        lines += [f"protocol         {p.protocol.describe()}",
                  f"  predicted      {_gives(p, targets)}{_span(p)}"]
        lines.append("verdict          " + (
            f"{p.protocol.describe()} reaches "
            + ", ".join(f"{LABELS[k]} {_pm(p.rel95[k])}" for k in targets)
            + " at 95 %: a reliable measurement is possible; the cheapest protocol of those "
            f"searched ({searched})."))
        lines += follow(p.protocol, d.auxiliary_sd, args.plan,
                        _minutes(args.reference_shot) if d.reference_shot else False)
        if d.camera_only:
            lines.append("  note           a camera-only design: uw3p measure fits with the "
                         "default budget, whose intervals are wider than predicted here")
    else:
        b = d.best
        lines += [f"best protocol    {b.protocol.describe()}",
                  f"  predicted      {_gives(b, targets)}{_span(b)}"]
        worst = max(targets, key=lambda k: b.rel95[k] / targets[k])
        if d.limiting == "no water":
            why = "the light crosses no water"
        elif d.limiting == "path model":
            why = ("limited by the path model: the photos cannot tell beam attenuation from "
                   "absorption, and the estimate's interval spans both")
        elif d.limiting == "noise":
            why = "limited by the camera's noise: move closer, shoot shallower or in brighter light"
        elif math.isfinite(d.without_limiting):
            why = (f"limited by {d.limiting} (known exactly: {LABELS[worst]} "
                   f"{_pm(d.without_limiting)})")
        else:
            why = f"limited by {d.limiting}"
        lines.append(f"verdict          {LABELS[worst]} cannot be measured to "
                     f"±{100 * targets[worst]:g} % here: no protocol searched ({searched}) "
                     f"meets every target; the best gives {LABELS[worst]} {_pm(b.rel95[worst])}, "
                     f"{why}.")
    shown = d.protocol if d.meets else d.best
    if d.reference_shot:
        lines += _with_and_without(d, targets)
    if args.plan:
        n = write_plan(args.plan, shown.protocol)
        lines.append(f"plan             wrote {args.plan}: {n} row(s), the "
                     f"{'' if d.meets else 'best '}protocol's photos as the metadata CSV "
                     "(replace the placeholder image names)")
    out.write("\n".join(lines) + "\n")
    return EXIT_OK if d.meets else EXIT_NOT_RELIABLE


def _default() -> dict:
    from sca.budget_defaults import DEFAULT_UNCERTAIN

    return dict(DEFAULT_UNCERTAIN)
