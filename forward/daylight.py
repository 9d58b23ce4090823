"""Daylight of another colour: the CIE daylight series as a function of its colour temperature.

The light at the surface is daylight whose colour follows the sun and the sky: correlated colour
temperatures of global daylight run from about 4000 K (a low sun) to beyond 10 000 K (overcast
or blue sky), 5700 K being the most typical (Hernández-Andrés et al. 2001, 2600 spectra over two
years). The CIE daylight series gives the spectrum at any temperature T from three basis
functions,

    S_D(lambda; T) = S0(lambda) + M1(T) S1(lambda) + M2(T) S2(lambda),

M1 and M2 from the daylight locus's chromaticity (x_D, y_D)(T) (CIE 015:2018, section 4.1.2).
:class:`DaylightTilt` gives the relative change of a surface light when its temperature moves
by ``shift`` mired (10^6 / T) from a reference: the ratio r = S_D(T) / S_D(T_ref) and the
derivative of ln r, the form in which the uncertainty budget's ``daylight`` nuisance enters the
chart model (:meth:`sca.ChartModel.predict`: the light at the chart is the surface light times
r, i.e. the optical depth less ln r).

The temperature is parameterised in mired because the daylight locus is smoother in 1 / T;
outside the series' range (4000-25 000 K, 40-250 mired) the locus's polynomials are extended
smoothly and the result is clipped to :data:`MIRED_RANGE`.

References
----------
CIE 015:2018, Colorimetry, 4th edition, section 4.1.2 and Table T.2 (the daylight series).
J. Hernández-Andrés, J. Romero, J. L. Nieves and R. L. Lee, "Color and spectral analysis of
daylight in southern Europe", J. Opt. Soc. Am. A 18 (2001) 1325-1335.
"""

from __future__ import annotations

import numpy as np

from .spectra import read_spectral_table, resample, wavelength_grid

__all__ = ["DAYLIGHT_BASIS_TABLE", "MIRED_RANGE", "DaylightTilt", "D_SERIES_CCT",
           "daylight_basis", "daylight_chromaticity", "daylight_coefficients", "daylight_spd",
           "mired"]

#: File of ``data/`` with the basis functions S0, S1, S2 (CIE 015:2018 Table T.2, 5 nm).
DAYLIGHT_BASIS_TABLE = "cie_daylight_basis_5nm.csv"
#: Where the temperature is clipped, mired (about 3300 K to 40 000 K).
MIRED_RANGE = (25.0, 300.0)
#: The correlated colour temperatures of the CIE standard daylight illuminants, K (their
#: nominal temperatures times 1.4388 / 1.4380, the change of the second radiation constant).
D_SERIES_CCT = {name: t * 1.4388 / 1.4380 for name, t in
                (("D50", 5000.0), ("D55", 5500.0), ("D65", 6500.0), ("D75", 7500.0))}

# The daylight locus x_D(T) = a3 / T^3 + a2 / T^2 + a1 / T + a0 (CIE 015:2018), for
# 4000-7000 K and for 7000-25 000 K, and y_D(x_D).
_X_LOW = (-4.6070e9, 2.9678e6, 0.09911e3, 0.244063)
_X_HIGH = (-2.0064e9, 1.9018e6, 0.24748e3, 0.237040)
_Y = (-3.000, 2.870, -0.275)
# M1 = (n1 . (1, x, y)) / (m . (1, x, y)), M2 likewise
_M = (0.0241, 0.2562, -0.7341)
_N1 = (-1.3515, -1.7703, 5.9114)
_N2 = (0.0300, -31.4424, 30.0717)


def mired(cct):
    """10^6 / T: a temperature in mired (micro reciprocal degrees).

    Parameters
    ----------
    cct : float or array_like
        Correlated colour temperature, K (> 0).

    Returns
    -------
    ndarray
        mired.
    """
    return 1e6 / np.asarray(cct, float)


def daylight_chromaticity(cct, *, derivative: bool = False):
    """The daylight locus: chromaticity (x_D, y_D) of daylight at temperature ``cct``.

    Parameters
    ----------
    cct : float or array_like
        Correlated colour temperature, K.
    derivative : bool, optional
        Also d(x_D, y_D) / d mired.

    Returns
    -------
    x, y : ndarray
    dx, dy : ndarray
        Per mired (with ``derivative``).

    References
    ----------
    CIE 015:2018, section 4.1.2.
    """
    u = 1.0 / np.asarray(cct, float)
    a3, a2, a1, a0 = (np.where(u >= 1.0 / 7000.0, lo, hi) for lo, hi in zip(_X_LOW, _X_HIGH))
    x = ((a3 * u + a2) * u + a1) * u + a0
    y = (_Y[0] * x + _Y[1]) * x + _Y[2]
    if not derivative:
        return x, y
    dx = ((3.0 * a3 * u + 2.0 * a2) * u + a1) * 1e-6  # d/du, and u = mired 1e-6
    dy = (2.0 * _Y[0] * x + _Y[1]) * dx
    return x, y, dx, dy


