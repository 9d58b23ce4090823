"""The water a correction uses: what a measurement, a dive's joint fit or a survey record holds.

:func:`correction_water` reads C, a_CDOM(440), their 95 % intervals, the path model, the fitted
nuisances (the Water constants of the budget, the camera's ``balance`` and ``camera_shift``,
the surface light's ``daylight`` shift), the depth, the chart's distance, the veiling light s
per channel and the exposure gain from

- a :class:`measure.Measurement`, or measurement.json (its path or its content: a dive's
  survey record is measurement.json's content);
- joint.json of ``uw3p measure DIVE --joint`` (its path or content): the dive's water, and the
  veiling light, gain, depth and distance of one of its photos (``photo``; default the one
  nearest in depth to ``depth``).

A frame photographed with another exposure than the chart's has its gain and veiling light
scaled by ``exposure_ratio`` (the frame's exposure over the chart photo's:
:func:`exposure_ratio` from their EXIF exposure time, f-number and ISO).
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path

import numpy as np

import forward
from forward.water import COEFFICIENT_PARAMS, Water
from forward.errors import InputError
from sca.model import CDOM_MAX, CHL_MAX

from .correctcamera import CameraUse, correction_setup

__all__ = ["CorrectionWater", "DEPTH_EXTRAPOLATION_MAX_M", "MODEL_NUISANCE", "correction_water",
           "exposure_ratio"]

#: How far (m) outside the measured depths (the dive's photos' depths, a single photo's depth)
#: a photo may be corrected: within it the correction says it extrapolates (notes,
#: ``extrapolated``); beyond it, refused naming ``depth`` (decision 0065-depth-extrapolation).
DEPTH_EXTRAPOLATION_MAX_M = 2.0

#: The fitted nuisances that the correction's model takes (:meth:`sca.model.ChartModel.predict`
#: parameters): the Water constants, the camera's curves as fitted and the daylight's colour.
MODEL_NUISANCE = ("balance", "camera_shift", "daylight") + COEFFICIENT_PARAMS


@dataclass
class CorrectionWater:
    """The water, light and camera state one photo is corrected with.

    Attributes
    ----------
    chl, cdom : float
        C (mg m^-3) and a_CDOM(440) (m^-1).
    chl_ci, cdom_ci : tuple of float
        Their 95 % intervals (``inf``: open).
    water : forward.Water
        The water model, with the path model the fit chose.
    nuisance : dict
        Fitted nuisances of :data:`MODEL_NUISANCE` (name -> float, or (3,) per channel).
    depth : float
        The depth of the photo (camera and scene), m.
    distance : float
        The chart's distance r0 at which ``backscatter`` was measured, m.
    backscatter : numpy.ndarray, (3,)
        The veiling light s along the chart's ray, raw units (DN above black).
    gain : float
        Raw units per model unit (a white reflector in air = 1 in the most sensitive channel).
    setup : forward.ChartSetup
        Camera P and illuminant i (the profile's balance applied).
    source : str
        Where the water came from.
    reliable : bool
        Whether the measurement it came from is reliable.
    notes : list of str
        What was assumed (a scaled exposure, a photo chosen).
    camera : measure.correctcamera.CameraUse or None
        The water's recorded camera and the camera and calibration applied.
    span : tuple of float
        The depths the water was measured at, (shallowest, deepest), m.
    extrapolated : dict or None
        ``depth_m``, ``span_m``, ``outside_m`` when the photo's depth lies outside ``span``.
    """

    chl: float
    cdom: float
    chl_ci: tuple
    cdom_ci: tuple
    water: Water
    nuisance: dict
    depth: float
    distance: float
    backscatter: np.ndarray
    gain: float
    setup: forward.ChartSetup = field(repr=False)
    source: str = ""
    reliable: bool = True
    notes: list = field(default_factory=list)
    camera: CameraUse | None = field(default=None, repr=False)
    span: tuple = ()
    extrapolated: dict | None = None

    def with_water(self, chl: float, cdom: float) -> "CorrectionWater":
        """The same state with other C (mg m^-3) and a_CDOM(440) (m^-1) (an interval's end)."""
        return dataclasses.replace(self, chl=float(chl), cdom=float(cdom), notes=list(self.notes))


def exposure_ratio(frame: dict, chart: dict) -> float | None:
    """The frame's exposure over the chart photo's, from EXIF: t ISO / N^2.

    Parameters
    ----------
    frame, chart : dict
        ``exposure_s`` (s), ``f_number`` and ``iso`` (a :class:`measure.Photo`'s ``exposure``).

    Returns
    -------
    float or None
        The ratio; None when either lacks one of the three.
    """
    def h(e):
        try:
            t, n, iso = float(e["exposure_s"]), float(e["f_number"]), float(e["iso"])
        except (KeyError, TypeError, ValueError):
            return None
        return t * iso / n ** 2 if t > 0 and n > 0 and iso > 0 else None
    a, b = h(frame or {}), h(chart or {})
    return None if a is None or b is None else a / b


def _load(source):
    if isinstance(source, dict):
        return dict(source), "given record"
    if hasattr(source, "to_dict") and hasattr(source, "setup"):  # a Measurement
        return source.to_dict(), str(getattr(source.photo, "path", "measurement"))
    p = Path(os.fspath(source))
    try:
        data = json.loads(p.read_text(encoding="utf-8"))
    except OSError as exc:
        raise InputError("water", f"cannot read {p}: {exc.strerror or exc}") from None
    except ValueError:
        raise InputError("water", f"{p}: not JSON (give measurement.json or joint.json)") from None
    if not isinstance(data, dict):
        raise InputError("water", f"{p}: not a measurement.json or joint.json")
    return data, str(p)


def _num(v) -> float:
    if v in (None, "inf", "Infinity"):
        return math.inf
    if v == "-inf":
        return -math.inf
    return float(v)


def _nuisance(raw: dict) -> dict:
    out = {}
    for k, v in (raw or {}).items():
        if k in MODEL_NUISANCE and v is not None:
            out[k] = np.asarray(v, float) if np.ndim(v) else float(v)
    return out


def _water_model(fields: dict | None, path_model: str | None) -> Water:
    given = {k: v for k, v in (fields or {}).items()
             if k in {f.name for f in dataclasses.fields(Water)} and not k.endswith("_table")}
    if path_model:
        given["path_model"] = path_model
    return Water(**given)


def _setup_from(record: dict, setup, options: dict):
    """(set-up, CameraUse): ``setup`` as given, else the recorded camera and calibration with
    ``options`` (camera, quantal, illuminant, profile) over them."""
    cam = record.get("camera") or {}
    if setup is not None:
        return setup, CameraUse(dict(cam), "the set-up given")
    return correction_setup(cam, **options)


def _from_measurement(rec: dict, source: str, setup, depth, ratio, options) -> CorrectionWater:
    e, inp = rec["estimate"], rec.get("inputs") or {}
    nuis = e.get("nuisance") or {}
    d = float(nuis.get("depth", inp.get("depth_m")))
    r0 = float(nuis.get("distance", inp.get("distance_m")))
    notes, measured = [], d
    s = np.asarray(e["backscatter"], float)
    gain = float(e["gain"])
    if depth is not None and abs(float(depth) - d) > 1e-9:
        notes.append(f"the photo's depth {float(depth):g} m, the chart's {d:.3g} m")
        d = float(depth)
    if ratio is not None and ratio != 1.0:
        s, gain = s * ratio, gain * ratio
        notes.append(f"gain and veiling light scaled by the exposure ratio {ratio:.4g}")
    setup, use = _setup_from(rec, setup, options)
    return CorrectionWater(
        chl=float(e["chl"]), cdom=float(e["cdom"]),
        chl_ci=tuple(_num(v) for v in e.get("chl_ci", (e["chl"], e["chl"]))),
        cdom_ci=tuple(_num(v) for v in e.get("cdom_ci", (e["cdom"], e["cdom"]))),
        water=_water_model(inp.get("water"), e.get("path_model") or inp.get("path_model")),
        nuisance=_nuisance(nuis), depth=d, distance=r0, backscatter=s, gain=gain,
        setup=setup, source=source, reliable=bool(e.get("reliable", True)),
        notes=notes, camera=use, span=(measured, measured))


def _from_joint(rec: dict, source: str, setup, depth, photo, ratio, model,
                options) -> CorrectionWater:
    photos = rec.get("photos") or {}
    if not photos:
        raise InputError("water", f"{source}: joint.json lists no photo")
    if photo is None:
        # the photo nearest in depth (its veiling light was lit most like the frame's)
        ref = depth if depth is not None else float(np.median([p["depth"] for p in photos.values()]))
        photo = min(photos, key=lambda k: abs(float(photos[k]["depth"]) - ref))
    if photo not in photos:
        raise InputError("photo", f"{photo!r} is not a photo of {source} ({', '.join(photos)})")
    p = photos[photo]
    notes = [f"veiling light and gain of {photo} (depth {float(p['depth']):.3g} m, distance "
             f"{float(p['distance']):.3g} m)"]
    s, gain = np.asarray(p["backscatter"], float), float(p["gain"])
    if ratio is not None and ratio != 1.0:
        s, gain = s * ratio, gain * ratio
        notes.append(f"gain and veiling light scaled by the exposure ratio {ratio:.4g}")
    d = float(p["depth"]) if depth is None else float(depth)
    model = (dataclasses.replace(model, path_model=rec.get("path_model") or model.path_model)
             if model is not None else _water_model({}, rec.get("path_model")))
    setup, use = _setup_from(rec, setup, options)
    depths = [float(q["depth"]) for q in photos.values()]
    return CorrectionWater(
        chl=float(rec["chl"]), cdom=float(rec["cdom"]),
        chl_ci=tuple(_num(v) for v in rec["chl_ci"]), cdom_ci=tuple(_num(v) for v in rec["cdom_ci"]),
        water=model, nuisance=_nuisance(rec.get("nuisance")), depth=d,
        distance=float(p["distance"]), backscatter=s, gain=gain,
        setup=setup, source=source, reliable=bool(rec.get("reliable", True)), notes=notes,
        camera=use, span=(min(depths), max(depths)))


def _check(cw: CorrectionWater, where: str) -> CorrectionWater:
    """Refuse, naming ``water``, a water outside the model's plausible ranges (C in
    [0, sca.model.CHL_MAX], a_CDOM(440) in [0, sca.model.CDOM_MAX], a finite positive gain
    and distance, three finite veiling lights, a finite depth >= 0)."""
    checks = (("C", cw.chl, 0.0 <= cw.chl <= CHL_MAX, f"in [0, {CHL_MAX:g}] mg m^-3"),
              ("a_CDOM(440)", cw.cdom, 0.0 <= cw.cdom <= CDOM_MAX, f"in [0, {CDOM_MAX:g}] m^-1"),
              ("gain", cw.gain, math.isfinite(cw.gain) and cw.gain > 0, "finite and > 0"),
              ("distance", cw.distance, math.isfinite(cw.distance) and cw.distance > 0,
               "finite and > 0 m"),
              ("depth", min(cw.span), all(math.isfinite(v) and v >= 0 for v in cw.span),
               "finite and >= 0 m"),
              ("backscatter", cw.backscatter.tolist(), cw.backscatter.shape == (3,)
               and bool(np.all(np.isfinite(cw.backscatter))), "three finite numbers"))
    for name, value, ok, want in checks:
        if not ok:
            raise InputError("water", f"{where}: {name} must be {want}, got {value!r}")
    return cw


def _extrapolate(cw: CorrectionWater) -> CorrectionWater:
    """Note a depth outside the measured span (``extrapolated``); refuse it, naming
    ``depth``, beyond :data:`DEPTH_EXTRAPOLATION_MAX_M`."""
    lo, hi = cw.span
    outside = max(lo - cw.depth, cw.depth - hi, 0.0)
    if outside <= 1e-9:
        return cw
    span = f"{lo:.3g} m" if lo == hi else f"{lo:.3g}-{hi:.3g} m"
    if outside > DEPTH_EXTRAPOLATION_MAX_M:
        raise InputError("depth", f"{cw.depth:g} m lies {outside:.3g} m outside the depths the "
                         f"water was measured at ({span}); at most {DEPTH_EXTRAPOLATION_MAX_M:g} "
                         "m is extrapolated: measure the water nearer this depth")
    cw.extrapolated = {"depth_m": cw.depth, "span_m": [lo, hi], "outside_m": outside}
    cw.notes.append(f"extrapolated: the depth {cw.depth:g} m lies {outside:.3g} m outside the "
                    f"depths the water was measured at ({span}); the veiling light is the "
                    "measured one")
    return cw


def correction_water(source, *, setup=None, depth=None, photo=None, exposure_ratio=None,
                     model=None, camera=None, quantal=None, illuminant=None,
                     profile=None) -> CorrectionWater:
    """The water, light and camera a photo is corrected with.

    Parameters
    ----------
    source : Measurement, dict, str or os.PathLike
        A :class:`measure.Measurement`, measurement.json or joint.json (a path, or the content:
        a survey record).
    setup : forward.ChartSetup, optional
        The camera and illuminant as they are; default the water's recorded camera with its
        calibration profile (:func:`measure.correctcamera.correction_setup`; a record without
        a camera: the default camera) and the options below over them.
    depth : float, optional
        The photo's depth, m (default the chart's).
    photo : str, optional
        joint.json: the photo whose veiling light, gain and distance anchor the correction
        (default the one nearest in depth).
    exposure_ratio : float, optional
        The photo's exposure over the chart photo's (:func:`exposure_ratio`); default 1.
    model : forward.Water, optional
        joint.json: the run's water model (joint.json records only the path model and the
        fitted constants); default the paper's.
    camera, quantal, illuminant, profile : optional
        Other curves, their kind, illuminant or calibration than the recorded ones
        (:func:`measure.correctcamera.correction_setup`; ignored with ``setup``).

    Returns
    -------
    CorrectionWater

    Raises
    ------
    ValueError
        Naming ``water`` (an unreadable file, neither a measurement nor a joint fit, a field
        missing, not a number or outside the model's ranges), ``photo``, ``depth`` (also
        more than :data:`DEPTH_EXTRAPOLATION_MAX_M` outside the measured depths),
        ``exposure_ratio``, ``profile`` or ``setup``.
    """
    if depth is not None and not (math.isfinite(float(depth)) and float(depth) >= 0):
        raise InputError("depth", f"must be finite and >= 0 m, got {depth!r}")
    if exposure_ratio is not None and not (math.isfinite(float(exposure_ratio))
                                           and float(exposure_ratio) > 0):
        raise InputError("exposure_ratio", f"must be finite and > 0, got {exposure_ratio!r}")
    if hasattr(source, "to_dict") and hasattr(source, "setup"):
        setup = source.setup if setup is None else setup
    rec, where = _load(source)
    options = {"camera": camera, "quantal": quantal, "illuminant": illuminant, "profile": profile}
    if "estimate" in rec:
        build = partial(_from_measurement, rec, where, setup, depth, exposure_ratio, options)
    elif "photos" in rec and "chl" in rec:
        build = partial(_from_joint, rec, where, setup, depth, photo, exposure_ratio, model,
                        options)
    else:
        raise InputError("water", f"{where}: neither measurement.json (an 'estimate') nor "
                         "joint.json ('photos')")
    try:
        cw = build()
    except InputError:
        raise
    except KeyError as exc:
        raise InputError("water", f"{where}: no {exc.args[0]!r} (not a whole measurement.json "
                         "or joint.json)") from None
    except (TypeError, ValueError, AttributeError) as exc:
        raise InputError("water", f"{where}: a field is not what uw3p writes ({exc})") from None
    return _extrapolate(_check(cw, where))
