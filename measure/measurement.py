"""From a photograph of a chart underwater to a measurement of the water and a corrected image.

:func:`measure`: read (or take) the photo, sample the chart in every corner order and keep the
one whose grey row falls from white to black (:mod:`measure.chart`), fit C, a_CDOM(440), the
veiling light and the unknown exposure gain with :func:`sca.estimate` (``gain="free"``, weighted
by the patches' standard errors), then assess it. :func:`correction` derives the paper's Fig 11
von Kries correction from the estimated attenuation: corrected = gains * (raw - offset), offset
the estimated veiling light, gains the ratio of a white's response in air to its response
through the water.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

import forward
import sca
from forward import validate
from forward.spectra import WHITE_PATCH
from forward.water import resolve_water
from sca.assess import BLOCKING

from .camera import Profile, camera_setup, load_profile
from .chart import (
    LAYOUTS,
    ChartLayout,
    PatchSample,
    describe_pose,
    orientations,
    parse_corners,
    pose,
    sample_patches,
)
from .detect import find_chart
from .image import Photo, read_image
from .lightfield import FIELDS, fit_light_field

__all__ = ["Measurement", "measure", "correction", "budget_for", "MEASURE_BLOCKING", "CLIPPED_SIGMA",
           "SATURATED_FRACTION", "WHITE_TARGET", "ORIENTATION_CHI2"]

#: Flags of the measurement itself that make it unreliable (besides sca.assess.BLOCKING):
#: the camera's channel balance is unknown (or its profile is not reliable), the chart's
#: orientation could not be verified, too many patch values are clipped.
MEASURE_BLOCKING = ("uncalibrated-camera", "orientation-unverified", "saturated",
                    "unreliable-profile")
#: A clipped patch value is left out of the fit by giving it this sigma (x the largest value):
#: its weight is then ~1e-12 of the others'.
CLIPPED_SIGMA = 1e6
#: More than this fraction of the 72 patch values clipped: 'saturated'.
SATURATED_FRACTION = 1 / 3
#: corrected.tiff: the corrected white patch's brightest channel is put at this fraction of
#: full scale (a common factor of the gains; the correction's colour is its ratios).
WHITE_TARGET = 0.8
#: When several orientations pass the grey-row test, the best fit must beat the others by this
#: chi^2 (else the orientation is not verified).
ORIENTATION_CHI2 = 25.0


@dataclass
class Measurement:
    """The result of :func:`measure` (``to_dict`` gives measurement.json).

    Attributes
    ----------
    estimate : sca.Estimate
        The fit: C (mg m^-3), a_CDOM(440) (m^-1), the exposure gain (raw units per model unit),
        the veiling light (raw units), k on the grid, intervals and flags.
    sample : PatchSample
        The sampled patch values (raw units) in the chosen orientation.
    orientation : str
        Corners given: how they were used, a name of :data:`measure.chart.ORIENTATIONS` ('as
        given', or the order the grey row chose). A chart found: ``'detected: '`` and its
        pose in the photo (:func:`measure.chart.describe_pose`, e.g. 'detected: rotated 177°
        clockwise, mirrored').
    corners : numpy.ndarray, (4, 2)
        The corners in pixels, in the chosen order.
    gains, offset : numpy.ndarray, (3,)
        The colour correction corrected = gains * (raw - offset) (:func:`correction`; offset in
        raw units).
    fitted : numpy.ndarray, (3, 24)
        The model's patch values at the estimate, raw units.
    attenuation_band : numpy.ndarray, (2, q)
        k (dimensionless) at the corners of the C and a_CDOM intervals (NaN if unbounded).
    camera : dict
        The camera, its profile and the illuminant used.
    photo : Photo
        The photograph.
    setup : forward.ChartSetup
        Camera, illuminant and chart as used (the profile's balance applied).
    flags : tuple of str
        The estimate's flags and the measurement's own (:data:`MEASURE_BLOCKING`,
        ``clipped-patches``, ``light-field``, ``orientation-corrected``).
    reliable : bool
        No blocking flag.
    notes : list of str
        Sentences for the user.
    light_field : dict
        The light-field model chosen and its tests (:mod:`measure.lightfield`).
    """

    estimate: sca.Estimate
    sample: PatchSample
    orientation: str
    corners: np.ndarray
    gains: np.ndarray
    offset: np.ndarray
    fitted: np.ndarray
    attenuation_band: np.ndarray
    camera: dict
    photo: Photo = field(repr=False)
    setup: forward.ChartSetup = field(repr=False)
    flags: tuple = ()
    reliable: bool = False
    notes: list = field(default_factory=list)
    #: the light-field model chosen by the nested-model test (measure.lightfield) and its tests
    light_field: dict = field(default_factory=dict)
    #: every input used (the audit trail of measurement.json): depth and distance (m) with
    #: their sds, the uncertainty budget, the water model and path model, the options
    inputs: dict = field(default_factory=dict)

    def to_dict(self, version: str = "") -> dict:
        """measurement.json's content (numbers as Python lists; units in ``estimate.units``),
        ``version`` the writer's."""
        e = self.estimate
        return {
            "estimate": {
                "chl": e.chl, "cdom": e.cdom, "chl_ci": list(e.chl_ci), "cdom_ci": list(e.cdom_ci),
                "gain": e.gain, "gain_ci": list(e.gain_ci),
                "attenuation": e.attenuation.tolist(),
                "attenuation_band": self.attenuation_band.tolist(),
                "wavelengths": e.wavelengths.tolist(), "backscatter": e.backscatter.tolist(),
                "reliable": self.reliable, "flags": list(self.flags), "fit_rms": e.fit_rms,
                "chi2_dof": e.chi2_dof, "chi2_p": e.chi2_p, "dof": e.dof,
                "converged": e.converged, "status": e.status,
                "budget": e.budget, "nuisance": {k: np.asarray(v, float).tolist()
                                                 for k, v in e.nuisance.items()},
                "units": {"chl": "mg m^-3", "cdom": "m^-1 at 440 nm", "gain": "raw units per "
                          "model unit", "backscatter": "raw units", "wavelengths": "nm",
                          "attenuation": "dimensionless k = exp(-(depth + distance) c)"},
            },
            "patches": {"rgb": self.sample.rgb.tolist(), "sigma": self.sample.sigma.tolist(),
                        "n_pixels": self.sample.n_pixels.tolist(),
                        "clipped": self.sample.clipped.tolist(),
                        "excluded": (None if self.sample.excluded is None else
                                     np.asarray(self.sample.excluded, float).tolist()),
                        "fitted": self.fitted.tolist(), "boxes": self.sample.boxes.tolist()},
            "orientation": self.orientation,
            "corners": self.corners.tolist(),
            "light_field": self.light_field,
            "correction": {"gains": self.gains.tolist(), "offset": self.offset.tolist()},
            "camera": self.camera,
            "image": {"path": self.photo.path, "size": list(self.photo.size),
                      "kind": self.photo.kind, "exposure": self.photo.exposure,
                      "black_level": self.photo.black.tolist(),
                      "white_level": self.photo.white.tolist()},
            "notes": self.notes,
            "inputs": self.inputs,
            "version": version,
        }


def _layout(layout) -> ChartLayout:
    if isinstance(layout, ChartLayout):
        return layout
    if layout not in LAYOUTS:
        raise ValueError(f"layout: must be one of {sorted(LAYOUTS)} or a ChartLayout, got {layout!r}")
    return LAYOUTS[layout]


def _data(sample: PatchSample):
    """(M, sigma) for the estimator: negative means (noise around a black level) at 0,
    clipped or unmeasurable values left out by a sigma of CLIPPED_SIGMA x the largest value."""
    M = np.maximum(sample.rgb, 0.0)
    if not M.max() > 0:
        raise ValueError("image: every sampled patch value is <= 0 after the black level: the "
                         "photo is black or the corners miss the chart")
    out = CLIPPED_SIGMA * float(M.max())
    ok = np.isfinite(sample.sigma) & (sample.sigma > 0) & ~(sample.clipped > 0)
    return M, np.where(ok, sample.sigma, out)


#: The engine of the fits (``sca.estimate``'s ``mode``): 'lm', the batch's variable projection
#: and Levenberg-Marquardt on the one chart (the DPP loop's optimum wherever the loop converges,
#: issue 21's target 4; no cvxpy), or 'safeguarded' / 'paper', the cvxpy loop
FIT_MODE = "lm"


def _fit(sample: PatchSample, setup, depth, distance, water, uncertain=None,
         mode=FIT_MODE):
    """sca.estimate with a free gain on the sample."""
    M, sig = _data(sample)
    return sca.estimate(M, depth=depth, distance=distance, sigma=sig, gain="free", setup=setup,
                        water=water, uncertain=uncertain, mode=mode)


def budget_for(uncertain, profile) -> dict:
    """The uncertainty budget of a measurement: ``uncertain`` as given, or the default
    (:data:`sca.budget.DEFAULT_UNCERTAIN`) with the profile's own numbers where it has them:
    its per-patch systematic error (``patch``) and the largest standard error of its channel
    gains (``balance``).

    Parameters
    ----------
    uncertain : dict or None
        The budget asked for (None: the default).
    profile : measure.Profile or None
        The camera's calibration.

    Returns
    -------
    dict
        name -> sd.
    """
    if uncertain is not None:
        return dict(uncertain)
    out = dict(sca.budget.DEFAULT_UNCERTAIN)
    if profile is not None:
        if profile.patch_sd is not None and np.isfinite(profile.patch_sd):
            out["patch"] = float(profile.patch_sd)
        se = np.asarray(profile.gains_se, float)
        if se.size and np.all(np.isfinite(se)):
            out["balance"] = float(np.max(se))
    return out


def _choose_orientation(photo, lay, cands, setup, depth, distance, water, uncertain=None,
                        mode=FIT_MODE):
    """(name, corners, sample, estimate, flags, notes) of the orientation to use."""
    passing = [name for name, (_, _, ok) in cands.items() if ok]
    full = {name: sample_patches(photo, cands[name][0], lay) for name in (passing or ["as given"])}
    cands = {name: (cands[name][0], full[name], cands[name][2]) for name in full}
    if len(passing) == 1:
        name = passing[0]
        c, s, _ = cands[name]
        notes = [] if name == "as given" else [
            f"the corners were given in the wrong order; the chart was found {name} with respect "
            "to them and sampled in its true orientation"]
        flags = [] if name == "as given" else ["orientation-corrected"]
        return name, c, s, _fit(s, setup, depth, distance, water, uncertain, mode), flags, notes
    pool = passing or list(cands)
    fits = {name: _fit(cands[name][1], setup, depth, distance, water, uncertain, mode)
            for name in pool}
    order = sorted(fits, key=lambda k: fits[k].objective)
    best = order[0]
    c, s, _ = cands[best]
    clear = len(order) > 1 and fits[order[1]].objective - fits[best].objective > ORIENTATION_CHI2
    if passing and clear:
        flags = [] if best == "as given" else ["orientation-corrected"]
        return best, c, s, fits[best], flags, [
            f"several orientations have a falling grey row; the fit chose {best} (chi^2 "
            f"{fits[best].objective:.4g} against {fits[order[1]].objective:.4g})"]
    c, s, _ = cands["as given"]
    why = ("no orientation of the corners shows the grey row (patches 19-24) falling from white "
           "to black in every channel" if not passing else
           "several orientations fit about equally well")
    return "as given", c, s, fits.get("as given") or _fit(s, setup, depth, distance, water,
                                                          uncertain, mode), \
        ["orientation-unverified"], [f"orientation not verified: {why}; check --corners"]


def correction(estimate: sca.Estimate, setup, white_value=None, full_scale=65535.0):
    """The paper's von Kries colour correction from the estimated attenuation.

    corrected = gains * (raw - offset): offset the estimated veiling light, gains the ratio
    (P^T i) / ((1 + beta) (P_delta^T diag(i r) k)) of a white's response in air to its response
    through the water as the fit found it (r: the surface daylight's change of colour, where the
    budget has the ``daylight`` term; beta and delta: the camera's fitted channel balance and
    curve shifts, where it has ``balance`` and ``camera_shift``, P_delta = P - delta dP/dlambda
    to first order as :mod:`sca.model` takes them; the corrected white is that of the given
    illuminant and the camera's nominal curves), times one common factor that puts the
    corrected white patch's brightest channel at :data:`WHITE_TARGET` x ``full_scale``.

    Parameters
    ----------
    estimate : sca.Estimate
        A fit with ``attenuation`` k (q,) and ``backscatter`` (3,) in raw units.
    setup : forward.ChartSetup
        Camera sensitivities P and illuminant i of the fit.
    white_value : array_like, (3,), optional
        The white patch's raw values (raw units); without it no common factor is applied.
    full_scale : float, optional
        Full scale of the corrected image, raw units (default 65535, 16 bits).

    Returns
    -------
    gains : numpy.ndarray, (3,)
        Channel gains, dimensionless.
    offset : numpy.ndarray, (3,)
        Offsets, raw units.

    References
    ----------
    H. Blasinski and J. Farrell, "A Three Parameter Underwater Image Formation Model", IS&T
    Electronic Imaging 2016, Fig 11 (von Kries correction with the estimated attenuation).
    """
    P, i = setup.sensitivities, setup.illuminant
    light = i * estimate.attenuation
    nuisance = estimate.nuisance or {}
    shift = nuisance.get("daylight")
    if shift:  # the surface light's colour as the fit found it (the budget's daylight term)
        from forward.daylight import DaylightTilt

        light = light * np.exp(DaylightTilt(setup.wavelengths,
                                            setup.daylight_cct).log_ratio(float(shift)))
    # the white through the water as the fit saw it: with the camera's fitted curve shifts (to
    # first order, as sca.model takes them) and channel balance (the budget's camera terms), so
    # that the correction inverts the whole colour path the fit found, not the water's part alone
    P_fit = P
    delta = nuisance.get("camera_shift")
    if delta is not None:
        P_fit = P - np.asarray(delta, float)[None, :] * np.gradient(P, setup.wavelengths, axis=0)
    through = P_fit.T @ light
    balance = nuisance.get("balance")
    if balance is not None:
        through = through * (1.0 + np.asarray(balance, float))
    vk = (P.T @ i) / through
    offset = np.asarray(estimate.backscatter, float)
    if white_value is not None:
        top = float(np.max(vk * (np.asarray(white_value, float) - offset)))
        if top > 0:
            vk = vk * (WHITE_TARGET * full_scale / top)
    return vk, offset


def _band(estimate: sca.Estimate, mdl_water, depth, distance, wl):
    """k at the corners of the (C, a_CDOM) intervals: k falls with both, so (k(hi, hi),
    k(lo, lo)) bound it over the box of the two intervals (a conservative band)."""
    lo_c, hi_c = estimate.chl_ci
    lo_a, hi_a = estimate.cdom_ci
    hi_c = min(hi_c, sca.assess.CHL_MAX)
    hi_a = min(hi_a, sca.assess.CDOM_MAX)
    k_low = forward.attenuation(wl, hi_c, hi_a, depth, distance, water=mdl_water)
    k_high = forward.attenuation(wl, lo_c, lo_a, depth, distance, water=mdl_water)
    return np.vstack([k_low, k_high])


def measure(image, *, corners=None, depth, distance, camera=forward.DEFAULT_CAMERA,
            quantal: bool = False, profile=None, illuminant=None, layout="patches",
            water: forward.Water | None = None, black_level=None,
            white_level=None, light_field: str = "auto", uncertain=None,
            mode: str = FIT_MODE) -> Measurement:
    """Measure the water from a photograph of a ColorChecker Classic underwater.

    Samples the chart in every corner order and keeps the one whose grey row falls from white
    to black, fits C, a_CDOM(440), the veiling light and the unknown exposure gain with
    :func:`sca.estimate` (``gain="free"``, weighted by the patches' standard errors; clipped
    values left out), models uneven light if the data need it, and assesses the result.

    Parameters
    ----------
    image : str, os.PathLike or Photo
        A RAW (any LibRaw format) or linear 16-bit TIFF, or a :class:`measure.Photo`.
    corners : str or array_like, (4, 2), optional
        'x1,y1 x2,y2 x3,y3 x4,y4' pixels: next to patch 1, 6, 24, 19 (see
        :mod:`measure.chart`). None (default): the chart is found in the photo
        (:func:`measure.find_chart`; what was found is in ``inputs['chart']``).
    depth, distance : float
        The chart's depth and the camera-to-chart distance, m.
    camera : str, path or array, optional
        Colour-science camera name or CSV (wavelength nm, red, green, blue).
    quantal : bool, optional
        The curves act on photons (converted to energy).
    profile : Profile, str or os.PathLike, optional
        A :class:`measure.Profile` or the path of ``uw3p calibrate``'s JSON. Without it the
        curves' own balance is used and the result is flagged ``uncalibrated-camera``.
    illuminant : str, path or array, optional
        The surface illuminant (default D65).
    layout : str or ChartLayout, optional
        'patches' (corners of the patch grid), 'card' or a :class:`measure.ChartLayout`.
    water : forward.Water, optional
        The water model (default the paper's).
    black_level, white_level : float or array_like, optional
        Override the file's, raw units (DN).
    light_field : str, optional
        'auto' (default: the smallest of none < plane < plane+radial that the likelihood-ratio
        test supports, :mod:`measure.lightfield`), or one of them to force it.
    uncertain : dict, optional
        The uncertainty budget (:mod:`sca.budget`). Default: :data:`sca.budget.DEFAULT_UNCERTAIN`
        with the profile's per-patch systematic error and gain standard errors
        (:func:`budget_for`); ``{}``: the paper's exact model.
    mode : {'lm', 'safeguarded', 'paper'}, optional
        The fits' engine (:func:`sca.estimate`'s ``mode``; default :data:`FIT_MODE`, 'lm': the
        batch's Levenberg-Marquardt on the chart, without cvxpy).

    Returns
    -------
    Measurement
        The estimate (C mg m^-3, a_CDOM(440) m^-1, gain, veiling light, k), its band, the
        colour correction, flags, ``reliable`` and notes.

    Raises
    ------
    ValueError
        Naming the argument (``image``, ``corners``, ``profile``, ``layout``,
        ``light_field``, ``mode``, ...) when it is wrong (``image`` when ``corners`` is None and
        the chart found lies partly outside the frame); :class:`measure.ChartNotFound` (``no
        chart found``, with the reason) when ``corners`` is None and the photo shows no chart.

    References
    ----------
    H. Blasinski and J. Farrell, "A Three Parameter Underwater Image Formation Model", IS&T
    Electronic Imaging 2016, eqs 15-18 (the estimator), Fig 11 (the correction).
    """
    if mode not in sca.MODES:  # before any work
        raise ValueError(f"mode: must be one of {sca.MODES}, got {mode!r}")
    photo = image if isinstance(image, Photo) else read_image(image, black_level=black_level,
                                                              white_level=white_level)
    if isinstance(profile, (str, bytes)) or hasattr(profile, "__fspath__"):
        profile = load_profile(profile)
    if profile is not None and not isinstance(profile, Profile):
        raise ValueError("profile: expected a measure.Profile or the path of a profile JSON")
    depth = validate.scalar("depth", depth)
    distance = validate.scalar("distance", distance)
    water = resolve_water(water)
    lay = _layout(layout)
    setup = camera_setup(camera, quantal=quantal, illuminant=illuminant,
                         gains=None if profile is None else profile.gains)
    if light_field != "auto" and light_field not in FIELDS:
        raise ValueError(f"light_field: must be 'auto' or one of {tuple(FIELDS)}, got {light_field!r}")
    budget = budget_for(uncertain, profile)
    if corners is None:
        found = find_chart(photo, lay)
        found.check_in_frame(photo.size)
        corners, chart = found.corners, found.to_dict()
    else:
        chart = {"corners": parse_corners(corners).tolist(), "detected": False}
    cands = orientations(photo, corners, lay)
    name, c, sample, est, flags, notes = _choose_orientation(photo, lay, cands, setup, depth,
                                                             distance, water, budget, mode)
    if chart["detected"]:  # how the chart lies, not how the detector's corners were used
        name = f"detected: {describe_pose(pose(c))}"
    fit_setup, field_report = setup, {"model": "none"}
    if light_field != "none":
        M, sig = _data(sample)
        models = tuple(FIELDS) if light_field == "auto" else ("none", light_field)
        lf = fit_light_field(M, sig, setup, depth, distance, water, models=models,
                             uncertain=budget)
        chosen = lf["model"] if light_field == "auto" else light_field
        field_report = {"model": chosen, "coefficients": lf["coefficients"] if chosen == lf["model"]
                        else [], "field": lf["field"].tolist(), "tests": lf["tests"],
                        "alpha": lf["alpha"], "terms": "f = 1 + a x + b y [+ c (x^2 + y^2 - "
                        "mean)], chart coordinates in [-1, 1]"}
        if chosen != "none":
            fit_setup = lf["setup"]
            est = _fit(sample, fit_setup, depth, distance, water, budget, mode)
            flags.append("light-field")
            notes.append(f"uneven light over the chart modelled ({chosen}: the field ranges "
                         f"{lf['field'].min():.3f}-{lf['field'].max():.3f}; likelihood-ratio "
                         f"p = {lf['tests'][chosen]['p_value']:.2g}); intervals are conditional "
                         "on it")
    clipped = sample.clipped > 0
    if clipped.any():
        flags.append("clipped-patches")
        bad = sorted({j + 1 for j in np.flatnonzero(clipped.any(axis=0))})
        notes.append(f"clipped values left out of the fit (patches {bad})")
    if clipped.mean() > SATURATED_FRACTION:
        flags.append("saturated")
    if profile is None:
        flags.append("uncalibrated-camera")
        notes.append("no camera profile: the curves' own channel balance was used (run uw3p "
                     "calibrate on a photo of the chart in air)")
    elif profile.camera not in ("custom", camera if isinstance(camera, str) else "custom"):
        raise ValueError(f"profile: made for camera {profile.camera!r}, not {camera!r}")
    elif not profile.reliable:
        flags.append("unreliable-profile")
        notes.append(f"the camera profile is not reliable (flags: {', '.join(profile.flags)}): "
                     "recalibrate before trusting the water's colour")
    all_flags = tuple(dict.fromkeys(list(est.flags) + flags))
    reliable = not any(f in BLOCKING or f in MEASURE_BLOCKING for f in all_flags)
    G = forward.camera_response(fit_setup.sensitivities, fit_setup.illuminant, est.attenuation,
                                fit_setup.reflectances)
    fitted = est.gain * G + est.backscatter[:, None]
    gains, offset = correction(est, setup, sample.rgb[:, WHITE_PATCH])
    band = _band(est, water, depth, distance, setup.wavelengths) if np.all(
        np.isfinite(est.chl_ci)) else np.vstack([est.attenuation, est.attenuation]) * np.nan
    cam = {"name": camera if isinstance(camera, str) else "custom", "quantal": bool(quantal),
           "profile": None if profile is None else {"gains": profile.gains,
                                                    "illuminant": profile.illuminant,
                                                    "image": profile.image},
           "illuminant": illuminant if isinstance(illuminant, str) else "D65"}
    inputs = {"depth_m": depth, "distance_m": distance,
              "depth_sd": est.uncertain.get("depth"), "distance_sd": est.uncertain.get("distance"),
              "uncertain": dict(est.uncertain),
              "water": {f.name: getattr(water, f.name) for f in dataclasses.fields(water)
                        if not f.name.endswith("_table")},
              "path_model": water.path_model, "light_field": light_field,
              "layout": dataclasses.asdict(lay), "chart": chart}
    return Measurement(est, sample, name, c, gains, offset, fitted, band, cam, photo, setup,
                       all_flags, reliable, notes, field_report, inputs)
