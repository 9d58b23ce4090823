"""Inherent optical properties of sea water: absorption, scattering, attenuation (eqs 4-12).

One function per physical term, each with its equation number. Wavelengths are in nm,
coefficients in m^-1, chlorophyll concentration ``chl`` (C) in mg m^-3, ``cdom`` is
a_CDOM(440 nm) in m^-1.

``chl`` and ``cdom`` may be scalars or arrays (any shape S); a spectrum then has shape S + (q,).

Reference: H. Blasinski and J. Farrell, "A Three Parameter Underwater Image Formation Model".
"""

from __future__ import annotations

import functools

import numpy as np

from . import _validate
from .spectra import LAMBDA_0_NM, phytoplankton_basis, read_table, read_spectral_table, resample, wavelength_grid

#: CDOM spectral slope S of eq 6 (nm^-1); the paper uses 0.014 (range 0.014-0.019).
CDOM_SLOPE = 0.014
#: NAP spectral slope of eq 7 (nm^-1); the paper uses 0.011 (range 0.006-0.014).
NAP_SLOPE = 0.011


_conc = _validate.nonnegative


def _outer(amount, shape):
    return np.multiply.outer(amount, shape)


@functools.lru_cache(maxsize=32)
def _a_w(wl_key):
    wl_src, vals = read_spectral_table("pure_water_absorption_smith_baker_1981.csv")
    out = resample(wl_src, vals[:, 0], np.array(wl_key), name="wavelengths")
    out.setflags(write=False)
    return out


def pure_water_absorption(wavelengths=None) -> np.ndarray:
    """Pure-water absorption a_w(lambda) in m^-1, the first term of eq 5.

    Smith & Baker (1981), Appl. Opt. 20(2):177-184, as tabulated by Mobley (1994) p. 90
    (``data/pure_water_absorption_smith_baker_1981.csv``), linearly interpolated.
    """
    wl = wavelength_grid(wavelengths)
    return _a_w(tuple(wl)).copy()


#: Eq 10: a_phi(440) = EQ10_SCALE * C ** EQ10_EXPONENT (Bricaud et al. 1998, ref. [18]).
EQ10_SCALE, EQ10_EXPONENT = 0.0378, 0.627
#: Eq 8: a_NAP(440) = EQ8_SCALE * C ** EQ8_EXPONENT (Bricaud et al. 1998, ref. [18]).
EQ8_SCALE, EQ8_EXPONENT = 0.0124, 0.724


# Formula kernels: plain arithmetic on floats or arrays, no validation, so that the batched
# solver can compile these same functions with numba (physics stays in this module).
def eq10(c):
    """0.0378 C^0.627 (eq 10)."""
    return EQ10_SCALE * c ** EQ10_EXPONENT


def eq10_derivative(c):
    """d/dC of eq 10, for C > 0 (written with the same power as eq10, so a compiler evaluates
    one power for both)."""
    return EQ10_EXPONENT * EQ10_SCALE * c ** EQ10_EXPONENT / c


def eq8(c):
    """0.0124 C^0.724 (eq 8)."""
    return EQ8_SCALE * c ** EQ8_EXPONENT


def eq8_derivative(c):
    """d/dC of eq 8, for C > 0 (the same power as eq8)."""
    return EQ8_EXPONENT * EQ8_SCALE * c ** EQ8_EXPONENT / c


def eq12_small(c, c12, s12):
    """Pico + nano chlorophyll of eq 12: C12 (1 - exp(-S12 C)), mg m^-3."""
    return c12 * (1.0 - np.exp(-s12 * c))


def eq12_small_derivative(c, c12, s12):
    """d/dC of :func:`eq12_small` (the same exponential)."""
    return c12 * s12 * np.exp(-s12 * c)


def _power_law(chl, value, derivative_fn, derivative):
    c = _conc("chl", chl)
    val = value(c)
    if not derivative:
        return val
    with np.errstate(divide="ignore"):
        d = np.where(c > 0, derivative_fn(np.where(c > 0, c, 1.0)), np.inf)
    return val, d


