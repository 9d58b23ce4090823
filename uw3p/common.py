"""What the ``uw3p`` subcommands share: exit codes, common options and output helpers.

Each subcommand lives in its own module (``cmd_<name>.py``) and imports from here. This module
imports nothing heavy at load time (numpy, ``forward`` and ``measure`` are imported inside the
functions that need them), so that ``uw3p --help`` stays cheap.
"""

from __future__ import annotations

import json
from pathlib import Path

from forward import files
from forward.errors import InputError

__all__ = [
    "EXIT_OK", "EXIT_NOT_RELIABLE", "EXIT_BAD_INPUT", "EXIT_INTERRUPTED",
    "add_setup_options", "add_water_options", "add_photo_options", "add_budget_options",
    "add_auxiliary_options", "add_chart_option", "auxiliary_from_args", "chart_from_args",
    "uncertain_from_args", "budget_text", "check_spectra_args", "camera_note",
    "wavelengths_from_args", "water_from_args", "setup_kwargs", "read_photo",
    "write_file", "write_atomic", "atomic_open", "json_text", "option_message", "plain",
    "replication_root",
]

#: Exit status: success (every estimate reliable / converged).
EXIT_OK = 0
#: Exit status: an estimate is not reliable or did not converge (its flags say why).
EXIT_NOT_RELIABLE = 1
#: Exit status: bad input; the message names the argument or file.
EXIT_BAD_INPUT = 2
#: Exit status: interrupted (Ctrl-C).
EXIT_INTERRUPTED = 130

#: Wavelength step (nm) used when ``--wl-min``/``--wl-max`` are given without ``--step``.
#: Without any of the three the package's own grid is used (400-700 nm at 1 nm,
#: ``forward.spectra.DEFAULT_STEP_NM``).
_RANGE_STEP_NM = 10.0


#: Why ``uw3p figures`` and ``uw3p bench`` refuse to run from the installed package.
_NOT_INSTALLED = ("not installed: uw3p {} runs from the repository (a checkout of uw3p: git "
                  "clone, then pip install -e '.[test]'), not from the installed package, which "
                  "does not ship experiments/ (decision 0082-installed-packages)")


def replication_root(command: str) -> Path:
    """The checkout holding ``experiments/`` (the replication side), importable once this returns.

    ``uw3p figures`` and ``uw3p bench`` run its scripts; the wheel ships only ``forward``,
    ``sca``, ``measure``, ``uw3p`` and ``uw3p_data`` (decision 0082-installed-packages). An
    editable install maps only those, so the checkout beside this package is put on
    ``sys.path`` when ``experiments`` is not already importable.

    Parameters
    ----------
    command : str
        The subcommand (named in the error).

    Returns
    -------
    pathlib.Path
        The folder that holds ``experiments/``.

    Raises
    ------
    forward.InputError
        Naming ``experiments`` when no checkout holds it (an installed wheel).
    """
    import importlib.util
    import sys

    spec = importlib.util.find_spec("experiments")
    if spec is not None and spec.origin:
        return Path(spec.origin).resolve().parents[1]
    root = Path(__file__).resolve().parents[1]
    if not (root / "experiments" / "__init__.py").is_file():
        raise InputError("experiments", _NOT_INSTALLED.format(command))
    sys.path.insert(0, str(root))
    return root


# --------------------------------------------------------------------------- options
def add_setup_options(p) -> None:
    """Add the camera, illuminant, chart, wavelength-grid and water options.

    Used by the commands that run the model on a chart (``simulate``, ``estimate``, ``design``).

    Parameters
    ----------
    p : argparse.ArgumentParser
        The subcommand's parser; options ``--camera``, ``--illuminant``, ``--reflectances``,
        ``--step``, ``--wl-min``, ``--wl-max`` and those of :func:`add_water_options` are added.

    Returns
    -------
    None
    """
    p.add_argument("--camera", default="Nikon 5100 (NPL)",
                   help="colour-science camera name or CSV file (default: %(default)s)")
    p.add_argument("--illuminant", default=None, help="colour-science illuminant name or CSV (default D65)")
    p.add_argument("--reflectances", default=None, help="chart name or CSV (default BabelColor Average)")
    p.add_argument("--step", type=float, default=None,
                   help="wavelength step in nm (default 1: the package grid, 400-700 nm; 10 when "
                        "--wl-min or --wl-max is given)")
    p.add_argument("--wl-min", type=float, default=400.0, help="first wavelength, nm (default 400)")
    p.add_argument("--wl-max", type=float, default=700.0, help="last wavelength, nm (default 700)")
    add_water_options(p)


