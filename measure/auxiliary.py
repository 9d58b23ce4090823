"""What a user measured besides the photos, as the photos' fits take it (:mod:`sca.auxiliary`):
the command line's ``VALUE:SD`` texts, a dive's per-photo measurements over the run's defaults,
and one dive's several readings of one water combined for its joint fit.

The form every function here returns is :func:`sca.auxiliary.auxiliary_observations`'s:
``{'cdom': (value, sd), 'secchi': (depth_m, sd_m), 'kd': {nm: (value, sd)}}`` (m^-1, m, nm).

**Several readings of one water** (rows of a dive's metadata CSV, the run's default) enter the
dive's joint fit as one measurement per quantity (per band for K_d): their inverse-variance
weighted mean, with the sd of that mean, widened by the Birge ratio sqrt(chi^2 / (n - 1)) where
the readings disagree beyond their sds (the Particle Data Group's scale factor). Not one
observation per reading: the Secchi relation's and the K_d model's own scatter
(:data:`sca.auxiliary.SECCHI_GAMMA_REL`, :data:`sca.auxiliary.KD_MODEL_REL`) are the same for every
reading of one water and must not average down; :mod:`sca.auxiliary` adds them once, to the
combined reading. A reading is counted once however many photos used it (the run's default
enters every photo's fit that has no reading of its own, and the joint fit once).

References
----------
R. T. Birge, "The calculation of errors by the method of least squares", Phys. Rev. 40 (1932)
207-227; Particle Data Group, R. L. Workman et al., Prog. Theor. Exp. Phys. 2022, 083C01,
"Introduction: 5.2 Unconstrained averaging" (the scale factor S).
"""

from __future__ import annotations

import math
from forward.errors import InputError

__all__ = ["KINDS", "OPTIONS", "auxiliary_record", "combine_readings", "dive_auxiliary",
           "merge_auxiliary", "option_sources", "parse_kd", "parse_pair"]

#: The measurements, as :mod:`sca.auxiliary` names them.
KINDS = ("cdom", "secchi", "kd")
#: Each kind's command-line option and what its value means.
OPTIONS = {"cdom": ("--cdom-sample", "VALUE:SD", "m^-1"),
           "secchi": ("--secchi", "DEPTH:SD", "m"),
           "kd": ("--kd", "NM=VALUE:SD", "m^-1")}


def _positive(option, what, text) -> float:
    try:
        x = float(text)
    except (TypeError, ValueError):
        raise InputError(option, f"{what} is not a number: {text!r}") from None
    if not (math.isfinite(x) and x > 0):
        raise InputError(option, f"{what} must be finite and > 0, got {text!r}")
    return x


def parse_pair(option: str, text: str, form: str = "VALUE:SD") -> tuple:
    """A measurement and its standard deviation from ``VALUE:SD``.

    Parameters
    ----------
    option : str
        The option, named in errors (``--secchi``).
    text : str
        E.g. ``"4.5:0.5"``.
    form : str, optional
        How the value is written, for errors (``DEPTH:SD``).

    Returns
    -------
    tuple of float
        (value, sd), both finite and > 0.

    Raises
    ------
    ValueError
        Naming ``option``: not two numbers separated by ':', or a value or sd not > 0.
    """
    value, sep, sd = str(text).partition(":")
    if not sep:
        raise InputError(option, f"expected {form} (the measurement and its standard "
                         f"deviation), got {text!r}")
    return (_positive(option, "the value", value.strip()),
            _positive(option, "the sd", sd.strip()))


def parse_kd(option: str, text: str) -> tuple:
    """A radiometer's K_d at one band from ``NM=VALUE:SD``.

    Parameters
    ----------
    option : str
        The option, named in errors (``--kd``).
    text : str
        E.g. ``"490=0.12:0.01"``.

    Returns
    -------
    tuple
        (band nm, (value m^-1, sd m^-1)).

    Raises
    ------
    ValueError
        Naming ``option``: malformed, or a band outside 400-700 nm.
    """
    band, sep, rest = str(text).partition("=")
    if not sep:
        raise InputError(option, f"expected NM=VALUE:SD (e.g. 490=0.12:0.01), got {text!r}")
    nm = _positive(option, "the band (nm)", band.strip())
    if not 400.0 <= nm <= 700.0:
        raise InputError(option, f"the band {nm:g} nm lies outside 400-700 nm")
    return nm, parse_pair(option, rest, "NM=VALUE:SD")


