"""The camera of a photograph: its spectral curves, their channel balance, and its calibration.

Published sensitivity curves are often normalised to peak 1 per channel (colour-science's NPL
curves are, and :func:`forward.camera_sensitivities` normalises every camera so), so the
camera's true R:G:B balance is unknown -- and underwater that balance carries the colour of the
water. :func:`calibrate` fits it: from a photograph of the chart in air under a known
illuminant, the per-channel gains g_c with M_c = g_c (P^T diag(i) R)_c (weighted least squares,
one gain per channel, no offset: in air there is no veiling light). A :class:`Profile` stores
them; :func:`camera_setup` applies them to the curves. Curves that carry a measured balance
(a CSV or array whose channels do not all peak at 1, e.g. the Canon G7X's) keep it
(:func:`own_balance`); a profile's gains are relative to it.

``quantal=True`` says the curves act on photons (quantum efficiencies): they are converted to
act on energy, S_E(lambda) = S_Q(lambda) lambda (photons per unit energy are proportional to
lambda), before use.
"""

from __future__ import annotations

import json
import os
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

import forward
from forward.imaging import ChartSetup
from forward.errors import InputError

__all__ = [
    "CHART_PATCHES",
    "HASH_CHUNK_BYTES",
    "MIN_CALIBRATION_PATCHES",
    "PATCH_SD_MAX",
    "Profile",
    "calibrate",
    "camera_record",
    "camera_setup",
    "chart_digest",
    "curves_digest",
    "file_digest",
    "load_profile",
    "own_balance",
    "patch_systematic",
    "profile_digest",
    "read_chart_reflectance",
]

#: A calibration whose per-patch systematic error (beyond photon noise, relative) exceeds this
#: is not reliable: a ColorChecker's reflectance tolerance (0.1-0.7 % per patch) and a camera
#: curve's measurement error (~1 %) stay well below it; a wrong illuminant or wrong curves do
#: not (flag ``systematic``).
PATCH_SD_MAX = 0.03
#: Fewest unclipped patches a channel needs for its gain (half the chart): fewer, and the
#: channel is flagged ``few-patches-<R|G|B>``.
MIN_CALIBRATION_PATCHES = 12
#: Patches of a ColorChecker Classic: the columns of a measured chart's file
#: (:func:`read_chart_reflectance`).
CHART_PATCHES = 24
#: A reflectance factor above this is refused as not a 0-1 factor; above 1.5 the message
#: suggests the file is in percent (a ColorChecker's white is about 0.9).
_REFLECTANCE_MAX = 1.0


def read_chart_reflectance(path, wavelengths=None, *, name: str = "chart_reflectance"):
    """A chart's reflectance spectra measured with a spectrometer, on the grid.

    The file: a CSV (comma or semicolon; '#' comments and a header line allowed,
    :func:`forward.spectra.read_spectral_csv`) with the wavelength in nm, then
    :data:`CHART_PATCHES` columns of reflectance factor (0-1) in ColorChecker order (patch 1,
    dark skin, to patch 24, black: row by row), covering the grid (400-700 nm by default;
    resampled linearly).

    Parameters
    ----------
    path : str or os.PathLike
        The CSV file.
    wavelengths : array_like, optional
        The grid in nm (default 400-700 nm at 1 nm).
    name : str, optional
        The argument named in errors (``--chart-reflectance`` from the command line).

    Returns
    -------
    numpy.ndarray, (q, 24)
        Reflectance factors on the grid, one column per patch.

    Raises
    ------
    ValueError
        Naming ``name``: a missing or malformed file, not 24 value columns, a value outside
        0-1 (a file in percent is recognised and said so), a table that does not cover the
        grid, or a grey row (patches 19-24) that does not fall from white to black (columns
        not in ColorChecker order).
    """
    from forward.spectra import read_spectral_csv, resample

    wl_src, values = read_spectral_csv(path, name=name)
    if values.shape[1] != CHART_PATCHES:
        raise InputError(name, f"{path} has {values.shape[1]} reflectance columns; expected "
                         f"{CHART_PATCHES} (wavelength nm, then patch 1 dark skin ... patch 24 "
                         "black, in ColorChecker order)")
    top, bottom = float(values.max()), float(values.min())
    if top > _REFLECTANCE_MAX or bottom < 0:
        hint = " (the file looks like percent: divide by 100)" if top > 1.5 else ""
        raise InputError(name, f"{path}: reflectance factors must lie in 0-1, found "
                         f"{bottom:.4g}-{top:.4g}{hint}")
    wl = forward.wavelength_grid(wavelengths)
    refl = resample(wl_src, values, wl, name=name)
    grey = refl[:, 18:24].mean(axis=0)
    if not np.all(np.diff(grey) < 0):
        raise InputError(name, f"{path}: the grey row (patches 19-24) does not fall from "
                         "white to black (mean reflectance "
                         + ", ".join(f"{g:.3g}" for g in grey)
                         + "): the columns are not in ColorChecker order")
    return refl


