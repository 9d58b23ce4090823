"""Image formation: path attenuation k (eqs 3, 13, 14), veiling light (eq 2), camera response (eq 1).

Lengths in m, wavelengths in nm. ``depth`` is the chart's depth below the surface, ``distance``
the camera-to-chart distance (horizontal viewing, camera at the chart's depth); see DECISIONS.md.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from . import validate
from .spectra import (
    DEFAULT_CAMERA,
    camera_sensitivities,
    chart_reflectances,
    illuminant_spd,
    quadrature_weights,
    wavelength_grid,
)
from .water import PATH_MODELS, Water, resolve_water  # noqa: F401  (PATH_MODELS: re-exported)


def length(name: str, value) -> np.ndarray:
    """A path length in m (scalar or array): finite and >= 0, else ``ValueError`` naming it."""
    return validate.nonnegative(name, value, unit="m")


def path_length(depth, distance) -> np.ndarray:
    """Total path L = depth + distance in m: down to the chart, then to the camera (eq 3's d)."""
    return length("depth", depth) + length("distance", distance)


def attenuation(wavelengths=None, chl=1.0, cdom=0.1, depth=10.0, distance=5.0, *,
                path_model: str | None = None, water: Water | None = None, basis=None,
                weights=None, cdom_slope: float | None = None) -> np.ndarray:
    """Path attenuation k(lambda) = exp(-(depth + distance) c(lambda)), dimensionless (eqs 3, 14).

    ``water`` (:class:`forward.Water`, default the paper's) gives c; its path model 'absorption'
    (or ``path_model='absorption'``) uses the paper's literal eq 13, exp(-d a(lambda)).
    Broadcasts over array ``chl``/``cdom``/``depth``/``distance`` (all of one shape S): (S..., q).
    """
    wl = wavelength_grid(wavelengths)
    L = path_length(depth, distance)
    water = resolve_water(water, path_model=path_model, cdom_slope=cdom_slope)
    terms = water.on_grid(wl, basis=basis, weights=weights)
    coef = terms.coefficient(validate.nonnegative("chl", chl), validate.nonnegative("cdom", cdom))
    return np.exp(-L[..., None] * coef)


def veiling_light(wavelengths=None, chl=1.0, cdom=0.1, depth=10.0, distance=5.0, *,
                  illuminant=None, water: Water | None = None, basis=None, weights=None,
                  cdom_slope: float | None = None) -> np.ndarray:
    """Backscattered (veiling) light rho_b(lambda) of eq 2, in the units of i(lambda) x reflectance.

    Single scattering along the camera ray of length ``distance`` at the chart's depth, lit by
    the surface illuminant attenuated over ``depth``:

        rho_b = i(lambda) exp(-c depth) (b_b / c) (1 - exp(-c distance)),

    the classical veiling-light form (b_b / c is the asymptote of an infinitely long ray).
    Uses the beam attenuation c (eq 4) and b_b of :meth:`forward.WaterTerms.backscattering`,
    whatever the path model.
    """
    wl = wavelength_grid(wavelengths)
    i = illuminant_spd(illuminant, wl)
    d = length("depth", depth)
    r = length("distance", distance)
    terms = resolve_water(water, cdom_slope=cdom_slope).on_grid(wl, basis=basis, weights=weights)
    chl, cdom = validate.nonnegative("chl", chl), validate.nonnegative("cdom", cdom)
    c = terms.beam_coefficient(chl, cdom)
    bb = terms.backscattering(chl)
    return i * np.exp(-d[..., None] * c) * (bb / c) * -np.expm1(-r[..., None] * c)


@dataclass(frozen=True, eq=False)
class ChartSetup:
    """The fixed matrices of eq 15 on one wavelength grid.

    Attributes
    ----------
    wavelengths : (q,) nm
    sensitivities : (q, m) the matrix P of eq 15: camera sensitivities times the quadrature
        weights of eq 1, scaled so that a perfect white reflector in air under the illuminant
        gives 1 in the most sensitive channel. Model signals are in these units.
    illuminant : (q,) relative SPD i of the surface illuminant (max 1).
    reflectances : (q, n) R.
    camera : the camera's name (or 'custom').
    """

    wavelengths: np.ndarray
    sensitivities: np.ndarray
    illuminant: np.ndarray
    reflectances: np.ndarray
    camera: str
    raw_sensitivities: np.ndarray

    @property
    def white_response(self) -> np.ndarray:
        """Model signal (m,) of a perfect white reflector in air: P^T i."""
        return self.sensitivities.T @ self.illuminant


def chart_setup(camera=DEFAULT_CAMERA, illuminant=None, reflectances=None, wavelengths=None,
                channel_gains=None) -> ChartSetup:
    """Build the P, i, R of eq 15 on a grid; used by both the simulator and the estimator.

    ``channel_gains`` (m,): the camera's channel balance, multiplying its peak-normalised curves
    (:func:`camera_sensitivities`) before P is scaled (a calibrated camera; default: none).
    Named (string) inputs are cached, so repeated calls return the same object.
    """
    wl = wavelength_grid(wavelengths)
    if channel_gains is None and all(
            x is None or (isinstance(x, str) and not x.lower().endswith((".csv", ".txt")))
            for x in (camera, illuminant, reflectances)):
        return _chart_setup_named(camera, illuminant, reflectances, tuple(wl))
    return _build_setup(camera, illuminant, reflectances, wl, channel_gains)


@functools.lru_cache(maxsize=32)
def _chart_setup_named(camera, illuminant, reflectances, wl_key):
    return _build_setup(camera, illuminant, reflectances, np.array(wl_key))


def _build_setup(camera, illuminant, reflectances, wl, channel_gains=None) -> ChartSetup:
    sens = camera_sensitivities(camera, wl)
    if channel_gains is not None:
        g = np.asarray(channel_gains, dtype=float)
        if g.shape != (sens.shape[1],) or not np.all(np.isfinite(g)) or np.any(g <= 0):
            raise ValueError(f"channel_gains: expected {sens.shape[1]} positive numbers, got "
                             f"{channel_gains!r}")
        sens = sens * g
    i = illuminant_spd(illuminant, wl)
    R = chart_reflectances(reflectances, wl)
    P = sens * quadrature_weights(wl)[:, None]
    white = P.T @ i
    P = P / white.max()
    name = camera if isinstance(camera, str) else "custom"
    wl = np.array(wl, dtype=float)
    for arr in (wl, P, i, R, sens):
        arr.setflags(write=False)
    return ChartSetup(wl, P, i, R, name, sens)


def resolve_setup(setup, camera=DEFAULT_CAMERA, illuminant=None, reflectances=None,
                  wavelengths=None) -> ChartSetup:
    """``setup`` if given (checking that ``wavelengths``, if also given, is its grid), else
    :func:`chart_setup` of the other arguments."""
    if setup is None:
        return chart_setup(camera, illuminant, reflectances, wavelengths)
    if not isinstance(setup, ChartSetup):
        raise ValueError("setup: expected a forward.ChartSetup (from forward.chart_setup)")
    if wavelengths is not None and not np.array_equal(np.asarray(wavelengths, float), setup.wavelengths):
        raise ValueError("wavelengths: differ from the grid of the given setup")
    return setup


def camera_response(sensitivities, illuminant, attenuation, reflectances, backscatter=None) -> np.ndarray:
    """m = P^T diag(i) diag(k) R + s 1^T (eqs 1, 15): the noise-free (m, n) patch values.

    ``attenuation`` may be (q,) or (N, q) (then the result is (N, m, n)); ``backscatter`` is
    (m,) or (N, m).
    """
    P = np.asarray(sensitivities, dtype=float)
    i = np.asarray(illuminant, dtype=float)
    R = np.asarray(reflectances, dtype=float)
    k = np.asarray(attenuation, dtype=float)
    out = np.einsum("qm,...q,qn->...mn", P, i * k, R)
    if backscatter is not None:
        out = out + np.asarray(backscatter, dtype=float)[..., :, None]
    return out
