"""The public function API: one function per physical term of eqs 4-12 (each a view of
:class:`forward.water.Water` on a grid; ``water=None`` is the paper's model), in m^-1.
"""

from __future__ import annotations


import numpy as np

from .. import validate
from ..spectra import (
    wavelength_grid,
)
from .grid import WaterTerms
from .model import Water, resolve_water


__all__ = ["absorption", "attenuation_coefficient", "backscattering", "cdom_absorption",
           "nap_absorption", "nap_absorption_440", "particle_scattering",
           "particle_scattering_terms", "particle_scattering_weights",
           "phytoplankton_absorption", "phytoplankton_absorption_440", "pure_water_absorption",
           "pure_water_scattering", "scattering", "table1"]

# =========================================================================== public functions
# One function per physical term (each a view of Water; ``water=None`` is the paper's model).
def _terms(wavelengths, water, **kw) -> WaterTerms:
    return resolve_water(water, **kw).on_grid(wavelengths)


_conc = validate.nonnegative


def pure_water_absorption(wavelengths=None, *, water: Water | None = None) -> np.ndarray:
    """Pure-water absorption a_w(lambda) in m^-1, the first term of eq 5.

    Parameters
    ----------
    wavelengths : array_like, shape (q,), optional
        Wavelengths in nm (default: 400-700 nm at 1 nm).
    water : Water, optional
        The water model whose table is used (default: the paper's).

    Returns
    -------
    numpy.ndarray, shape (q,)
        a_w, m^-1 (a fresh copy).

    References
    ----------
    Blasinski & Farrell, eq 5. Smith & Baker (1981), Appl. Opt. 20(2):177-184, as tabulated by
    Mobley (1994) p. 90 (``data/pure_water_absorption_smith_baker_1981.csv``), linearly
    interpolated.
    """
    return _terms(wavelengths, water).pure_water_absorption.copy()


def phytoplankton_absorption_440(chl, *, derivative: bool = False, water: Water | None = None):
    """a_phi(440 nm) = 0.0378 C^0.627 in m^-1 (eq 10; the right side of eq 17).

    Parameters
    ----------
    chl : float or array_like, shape S
        Chlorophyll concentration C, mg m^-3 (>= 0).
    derivative : bool, optional
        Also return d a_phi(440) / dC (default False).
    water : Water, optional
        The water model (default: the paper's).

    Returns
    -------
    value : numpy.ndarray, shape S
        a_phi(440 nm), m^-1.
    derivative : numpy.ndarray, shape S
        d value / dC, m^-1 per mg m^-3 (only with ``derivative=True``; then a tuple is
        returned). Infinite at C = 0 (the estimator evaluates it at a small floor, see
        decision 0024-sca-loop).

    Raises
    ------
    ValueError
        If ``chl`` is negative or not finite.

    References
    ----------
    Blasinski & Farrell, eqs 10 and 17; Bricaud et al. 1998 (ref. [18]).
    """
    return resolve_water(water).phytoplankton_440(_conc("chl", chl), derivative=derivative)


def phytoplankton_absorption(wavelengths=None, chl=1.0, *, basis=None, weights=None,
                             water: Water | None = None) -> np.ndarray:
    """Phytoplankton absorption a_phi(lambda) = T w in m^-1 (eq 9), scaled by eq 10.

    Parameters
    ----------
    wavelengths : array_like, shape (q,), optional
        Wavelengths in nm (default: 400-700 nm at 1 nm).
    chl : float or array_like, shape S
        Chlorophyll concentration C, mg m^-3 (default 1).
    basis : array_like, shape (q,) or (q, z), or str or os.PathLike, optional
        The T of eq 9 on the grid (default: the water's table); see
        :func:`phytoplankton_basis`.
    weights : array_like, shape (z,), optional
        The shape for z > 1 basis functions, rescaled so that (T w)(440) = 0.0378 C^0.627.
        Required for z > 1.
    water : Water, optional
        The water model (default: the paper's).

    Returns
    -------
    numpy.ndarray, shape S + (q,)
        a_phi, m^-1.

    Raises
    ------
    ValueError
        For a negative ``chl``, an invalid basis or weights, or a z > 1 basis without weights.

    References
    ----------
    Blasinski & Farrell, eqs 9, 10 and 17; Bricaud et al. 1998; basis from Fujiki & Taguchi
    2002.
    """
    wl = wavelength_grid(wavelengths)
    water = resolve_water(water)
    terms = water.on_grid(wl, basis=basis, weights=weights)
    terms._check_shape(None)
    return np.multiply.outer(water.phytoplankton_440(_conc("chl", chl)), terms.phyto_shape)


