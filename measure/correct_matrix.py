"""The spectral colour correction: a 3 x 3 colour matrix per range (``method="matrix"``, the
default of :func:`measure.correct_image`).

The diagonal (von Kries) correction divides each channel by the white's transmittance
t_c(r). A camera channel integrates the attenuation over its band, so what a channel loses
depends on each reflectance's own spectrum: no diagonal correction can undo it (the far charts
of CORRECTION.md keep a median ΔE00 of 4-6 with the true water). The matrix method learns that
cross-talk from the model itself: the camera responses, through the water along range r and in
air, of a set of training reflectances that excludes the ColorChecker -- the 29 test colour
samples of colour-science (:data:`TRAINING_SETS`: CIE 13.3/1995's 14 TCS and NIST CQS 9.0's
15 VS) -- computed by the estimators' model function (:meth:`sca.model.ChartModel.predict`,
the one :func:`measure.correct.correction_table` uses for the white).

Per range r of the table, with U_k(r) the responses through the water (unit gain, no veil)
of training reflectance k, D(r) = diag(1 / t(r)) the diagonal correction and A_k its response
in air, M(r) is the 3 x 3 least-squares fit

    min_M  sum_k || M D(r) U_k(r) - A_k ||^2   subject to   M w = w,

w the white's response in air (camera units in air, unweighted; the constraint keeps a white
-- and every neutral -- exactly where the diagonal puts it, so the matrix only removes the
colour cross-talk: white-preserving least squares, Finlayson & Drew 1997; decision
0076-spectral-matrix-correction). A pixel is corrected as J = M(r) D(r) (raw - s(r)) / gain,
M interpolated linearly between the table's ranges like the diagonal factors.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .correctwater import CorrectionWater
from forward.errors import InputError

__all__ = ["METHODS", "TRAINING_SETS", "check_held_out", "colour_matrices", "model_response",
           "training_reflectances"]

#: The correction methods: the colour matrix per range (default) and the diagonal
METHODS = ("matrix", "diagonal")
#: The training reflectances: (colour-science database of ``colour.quality.datasets``, name):
#: CIE 13.3 / CIE 1995 test colour samples TCS01-14 and NIST CQS 9.0 samples VS1-15 (29)
TRAINING_SETS = (("SDS_TCS", "CIE 1995"), ("SDS_VS", "NIST CQS 9.0"))
#: A chart's reflectance within this (largest absolute difference over the grid) of a training
#: reflectance counts as the same sample (:func:`check_held_out`)
SAME_SAMPLE = 1e-3


def check_method(method) -> str:
    """The method, or an :class:`InputError` naming ``method``."""
    if method not in METHODS:
        raise InputError("method", f"one of {', '.join(METHODS)}, got {method!r}")
    return method


def training_reflectances(wavelengths) -> tuple:
    """The training reflectances on the grid: colour-science's, resampled as the package
    resamples every spectrum and read from the package's cached table
    (:func:`forward.spectra.colour_samples`; no colour-science import).

    Parameters
    ----------
    wavelengths : array_like, (q,)
        nm.

    Returns
    -------
    names : tuple of str
        '<set> <sample>', e.g. 'CIE 1995 TCS01'.
    reflectances : numpy.ndarray, (q, 29)
        Read-only.
    """
    from forward.spectra import colour_samples

    sets = [colour_samples(db, name, wavelengths) for db, name in TRAINING_SETS]
    refl = np.hstack([r for _, r in sets])
    refl.setflags(write=False)
    return sum((n for n, _ in sets), ()), refl


def check_held_out(chart, training, argument: str = "reflectances") -> None:
    """Refuse a chart that shares a sample with the training set.

    Parameters
    ----------
    chart, training : numpy.ndarray, (q, n) and (q, k)
        Reflectances on one grid.
    argument : str, optional
        The argument named in the error.

    Raises
    ------
    InputError
        Naming ``argument`` when a chart column lies within :data:`SAME_SAMPLE` of a training
        column.
    """
    gap = np.abs(np.asarray(chart, float)[:, :, None]
                 - np.asarray(training, float)[:, None, :]).max(axis=0)
    same = np.argwhere(gap < SAME_SAMPLE)
    if same.size:
        raise InputError(argument, f"patch {same[0, 0] + 1} is training sample "
                                   f"{same[0, 1] + 1} of the colour matrix")


def model_response(cw: CorrectionWater, ranges, reflectances) -> np.ndarray:
    """The camera's response (n, 3, k) to reflectances (q, k) at each range, unit gain, no veil:
    the estimators' model function (:meth:`sca.model.ChartModel.predict`) with the water's
    fitted nuisances (camera balance and curve shifts, the daylight's shift)."""
    from sca.model import ChartModel

    r = np.atleast_1d(np.asarray(ranges, float))
    n, k = r.size, reflectances.shape[1]
    model = ChartModel(dataclasses.replace(cw.setup, reflectances=reflectances), water=cw.water)
    params = {"chl": np.full(n, cw.chl), "cdom": np.full(n, cw.cdom),
              "depth": np.full(n, cw.depth), "distance": r}
    for name, v in cw.nuisance.items():
        params[name] = np.broadcast_to(np.asarray(v, float), (n, 3)) if np.ndim(v) else float(v)
    return model.predict(params, jacobian=False).signal.reshape(n, 3, k)


def colour_matrices(cw: CorrectionWater, ranges, transmission) -> np.ndarray:
    """M(r) (n, 3, 3) of the module's docstring: after the diagonal correction by
    ``transmission`` (n, 3), the white-preserving least-squares map of the training
    reflectances' responses to their responses in air."""
    _, refl = training_reflectances(cw.setup.wavelengths)
    setup = cw.setup
    under = model_response(cw, ranges, refl) / np.asarray(transmission)[:, :, None]  # (n, 3, k)
    air = setup.sensitivities.T @ (setup.illuminant[:, None] * refl)  # (3, k)
    white = setup.white_response
    gram = under @ under.transpose(0, 2, 1)  # (n, 3, 3)
    n = gram.shape[0]
    # each row m_c: min ||U^T m_c - a_c||^2 s.t. w . m_c = w_c (the KKT system, 4 x 4)
    kkt = np.zeros((n, 4, 4))
    kkt[:, :3, :3] = gram
    kkt[:, :3, 3] = kkt[:, 3, :3] = white
    rhs = np.empty((n, 4, 3))
    rhs[:, :3, :] = under @ air.T
    rhs[:, 3, :] = white
    return np.linalg.solve(kkt, rhs)[:, :3, :].transpose(0, 2, 1)