def phytoplankton_absorption_440(chl, *, derivative: bool = False):
    """a_phi(440 nm) = 0.0378 C^0.627 in m^-1 (eq 10; the right side of eq 17).

    With ``derivative=True`` returns (value, d value / dC). The derivative is infinite at
    C = 0 (the estimator evaluates it at a small floor, see DECISIONS.md).
    """
    return _power_law(chl, eq10, eq10_derivative, derivative)


def phytoplankton_absorption(wavelengths=None, chl=1.0, *, basis=None, weights=None) -> np.ndarray:
    """Phytoplankton absorption a_phi(lambda) = T w in m^-1 (eq 9), scaled by eq 10.

    ``basis`` is the T of eq 9 (see :func:`forward.spectra.phytoplankton_basis`); ``weights``
    (z,) give the shape for z > 1 basis functions and are rescaled so that
    (T w)(440 nm) = 0.0378 C^0.627 (eq 10). With one basis function no weights are needed.
    """
    wl = wavelength_grid(wavelengths)
    T, t440 = phytoplankton_basis(wl, basis)
    z = T.shape[1]
    if weights is None:
        if z != 1:
            raise ValueError(f"weights: required for a basis of z = {z} functions")
        weights = np.ones(1)
    w = _validate.array("weights", weights, shape=(z,), nonnegative=False)
    scale440 = float(t440 @ w)
    if scale440 <= 0:
        raise ValueError("weights: the basis combination T w must be positive at 440 nm")
    shape = T @ w / scale440
    if np.any(shape < -1e-12):
        raise ValueError("weights: T w is negative at some wavelength (violates eq 16)")
    return _outer(phytoplankton_absorption_440(chl), shape)


def cdom_absorption(wavelengths=None, cdom=0.1, *, slope: float = CDOM_SLOPE) -> np.ndarray:
    """CDOM absorption a_CDOM(lambda) = a_CDOM,440 exp(-S (lambda - 440)) in m^-1 (eq 6)."""
    wl = wavelength_grid(wavelengths)
    s = _validate.scalar("slope", slope)
    return _outer(_conc("cdom", cdom), np.exp(-s * (wl - LAMBDA_0_NM)))


def nap_absorption_440(chl, *, derivative: bool = False):
    """a_NAP(440 nm) = 0.0124 C^0.724 in m^-1 (eq 8). ``derivative=True``: also d/dC."""
    return _power_law(chl, eq8, eq8_derivative, derivative)


def nap_absorption(wavelengths=None, chl=1.0, *, slope: float = NAP_SLOPE, derivative: bool = False):
    """Non-algal particle absorption a_NAP(lambda) = a_NAP,440 exp(-0.011 (lambda - 440)) (eqs 7, 8).

    ``derivative=True`` returns (value, d value / dC).
    """
    wl = wavelength_grid(wavelengths)
    s = _validate.scalar("slope", slope)
    shape = np.exp(-s * (wl - LAMBDA_0_NM))
    if not derivative:
        return _outer(nap_absorption_440(chl), shape)
    v, d = nap_absorption_440(chl, derivative=True)
    return _outer(v, shape), _outer(d, shape)


def absorption(wavelengths=None, chl=1.0, cdom=0.1, *, basis=None, weights=None,
               phytoplankton=None, cdom_slope: float = CDOM_SLOPE) -> np.ndarray:
    """Total absorption a = a_w + a_phi + a_CDOM + a_NAP in m^-1 (eq 5).

    ``phytoplankton`` may give a_phi (= T w, shape (..., q)) directly, as the estimator does;
    otherwise it is computed from ``chl`` with :func:`phytoplankton_absorption`.
    """
    wl = wavelength_grid(wavelengths)
    if phytoplankton is None:
        a_phi = phytoplankton_absorption(wl, chl, basis=basis, weights=weights)
    else:
        a_phi = _validate.array("phytoplankton", phytoplankton)
    return (pure_water_absorption(wl) + a_phi + cdom_absorption(wl, cdom, slope=cdom_slope)
            + nap_absorption(wl, chl))


def pure_water_scattering(wavelengths=None) -> np.ndarray:
    """Pure sea-water scattering b_w(lambda) = 0.00288 (lambda / 500)^-4.32 in m^-1 (eq 11).

    Morel (1974), "Optical properties of pure water and pure sea water" (ref. [23]).
    """
    wl = wavelength_grid(wavelengths)
    return 0.00288 * (wl / 500.0) ** -4.32