def cdom_absorption(wavelengths=None, cdom=0.1, *, slope: float | None = None,
                    water: Water | None = None) -> np.ndarray:
    """CDOM absorption a_CDOM(lambda) = a_CDOM,440 exp(-S (lambda - 440)) in m^-1 (eq 6).

    Parameters
    ----------
    wavelengths : array_like, shape (q,), optional
        Wavelengths in nm (default: 400-700 nm at 1 nm).
    cdom : float or array_like, shape S
        a_CDOM(440 nm), m^-1 (default 0.1).
    slope : float, optional
        S, nm^-1; replaces ``water.cdom_slope`` (default: the water's, 0.014).
    water : Water, optional
        The water model (default: the paper's).

    Returns
    -------
    numpy.ndarray, shape S + (q,)
        a_CDOM, m^-1.

    Raises
    ------
    ValueError
        If ``cdom`` is negative or not finite, or ``slope`` is not a finite number.

    References
    ----------
    Blasinski & Farrell, eq 6; Bricaud et al. 1981 (ref. [19]).
    """
    s = None if slope is None else validate.scalar("slope", slope, nonnegative=False)
    return np.multiply.outer(_conc("cdom", cdom), _terms(wavelengths, water, cdom_slope=s).cdom_shape)


def nap_absorption_440(chl, *, derivative: bool = False, water: Water | None = None):
    """a_NAP(440 nm) = 0.0124 C^0.724 in m^-1 (eq 8).

    Parameters
    ----------
    chl : float or array_like, shape S
        Chlorophyll concentration C, mg m^-3 (>= 0).
    derivative : bool, optional
        Also return d a_NAP(440) / dC (default False).
    water : Water, optional
        The water model (default: the paper's).

    Returns
    -------
    value : numpy.ndarray, shape S
        a_NAP(440 nm), m^-1.
    derivative : numpy.ndarray, shape S
        d value / dC, m^-1 per mg m^-3, infinite at C = 0 (only with ``derivative=True``; then
        a tuple is returned).

    Raises
    ------
    ValueError
        If ``chl`` is negative or not finite.

    References
    ----------
    Blasinski & Farrell, eq 8; Bricaud et al. 1998 (ref. [18]).
    """
    out = resolve_water(water).chl_weights(_conc("chl", chl), derivative=derivative)
    return (out[0][..., 1], out[1][..., 1]) if derivative else out[..., 1]


def nap_absorption(wavelengths=None, chl=1.0, *, derivative: bool = False,
                   water: Water | None = None):
    """Non-algal particle absorption a_NAP(lambda) = a_NAP,440 exp(-0.011 (lambda - 440)) (eqs 7, 8).

    Parameters
    ----------
    wavelengths : array_like, shape (q,), optional
        Wavelengths in nm (default: 400-700 nm at 1 nm).
    chl : float or array_like, shape S
        Chlorophyll concentration C, mg m^-3 (default 1).
    derivative : bool, optional
        Also return d a_NAP / dC (default False).
    water : Water, optional
        The water model (default: the paper's).

    Returns
    -------
    value : numpy.ndarray, shape S + (q,)
        a_NAP, m^-1.
    derivative : numpy.ndarray, shape S + (q,)
        d value / dC, m^-1 per mg m^-3 (only with ``derivative=True``; then a tuple
        ``(value, derivative)`` is returned).

    Raises
    ------
    ValueError
        If ``chl`` is negative or not finite.

    References
    ----------
    Blasinski & Farrell, eqs 7 and 8; Roesler et al. 1989 (ref. [20], the slope); Bricaud
    et al. 1998 (ref. [18], eq 8).
    """
    shape = _terms(wavelengths, water).nap_shape
    if not derivative:
        return np.multiply.outer(nap_absorption_440(chl, water=water), shape)
    v, d = nap_absorption_440(chl, derivative=True, water=water)
    return np.multiply.outer(v, shape), np.multiply.outer(d, shape)


