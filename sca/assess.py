"""Is an estimate trustworthy? Goodness of fit, input sanity, intervals and the verdict.

One set of rules for :func:`sca.estimate` and :func:`sca.estimate_batch` (DECISIONS.md,
"Trust"):

* **goodness of fit**: ``fit_rms`` = ||M - G - s|| / ||M||; with the noise known, chi^2 of the
  whitened residual on ``dof`` = m n - (free C, a_CDOM, active s) degrees of freedom, its
  reduced value ``chi2_dof`` and p-value; p < :data:`MISFIT_P` is a ``misfit``;
* **intervals**: 95 % profile likelihood (:func:`profile_delta`): the set of C (or a_CDOM)
  whose profile objective is within chi^2_1(0.95) = 3.84 of the minimum (noise known) or within
  F(0.95; 1, dof) times the residual variance (noise estimated from the residual);
* **input sanity** (:func:`input_flags`): ``saturated`` (a value at the sensor's clip level, or
  two or more values tied at the chart's maximum), ``dark`` (the grey row's white-black contrast below
  :data:`DARK_SNR` standard deviations in every channel), ``patch-order`` (the grey row of a
  ColorChecker not falling from white to black);
* ``reliable`` is True only when no flag of :data:`BLOCKING` is raised.
"""

from __future__ import annotations

import numpy as np
from scipy import stats

#: Confidence level of ``chl_ci`` and ``cdom_ci``.
CONFIDENCE = 0.95
#: A fit whose chi^2 p-value is below this is a ``misfit`` (one in a thousand false alarms).
MISFIT_P = 1e-3
#: The grey row's white-black contrast must exceed this many standard deviations in at least
#: one channel, else the chart is ``dark``.
DARK_SNR = 10.0
#: A patch-order check tolerance: a grey-row step may rise by at most this many standard
#: deviations (noise) before the order is called wrong.
ORDER_SIGMAS = 4.0
#: Profile upper ends beyond these are open (``inf``): C in mg m^-3, a_CDOM(440) in m^-1 (far
#: beyond natural waters: Mobley 1994 lists C up to ~100, a_CDOM(440) up to ~10).
CHL_MAX, CDOM_MAX = 1e4, 1e3
#: ColorChecker grey row (0-based patch indices, white to black).
GREY_ROW = tuple(range(18, 24))

#: Flags that make an estimate unreliable; any other flag is information.
BLOCKING = ("not-converged", "misfit", "noise-unknown", "unbounded-chl", "unbounded-cdom",
            "interval-failed", "interval-approximate", "no-interval", "dark", "saturated",
            "patch-order")
#: Flags that describe the estimate without making it unreliable.
INFORMATIVE = ("at-bound-chl", "at-bound-cdom")


def profile_delta(noise_known: bool, f_min, dof, f_data=None):
    """The rise of the profile objective that bounds the 95 % interval (arrays allowed).

    With the noise estimated from the residual, a residual at rounding level (below 1e-20 of
    ``f_data``, the data's own sum of squares) gives 0: the interval has zero width."""
    f_min = np.asarray(f_min, float)
    dof = np.maximum(np.asarray(dof), 1)
    if noise_known:
        return np.full(f_min.shape, stats.chi2.ppf(CONFIDENCE, 1))
    delta = stats.f.ppf(CONFIDENCE, 1, dof) * f_min / dof
    if f_data is not None:
        delta = np.where(f_min <= 1e-20 * np.asarray(f_data, float), 0.0, delta)
    return delta


def goodness(chi2, dof, noise_known: bool):
    """(chi2_dof, p-value): NaN where the noise is unknown (it cannot be tested)."""
    chi2 = np.asarray(chi2, float)
    dof = np.maximum(np.asarray(dof), 1)
    if not noise_known:
        nan = np.full(chi2.shape, np.nan)
        return nan, nan
    return chi2 / dof, stats.chi2.sf(chi2, dof)


def input_flags(M, sigma=None, saturation=None) -> list:
    """Sanity flags of one chart's values ``M`` (m, n) with noise ``sigma`` (m, n) or None and
    the sensor's clip level ``saturation`` (data units) or None."""
    M = np.asarray(M, float)
    flags = []
    if saturation is not None:
        if np.any(M >= saturation * (1 - 1e-9)):
            flags.append("saturated")
    else:  # clipping leaves patches tied at the chart's maximum (the brightest channel clips
        # first; ties within a dark channel are quantisation, not clipping)
        top = M.max()
        if top > 0 and np.sum(M == top) >= 2:
            flags.append("saturated")
    if M.shape[1] == 24:
        grey = M[:, GREY_ROW]
        steps = np.diff(grey, axis=1)  # falls from white to black: steps < 0
        if sigma is not None:
            sg = np.asarray(sigma, float)[:, GREY_ROW]
            noise = np.sqrt(sg[:, 1:] ** 2 + sg[:, :-1] ** 2)
            contrast = (grey[:, 0] - grey[:, -1]) / np.sqrt(sg[:, 0] ** 2 + sg[:, -1] ** 2)
            if np.max(contrast) < DARK_SNR:
                flags.append("dark")
        else:
            noise = 1e-2 * np.abs(grey[:, :1]) / ORDER_SIGMAS + 1e-300  # 1 % of white
        if np.any(steps > ORDER_SIGMAS * noise) and "dark" not in flags:
            flags.append("patch-order")
    return flags


def estimate_flags(*, converged, noise_known, p_value, chl, cdom, chl_ci, cdom_ci, ci_codes,
                   free_chl=True, free_cdom=True) -> list:
    """The flags of a fit (besides :func:`input_flags`); ``ci_codes`` are the four
    ``BOUND_*`` codes of (chl low, chl high, cdom low, cdom high) or None (no intervals)."""
    from ._batch_kernel import BOUND_FAILED, BOUND_OPEN

    flags = []
    if not converged:
        flags.append("not-converged")
    if not noise_known:
        flags.append("noise-unknown")
    elif not p_value >= MISFIT_P:
        flags.append("misfit")
    if ci_codes is None:
        flags.append("no-interval")
    else:
        if any(c == BOUND_FAILED for c in ci_codes) or not np.all(np.isfinite(
                [chl_ci[0], cdom_ci[0]])):
            flags.append("interval-failed")
        if free_chl and (ci_codes[1] == BOUND_OPEN or not np.isfinite(chl_ci[1])):
            flags.append("unbounded-chl")
        if free_cdom and (ci_codes[3] == BOUND_OPEN or not np.isfinite(cdom_ci[1])):
            flags.append("unbounded-cdom")
    if free_chl and chl <= 0.0:
        flags.append("at-bound-chl")
    if free_cdom and cdom <= 0.0:
        flags.append("at-bound-cdom")
    return flags


def is_reliable(flags) -> bool:
    return not any(f in BLOCKING for f in flags)