def add_water_options(p) -> None:
    """Add the water-model options (fields of ``forward.Water``; defaults: the paper's).

    Parameters
    ----------
    p : argparse.ArgumentParser
        The subcommand's parser; an argument group with ``--path-model``, ``--cdom-slope``
        (nm^-1), ``--nap-slope`` (nm^-1) and ``--b-k`` (m^-1) is added.

    Returns
    -------
    None
    """
    g = p.add_argument_group("water model (forward.Water; defaults: the paper's)")
    g.add_argument("--path-model", default="beam", choices=["beam", "absorption", "split"],
                   help="the water's own path model: k = exp(-L c) (beam, default), exp(-L a) "
                        "(eq 13 as printed) or exp(-depth Kd - distance c) (split); with the "
                        "uncertainty budget every one is fitted and the data decide (or the "
                        "intervals span them)")
    g.add_argument("--cdom-slope", type=float, default=None, help="eq 6 slope, nm^-1 (0.014)")
    g.add_argument("--nap-slope", type=float, default=None, help="eq 7 slope, nm^-1 (0.011)")
    g.add_argument("--b-k", type=float, default=None, help="Table 1 b_k at 470 nm, m^-1 (0.00068)")


def add_budget_options(p) -> None:
    """Add the uncertainty-budget options (:mod:`sca.budget`): ``--depth-sd``,
    ``--distance-sd``, ``--uncertain NAME=SD`` (repeatable) and ``--exact``.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The subcommand's parser.
    """
    # plain data: no numpy at start-up
    from sca.budget_defaults import DEFAULT_UNCERTAIN

    def pct(v):  # argparse expands help with %: a percentage's sign is written %%
        return str(v).replace("%", "%%")

    defaults = ", ".join(f"{k}={pct(v)}" for k, v in DEFAULT_UNCERTAIN.items())
    p.add_argument("--depth-sd", default=None, metavar="SD",
                   help=f"standard deviation of --depth, m or a percentage like 2%% (default "
                        f"{pct(DEFAULT_UNCERTAIN['depth'])} m)")
    p.add_argument("--distance-sd", default=None, metavar="SD",
                   help=f"standard deviation of --distance, m or a percentage (default "
                        f"{pct(DEFAULT_UNCERTAIN['distance'])})")
    p.add_argument("--uncertain", action="append", default=[], metavar="NAME=SD",
                   help="one more entry of the uncertainty budget, e.g. cdom_slope=0.002, "
                        "balance=0.005 (relative, per channel) or patch=0.005 (relative, per "
                        f"patch); repeatable. The default budget: {defaults}")
    p.add_argument("--exact", action="store_true",
                   help="the paper's exact model: nothing uncertain but the sensor noise "
                        "(entries given with the options above are still applied)")


def add_auxiliary_options(p, folder: bool = False) -> None:
    """Add the options of what was measured of the water besides the photos
    (:mod:`sca.auxiliary`): ``--cdom-sample VALUE:SD``, ``--secchi DEPTH:SD`` and
    ``--kd NM=VALUE:SD`` (repeatable).

    Parameters
    ----------
    p : argparse.ArgumentParser
        The subcommand's parser.
    folder : bool, optional
        The command also measures folders (``measure``): the help says the options are the
        photos' defaults there.
    """
    g = p.add_argument_group(
        "measurements of the water besides the photos",
        "Each with its standard deviation, fused in the fit (sca.auxiliary)."
        + (" For a folder: the default of every photo whose metadata row has none; the joint "
           "fit counts each reading once." if folder else ""))
    g.add_argument("--cdom-sample", default=None, metavar="VALUE:SD",
                   help="a_CDOM(440) of a water sample and its sd, m^-1 (e.g. 0.12:0.02): it "
                        "separates C from CDOM")
    g.add_argument("--secchi", default=None, metavar="DEPTH:SD",
                   help="a Secchi-disk depth and its sd, m (e.g. 8:0.5), through z = 8.7 / "
                        "(c + K_d) at 555 nm with 20 %% scatter (Tyler 1968; Preisendorfer 1986)")
    g.add_argument("--kd", action="append", default=[], metavar="NM=VALUE:SD",
                   help="a radiometer's K_d at a band and its sd, m^-1 (e.g. 490=0.12:0.01; "
                        "400-700 nm; the model's own 15 %% error added); repeatable")