def absorption(wavelengths=None, chl=1.0, cdom=0.1, *, basis=None, weights=None,
               phytoplankton=None, cdom_slope: float | None = None,
               water: Water | None = None) -> np.ndarray:
    """Total absorption a = a_w + a_phi + a_CDOM + a_NAP in m^-1 (eq 5).

    Parameters
    ----------
    wavelengths : array_like, shape (q,), optional
        Wavelengths in nm (default: 400-700 nm at 1 nm).
    chl : float or array_like, shape S
        Chlorophyll concentration C, mg m^-3 (default 1); sets a_NAP (eq 8) and, unless
        ``phytoplankton`` is given, a_phi (eq 10).
    cdom : float or array_like, shape S
        a_CDOM(440 nm), m^-1 (default 0.1).
    basis : array_like, shape (q,) or (q, z), or str or os.PathLike, optional
        The T of eq 9 (default: the water's table); see :func:`phytoplankton_basis`.
    weights : array_like, shape (z,), optional
        The shape w of eq 9 for z > 1 basis functions (rescaled so that eq 10 holds).
    phytoplankton : array_like, shape (..., q), optional
        a_phi in m^-1, given directly instead of computed from ``chl``.
    cdom_slope : float, optional
        S of eq 6, nm^-1; replaces ``water.cdom_slope``.
    water : Water, optional
        The water model (default: the paper's).

    Returns
    -------
    numpy.ndarray, shape S + (q,)
        a, m^-1.

    Raises
    ------
    ValueError
        For negative or non-finite ``chl`` / ``cdom`` / ``phytoplankton``, or an invalid grid,
        basis or weights.

    References
    ----------
    Blasinski & Farrell, eqs 5-10; Smith & Baker 1981; Bricaud et al. 1981, 1998; Roesler et
    al. 1989.
    """
    wl = wavelength_grid(wavelengths)
    water = resolve_water(water, cdom_slope=cdom_slope)
    terms = water.on_grid(wl, basis=basis, weights=weights)
    chl, cdom = _conc("chl", chl), _conc("cdom", cdom)
    a = terms.absorption(chl, cdom)
    if phytoplankton is not None:
        a_phi = validate.array("phytoplankton", phytoplankton)
        a = a - np.multiply.outer(water.phytoplankton_440(chl), terms.phyto_shape) + a_phi
    return a


def pure_water_scattering(wavelengths=None, *, water: Water | None = None) -> np.ndarray:
    """Pure sea-water scattering b_w(lambda) = 0.00288 (lambda / 500)^-4.32 in m^-1 (eq 11).

    Parameters
    ----------
    wavelengths : array_like, shape (q,), optional
        Wavelengths in nm (default: 400-700 nm at 1 nm).
    water : Water, optional
        The water model whose ``water_scattering`` constants are used (default: the paper's).

    Returns
    -------
    numpy.ndarray, shape (q,)
        b_w, m^-1 (a fresh copy).

    References
    ----------
    Blasinski & Farrell, eq 11. Morel (1974), "Optical properties of pure water and pure sea
    water" (ref. [23]).
    """
    return _terms(wavelengths, water).pure_water_scattering.copy()