def merge_auxiliary(defaults, own) -> dict:
    """One photo's measurements: its own (a metadata row's) over the run's defaults, kind by
    kind and, for K_d, band by band.

    Parameters
    ----------
    defaults, own : dict or None
        In :mod:`sca.auxiliary`'s form.

    Returns
    -------
    dict
        The merged measurements ({} for none).
    """
    out = {k: v for k, v in (defaults or {}).items() if k != "kd"}
    out.update({k: v for k, v in (own or {}).items() if k != "kd"})
    kd = {float(b): v for b, v in ((defaults or {}).get("kd") or {}).items()}
    kd.update({float(b): v for b, v in ((own or {}).get("kd") or {}).items()})
    if kd:
        out["kd"] = kd
    return out


def option_sources(auxiliary) -> dict:
    """Each measurement's source when the command line's options gave it: kind (or
    ``'kd <nm>'``) -> the option (:data:`OPTIONS`).

    Parameters
    ----------
    auxiliary : dict or None
        In :mod:`sca.auxiliary`'s form.

    Returns
    -------
    dict
    """
    out = {k: OPTIONS[k][0] for k in (auxiliary or {}) if k != "kd"}
    out.update({f"kd {float(b):g}": OPTIONS["kd"][0] for b in (auxiliary or {}).get("kd", {})})
    return out


def auxiliary_record(auxiliary, sources=None) -> list:
    """The measurements as measurement.json records them: one entry per reading.

    Parameters
    ----------
    auxiliary : dict or None
        In :mod:`sca.auxiliary`'s form.
    sources : dict, optional
        Where each reading came from: kind (or ``'kd <nm>'``) -> text (``'metadata line 3'``,
        ``'--secchi'``).

    Returns
    -------
    list of dict
        ``{'kind', 'band_nm' (K_d only), 'value', 'sd', 'units', 'source'}``.
    """
    sources = sources or {}
    out = []
    for kind in KINDS:
        if kind not in (auxiliary or {}):
            continue
        entries = ([(float(b), e) for b, e in sorted(auxiliary["kd"].items(),
                                                      key=lambda kv: float(kv[0]))]
                   if kind == "kd" else [(None, auxiliary[kind])])
        for band, (value, sd) in entries:
            key = kind if band is None else f"kd {band:g}"
            row = {"kind": kind, "value": float(value), "sd": float(sd),
                   "units": OPTIONS[kind][2], "source": str(sources.get(key, "given"))}
            if band is not None:
                row["band_nm"] = band
            out.append(row)
    return out


def combine_readings(readings) -> tuple:
    """Readings of one quantity of one water as one measurement: the inverse-variance weighted
    mean and its sd, times the Birge ratio sqrt(chi^2 / (n - 1)) where it exceeds 1 (the
    module's rule).

    Parameters
    ----------
    readings : sequence of (value, sd)
        sd > 0.

    Returns
    -------
    tuple of float
        (value, sd).

    Raises
    ------
    ValueError
        Naming ``readings`` when there is none.
    """
    readings = [(float(v), float(s)) for v, s in readings]
    if not readings:
        raise InputError("readings", "none to combine")
    w = [1.0 / s ** 2 for _, s in readings]
    mean = sum(wi * v for wi, (v, _) in zip(w, readings)) / sum(w)
    sd = 1.0 / math.sqrt(sum(w))
    n = len(readings)
    if n > 1:
        chi2 = sum(wi * (v - mean) ** 2 for wi, (v, _) in zip(w, readings))
        sd *= max(1.0, math.sqrt(chi2 / (n - 1)))
    return mean, sd


def dive_auxiliary(records) -> dict:
    """Every measurement of a dive's water, from its photos' measurement.json records, as one
    measurement per quantity (the module's rule).

    A reading is told from another by its kind, band, value, sd and source: the run's default
    that entered every photo counts once; two metadata rows are two readings, even with equal
    numbers; readings of unknown source with equal numbers count once.

    Parameters
    ----------
    records : sequence of dict or measure.joint.JointPhoto
        measurement.json contents (``inputs['auxiliary']``: :func:`auxiliary_record`'s list)
        or the joint fit's photos (their ``auxiliary``).

    Returns
    -------
    dict
        In :mod:`sca.auxiliary`'s form ({} when no photo has one).
    """
    seen = {}
    for rec in records:
        readings = (rec.get("inputs") or {}).get("auxiliary") if isinstance(rec, dict) \
            else rec.auxiliary
        for r in readings or []:
            key = (r["kind"], r.get("band_nm"), float(r["value"]), float(r["sd"]),
                   r.get("source", "given"))
            seen[key] = (float(r["value"]), float(r["sd"]))
    groups = {}
    for (kind, band, *_), reading in seen.items():
        groups.setdefault((kind, band), []).append(reading)
    out = {}
    for (kind, band), readings in groups.items():
        if kind == "kd":
            out.setdefault("kd", {})[float(band)] = combine_readings(readings)
        else:
            out[kind] = combine_readings(readings)
    return out
