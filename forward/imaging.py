"""Image formation: path attenuation k (eqs 3, 13, 14), veiling light (eq 2), camera response (eq 1).

Lengths in m, wavelengths in nm. ``depth`` is the chart's depth below the surface, ``distance``
the camera-to-chart distance (horizontal viewing, camera at the chart's depth); see decision
0013-geometry-path-length.
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
    is_path,
    quadrature_weights,
    wavelength_grid,
)
from .daylight import D_SERIES_CCT
from .water import DIFFUSE_TERMS, PATH_MODELS, Water, resolve_water  # PATH_MODELS: re-exported
from forward.errors import InputError

__all__ = [
    "PATH_MODELS",
    "ChartSetup",
    "attenuation",
    "camera_response",
    "chart_setup",
    "length",
    "path_length",
    "resolve_setup",
    "veiling_light",
]


def length(name: str, value) -> np.ndarray:
    """Check a path length in m (scalar or array): finite and >= 0, else ``ValueError`` naming it.

    Parameters
    ----------
    name : str
        The argument's name (e.g. ``'depth'``), used at the start of the error message.
    value : float or array_like
        The length, m.

    Returns
    -------
    numpy.ndarray
        ``value`` as a float array (0-d for a scalar), m.

    Raises
    ------
    ValueError
        If any element is negative or not finite.
    """
    return validate.nonnegative(name, value, unit="m")


def path_length(depth, distance) -> np.ndarray:
    """Total path L = depth + distance in m: down to the chart, then to the camera (eq 3's d).

    Parameters
    ----------
    depth : float or array_like
        Depth of the chart below the surface, m (the daylight's path down).
    distance : float or array_like
        Camera-to-chart distance, m (horizontal view at the chart's depth).

    Returns
    -------
    numpy.ndarray
        L, m (broadcast shape of ``depth`` and ``distance``; 0-d for scalars).

    Raises
    ------
    ValueError
        If a length is negative or not finite.

    References
    ----------
    Blasinski & Farrell, eqs 3, 13 and 14 (the path length d); decision 0013-geometry-path-length.
    """
    return length("depth", depth) + length("distance", distance)


def attenuation(wavelengths=None, chl=1.0, cdom=0.1, depth=10.0, distance=5.0, *,
                path_model: str | None = None, water: Water | None = None, basis=None,
                weights=None, cdom_slope: float | None = None) -> np.ndarray:
    """Path attenuation k(lambda) = exp(-(depth + distance) c(lambda)), dimensionless (eqs 3, 14).

    ``water`` (:class:`forward.Water`, default the paper's) gives c; its path model 'absorption'
    (or ``path_model='absorption'``) uses the paper's literal eq 13, exp(-d a(lambda)).

    Parameters
    ----------
    wavelengths : array_like, shape (q,), optional
        Wavelengths in nm (default: 400-700 nm at 1 nm).
    chl : float or array_like, shape S
        Chlorophyll concentration C, mg m^-3 (default 1).
    cdom : float or array_like, shape S
        a_CDOM(440 nm), m^-1 (default 0.1).
    depth : float or array_like, shape S
        Depth of the chart below the surface, m (default 10).
    distance : float or array_like, shape S
        Camera-to-chart distance, m (default 5).
    path_model : {'beam', 'absorption', 'split'}, optional
        Replaces ``water.path_model``.
    water : Water, optional
        The water model (default: the paper's).
    basis : array_like, shape (q,) or (q, z), or str or os.PathLike, optional
        The phytoplankton basis T of eq 9 (default: the water's table).
    weights : array_like, shape (z,), optional
        The shape w of eq 9 for z > 1 basis functions.
    cdom_slope : float, optional
        S of eq 6, nm^-1; replaces ``water.cdom_slope``.

    Returns
    -------
    numpy.ndarray, shape S + (q,)
        k, dimensionless. Broadcasts over array ``chl``/``cdom``/``depth``/
        ``distance`` (all of one shape S).

    Raises
    ------
    ValueError
        For negative or non-finite concentrations or lengths, or an invalid grid or water.

    References
    ----------
    Blasinski & Farrell, eqs 3, 4, 13 and 14; decision
    0013-geometry-path-length.
    """
    wl = wavelength_grid(wavelengths)
    path_length(depth, distance)  # checks both lengths
    water = resolve_water(water, path_model=path_model, cdom_slope=cdom_slope)
    terms = water.on_grid(wl, basis=basis, weights=weights)
    tau, _ = terms.optical_depth(validate.nonnegative("chl", chl),
                                 validate.nonnegative("cdom", cdom), depth, distance)
    return np.exp(-tau)


def veiling_light(wavelengths=None, chl=1.0, cdom=0.1, depth=10.0, distance=5.0, *,
                  illuminant=None, water: Water | None = None, basis=None, weights=None,
                  cdom_slope: float | None = None) -> np.ndarray:
    """Backscattered (veiling) light rho_b(lambda) of eq 2, in the units of i(lambda) x reflectance.

    Single scattering along the camera ray of length ``distance`` at the chart's depth, lit by
    the surface illuminant attenuated over ``depth``:

        rho_b = i(lambda) exp(-c depth) (b_b / c) (1 - exp(-c distance)),

    the classical veiling-light form (b_b / c is the asymptote of an infinitely long ray).
    Uses the beam attenuation c (eq 4) and b_b of :meth:`forward.WaterTerms.backscattering`
    (for the 'split' path model the way down is attenuated by K_d instead of c).

    Parameters
    ----------
    wavelengths : array_like, shape (q,), optional
        Wavelengths in nm (default: 400-700 nm at 1 nm).
    chl : float or array_like, shape S
        Chlorophyll concentration C, mg m^-3 (default 1).
    cdom : float or array_like, shape S
        a_CDOM(440 nm), m^-1 (default 0.1).
    depth : float or array_like, shape S
        Depth of the chart (and camera) below the surface, m (default 10).
    distance : float or array_like, shape S
        Camera-to-chart distance, m (default 5).
    illuminant : optional
        The surface illuminant, as for :func:`forward.illuminant_spd` (default D65; scaled to
        maximum 1).
    water : Water, optional
        The water model (default: the paper's); of its path model only 'split' matters here.
    basis : array_like, shape (q,) or (q, z), or str or os.PathLike, optional
        The phytoplankton basis T of eq 9 (default: the water's table).
    weights : array_like, shape (z,), optional
        The shape w of eq 9 for z > 1 basis functions.
    cdom_slope : float, optional
        S of eq 6, nm^-1; replaces ``water.cdom_slope``.

    Returns
    -------
    numpy.ndarray, shape S + (q,)
        rho_b, in the units of i(lambda) x reflectance (the units of the direct term i k r).

    Raises
    ------
    ValueError
        For negative or non-finite concentrations or lengths, or an invalid grid, illuminant
        or water.

    References
    ----------
    Blasinski & Farrell, eq 2 (which leaves rho_b unmodelled) and eq 4; decision
    0016-veiling-light.
    """
    wl = wavelength_grid(wavelengths)
    i = illuminant_spd(illuminant, wl)
    d = length("depth", depth)
    r = length("distance", distance)
    water = resolve_water(water, cdom_slope=cdom_slope)
    terms = water.on_grid(wl, basis=basis, weights=weights)
    chl, cdom = validate.nonnegative("chl", chl), validate.nonnegative("cdom", cdom)
    c = terms.beam_coefficient(chl, cdom)
    bb = terms.backscattering(chl)
    # the daylight's way down: c, or K_d for the 'split' path model
    down = (terms.path_coefficient(chl, cdom, terms=DIFFUSE_TERMS)[0]
            if water.path_model == "split" else c)
    return i * np.exp(-d[..., None] * down) * (bb / c) * -np.expm1(-r[..., None] * c)


@dataclass(frozen=True, eq=False)
class ChartSetup:
    """The fixed matrices of eq 15 on one wavelength grid.

    Build one with :func:`chart_setup`; every parameter is also a (read-only) attribute.

    Parameters
    ----------
    wavelengths : numpy.ndarray, shape (q,)
        The grid, nm.
    sensitivities : numpy.ndarray, shape (q, m)
        The matrix P of eq 15: camera sensitivities times the quadrature weights of eq 1 (nm),
        scaled so that a perfect white reflector in air under the illuminant gives 1 in the
        most sensitive channel. Model signals are in these units.
    illuminant : numpy.ndarray, shape (q,)
        Relative SPD i of the surface illuminant (max 1).
    reflectances : numpy.ndarray, shape (q, n)
        R, reflectance factors of the n patches.
    camera : str
        The camera's name (or 'custom').
    raw_sensitivities : numpy.ndarray, shape (q, m)
        The camera's peak-normalised sensitivities times ``channel_gains`` (if any), before
        the quadrature weights and the scaling of P (used by the sensor to count photons).
    daylight_cct : float, optional
        The correlated colour temperature of the illuminant as a daylight, K: a CIE D
        illuminant's (:data:`forward.daylight.D_SERIES_CCT`), else D65's; the reference of
        the uncertainty budget's ``daylight`` term (:class:`forward.daylight.DaylightTilt`).

    References
    ----------
    Blasinski & Farrell, eqs 1 and 15.
    """

    wavelengths: np.ndarray
    sensitivities: np.ndarray
    illuminant: np.ndarray
    reflectances: np.ndarray
    camera: str
    raw_sensitivities: np.ndarray
    daylight_cct: float = D_SERIES_CCT["D65"]

    @property
    def white_response(self) -> np.ndarray:
        """Model signal of a perfect white reflector in air: P^T i.

        Returns
        -------
        numpy.ndarray, shape (m,)
            In model units; 1 in the most sensitive channel.

        References
        ----------
        Blasinski & Farrell, eq 15 with k = 1, R = 1, s = 0.
        """
        return self.sensitivities.T @ self.illuminant


def chart_setup(camera=DEFAULT_CAMERA, illuminant=None, reflectances=None, wavelengths=None,
                channel_gains=None) -> ChartSetup:
    """Build the P, i, R of eq 15 on a grid; used by both the simulator and the estimator.

    Named (string) inputs are cached, so repeated calls return the same object.

    Parameters
    ----------
    camera : optional
        As for :func:`forward.camera_sensitivities` (default 'Nikon 5100 (NPL)').
    illuminant : optional
        As for :func:`forward.illuminant_spd` (default D65).
    reflectances : optional
        As for :func:`forward.chart_reflectances` (default the 24 'BabelColor Average'
        patches).
    wavelengths : array_like, shape (q,), optional
        Wavelengths in nm (default: 400-700 nm at 1 nm).
    channel_gains : array_like, shape (m,), optional
        The camera's channel balance (positive, dimensionless), multiplying its peak-normalised
        curves (:func:`camera_sensitivities`) before P is scaled (a calibrated camera;
        default: none).

    Returns
    -------
    ChartSetup
        The matrices P (scaled: white in air = 1 in the most sensitive channel), i and R; all
        arrays read-only.

    Raises
    ------
    ValueError
        For an invalid grid, camera, illuminant, chart or ``channel_gains``.

    References
    ----------
    Blasinski & Farrell, eqs 1 and 15.
    """
    wl = wavelength_grid(wavelengths)
    # only built-in names are cached: a file's numbers may change under the same name
    if channel_gains is None and all(x is None or (isinstance(x, str) and not is_path(x))
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
            raise InputError("channel_gains", f"expected {sens.shape[1]} positive numbers, got "
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
    cct = D_SERIES_CCT.get(illuminant.upper(), D_SERIES_CCT["D65"]) \
        if isinstance(illuminant, str) and not is_path(illuminant) else D_SERIES_CCT["D65"]
    return ChartSetup(wl, P, i, R, name, sens, cct)


def resolve_setup(setup, camera=DEFAULT_CAMERA, illuminant=None, reflectances=None,
                  wavelengths=None) -> ChartSetup:
    """Return ``setup`` if given, else :func:`chart_setup` of the other arguments.

    Parameters
    ----------
    setup : ChartSetup or None
        A prebuilt setup; when given, ``camera``, ``illuminant`` and ``reflectances`` are
        ignored.
    camera, illuminant, reflectances : optional
        As for :func:`chart_setup`.
    wavelengths : array_like, shape (q,), optional
        Wavelengths in nm; with ``setup``, checked to be its grid.

    Returns
    -------
    ChartSetup
        ``setup`` or a new (possibly cached) one.

    Raises
    ------
    ValueError
        If ``setup`` is not a :class:`ChartSetup`, or ``wavelengths`` differ from its grid.
    """
    if setup is None:
        return chart_setup(camera, illuminant, reflectances, wavelengths)
    if not isinstance(setup, ChartSetup):
        raise InputError("setup", "expected a forward.ChartSetup (from forward.chart_setup)")
    if wavelengths is not None and not np.array_equal(np.asarray(wavelengths, float), setup.wavelengths):
        raise InputError("wavelengths", "differ from the grid of the given setup")
    return setup


def camera_response(sensitivities, illuminant, attenuation, reflectances, backscatter=None) -> np.ndarray:
    """m = P^T diag(i) diag(k) R + s 1^T (eqs 1, 15): the noise-free (m, n) patch values.

    Parameters
    ----------
    sensitivities : array_like, shape (q, m)
        P (:attr:`ChartSetup.sensitivities`).
    illuminant : array_like, shape (q,)
        i, relative (max 1).
    attenuation : array_like, shape (q,) or (N, q)
        k, dimensionless (:func:`attenuation`).
    reflectances : array_like, shape (q, n)
        R.
    backscatter : array_like, shape (m,) or (N, m), optional
        s, the veiling light per channel in model units (default: none).

    Returns
    -------
    numpy.ndarray, shape (m, n) or (N, m, n)
        Patch values in model units (a white reflector in air = 1 in the most sensitive
        channel).

    References
    ----------
    Blasinski & Farrell, eqs 1, 2, 3 and 15.
    """
    P = np.asarray(sensitivities, dtype=float)
    i = np.asarray(illuminant, dtype=float)
    R = np.asarray(reflectances, dtype=float)
    k = np.asarray(attenuation, dtype=float)
    out = np.einsum("qm,...q,qn->...mn", P, i * k, R)
    if backscatter is not None:
        out = out + np.asarray(backscatter, dtype=float)[..., :, None]
    return out
