"""The camera of a photograph: its spectral curves, their channel balance, and its calibration.

Published sensitivity curves are often normalised to peak 1 per channel (colour-science's NPL
curves are, and :func:`forward.camera_sensitivities` normalises every camera so), so the
camera's true R:G:B balance is unknown -- and underwater that balance carries the colour of the
water. :func:`calibrate` fits it: from a photograph of the chart in air under a known
illuminant, the per-channel gains g_c with M_c = g_c (P^T diag(i) R)_c (weighted least squares,
one gain per channel, no offset: in air there is no veiling light). A :class:`Profile` stores
them; :func:`camera_setup` applies them to the curves.

``quantal=True`` says the curves act on photons (quantum efficiencies): they are converted to
act on energy, S_E(lambda) = S_Q(lambda) lambda (photons per unit energy are proportional to
lambda), before use.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
from scipy import stats

import forward
from forward.imaging import ChartSetup

__all__ = ["Profile", "camera_setup", "calibrate", "load_profile", "CALIBRATION_MISFIT_P"]

#: A calibration whose chi^2 p-value is below this is reported as a misfit (the curves or the
#: illuminant do not describe the photo); as sca.assess.MISFIT_P.
CALIBRATION_MISFIT_P = 1e-3


@dataclass
class Profile:
    """A camera's channel balance from :func:`calibrate`: ``gains`` (3,) relative, largest 1;
    ``gains_raw`` (3,) raw units per model unit of the calibration photo; goodness of fit."""

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

    def to_json(self) -> str:
        return json.dumps(asdict(self), indent=1) + "\n"


def load_profile(path) -> Profile:
    """Read a profile written by ``uw3p calibrate`` (ValueError naming the file if it is not)."""
    p = Path(path)
    try:
        data = json.loads(p.read_text(encoding="utf-8"))
        prof = Profile(**{k: data[k] for k in Profile.__dataclass_fields__ if k in data})
        gains = np.asarray(prof.gains, float)
    except (OSError, ValueError, TypeError, KeyError) as exc:
        raise ValueError(f"profile: {p}: not a uw3p camera profile ({type(exc).__name__})") from None
    if gains.shape != (3,) or not np.all(np.isfinite(gains)) or np.any(gains <= 0):
        raise ValueError(f"profile: {p}: gains must be three positive numbers, got {prof.gains}")
    return prof


def camera_setup(camera=forward.DEFAULT_CAMERA, *, quantal: bool = False, gains=None,
                 illuminant=None, wavelengths=None) -> ChartSetup:
    """The :class:`forward.ChartSetup` of ``camera`` (a colour-science name or a CSV of
    wavelength, red, green, blue), its curves converted from photons to energy if ``quantal``,
    each channel scaled by ``gains`` (a profile's balance; default: the curves as they are)."""
    wl = forward.wavelength_grid(wavelengths)
    sens = forward.camera_sensitivities(camera, wl)
    if sens.shape[1] != 3:
        raise ValueError(f"camera: expected three channels (red, green, blue), got {sens.shape[1]}")
    if quantal:
        camera = sens * wl[:, None]  # photons -> energy (renormalised to peak 1 by forward)
    if gains is not None:
        gains = np.asarray(gains, float)
        if gains.shape != (3,) or np.any(~np.isfinite(gains)) or np.any(gains <= 0):
            raise ValueError(f"gains: expected three positive numbers, got {gains!r}")
    return forward.chart_setup(camera, illuminant, None, wl, channel_gains=gains)


def calibrate(sample, *, camera=forward.DEFAULT_CAMERA, quantal: bool = False, illuminant=None,
              image: str = "") -> Profile:
    """Fit the per-channel gains of ``camera`` from a chart photographed in air
    (:class:`measure.PatchSample` in raw units) under ``illuminant`` (default D65).

    Per channel: g_c = sum(w M G) / sum(w G^2), w = 1 / sigma^2, its standard error, the
    reduced chi^2 and fit_rms. Clipped patch values are left out. ``reliable`` is False (with
    ``flags``) when a channel misfits (chi^2 p-value below CALIBRATION_MISFIT_P) or fewer than
    12 patches remain in a channel.
    """
    setup = camera_setup(camera, quantal=quantal, illuminant=illuminant)
    G = setup.sensitivities.T @ (setup.illuminant[:, None] * setup.reflectances)  # (3, 24)
    M, sig = np.asarray(sample.rgb, float), np.asarray(sample.sigma, float)
    use = (np.asarray(sample.clipped) == 0) & np.isfinite(sig) & (sig > 0)
    gains, se, chi2, rms, flags = np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3), []
    for c in range(3):
        u = use[c]
        if u.sum() < 12:
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
        if stats.chi2.sf(chi2[c] * dof, dof) < CALIBRATION_MISFIT_P:
            flags.append(f"misfit-{'RGB'[c]}")
    top = np.nanmax(gains)
    name = camera if isinstance(camera, str) else "custom"
    illum = illuminant if isinstance(illuminant, str) else ("D65" if illuminant is None else "custom")
    return Profile(camera=name, quantal=bool(quantal), illuminant=illum,
                   gains=(gains / top).tolist(), gains_se=(se / top).tolist(),
                   gains_raw=gains.tolist(), chi2_dof=chi2.tolist(), fit_rms=rms.tolist(),
                   reliable=not flags, flags=flags, image=str(image), version=_version())


def _version() -> str:
    try:
        from importlib.metadata import version
        return version("uw3p")
    except Exception:
        return ""