def auxiliary_from_args(args) -> dict:
    """The ``auxiliary=`` dict of the options of :func:`add_auxiliary_options`.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options (``cdom_sample``, ``secchi``, ``kd``).

    Returns
    -------
    dict
        :mod:`sca.auxiliary`'s form ({} when none is given).

    Raises
    ------
    ValueError
        Naming the option: a malformed value, a value or sd not > 0, a band outside
        400-700 nm or given twice.
    """
    from measure.auxiliary import parse_kd, parse_pair

    out = {}
    if getattr(args, "cdom_sample", None) is not None:
        out["cdom"] = parse_pair("--cdom-sample", args.cdom_sample)
    if getattr(args, "secchi", None) is not None:
        out["secchi"] = parse_pair("--secchi", args.secchi, "DEPTH:SD")
    for item in getattr(args, "kd", None) or []:
        band, pair = parse_kd("--kd", item)
        if band in out.get("kd", {}):
            raise InputError("--kd", f"the band {band:g} nm is given twice")
        out.setdefault("kd", {})[band] = pair
    return out


def add_chart_option(p) -> None:
    """Add ``--chart-reflectance FILE``: the chart's own spectra measured with a spectrometer.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The subcommand's parser (``calibrate``, ``measure``).
    """
    from sca.budget_defaults import MEASURED_CHART_PATCH

    p.add_argument("--chart-reflectance", default=None, metavar="FILE",
                   help="your chart's reflectance spectra measured with a spectrometer: a CSV "
                        "of wavelength (nm) then 24 columns of reflectance factor (0-1) in "
                        "ColorChecker order (patch 1 dark skin ... 24 black), covering "
                        "400-700 nm; it replaces the nominal chart, and the default budget's "
                        f"per-patch term falls from 1 %% to {100 * MEASURED_CHART_PATCH:g} %% "
                        "(a profile's measured term still applies)")


def chart_from_args(args):
    """The ``--chart-reflectance`` file, checked (None without it).

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options (``chart_reflectance``).

    Returns
    -------
    str or None
        The file's path.

    Raises
    ------
    ValueError
        Naming ``--chart-reflectance``: a missing or malformed file
        (:func:`measure.camera.read_chart_reflectance`).
    """
    path = getattr(args, "chart_reflectance", None)
    if path is None:
        return None
    from measure.camera import read_chart_reflectance

    read_chart_reflectance(path, name="--chart-reflectance")
    return path


def uncertain_from_args(args) -> dict:
    """The ``uncertain=`` dict asked for by the options of :func:`add_budget_options`.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options (``exact``, ``depth_sd``, ``distance_sd``, ``uncertain``).

    Returns
    -------
    dict
        name -> sd (floats, or percentage strings for the lengths).

    Raises
    ------
    ValueError
        For a malformed ``--uncertain`` entry (the message names the option).
    """
    from sca.budget import DEFAULT_UNCERTAIN, NUISANCE, SYSTEMATIC

    out = {} if args.exact else dict(DEFAULT_UNCERTAIN)
    for opt, name in (("depth_sd", "depth"), ("distance_sd", "distance")):
        value = getattr(args, opt)
        if value is not None:
            out[name] = value if str(value).strip().endswith("%") else _float(f"--{opt.replace('_', '-')}", value)
    for item in args.uncertain:
        name, sep, value = item.partition("=")
        name = name.strip()
        if not sep or not name:
            raise InputError("--uncertain", f"expected NAME=SD, got {item!r}")
        if name not in NUISANCE + SYSTEMATIC:
            raise InputError("--uncertain", f"unknown name {name!r}; choose from "
                             f"{', '.join(NUISANCE + SYSTEMATIC)}")
        value = value.strip()
        out[name] = value if value.endswith("%") else _float(f"--uncertain {name}", value)
    return out