#: Files are hashed in chunks of this many bytes (a 50 MB RAW file is not read into memory
#: at once; SHA-256 streams at several hundred MB/s, below a disk's or network's reading)
HASH_CHUNK_BYTES = 1 << 20


def file_digest(path) -> str:
    """The SHA-256 of a file's content, read in chunks.

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    str
        Hex digest.

    Raises
    ------
    OSError
        The file cannot be read.
    """
    import hashlib

    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(HASH_CHUNK_BYTES), b""):
            h.update(chunk)
    return h.hexdigest()


#: The SHA-256 of a measured chart's file (what a profile and a measurement record): the same
#: digest as any file's (:func:`file_digest`).
chart_digest = file_digest


@dataclass
class Profile:
    """A camera's channel balance, as fitted by :func:`calibrate` (``uw3p calibrate``'s JSON).

    Attributes
    ----------
    camera : str
        The colour-science camera name, or ``"custom"`` for curves given as an array or CSV.
    quantal : bool
        The curves were taken as quantum efficiencies (converted to act on energy).
    illuminant : str
        The illuminant of the calibration photo (``"D65"`` by default, ``"custom"``).
    gains : list of float, (3,)
        Relative channel gains (R, G, B), dimensionless, the largest 1, relative to the
        curves' own balance (:func:`own_balance`; (1, 1, 1) for peak-normalised curves).
    gains_se : list of float, (3,)
        Their standard errors, same scale.
    gains_raw : list of float, (3,)
        The gains in raw units (DN) per model unit of the calibration photo.
    chi2_dof : list of float, (3,)
        Reduced chi^2 of each channel's fit with photon noise alone, dimensionless (thousands
        of pixels per patch make it large on any real chart; it does not decide).
    fit_rms : list of float, (3,)
        Relative RMS residual of each channel, ||M - g G|| / ||M||.
    reliable : bool
        No flag was raised.
    flags : list of str
        ``systematic`` (the per-patch systematic error exceeds :data:`PATCH_SD_MAX`),
        ``few-patches-<R|G|B>``.
    image : str
        Path of the calibration photo.
    version : str
        uw3p's version that wrote it.
    patch_sd : float or None
        The per-patch systematic error beyond photon noise, relative (the uncertainty budget's
        ``patch``, :func:`patch_systematic`); None in profiles written before it was estimated.
    chi2_dof_patch : list of float or None
        Reduced chi^2 of each channel's fit with ``patch_sd`` in the noise (their pooled value
        is 1 by the definition of ``patch_sd``); None in profiles written before it.
    chart : str
        The chart the calibration used: '' for the nominal chart, else the SHA-256 of the
        measured chart's file (:func:`read_chart_reflectance`, :func:`chart_digest`).
    """

    camera: str
    quantal: bool
    illuminant: str
    gains: list
    gains_se: list
    gains_raw: list
    chi2_dof: list
    fit_rms: list
    reliable: bool
    flags: list = field(default_factory=list)
    image: str = ""
    version: str = ""
    patch_sd: float | None = None
    chi2_dof_patch: list | None = None
    chart: str = ""

    def to_json(self) -> str:
        """The profile as indented JSON text (what ``uw3p calibrate`` writes)."""
        return json.dumps(asdict(self), indent=1) + "\n"


def profile_digest(profile: Profile) -> str:
    """The SHA-256 of a profile's content (its JSON, :meth:`Profile.to_json`): the same
    calibration gives the same digest wherever its file lies."""
    import hashlib

    return hashlib.sha256(profile.to_json().encode()).hexdigest()


def curves_digest(camera) -> str:
    """The SHA-256 of a camera's curves as read (:func:`forward.camera_sensitivities`, their
    own balance, on the default grid; float64 little-endian bytes)."""
    import hashlib

    sens = forward.camera_sensitivities(camera, normalise=False)
    return hashlib.sha256(np.ascontiguousarray(sens, "<f8").tobytes()).hexdigest()


