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

from forward.spectra import WHITE_PATCH

from .model import CDOM_MAX, CHL_MAX  # where a profile interval is open (one definition)

__all__ = ["CONFIDENCE", "MISFIT_P", "DARK_SNR", "ORDER_SIGMAS", "CHL_MAX", "CDOM_MAX", "GREY_ROW",
           "BLOCKING", "INFORMATIVE", "profile_delta", "gain_wald", "goodness",
           "input_flag_table", "input_flags", "estimate_flag_table", "estimate_flags",
           "flag_tuples", "is_reliable", "EXACT_SIGMA_FLOOR", "ORDER_FRACTION"]

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
#: Without sigma, a grey-row step may rise by this fraction of white before the order is
#: called wrong; EXACT_SIGMA_FLOOR keeps the test defined on an all-black row.
ORDER_FRACTION, EXACT_SIGMA_FLOOR = 1e-2, 1e-300
#: ColorChecker grey row (0-based patch indices, white to black).
GREY_ROW = tuple(range(WHITE_PATCH, WHITE_PATCH + 6))

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


def gain_wald(gain, var, f_min, dof, noise_known: bool):
    """95 % Wald intervals (N, 2) of the gain from its Gauss-Newton variance ``var`` (noise
    variance 1 units; scaled by f_min / dof where the noise is estimated), clipped at 0."""
    gain = np.asarray(gain, float)
    var = np.asarray(var, float) * (1.0 if noise_known else np.asarray(f_min, float)
                                    / np.maximum(np.asarray(dof), 1))
    half = stats.norm.ppf(0.5 + CONFIDENCE / 2) * np.sqrt(var)
    return np.column_stack([np.maximum(gain - half, 0.0), gain + half])


def goodness(chi2, dof, noise_known: bool):
    """(chi2_dof, p-value): NaN where the noise is unknown (it cannot be tested)."""
    chi2 = np.asarray(chi2, float)
    dof = np.maximum(np.asarray(dof), 1)
    if not noise_known:
        nan = np.full(chi2.shape, np.nan)
        return nan, nan
    return chi2 / dof, stats.chi2.sf(chi2, dof)


def input_flag_table(M, sigma=None, saturation=None) -> dict:
    """Sanity checks of N charts at once: {flag: (N,) bool} for ``M`` (N, m, n), ``sigma``
    (N, m, n) or None, and the clip level ``saturation`` (N,) in data units or None."""
    M = np.asarray(M, float)
    N = M.shape[0]
    flat = M.reshape(N, -1)
    top = flat.max(axis=1)
    if saturation is not None:
        saturated = np.any(flat >= (np.asarray(saturation, float) * (1 - 1e-9))[:, None], axis=1)
    else:  # clipping leaves values tied at the chart's maximum (the brightest channel clips
        # first; ties within a dark channel are quantisation, not clipping)
        saturated = (top > 0) & (np.sum(flat == top[:, None], axis=1) >= 2)
    dark = np.zeros(N, dtype=bool)
    order = np.zeros(N, dtype=bool)
    if M.shape[2] == 24:
        grey = M[:, :, GREY_ROW]
        steps = np.diff(grey, axis=2)  # falls from white to black: steps < 0
        if sigma is not None:
            sg = np.asarray(sigma, float)[:, :, GREY_ROW]
            noise = np.sqrt(sg[:, :, 1:] ** 2 + sg[:, :, :-1] ** 2)
            # a magnitude: a chart read in reverse is not dark, its order is wrong (below)
            contrast = np.abs(grey[:, :, 0] - grey[:, :, -1]) / np.sqrt(sg[:, :, 0] ** 2
                                                                       + sg[:, :, -1] ** 2)
            dark = contrast.max(axis=1) < DARK_SNR
        else:
            noise = ORDER_FRACTION * np.abs(grey[:, :, :1]) / ORDER_SIGMAS + EXACT_SIGMA_FLOOR
        order = np.any(steps > ORDER_SIGMAS * noise, axis=(1, 2)) & ~dark
    return {"saturated": saturated, "dark": dark, "patch-order": order}


def input_flags(M, sigma=None, saturation=None) -> list:
    """The sanity flags of one chart ``M`` (m, n) (see :func:`input_flag_table`)."""
    table = input_flag_table(np.asarray(M, float)[None], None if sigma is None else
                             np.asarray(sigma, float)[None],
                             None if saturation is None else np.array([saturation], float))
    return [k for k, v in table.items() if v[0]]


def estimate_flag_table(*, converged, noise_known, p_value, chl, cdom, chl_ci, cdom_ci,
                        ci_codes, free_chl=True, free_cdom=True) -> dict:
    """The flags of N fits at once (besides :func:`input_flag_table`): {flag: (N,) bool}.
    ``ci_codes`` (N, 4) are the ``BOUND_*`` codes of (chl low, chl high, cdom low, cdom high),
    or None (no intervals computed)."""
    from .intervals import BOUND_FAILED, BOUND_OPEN

    converged = np.asarray(converged, bool).reshape(-1)
    N = converged.size
    chl_ci, cdom_ci = np.asarray(chl_ci, float).reshape(N, 2), np.asarray(cdom_ci, float).reshape(N, 2)
    out = {"not-converged": ~converged,
           "noise-unknown": np.full(N, not noise_known),
           "misfit": (~(np.asarray(p_value, float).reshape(N) >= MISFIT_P)) if noise_known
           else np.zeros(N, bool)}
    if ci_codes is None:
        out["no-interval"] = np.ones(N, bool)
    else:
        codes = np.asarray(ci_codes).reshape(N, 4)
        out["interval-failed"] = (np.any(codes == BOUND_FAILED, axis=1)
                                  | ~np.isfinite(chl_ci[:, 0]) | ~np.isfinite(cdom_ci[:, 0]))
        out["unbounded-chl"] = free_chl & ((codes[:, 1] == BOUND_OPEN) | ~np.isfinite(chl_ci[:, 1]))
        out["unbounded-cdom"] = free_cdom & ((codes[:, 3] == BOUND_OPEN)
                                             | ~np.isfinite(cdom_ci[:, 1]))
    out["at-bound-chl"] = free_chl & (np.asarray(chl, float).reshape(N) <= 0.0)
    out["at-bound-cdom"] = free_cdom & (np.asarray(cdom, float).reshape(N) <= 0.0)
    return out


def estimate_flags(**kw) -> list:
    """The flags of one fit (see :func:`estimate_flag_table`; scalars and one chart's ends)."""
    codes = kw.pop("ci_codes")
    table = estimate_flag_table(ci_codes=None if codes is None else np.array(codes)[None], **kw)
    return [k for k, v in table.items() if v[0]]


def flag_tuples(*tables) -> tuple:
    """Per-chart flag tuples and the (N,) reliable verdict from flag tables."""
    names = [k for t in tables for k in t]
    F = np.column_stack([np.asarray(t[k], bool) for t in tables for k in t])
    blocking = np.array([k in BLOCKING for k in names])
    reliable = ~np.any(F[:, blocking], axis=1)
    # one tuple per distinct combination (charts share them): fast for large batches
    bits = F.astype(np.int64) @ (np.int64(1) << np.arange(len(names), dtype=np.int64))
    uniq, inv = np.unique(bits, return_inverse=True)
    combos = [tuple(n for j, n in enumerate(names) if (u >> j) & 1) for u in uniq.tolist()]
    return [combos[i] for i in inv.tolist()], reliable


def is_reliable(flags) -> bool:
    return not any(f in BLOCKING for f in flags)