def _float(option, value) -> float:
    try:
        return float(value)
    except ValueError:
        raise InputError(option, f"expected a number, got {value!r}") from None


def budget_text(budget: dict, name: str = "chl") -> str:
    """One line: each source's share of the variance of ``name``, largest first.

    Parameters
    ----------
    budget : dict
        ``Estimate.budget`` or ``Precision.budget`` (floats).
    name : str
        'chl' or 'cdom'.

    Returns
    -------
    str
        E.g. ``"patch 46 %, cdom_slope 43 %, depth 7 %"``; '' without a budget.
    """
    shares = budget.get(name, {}).get("shares", {})
    parts = sorted(shares.items(), key=lambda kv: -kv[1])
    return ", ".join(f"{k} {100 * v:.0f} %" for k, v in parts if v >= 0.005)


def add_photo_options(p) -> None:
    """Add the options of the commands that read a photograph (``calibrate``, ``measure``).

    Parameters
    ----------
    p : argparse.ArgumentParser
        The subcommand's parser; ``--camera``, ``--quantal``, ``--corners`` (pixels; optional),
        ``--layout``, ``--illuminant``, ``--black-level`` and ``--white-level`` (raw units) are
        added.

    Returns
    -------
    None
    """
    p.add_argument("--camera", default="Nikon 5100 (NPL)",
                   help="colour-science camera name or CSV (wavelength,red,green,blue)")
    p.add_argument("--quantal", action="store_true",
                   help="the camera curves act on photons (quantum efficiency): convert to energy")
    p.add_argument("--corners", default=None,
                   help='the chart\'s outer corners in pixels, "x1,y1 x2,y2 x3,y3 x4,y4": next to '
                        "patch 1 (dark skin), patch 6 (bluish green), patch 24 (black), patch 19 "
                        "(white); default: the chart is found in the photo (this overrides it)")
    p.add_argument("--layout", default="patches", choices=["patches", "card"],
                   help="the corners are those of the patch grid (default) or of the whole card")
    p.add_argument("--illuminant", default=None, help="surface illuminant name or CSV (default D65)")
    p.add_argument("--black-level", type=float, default=None, help="override the file's, raw units")
    p.add_argument("--white-level", type=float, default=None, help="override the file's, raw units")


# --------------------------------------------------------------------------- option values
def check_spectra_args(args) -> None:
    """Refuse a ``--camera``, ``--illuminant``, ``--reflectances`` or ``--profile`` that names a
    folder or a missing file, before a library call reports it as an unknown name.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options; those absent or None are skipped.

    Raises
    ------
    ValueError
        Naming the option: the path is a folder, or a ``.csv``/``.txt``/``.json`` path that
        does not exist.
    """
    for opt in ("camera", "illuminant", "reflectances", "profile"):
        value = getattr(args, opt, None)
        if value is None:
            continue
        p = Path(value)
        if p.is_dir():
            raise InputError(f"--{opt}", f"{p} is a folder, not a file")
        if (opt == "profile" or str(value).lower().endswith((".csv", ".txt", ".json"))) \
                and not p.exists():
            raise InputError(f"--{opt}", f"file not found: {p}")