def camera_record(camera, *, quantal: bool = False, illuminant=None, profile=None,
                  profile_path=None, photo=None) -> dict:
    """What a measurement records of its camera (measurement.json's and joint.json's
    ``camera``): the curves' name and digest (:func:`curves_digest`), the photo's EXIF Make
    and Model (None where unknown), the calibration profile (its gains, the file's path where
    it was read from one, its digest :func:`profile_digest`) and the illuminant.

    Parameters
    ----------
    camera : str, path or array
        The curves (as :func:`camera_setup`).
    quantal : bool, optional
    illuminant : str or array, optional
    profile : Profile, optional
    profile_path : str or os.PathLike, optional
        The profile's file.
    photo : measure.Photo, optional
        The photo measured (its ``camera``: EXIF Make and Model).

    Returns
    -------
    dict
    """
    exif = getattr(photo, "camera", None) or {}
    prof = None if profile is None else {
        "gains": profile.gains, "illuminant": profile.illuminant, "image": profile.image,
        "path": None if profile_path is None else str(profile_path),
        "sha256": profile_digest(profile)}
    return {"name": camera if isinstance(camera, str) else "custom", "quantal": bool(quantal),
            "curves_sha256": curves_digest(camera), "make": exif.get("make"),
            "model": exif.get("model"), "profile": prof,
            "illuminant": _illuminant_record(illuminant)}


def _illuminant_record(illuminant):
    """How measurement.json names the light a camera set-up was built with: its name (None:
    D65), a file's path as given, or 'custom' for spectra given in memory (a later correction
    then needs them again: :func:`measure.correctcamera.correction_setup`)."""
    if illuminant is None:
        return "D65"
    if isinstance(illuminant, (str, os.PathLike)):
        return os.fspath(illuminant)
    return "custom"


def load_profile(path) -> Profile:
    """Read a profile written by ``uw3p calibrate``.

    Parameters
    ----------
    path : str or os.PathLike
        The profile's JSON file.

    Returns
    -------
    Profile
        The profile, its gains checked to be three positive finite numbers.

    Raises
    ------
    ValueError
        Naming the file, when it is missing, not JSON, not a profile, or its gains are invalid.
    """
    p = Path(path)
    if not p.exists():
        raise InputError("profile", f"{p}: no such file")
    if p.is_dir():
        raise InputError("profile", f"{p}: is a folder, not a profile JSON")
    try:
        data = json.loads(p.read_text(encoding="utf-8"))
        prof = Profile(**{k: data[k] for k in Profile.__dataclass_fields__ if k in data})
        gains = np.asarray(prof.gains, float)
    except (OSError, ValueError, TypeError, KeyError) as exc:
        raise InputError("profile", f"{p}: not a uw3p camera profile ({type(exc).__name__})") from None
    if gains.shape != (3,) or not np.all(np.isfinite(gains)) or np.any(gains <= 0):
        raise InputError("profile", f"{p}: gains must be three positive numbers, got {prof.gains}")
    return prof


def camera_setup(camera=forward.DEFAULT_CAMERA, *, quantal: bool = False, gains=None,
                 illuminant=None, wavelengths=None, reflectances=None) -> ChartSetup:
    """The chart set-up (camera, illuminant, chart on a grid) of a camera with a known balance.

    Parameters
    ----------
    camera : str, path or array, optional
        A colour-science camera name, a CSV of wavelength (nm), red, green, blue, or an array
        (q, 3) on the grid; default :data:`forward.DEFAULT_CAMERA`.
    quantal : bool, optional
        The curves act on photons (quantum efficiencies): they are converted to act on energy,
        S_E(lambda) = S_Q(lambda) lambda, before use.
    gains : array_like, (3,), optional
        Channel gains (a :class:`Profile`'s ``gains``, dimensionless, positive), relative to
        the curves' own balance (:func:`own_balance`, which is always applied: the set-up's
        balance is ``own_balance * gains``); default: the curves' own balance alone.
    illuminant : str, path or array, optional
        The surface illuminant (default D65).
    wavelengths : array_like, optional
        The grid in nm (default 400-700 nm at 1 nm).
    reflectances : optional
        The chart: as :func:`forward.chart_reflectances` (default the nominal ColorChecker;
        a measured chart's spectra on the grid, :func:`read_chart_reflectance`).

    Returns
    -------
    forward.ChartSetup
        Sensitivities, illuminant and ColorChecker reflectances on the grid.

    Raises
    ------
    ValueError
        When the camera has not three channels or ``gains`` are not three positive numbers.
    """
    wl = forward.wavelength_grid(wavelengths)
    sens = forward.camera_sensitivities(camera, wl, normalise=False)  # the curves' own balance
    if sens.shape[1] != 3:
        raise InputError("camera", f"expected three channels (red, green, blue), got {sens.shape[1]}")
    if quantal:
        sens = camera = sens * wl[:, None]  # photons -> energy, balance included
    if gains is not None:
        gains = np.asarray(gains, float)
        if gains.shape != (3,) or np.any(~np.isfinite(gains)) or np.any(gains <= 0):
            raise InputError("gains", f"expected three positive numbers, got {gains!r}")
    balance = own_balance(sens)
    total = balance if gains is None else balance * gains
    if gains is None and np.all(balance == 1.0):
        total = None  # peak-normalised curves (colour-science's NPL cameras): the cached set-up
    return forward.chart_setup(camera, illuminant, reflectances, wl, channel_gains=total)


