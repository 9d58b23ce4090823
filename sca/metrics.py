"""Eq 19, the relative root-mean-squared error of the paper's Figure 10."""

from __future__ import annotations

import numpy as np

__all__ = ["RRMSE_BANDS_NM", "rrmse", "rrmse_bands"]

#: The paper's q = 31 bands (every 10 nm, 400-700 nm): eq 19 divides by sqrt(q), so its value
#: depends on the grid; the figures, the benchmark and sca.precision evaluate it on these.
RRMSE_BANDS_NM = np.arange(400.0, 701.0, 10.0)


def rrmse_bands(wavelengths, estimate, truth) -> float:
    """Eq 19 on the :data:`RRMSE_BANDS_NM` samples of two spectra on ``wavelengths``.

    Parameters
    ----------
    wavelengths : array_like, (q,)
        The spectra's grid, nm. Samples are selected by exact equality with
        :data:`RRMSE_BANDS_NM` (400, 410, ..., 700 nm); bands missing from the grid are left
        out (q in eq 19 is then the number found).
    estimate, truth : array_like, (q,)
        The estimated and the true spectrum (e.g. the attenuation k), same units.

    Returns
    -------
    float
        The RRMSE of :func:`rrmse` on the selected bands (dimensionless).

    References
    ----------
    Blasinski & Farrell, "A Three Parameter Underwater Image Formation Model", eq 19 and
    Figure 10.
    """
    sel = np.isin(np.asarray(wavelengths), RRMSE_BANDS_NM)
    return rrmse(np.asarray(estimate)[sel], np.asarray(truth)[sel])


def rrmse(estimate, truth) -> float:
    """Relative root-mean-squared error of eq 19: ||y_hat - y|| / (sqrt(q) ||y||).

    Parameters
    ----------
    estimate : array_like
        y_hat, the estimated spectrum (q values; any shape, flattened by the norm).
    truth : array_like
        y, the true spectrum, same shape and units; q is its number of values.

    Returns
    -------
    float
        The RRMSE (dimensionless; NaN or inf where ||y|| = 0).

    References
    ----------
    Blasinski & Farrell, "A Three Parameter Underwater Image Formation Model", eq 19.
    """
    y_hat = np.asarray(estimate, float)
    y = np.asarray(truth, float)
    return float(np.linalg.norm(y_hat - y) / (np.sqrt(y.size) * np.linalg.norm(y)))

