"""From a photograph of a chart underwater to a measurement of the water and a corrected image.

:func:`measure`: read (or take) the photo, sample the chart in every corner order and keep the
one whose grey row falls from white to black (:mod:`measure.chart`), fit C, a_CDOM(440), the
veiling light and the unknown exposure gain with :func:`sca.estimate` (``gain="free"``, weighted
by the patches' standard errors), then assess it, and derive the paper's Fig 11 von Kries
correction from the estimated attenuation (:func:`measure.correct.correction`).
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import forward
import sca
from forward import validate
from forward.spectra import WHITE_PATCH
from forward.water import resolve_water
from sca.assess import BLOCKING
from sca.auxiliary import auxiliary_observations
from sca.budget import parse_sd
from sca.budget_defaults import MEASURED_CHART_PATCH
from sca.pathmodels import span_note

from .auxiliary import auxiliary_record
from .camera import Profile, camera_record, camera_setup, chart_digest, load_profile, read_chart_reflectance
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
from .correct import correction
from .detect import find_chart
from .image import Photo, read_image
from .lightfield import FIELDS, fit_light_field
from forward.errors import InputError

__all__ = ["Measurement", "measure", "budget_for", "MEASURE_BLOCKING", "CLIPPED_SIGMA",
           "SATURATED_FRACTION", "ORIENTATION_CHI2"]

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
        The colour correction corrected = gains * (raw - offset) (:func:`measure.correct.correction`;
        offset in raw units).
    fitted : numpy.ndarray, (3, 24)
        The model's patch values at the estimate (the budget's nuisances at their fitted
        values), raw units.
    transmittance_band : numpy.ndarray, (2, q)
        A 95 % band of the path's transmittance k = exp(-(depth + distance) c)
        (dimensionless; lower, upper): from the attenuation coefficient's own interval and the
        budget's sd of the path length (conservative where the geometry is uncertain).
    camera : dict
        The camera (its curves' name and digest, the photo's EXIF Make and Model), its
        profile (gains, file path, digest) and the illuminant used
        (:func:`measure.camera.camera_record`).
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
    transmittance_band: np.ndarray
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
    #: the correction's own uncertainty: the ΔE00 spread of the corrected chart and of a grey
    #: at each range over the water's 95 % intervals (:func:`measure.correct_uncertainty.
    #: correction_spread`)
    correction_uncertainty: dict = field(default_factory=dict)

    @property
    def attenuation_band(self) -> np.ndarray:
        """The former name of :attr:`transmittance_band` (the transmittance, not the
        attenuation coefficient)."""
        return self.transmittance_band

    @property
    def auxiliary_kinds(self) -> set:
        """The kinds of auxiliary measurement fused in the fit ('cdom', 'secchi', 'kd')."""
        return {r["kind"] for r in self.inputs.get("auxiliary") or []}

    @property
    def patch_term(self) -> float:
        """The budget's per-patch term the fit used (relative sd; 0 without one)."""
        return float(parse_sd("patch", self.estimate.uncertain.get("patch", 0.0)))

    @property
    def residual_sd(self) -> np.ndarray:
        """(3, 24) the standard error of each patch value that chi^2 uses: the photon noise
        with the budget's per-patch term, sqrt(sigma^2 + (patch M)^2), raw units (clipped
        values: :data:`CLIPPED_SIGMA` x the largest value)."""
        M, sig = _data(self.sample)
        return np.sqrt(sig ** 2 + (self.patch_term * M) ** 2)

    def to_dict(self, version: str = "") -> dict:
        """measurement.json's content (numbers as Python lists; units in ``estimate.units``),
        ``version`` the writer's."""
        from .statements import statements

        e = self.estimate
        return {
            "estimate": {
                "chl": e.chl, "cdom": e.cdom, "chl_ci": list(e.chl_ci), "cdom_ci": list(e.cdom_ci),
                "gain": e.gain, "gain_ci": list(e.gain_ci),
                "quantities": {k: float(v) for k, v in e.quantities.items()},
                "quantity_intervals": {k: [float(a) for a in v]
                                       for k, v in e.quantity_intervals.items()},
                "verdicts": {k: str(v) for k, v in e.verdicts.items()},
                "statements": statements(e, "photo", self.auxiliary_kinds),
                "beam_attenuation": np.asarray(e.beam_attenuation, float).tolist(),
                "beam_attenuation_ci": np.asarray(e.beam_attenuation_ci, float).tolist(),
                "path_model": e.path_model, "path_models": list(e.path_models),
                "transmittance": e.attenuation.tolist(),
                "transmittance_band": self.transmittance_band.tolist(),
                "wavelengths": e.wavelengths.tolist(), "backscatter": e.backscatter.tolist(),
                "reliable": self.reliable, "flags": list(self.flags), "fit_rms": e.fit_rms,
                "chi2_dof": e.chi2_dof, "chi2_p": e.chi2_p, "dof": e.dof,
                "converged": e.converged, "status": e.status,
                "consistency": e.consistency, "budget": e.budget,
                "nuisance": {k: np.asarray(v, float).tolist() for k, v in e.nuisance.items()},
                "units": {"chl": "mg m^-3", "cdom": "m^-1 at 440 nm", "gain": "raw units per "
                          "model unit", "backscatter": "raw units", "wavelengths": "nm",
                          "quantities": "m^-1 (sca.derived.QUANTITIES); tau_*: dimensionless "
                          "optical depth of the light's path, c (depth + distance)",
                          "beam_attenuation": "m^-1: the attenuation coefficient of the light's "
                          "path, tau / (depth + distance) (path model 'beam': the beam "
                          "attenuation c = a + b; 'absorption': a; 'split': the path-weighted "
                          "mean of K_d and c)",
                          "transmittance": "dimensionless k = exp(-(depth + distance) c)"},
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
            "correction": {"gains": self.gains.tolist(), "offset": self.offset.tolist(),
                           "uncertainty": self.correction_uncertainty},
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
        raise InputError("layout", f"must be one of {sorted(LAYOUTS)} or a ChartLayout, got {layout!r}")
    return LAYOUTS[layout]


def _data(sample: PatchSample):
    """(M, sigma) for the estimator: negative means (noise around a black level) at 0,
    clipped or unmeasurable values left out by a sigma of CLIPPED_SIGMA x the largest value."""
    M = np.maximum(sample.rgb, 0.0)
    if not M.max() > 0:
        raise InputError("image", "every sampled patch value is <= 0 after the black level: the "
                         "photo is black or the corners miss the chart")
    out = CLIPPED_SIGMA * float(M.max())
    ok = np.isfinite(sample.sigma) & (sample.sigma > 0) & ~(sample.clipped > 0)
    return M, np.where(ok, sample.sigma, out)


#: The engine of the fits (``sca.estimate``'s ``mode``): 'lm', the batch's variable projection
#: and Levenberg-Marquardt on the one chart (the DPP loop's optimum wherever the loop converges,
#: issue 21's target 4; no cvxpy), or 'safeguarded' / 'paper', the cvxpy loop
FIT_MODE = "lm"


def _fit(sample: PatchSample, setup, depth, distance, water, uncertain=None,
         mode=FIT_MODE, auxiliary=None):
    """sca.estimate with a free gain on the sample (and the auxiliary measurements)."""
    M, sig = _data(sample)
    return sca.estimate(M, depth=depth, distance=distance, sigma=sig, gain="free", setup=setup,
                        water=water, uncertain=uncertain, mode=mode, auxiliary=auxiliary or None)


def budget_for(uncertain, profile, measured_chart: bool = False,
               patch_floor: float | None = 0.0) -> dict:
    """The uncertainty budget of a measurement: ``uncertain`` as given, or the default
    (:data:`sca.budget.DEFAULT_UNCERTAIN`; with a measured chart its per-patch term is
    :data:`sca.budget_defaults.MEASURED_CHART_PATCH`) with the profile's own numbers where it
    has them: its per-patch systematic error (``patch``, never below ``patch_floor``) and the
    largest standard error of its channel gains (``balance``).

    Parameters
    ----------
    uncertain : dict or None
        The budget asked for (None: the default).
    profile : measure.Profile or None
        The camera's calibration.
    measured_chart : bool, optional
        The chart's own spectra were measured (``chart_reflectance``): the default per-patch
        term is what such a chart still leaves.
    patch_floor : float or None, optional
        The per-patch term underwater is at least this. Default 0: the calibration's value as it
        is. None: the default budget's own (1 %, or
        :data:`sca.budget_defaults.MEASURED_CHART_PATCH` with a measured chart), since the
        calibration in air measures the chart's and the camera's part under the light in air,
        not what only the light's path through water shows; not the default, for want of
        evidence (decision 0053-patch-floor).

    Returns
    -------
    dict
        name -> sd.
    """
    if uncertain is not None:
        return dict(uncertain)
    out = dict(sca.budget.DEFAULT_UNCERTAIN)
    if measured_chart:
        out["patch"] = MEASURED_CHART_PATCH
    floor = out["patch"] if patch_floor is None else float(patch_floor)
    if profile is not None:
        if profile.patch_sd is not None and np.isfinite(profile.patch_sd):
            out["patch"] = max(float(profile.patch_sd), floor)
        se = np.asarray(profile.gains_se, float)
        if se.size and np.all(np.isfinite(se)):
            out["balance"] = float(np.max(se))
    return out


def _choose_orientation(photo, lay, cands, setup, depth, distance, water, uncertain=None,
                        mode=FIT_MODE, auxiliary=None):
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
        return name, c, s, _fit(s, setup, depth, distance, water, uncertain, mode,
                                auxiliary), flags, notes
    pool = passing or list(cands)
    fits = {name: _fit(cands[name][1], setup, depth, distance, water, uncertain, mode,
                       auxiliary) for name in pool}
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
                                                          uncertain, mode, auxiliary), \
        ["orientation-unverified"], [f"orientation not verified: {why}; check --corners"]


def _band(estimate: sca.Estimate, depth, distance) -> np.ndarray:
    """(2, q) a 95 % band of the transmittance k = exp(-tau), tau = L c the path's optical
    depth, lower end first: tau's ends are L c at the ends of the attenuation coefficient's own
    interval (:mod:`sca.derived`: the correlation of C and a_CDOM included), L the fit's path
    length, widened by 1.96 times the relative sd of L the budget gives its depth and distance
    (c = tau / L: adding the two relative widths bounds tau's from above, so the band is
    conservative where the geometry is uncertain and exact where it is held)."""
    from sca.assess import Z95

    ci = np.asarray(estimate.beam_attenuation_ci, float)
    nuisance = estimate.nuisance or {}
    L = float(nuisance.get("depth", depth)) + float(nuisance.get("distance", distance))
    sd = [float(parse_sd(g, estimate.uncertain[g], ref)) if g in estimate.uncertain else 0.0
          for g, ref in (("depth", depth), ("distance", distance))]
    widen = np.exp(Z95 * np.hypot(*sd) / L)
    with np.errstate(over="ignore", invalid="ignore"):
        return np.vstack([np.exp(-L * ci[:, 1] * widen), np.exp(-L * ci[:, 0] / widen)])


def _fitted(est: sca.Estimate, setup, water, depth, distance) -> np.ndarray:
    """(m, n) the fit's patch values, raw units: the model at the estimate with the budget's
    nuisances (balance, camera shift, daylight, depth, distance, water constants) at their
    fitted values, under the best path model."""
    import dataclasses as dc

    from sca.model import PARAMS

    params = {"chl": est.chl, "cdom": est.cdom, "depth": depth, "distance": distance,
              "gain": est.gain, "backscatter": np.asarray(est.backscatter, float)}
    params.update({k: np.asarray(v, float) for k, v in (est.nuisance or {}).items()
                   if k in PARAMS})
    mdl = sca.ChartModel(setup, water=dc.replace(water, path_model=est.path_model))
    return np.asarray(mdl.predict(params, jacobian=False).values, float).reshape(
        mdl.m, mdl.n)


def _same_camera(recorded: str, camera) -> bool:
    """Whether a profile made for camera ``recorded`` (a name, a curves file as the user typed
    it, or 'custom') fits ``camera``: a curves file given by another path to the same file
    name (relative in calibrate, absolute in a dive) fits."""
    name = camera if isinstance(camera, str) else "custom"
    if recorded in ("custom", name):
        return True
    return isinstance(camera, (str, os.PathLike)) and forward.spectra.is_path(camera) \
        and Path(recorded).name == Path(camera).name


def measure(image, *, corners=None, depth, distance, camera=forward.DEFAULT_CAMERA,
            quantal: bool = False, profile=None, illuminant=None, layout="patches",
            water: forward.Water | None = None, black_level=None,
            white_level=None, light_field: str = "auto", uncertain=None,
            mode: str = FIT_MODE, auxiliary=None, chart_reflectance=None) -> Measurement:
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
    auxiliary : dict, optional
        What was measured of the water besides the photo, each with its sd, fused in the fit
        (:func:`sca.auxiliary.auxiliary_observations`): ``{'cdom': (value, sd)}`` a water
        sample's a_CDOM(440) (m^-1), ``'secchi': (depth, sd)`` a Secchi-disk depth (m),
        ``'kd': {nm: (value, sd)}`` a radiometer's K_d (m^-1).
    chart_reflectance : str or os.PathLike, optional
        The chart's own spectra measured with a spectrometer (a CSV,
        :func:`measure.camera.read_chart_reflectance`), replacing the nominal chart; the default
        budget's per-patch term is then :data:`sca.budget_defaults.MEASURED_CHART_PATCH`
        (:func:`budget_for`).

    Returns
    -------
    Measurement
        The estimate (C mg m^-3, a_CDOM(440) m^-1, the attenuation coefficient of the light's
        path and the quantities of :mod:`sca.derived` in m^-1 with their intervals and
        verdicts, gain, veiling light, the transmittance k and its band), the colour
        correction, flags, ``reliable`` and notes.

    Raises
    ------
    ValueError
        Naming the argument (``image``, ``corners``, ``profile``, ``layout``,
        ``light_field``, ``mode``, ``auxiliary``, ``chart_reflectance``, ...) when it is wrong
        (``image`` when ``corners`` is None and the chart found lies partly outside the
        frame); :class:`measure.ChartNotFound` (``no chart found``, with the reason) when
        ``corners`` is None and the photo shows no chart.

    References
    ----------
    H. Blasinski and J. Farrell, "A Three Parameter Underwater Image Formation Model", IS&T
    Electronic Imaging 2016, eqs 15-18 (the estimator), Fig 11 (the correction).

    Examples
    --------
    A generated photo (a DNG of a chart at 5 m, seen from 1.5 m) measured as a user's would be:

    >>> import tempfile, pathlib, measure
    >>> from measure.synthetic_photo import Scene, default_corners, render_mosaic, write_dng
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> corners = default_corners(360, 240)
    >>> photo = write_dng(render_mosaic(Scene(chl=2.0, cdom=0.1, depth=5.0, distance=1.5,
    ...                                       gain=30000, width=360, height=240, seed=2), corners),
    ...                   folder / "reef.dng")
    >>> m = measure.measure(photo, corners=corners, depth=5.0, distance=1.5)
    >>> m.estimate.verdicts["c_490"]
    'measured'
    >>> lo, hi = m.estimate.quantity_intervals["c_490"]
    >>> bool(lo < 0.130 < hi)     # the generated water's c(490), m^-1
    True
    """
    if mode not in sca.MODES:  # before any work
        raise InputError("mode", f"must be one of {sca.MODES}, got {mode!r}")
    photo = image if isinstance(image, Photo) else read_image(image, black_level=black_level,
                                                              white_level=white_level)
    profile_path = None
    if isinstance(profile, (str, bytes)) or hasattr(profile, "__fspath__"):
        profile_path, profile = os.path.abspath(os.fsdecode(profile)), load_profile(profile)
    if profile is not None and not isinstance(profile, Profile):
        raise InputError("profile", "expected a measure.Profile or the path of a profile JSON")
    depth = validate.scalar("depth", depth)
    distance = validate.scalar("distance", distance)
    water = resolve_water(water)
    auxiliary_observations(auxiliary, water)  # refused here, before any work
    lay = _layout(layout)
    refl = None if chart_reflectance is None else read_chart_reflectance(chart_reflectance)
    setup = camera_setup(camera, quantal=quantal, illuminant=illuminant,
                         gains=None if profile is None else profile.gains, reflectances=refl)
    if light_field != "auto" and light_field not in FIELDS:
        raise InputError("light_field", f"must be 'auto' or one of {tuple(FIELDS)}, got {light_field!r}")
    budget = budget_for(uncertain, profile, measured_chart=refl is not None)
    if corners is None:
        found = find_chart(photo, lay)
        found.check_in_frame(photo.size)
        corners, chart = found.corners, found.to_dict()
    else:
        chart = {"corners": parse_corners(corners).tolist(), "detected": False}
    cands = orientations(photo, corners, lay)
    name, c, sample, est, flags, notes = _choose_orientation(photo, lay, cands, setup, depth,
                                                             distance, water, budget, mode,
                                                             auxiliary)
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
            est = _fit(sample, fit_setup, depth, distance, water, budget, mode, auxiliary)
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
    elif not _same_camera(profile.camera, camera):
        raise InputError("profile", f"made for camera {profile.camera!r}, not {camera!r}")
    elif not profile.reliable:
        flags.append("unreliable-profile")
        notes.append(f"the camera profile is not reliable (flags: {', '.join(profile.flags)}): "
                     "recalibrate before trusting the water's colour")
    chart_file = None if refl is None else {"path": str(chart_reflectance),
                                            "sha256": chart_digest(chart_reflectance)}
    if profile is not None and (profile.chart or "") != (chart_file or {}).get("sha256", ""):
        used = "the nominal chart" if refl is None else "a measured chart"
        had = "another measured chart" if profile.chart else "the nominal chart"
        notes.append(f"the camera profile was calibrated with {had}, this photo is measured "
                     f"with {used}: calibrate with the same --chart-reflectance for a "
                     "consistent balance")
    all_flags = tuple(dict.fromkeys(list(est.flags) + flags))
    notes += [n for n in (span_note(all_flags, est.path_models),) if n]
    reliable = not any(f in BLOCKING or f in MEASURE_BLOCKING for f in all_flags)
    fitted = _fitted(est, fit_setup, water, depth, distance)
    gains, offset = correction(est, setup, sample.rgb[:, WHITE_PATCH])
    band = _band(est, depth, distance)
    cam = camera_record(camera, quantal=quantal, illuminant=illuminant, profile=profile,
                        profile_path=profile_path, photo=photo)
    inputs = {"depth_m": depth, "distance_m": distance,
              "depth_sd": est.uncertain.get("depth"), "distance_sd": est.uncertain.get("distance"),
              "uncertain": dict(est.uncertain),
              "water": {f.name: getattr(water, f.name) for f in dataclasses.fields(water)
                        if not f.name.endswith("_table")},
              "path_model": water.path_model, "light_field": light_field,
              "layout": dataclasses.asdict(lay), "chart": chart,
              "auxiliary": auxiliary_record(auxiliary), "chart_reflectance": chart_file}
    meas = Measurement(est, sample, name, c, gains, offset, fitted, band, cam, photo, setup,
                       all_flags, reliable, notes, field_report, inputs)
    from .correct_uncertainty import correction_spread
    from .correctwater import correction_water

    meas.correction_uncertainty = correction_spread(correction_water(meas),
                                                    chart_rgb=sample.rgb)
    return meas