def own_balance(sensitivities) -> np.ndarray:
    """The channel balance that a camera's curves carry: each channel's peak over the largest.

    Measured curves (the Canon G7X's of Blasinski & Farrell's uwSim, fitted against a
    monochromator) keep the camera's R:G:B balance; :func:`forward.camera_sensitivities`
    scales every channel to peak 1, so :func:`camera_setup` puts the balance back with
    :func:`forward.chart_setup`'s ``channel_gains``. Curves normalised per channel (the NPL
    curves of colour-science) give (1, 1, 1).

    Parameters
    ----------
    sensitivities : array_like, (q, 3)
        The curves on the grid as given (not normalised), any unit.

    Returns
    -------
    numpy.ndarray, (3,)
        Peak of each channel over the largest peak, dimensionless (a zero channel gives 1).
    """
    peak = np.max(np.asarray(sensitivities, float), axis=0)
    top = float(np.max(peak))
    return np.where(peak > 0, peak / top, 1.0)


def patch_systematic(residuals, sigma, values, dof: int) -> float:
    """The relative per-patch systematic error that the residuals show beyond photon noise.

    The sd f >= 0 with sum r^2 / (sigma^2 + (f M)^2) = dof (the method of moments: the reduced
    chi^2 with the systematic term in the noise is 1); 0 where the photon noise alone explains
    the residuals.

    Parameters
    ----------
    residuals, sigma, values : array_like
        Residuals r, photon-noise standard errors sigma and patch values M (same units).
    dof : int
        Degrees of freedom of the fit.

    Returns
    -------
    float
        f, relative (e.g. 0.005 for 0.5 % of each patch's value).

    References
    ----------
    JCGM 100:2008 (GUM), sec. 4.2 (Type A evaluation); the method of moments for a variance
    component (e.g. R. J. Paule and J. Mandel, J. Res. NBS 87 (1982) 377-385).
    """
    r2, s2, m2 = (np.asarray(a, float) ** 2 for a in (residuals, sigma, values))

    def excess(f):
        return float(np.sum(r2 / (s2 + f * f * m2))) - dof
    if dof <= 0 or excess(0.0) <= 0:
        return 0.0
    if excess(1.0) > 0:
        return 1.0
    from scipy import optimize  # only a calibration needs it (decision 0007-start-up)

    return float(optimize.brentq(excess, 0.0, 1.0, xtol=1e-6))