def camera_note(camera, wavelengths=None) -> str:
    """A note for the user when the camera's curves stop inside the wavelength grid (taken as
    0 beyond their data: :data:`forward.spectra.TAIL_FRACTION`); '' otherwise.

    Parameters
    ----------
    camera : str
        ``--camera``: a colour-science name or a CSV file.
    wavelengths : array_like, optional
        The grid in nm (default 400-700 nm).

    Returns
    -------
    str
        E.g. "note: camera 'Sigma SDMerill (NPL)': its curves stop at 680 nm (at under 2 % of
        their peak); taken as 0 from there to 700 nm\n".
    """
    import numpy as np

    from forward.spectra import (
        TAIL_FRACTION,
        camera_sensitivities,
        colour_wavelength_range,
        is_path,
        read_spectral_csv,
        wavelength_grid,
    )

    try:
        camera_sensitivities(camera, wavelengths)  # refused: the error says it, not a note
        if is_path(camera):
            src, _ = read_spectral_csv(camera, name="camera")
        else:  # no colour-science import for a cached camera
            src = np.asarray(colour_wavelength_range("MSDS_CAMERA_SENSITIVITIES", camera))
        wl = wavelength_grid(wavelengths)
    except (KeyError, ValueError):
        return ""  # the library call that follows reports it
    parts = []
    if wl[0] < src[0]:
        parts.append(f"from {wl[0]:g} nm to {src[0]:g} nm")
    if wl[-1] > src[-1]:
        parts.append(f"from {src[-1]:g} nm to {wl[-1]:g} nm")
    if not parts:
        return ""
    return (f"note: camera {camera!r}: its curves cover {src[0]:g}-{src[-1]:g} nm; taken as 0 "
            f"{' and '.join(parts)} (where they stop they are under "
            f"{100 * TAIL_FRACTION:g} % of their peak)\n")


def wavelengths_from_args(args):
    """The wavelength grid asked for by ``--step``, ``--wl-min`` and ``--wl-max``.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options of :func:`add_setup_options`.

    Returns
    -------
    numpy.ndarray or None
        Wavelengths in nm from ``--wl-min`` to ``--wl-max`` (inclusive) in steps of ``--step``
        (10 nm when only the range is given), or None -- the package's default grid, 400-700 nm
        at 1 nm -- when none of the three options is given.

    Raises
    ------
    ValueError
        ``--step`` is not positive.
    """
    if args.step is None and args.wl_min == 400.0 and args.wl_max == 700.0:
        return None
    import numpy as np

    step = _RANGE_STEP_NM if args.step is None else args.step
    if not step > 0:
        raise InputError("--step", f"must be > 0, got {step}")
    return np.arange(args.wl_min, args.wl_max + step / 2, step)


def water_from_args(args):
    """The water model asked for by the options of :func:`add_water_options`.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options: ``path_model``, and ``cdom_slope``, ``nap_slope``, ``b_k`` (None: the
        paper's value).

    Returns
    -------
    forward.Water

    Raises
    ------
    ValueError
        A value ``forward.Water`` refuses; the message names the option (``--b-k: ...``).
    """
    import forward

    kw = {"path_model": args.path_model}
    for opt, key in (("cdom_slope", "cdom_slope"), ("nap_slope", "nap_slope"), ("b_k", "b_k")):
        if getattr(args, opt) is not None:
            kw[key] = getattr(args, opt)
    for opt in ("cdom_slope", "nap_slope"):  # eqs 6, 7: absorption falls with wavelength
        value = getattr(args, opt)
        if value is not None and not value > 0:
            raise InputError(f"--{opt.replace('_', '-')}", f"must be > 0 nm^-1 (the absorption "
                             f"falls with wavelength, eqs 6-7), got {value:g}")
    try:
        return forward.Water(**kw)
    except ValueError as exc:
        if getattr(exc, "argument", None) is None:
            raise
        raise InputError("--" + exc.argument.replace("_", "-"), exc.reason) from None


def setup_kwargs(args) -> dict:
    """Keyword arguments of the ``sca`` estimators for the options of :func:`add_setup_options`.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options of :func:`add_setup_options`.

    Returns
    -------
    dict
        ``camera``, ``illuminant``, ``reflectances``, ``wavelengths`` (nm, or None) and
        ``water`` (a ``forward.Water``).
    """
    return dict(camera=args.camera, illuminant=args.illuminant, reflectances=args.reflectances,
                wavelengths=wavelengths_from_args(args), water=water_from_args(args))