def table1(water: Water | None = None) -> dict:
    """The constants of Table 1 (eq 12) of ``water``; a fresh dict each call.

    Parameters
    ----------
    water : Water, optional
        The water model (default: as published, from ``data/particle_scattering_table1.csv``).

    Returns
    -------
    dict of str to float
        See :meth:`Water.table1` (C_12 mg m^-3, S_12 m^3 mg^-1, b*_p m^2 mg^-1, b_k m^-1,
        exponents dimensionless, lambda_0 nm).

    References
    ----------
    Blasinski & Farrell, Table 1; Brewin et al. 2012 (ref. [24]).
    """
    return resolve_water(water).table1()


def particle_scattering_terms(wavelengths=None, *, water: Water | None = None):
    """The three spectral terms of eq 12 (Table 1 constants).

    Parameters
    ----------
    wavelengths : array_like, shape (q,), optional
        Wavelengths in nm (default: 400-700 nm at 1 nm).
    water : Water, optional
        The water model (default: the paper's).

    Returns
    -------
    small : numpy.ndarray, shape (q,)
        b*_p12 (l/l0)^-g12, m^2 mg^-1 (m^-1 per mg m^-3 of weight).
    large : numpy.ndarray, shape (q,)
        b*_p3 (l/l0)^-g3, m^2 mg^-1.
    background : numpy.ndarray, shape (q,)
        b_k (l/l0)^-gk, m^-1.

    References
    ----------
    Blasinski & Farrell, eq 12 and Table 1; Brewin et al. 2012.
    """
    t = _terms(wavelengths, water)
    return t.particle_shapes[0].copy(), t.particle_shapes[1].copy(), t.background_scattering.copy()


def particle_scattering_weights(chl, *, derivative: bool = False, water: Water | None = None):
    """The chlorophyll weights of eq 12's first two terms, in mg m^-3.

    Parameters
    ----------
    chl : float or array_like, shape S
        Chlorophyll concentration C, mg m^-3 (>= 0).
    derivative : bool, optional
        Also return their d/dC (default False).
    water : Water, optional
        The water model (default: the paper's).

    Returns
    -------
    weights : tuple of numpy.ndarray, each shape S
        (C12 (1 - e^(-S12 C)), C - C12 (1 - e^(-S12 C))): pico + nano and micro, mg m^-3.
    derivatives : tuple of numpy.ndarray, each shape S
        Their d/dC, dimensionless (only with ``derivative=True``; then ``(weights,
        derivatives)`` is returned).

    Raises
    ------
    ValueError
        If ``chl`` is negative or not finite.

    References
    ----------
    Blasinski & Farrell, eq 12 and Table 1; Brewin et al. 2012.
    """
    out = resolve_water(water).chl_weights(_conc("chl", chl), derivative=derivative)
    if not derivative:
        return out[..., 2], out[..., 3]
    return (out[0][..., 2], out[0][..., 3]), (out[1][..., 2], out[1][..., 3])


def particle_scattering(wavelengths=None, chl=1.0, *, derivative: bool = False,
                        water: Water | None = None):
    """Particle scattering b_p(lambda) in m^-1, eq 12 with the Table 1 constants (lambda_0 = 470 nm).

    The Table 1 constants come from Brewin et al. (2012), who fit particle *back*scattering;
    the paper (and this function) use them as b_p (decision 0015-eq12-backscattering).

    Parameters
    ----------
    wavelengths : array_like, shape (q,), optional
        Wavelengths in nm (default: 400-700 nm at 1 nm).
    chl : float or array_like, shape S
        Chlorophyll concentration C, mg m^-3 (default 1).
    derivative : bool, optional
        Also return d b_p / dC (default False).
    water : Water, optional
        The water model (default: the paper's).

    Returns
    -------
    value : numpy.ndarray, shape S + (q,)
        b_p (all three terms of eq 12, the background b_k included), m^-1.
    derivative : numpy.ndarray, shape S + (q,)
        d b_p / dC, m^-1 per mg m^-3 (only with ``derivative=True``; then a tuple is
        returned).

    Raises
    ------
    ValueError
        If ``chl`` is negative or not finite.

    References
    ----------
    Blasinski & Farrell, eq 12 and Table 1; Brewin et al. 2012 (ref. [24]).
    """
    t = _terms(wavelengths, water)
    chl = _conc("chl", chl)
    if not derivative:
        return t.particle_scattering(chl)
    _, d = resolve_water(water).chl_weights(chl, derivative=True)
    return t.particle_scattering(chl), d[..., 2:] @ t.particle_shapes