def calibrate(sample, *, camera=forward.DEFAULT_CAMERA, quantal: bool = False, illuminant=None,
              image: str = "", chart_reflectance=None) -> Profile:
    """Fit the per-channel gains of ``camera`` from a chart photographed in air.

    Per channel, weighted least squares through the origin (in air there is no veiling light):
    g_c = sum(w M G) / sum(w G^2), w = 1 / sigma^2, with G = P^T diag(i) R the model's patch
    values, its standard error 1 / sqrt(sum(w G^2)), the reduced chi^2 and fit_rms. Clipped
    patch values are left out.

    Parameters
    ----------
    sample : measure.PatchSample
        The chart's patch values and standard errors in raw units (DN), from
        :func:`measure.sample_patches` of a photo in air.
    camera : str, path or array, optional
        As :func:`camera_setup`.
    quantal : bool, optional
        As :func:`camera_setup`.
    illuminant : str, path or array, optional
        The illuminant of the photo in air (default D65).
    image : str, optional
        Path of the photo, recorded in the profile.
    chart_reflectance : str or os.PathLike, optional
        The chart's spectra measured with a spectrometer (:func:`read_chart_reflectance`),
        replacing the nominal chart; the profile records its file's SHA-256 (``chart``).

    Returns
    -------
    Profile
        Gains relative to the largest (and in raw units per model unit), their standard errors
        (with the per-patch systematic term in the noise) and goodness of fit, and the
        per-patch systematic error ``patch_sd`` that the residuals show beyond photon noise
        (:func:`patch_systematic`). ``reliable`` is False (with ``flags``) when ``patch_sd``
        exceeds :data:`PATCH_SD_MAX` (the curves or the illuminant do not describe the photo)
        or fewer than :data:`MIN_CALIBRATION_PATCHES` patches remain in a channel. The
        reduced chi^2 of each channel (photon noise only) is recorded; with thousands of
        pixels per patch it is above 1 for any real chart, and it no longer decides; with
        ``patch_sd`` in the noise it is ``chi2_dof_patch`` (pooled over the channels, 1).
    """
    refl = None if chart_reflectance is None else read_chart_reflectance(chart_reflectance)
    setup = camera_setup(camera, quantal=quantal, illuminant=illuminant, reflectances=refl)
    G = setup.sensitivities.T @ (setup.illuminant[:, None] * setup.reflectances)  # (3, 24)
    M, sig = np.asarray(sample.rgb, float), np.asarray(sample.sigma, float)
    use = (np.asarray(sample.clipped) == 0) & np.isfinite(sig) & (sig > 0)
    gains, se, chi2, rms, flags = np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3), []
    for c in range(3):
        u = use[c]
        if u.sum() < MIN_CALIBRATION_PATCHES:
            flags.append(f"few-patches-{'RGB'[c]}")
            gains[c] = se[c] = chi2[c] = rms[c] = np.nan
            continue
        w = 1.0 / sig[c, u] ** 2
        g = float(np.sum(w * M[c, u] * G[c, u]) / np.sum(w * G[c, u] ** 2))
        r = M[c, u] - g * G[c, u]
        dof = int(u.sum()) - 1
        gains[c], se[c] = g, 1.0 / np.sqrt(np.sum(w * G[c, u] ** 2))
        chi2[c] = float(np.sum(w * r * r)) / dof
        rms[c] = float(np.linalg.norm(r) / np.linalg.norm(M[c, u]))
    resid, sig_all, val_all, dof_all = [], [], [], 0
    for c in range(3):
        u = use[c]
        if np.isfinite(gains[c]):
            resid.append(M[c, u] - gains[c] * G[c, u])
            sig_all.append(sig[c, u])
            val_all.append(M[c, u])
            dof_all += int(u.sum()) - 1
    patch_sd = patch_systematic(np.concatenate(resid), np.concatenate(sig_all),
                                np.concatenate(val_all), dof_all) if resid else float("nan")
    if not patch_sd <= PATCH_SD_MAX:
        flags.append("systematic")
    chi2_patch = np.full(3, np.nan)
    for c in range(3):  # the gains' standard errors and chi^2 with the systematic term
        u = use[c]
        if np.isfinite(gains[c]):
            w = 1.0 / (sig[c, u] ** 2 + (patch_sd * M[c, u]) ** 2)
            se[c] = 1.0 / np.sqrt(np.sum(w * G[c, u] ** 2))
            chi2_patch[c] = float(np.sum(w * (M[c, u] - gains[c] * G[c, u]) ** 2)) / (
                int(u.sum()) - 1)
    top = np.nanmax(gains)
    name = camera if isinstance(camera, str) else "custom"
    illum = illuminant if isinstance(illuminant, str) else ("D65" if illuminant is None else "custom")
    return Profile(camera=name, quantal=bool(quantal), illuminant=illum,
                   gains=(gains / top).tolist(), gains_se=(se / top).tolist(),
                   gains_raw=gains.tolist(), chi2_dof=chi2.tolist(), fit_rms=rms.tolist(),
                   reliable=not flags, flags=flags, image=str(image), version=_version(),
                   patch_sd=float(patch_sd), chi2_dof_patch=chi2_patch.tolist(),
                   chart="" if chart_reflectance is None else chart_digest(chart_reflectance))


def _version() -> str:
    try:
        from importlib.metadata import version
        return version("uw3p")
    except Exception:
        return ""