def daylight_coefficients(cct, *, derivative: bool = False):
    """M1 and M2 of the CIE daylight series at temperature ``cct`` (unrounded).

    Parameters
    ----------
    cct : float or array_like
        Correlated colour temperature, K.
    derivative : bool, optional
        Also dM1 / d mired and dM2 / d mired.

    Returns
    -------
    M1, M2 : ndarray
    dM1, dM2 : ndarray
        Per mired (with ``derivative``).

    References
    ----------
    CIE 015:2018, section 4.1.2.
    """
    x, y, dx, dy = daylight_chromaticity(cct, derivative=True)
    m = _M[0] + _M[1] * x + _M[2] * y
    n1 = _N1[0] + _N1[1] * x + _N1[2] * y
    n2 = _N2[0] + _N2[1] * x + _N2[2] * y
    M1, M2 = n1 / m, n2 / m
    if not derivative:
        return M1, M2
    dm = _M[1] * dx + _M[2] * dy
    dM1 = ((_N1[1] * dx + _N1[2] * dy) - M1 * dm) / m
    dM2 = ((_N2[1] * dx + _N2[2] * dy) - M2 * dm) / m
    return M1, M2, dM1, dM2


def daylight_basis(wavelengths=None) -> np.ndarray:
    """S0, S1, S2 on the grid, (q, 3): linear between the table's 5 nm nodes.

    Parameters
    ----------
    wavelengths : array_like, (q,), optional
        nm (default: 400-700 nm at 1 nm).

    Returns
    -------
    ndarray, (q, 3)
    """
    wl = wavelength_grid(wavelengths)
    src_wl, vals = read_spectral_table(DAYLIGHT_BASIS_TABLE)
    return resample(src_wl, vals, wl, name="daylight basis")


def daylight_spd(cct, wavelengths=None) -> np.ndarray:
    """The CIE daylight spectrum at temperature ``cct`` (S_D(560) = 100).

    Parameters
    ----------
    cct : float or array_like, shape S
        Correlated colour temperature, K.
    wavelengths : array_like, (q,), optional
        nm (default: 400-700 nm at 1 nm).

    Returns
    -------
    ndarray, S + (q,)
    """
    M1, M2 = daylight_coefficients(cct)
    S = daylight_basis(wavelengths)
    return S[:, 0] + np.asarray(M1)[..., None] * S[:, 1] + np.asarray(M2)[..., None] * S[:, 2]


class DaylightTilt:
    """The relative change of a daylight when its temperature moves from a reference.

    Parameters
    ----------
    wavelengths : array_like, (q,)
        nm.
    reference_cct : float
        The surface light's temperature as given, K (a CIE D illuminant's, or 6504 K).

    Attributes
    ----------
    mired0 : float
        The reference, mired.
    """

    def __init__(self, wavelengths, reference_cct: float):
        self.basis = daylight_basis(wavelengths)
        self.mired0 = float(mired(reference_cct))
        M1, M2 = daylight_coefficients(reference_cct)
        self._ln_ref = np.log(self._spd(M1, M2))

    def _spd(self, M1, M2):
        S = self.basis
        return S[:, 0] + np.asarray(M1)[..., None] * S[:, 1] + np.asarray(M2)[..., None] * S[:, 2]

    def log_ratio(self, shift, derivative: bool = False):
        """ln r(lambda) = ln S_D(T) - ln S_D(T_ref) where 10^6 / T = 10^6 / T_ref + ``shift``.

        Parameters
        ----------
        shift : float or array_like, shape S
            The temperature's change, mired (the result clipped to :data:`MIRED_RANGE`).
        derivative : bool, optional
            Also d ln r / d shift (0 where clipped).

        Returns
        -------
        ndarray, S + (q,)
            ln r.
        ndarray, S + (q,)
            d ln r / d shift, per mired (with ``derivative``).
        """
        raw = self.mired0 + np.asarray(shift, float)
        mu = np.clip(raw, *MIRED_RANGE)
        M1, M2, dM1, dM2 = daylight_coefficients(1e6 / mu, derivative=True)
        spd = self._spd(M1, M2)
        ln = np.log(spd) - self._ln_ref
        if not derivative:
            return ln
        inside = ((raw >= MIRED_RANGE[0]) & (raw <= MIRED_RANGE[1]))[..., None]
        S = self.basis
        d = (np.asarray(dM1)[..., None] * S[:, 1] + np.asarray(dM2)[..., None] * S[:, 2]) / spd
        return ln, np.where(inside, d, 0.0)