def scattering(wavelengths=None, chl=1.0, *, water: Water | None = None) -> np.ndarray:
    """Total scattering b = b_w + b_p in m^-1 (eq 11).

    Parameters
    ----------
    wavelengths : array_like, shape (q,), optional
        Wavelengths in nm (default: 400-700 nm at 1 nm).
    chl : float or array_like, shape S
        Chlorophyll concentration C, mg m^-3 (default 1).
    water : Water, optional
        The water model (default: the paper's).

    Returns
    -------
    numpy.ndarray, shape S + (q,)
        b, m^-1.

    Raises
    ------
    ValueError
        If ``chl`` is negative or not finite.

    References
    ----------
    Blasinski & Farrell, eqs 11 and 12; Morel 1974; Brewin et al. 2012.
    """
    return _terms(wavelengths, water).scattering(_conc("chl", chl))


def backscattering(wavelengths=None, chl=1.0, *, water: Water | None = None) -> np.ndarray:
    """Backscattering coefficient b_b = 0.5 b_w + b_bp in m^-1, used by the veiling light (eq 2).

    Pure water scatters symmetrically (half backwards). For particles we take eq 12 itself as
    b_bp, which is what Brewin et al. (2012), the source of Table 1, fitted (decision
    0015-eq12-backscattering).
    The fractions 0.5 and 1 are ``water.water_backscatter_fraction`` and
    ``water.particle_backscatter_fraction``.

    Parameters
    ----------
    wavelengths : array_like, shape (q,), optional
        Wavelengths in nm (default: 400-700 nm at 1 nm).
    chl : float or array_like, shape S
        Chlorophyll concentration C, mg m^-3 (default 1).
    water : Water, optional
        The water model (default: the paper's).

    Returns
    -------
    numpy.ndarray, shape S + (q,)
        b_b, m^-1.

    Raises
    ------
    ValueError
        If ``chl`` is negative or not finite.

    References
    ----------
    Blasinski & Farrell, eq 2 (which gives no model for rho_b) and eqs 11-12; Morel 1974;
    Brewin et al. 2012.
    """
    return _terms(wavelengths, water).backscattering(_conc("chl", chl))


def attenuation_coefficient(wavelengths=None, chl=1.0, cdom=0.1, *, basis=None, weights=None,
                            phytoplankton=None, cdom_slope: float | None = None,
                            water: Water | None = None) -> np.ndarray:
    """Beam attenuation coefficient c = a + b in m^-1 (eq 4), whatever ``water.path_model``.

    Parameters
    ----------
    wavelengths : array_like, shape (q,), optional
        Wavelengths in nm (default: 400-700 nm at 1 nm).
    chl : float or array_like, shape S
        Chlorophyll concentration C, mg m^-3 (default 1).
    cdom : float or array_like, shape S
        a_CDOM(440 nm), m^-1 (default 0.1).
    basis, weights, phytoplankton, cdom_slope : optional
        As for :func:`absorption`: the basis T and weights w of eq 9, a_phi given directly
        (m^-1), and the CDOM slope S of eq 6 (nm^-1).
    water : Water, optional
        The water model (default: the paper's).

    Returns
    -------
    numpy.ndarray, shape S + (q,)
        c, m^-1.

    Raises
    ------
    ValueError
        As :func:`absorption` and :func:`scattering`.

    References
    ----------
    Blasinski & Farrell, eqs 4-12 and Table 1.
    """
    wl = wavelength_grid(wavelengths)
    a = absorption(wl, chl, cdom, basis=basis, weights=weights, phytoplankton=phytoplankton,
                   cdom_slope=cdom_slope, water=water)
    return a + scattering(wl, chl, water=water)