@functools.lru_cache(maxsize=1)
def table1() -> dict:
    """The constants of Table 1 (eq 12), from ``data/particle_scattering_table1.csv``."""
    _, rows = read_table("particle_scattering_table1.csv")
    return {r[0].strip(): float(r[2]) for r in rows}


def particle_scattering_terms(wavelengths=None):
    """The three spectral terms of eq 12 (Table 1 constants), each (q,) in m^-1 per unit weight:

    b*_p12 (l/l0)^-g12 (weight: pico + nano chlorophyll C12 (1 - e^(-S12 C)), mg m^-3),
    b*_p3 (l/l0)^-g3 (weight: micro chlorophyll C - C12 (1 - e^(-S12 C))),
    b_k (l/l0)^-gk (weight 1, the background).
    """
    wl = wavelength_grid(wavelengths)
    t = table1()
    r = wl / t["lambda_0"]
    return (t["b_p12_star"] * r ** -t["gamma_12"], t["b_p3_star"] * r ** -t["gamma_3"],
            t["b_k"] * r ** -t["gamma_k"])


def particle_scattering_weights(chl, *, derivative: bool = False):
    """The chlorophyll weights of eq 12's first two terms: (C12 (1 - e^(-S12 C)),
    C - C12 (1 - e^(-S12 C))) in mg m^-3; ``derivative=True`` also returns their d/dC."""
    t = table1()
    c = _conc("chl", chl)
    small = eq12_small(c, t["C_12"], t["S_12"])
    if not derivative:
        return small, c - small
    dsmall = eq12_small_derivative(c, t["C_12"], t["S_12"])
    return (small, c - small), (dsmall, 1.0 - dsmall)


def particle_scattering(wavelengths=None, chl=1.0, *, derivative: bool = False):
    """Particle scattering b_p(lambda) in m^-1, eq 12 with the Table 1 constants (lambda_0 = 470 nm).

    b_p = b*_p12 (l/l0)^-g12 [C12 (1 - e^(-S12 C))] + b*_p3 (l/l0)^-g3 [C - C12 (1 - e^(-S12 C))]
          + b_k (l/l0)^-gk.
    The Table 1 constants come from Brewin et al. (2012), who fit particle *back*scattering;
    the paper (and this function) use them as b_p (DECISIONS.md). ``derivative=True`` also
    returns d b_p / dC. Terms and weights: :func:`particle_scattering_terms`,
    :func:`particle_scattering_weights`.
    """
    f12, f3, fk = particle_scattering_terms(wavelengths)
    if not derivative:
        w12, w3 = particle_scattering_weights(chl)
        return _outer(w12, f12) + _outer(w3, f3) + fk
    (w12, w3), (d12, d3) = particle_scattering_weights(chl, derivative=True)
    return _outer(w12, f12) + _outer(w3, f3) + fk, _outer(d12, f12) + _outer(d3, f3)


def scattering(wavelengths=None, chl=1.0) -> np.ndarray:
    """Total scattering b = b_w + b_p in m^-1 (eq 11)."""
    wl = wavelength_grid(wavelengths)
    return pure_water_scattering(wl) + particle_scattering(wl, chl)


def backscattering(wavelengths=None, chl=1.0) -> np.ndarray:
    """Backscattering coefficient b_b = 0.5 b_w + b_bp in m^-1, used by the veiling light (eq 2).

    Pure water scatters symmetrically (half backwards). For particles we take eq 12 itself as
    b_bp, which is what Brewin et al. (2012), the source of Table 1, fitted (DECISIONS.md).
    """
    wl = wavelength_grid(wavelengths)
    return 0.5 * pure_water_scattering(wl) + particle_scattering(wl, chl)


def attenuation_coefficient(wavelengths=None, chl=1.0, cdom=0.1, **absorption_kwargs) -> np.ndarray:
    """Beam attenuation coefficient c = a + b in m^-1 (eq 4).

    Keyword arguments go to :func:`absorption` (``basis``, ``weights``, ``phytoplankton``,
    ``cdom_slope``).
    """
    wl = wavelength_grid(wavelengths)
    return absorption(wl, chl, cdom, **absorption_kwargs) + scattering(wl, chl)