def read_photo(args, image):
    """Read a photograph with the black and white levels of ``--black-level``/``--white-level``.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options of :func:`add_photo_options`.
    image : str or pathlib.Path
        RAW (any LibRaw format) or linear 16-bit TIFF file.

    Returns
    -------
    measure.image.Photo
        What ``measure.read_image`` returns.
    """
    import measure

    return measure.read_image(image, black_level=args.black_level, white_level=args.white_level)


# --------------------------------------------------------------------------- output
def atomic_open(path, option: str = "--out"):
    """Open a file to be written whole or not at all: the ``with`` block writes a temporary
    file in the same folder, which replaces ``path`` when the block ends without an error (an
    error leaves ``path`` as it was and removes the temporary file).

    Parameters
    ----------
    path : str or pathlib.Path
        The file to write.
    option : str, optional
        The option named in error messages (default ``--out``).

    Returns
    -------
    context manager yielding a text stream
        UTF-8, newline '' (for the csv module): :func:`forward.files.atomic_open`.

    Raises
    ------
    ValueError
        The file cannot be written (a folder, a missing folder, no permission); the message
        names ``option`` and the reason.
    """
    p = Path(path)
    if p.is_dir():
        raise InputError(option, f"{p} is a folder; give a file name")
    if not p.parent.is_dir():
        raise InputError(option, f"cannot write {p}: its folder does not exist")
    return files.atomic_open(p, "w", option, encoding="utf-8", newline="")


def write_atomic(path, write, option: str = "--out") -> Path:
    """Write a file whole or not at all (:func:`atomic_open`): ``write(fh)`` fills it.

    Parameters
    ----------
    path : str or pathlib.Path
        The file to write.
    write : callable
        ``write(fh)`` writes the content to the text stream ``fh`` (UTF-8, newline '').
    option : str, optional
        The option named in error messages (default ``--out``).

    Returns
    -------
    pathlib.Path
        The file written.

    Raises
    ------
    ValueError
        The file cannot be written; the message names ``option`` and the reason.
    """
    with atomic_open(path, option) as fh:
        write(fh)
    return Path(path)


def write_file(path, text, err, option: str = "--out") -> None:
    """Write ``text`` to the ``--out`` file, whole or not at all, and say so on ``err``.

    Parameters
    ----------
    path : str or pathlib.Path
        The file to write (UTF-8).
    text : str
        Its content.
    err : text stream
        Where ``wrote <path>`` is reported.
    option : str, optional
        The option named in error messages (default ``--out``).

    Returns
    -------
    None

    Raises
    ------
    ValueError
        The file cannot be written; the message names the option and the reason.
    """
    p = write_atomic(path, lambda fh: fh.write(text), option)
    err.write(f"wrote {p}\n")


def json_text(obj) -> str:
    """Strict JSON text: an open interval end (inf) is written "inf", an untested value (NaN) null.

    Parameters
    ----------
    obj : object
        Anything ``measure.output.strict_json`` accepts (dicts, lists, numbers, numpy arrays).

    Returns
    -------
    str
        Indented JSON followed by a newline.
    """
    from measure.output import strict_json

    return json.dumps(strict_json(obj), indent=1, allow_nan=False) + "\n"


# --------------------------------------------------------------------------- messages
def plain(text: str) -> str:
    """Help text without reStructuredText markup (double backticks)."""
    return text.replace("``", "")


def option_message(message, options: dict, renames: dict | None = None) -> str:
    """A library's error said in the command's terms: the argument that is the destination of a
    command-line option becomes the option (``depth:`` -> ``--depth:``).

    Parameters
    ----------
    message : forward.InputError, ValueError or str
        The error: an :class:`forward.InputError` names its argument (``argument``); any other
        is said as it is (its text is not read for an argument).
    options : dict
        Option destination -> option string, e.g. {'depth': '--depth', 'max_iter':
        '--max-iter'}.
    renames : dict, optional
        Library argument names that are not option destinations -> what to call them, e.g.
        {'illuminance_lux': '--lux'}.

    Returns
    -------
    str
        The message, its leading argument renamed where one matches.
    """
    argument = getattr(message, "argument", None)
    if argument is None:  # not an input error: its text as it is
        return str(message)
    new = (renames or {}).get(argument) or options.get(argument)
    return f"{new}: {message.reason}" if new else str(message)
