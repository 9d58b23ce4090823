"""Is an estimate trustworthy? Goodness of fit, input sanity, intervals and the verdict.

One set of rules for :func:`sca.estimate` and :func:`sca.estimate_batch` (decision
0008-trust-noise-fit-flags):

* **goodness of fit**: ``fit_rms`` = ||M - gain G - s|| / ||M||; with the noise known, chi^2 of
  the whitened residual on ``dof`` = m n - (free C, a_CDOM and any other free nonlinear
  parameter, active s, a free gain) degrees of freedom, its reduced value ``chi2_dof`` and
  p-value; p < :data:`MISFIT_P` is a ``misfit``;
* **intervals**: 95 % profile likelihood (:func:`profile_delta`): the set of C (or a_CDOM)
  whose profile objective is within chi^2_1(0.95) = 3.84 of the minimum (noise known) or within
  F(0.95; 1, dof) times the residual variance (noise estimated from the residual);
* **input sanity** (:func:`input_flags`): ``saturated`` (a value at the sensor's clip level, or
  two or more values tied at the chart's maximum), ``dark`` (the grey row's white-black contrast below
  :data:`DARK_SNR` standard deviations in every channel), ``patch-order`` (the grey row of a
  ColorChecker not falling from white to black);
* **readings and priors against the photos** (:mod:`sca.consistency`): ``reading-conflict``
  (an auxiliary reading's likelihood-ratio test below ``CONFLICT_P``) and ``nuisance-pulled``
  (a prior's pull beyond ``PULL_MAX`` of its sds); ``reference-conflict`` (two reference shots
  bracketing the dive that disagree, :func:`sca.reference.bracket`);
* ``reliable`` is True only when no flag of :data:`BLOCKING` is raised.
"""

from __future__ import annotations

import numpy as np
from scipy import special  # chdtri, fdtri, ndtri, chdtrc: scipy.stats's own, without its import cost

from forward.spectra import WHITE_PATCH

from .model import CDOM_MAX, CHL_MAX  # where a profile interval is open (one definition)

__all__ = ["CONFIDENCE", "CONFLICT_P", "MISFIT_P", "SCALE_P", "DARK_SNR", "ORDER_SIGMAS", "CHL_MAX", "CDOM_MAX", "GREY_ROW",
           "BLOCKING", "INFORMATIVE", "Z95", "profile_delta", "gain_wald", "wald", "goodness",
           "input_flag_table", "input_flags", "estimate_flag_table", "estimate_flags",
           "flag_tuples", "is_reliable", "EXACT_SIGMA_FLOOR", "ORDER_FRACTION"]

#: Confidence level of ``chl_ci`` and ``cdom_ci``.
CONFIDENCE = 0.95
#: The standard normal quantile of :data:`CONFIDENCE`'s two-sided interval (1.96): every Wald
#: interval's and :func:`sca.precision`'s half-width in standard deviations.
Z95 = float(special.ndtri(0.5 + CONFIDENCE / 2))
#: A fit whose chi^2 p-value is below this is a ``misfit`` (one in a thousand false alarms).
MISFIT_P = 1e-3
#: A known gain whose likelihood-ratio test against a free one (:func:`sca.batch.scale_test`)
#: has a p-value below this is a ``scale-mismatch``: one in a hundred false alarms, since a
#: missed wrong scale is fitted as another water with a confident interval (decision
#: 0008-trust-noise-fit-flags).
SCALE_P = 0.01
#: A reading whose likelihood-ratio test against the photos has a p-value below this is a
#: ``reading-conflict`` (one in a thousand false alarms per reading, as ``misfit``).
CONFLICT_P = 1e-3
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
            "patch-order", "scale-mismatch", "reading-conflict", "nuisance-pulled",
            "reference-conflict")
#: Flags that describe the estimate without making it unreliable.
INFORMATIVE = ("at-bound-chl", "at-bound-cdom")


def profile_delta(noise_known: bool, f_min, dof, f_data=None):
    """The rise of the profile objective that bounds the 95 % interval (arrays allowed).

    chi^2_1(0.95) = 3.84 where the noise is known (the objective is chi^2); F(0.95; 1, dof)
    f_min / dof where it is estimated from the residual. With the noise estimated, a residual
    at rounding level (below 1e-20 of ``f_data``, the data's own sum of squares) gives 0: the
    interval has zero width.

    Parameters
    ----------
    noise_known : bool
        The objective is chi^2 (whitened by the known noise).
    f_min : float or array_like, (N,)
        The objective at the optimum (chi^2, or the unweighted sum of squares in the
        problem's units).
    dof : int or array_like, (N,)
        Degrees of freedom of the residual (values below 1 count as 1).
    f_data : float or array_like, (N,), optional
        The data's own (weighted) sum of squares, in the units of ``f_min``.

    Returns
    -------
    ndarray, shape of ``f_min``
        Delta: the interval is {theta_j : profile objective <= f_min + Delta}, in the units of
        ``f_min``.

    References
    ----------
    D. J. Venzon & S. H. Moolgavkar, "A method for computing profile-likelihood-based
    confidence intervals", Applied Statistics 37 (1988) 87-94.
    """
    f_min = np.asarray(f_min, float)
    dof = np.maximum(np.asarray(dof), 1)
    if noise_known:
        return np.full(f_min.shape, special.chdtri(1, 1.0 - CONFIDENCE))
    delta = special.fdtri(1, dof, CONFIDENCE) * f_min / dof
    if f_data is not None:
        delta = np.where(f_min <= 1e-20 * np.asarray(f_data, float), 0.0, delta)
    return delta


def gain_wald(gain, var, f_min, dof, noise_known: bool):
    """95 % Wald intervals (N, 2) of the gain from its Gauss-Newton variance ``var``.

    gain -/+ 1.96 sqrt(var'), var' = ``var`` (noise variance 1 units) where the noise is known,
    ``var`` f_min / dof where it is estimated; the lower end clipped at 0.

    Parameters
    ----------
    gain : array_like, (N,)
        The estimated gains (units of the measurements per model unit).
    var : array_like, (N,)
        Their Gauss-Newton variances for unit noise variance (``inf``: undetermined).
    f_min : array_like, (N,)
        The objective at the optimum (used only where the noise is estimated).
    dof : array_like, (N,)
        Degrees of freedom of the residual (values below 1 count as 1).
    noise_known : bool
        ``var`` is already in the units of the known noise.

    Returns
    -------
    ndarray, (N, 2)
        Lower and upper ends, units of ``gain``.
    """
    gain = np.asarray(gain, float)
    var = np.asarray(var, float) * (1.0 if noise_known else np.asarray(f_min, float)
                                    / np.maximum(np.asarray(dof), 1))
    return wald(gain, np.sqrt(var))


def wald(value, sd, lower=0.0):
    """The Wald interval value -/+ :data:`Z95` sd, the lower end clipped at ``lower``: the one
    linear interval (a log-scale one is :func:`sca.derived.delta_interval`).

    Parameters
    ----------
    value, sd : array_like, S
        The estimate and its standard deviation.
    lower : float or array_like, optional
        The lowest value possible (default 0; -inf: none).

    Returns
    -------
    ndarray, S + (2,)
        Lower and upper ends.
    """
    value, half = np.asarray(value, float), Z95 * np.asarray(sd, float)
    return np.stack([np.maximum(value - half, lower), value + half], axis=-1)


def goodness(chi2, dof, noise_known: bool):
    """(chi2_dof, p-value): NaN where the noise is unknown (it cannot be tested).

    Parameters
    ----------
    chi2 : float or array_like, (N,)
        chi^2 of the whitened residual (the objective with the noise known).
    dof : int or array_like, (N,)
        Degrees of freedom (values below 1 count as 1).
    noise_known : bool
        The residual is whitened by the known noise.

    Returns
    -------
    chi2_dof : ndarray, shape of ``chi2``
        chi2 / dof (NaN where the noise is unknown).
    p_value : ndarray, shape of ``chi2``
        P(X > chi2) for X ~ chi^2_dof (NaN where the noise is unknown).
    """
    chi2 = np.asarray(chi2, float)
    dof = np.maximum(np.asarray(dof), 1)
    if not noise_known:
        nan = np.full(chi2.shape, np.nan)
        return nan, nan
    return chi2 / dof, special.chdtrc(dof, chi2)


def input_flag_table(M, sigma=None, saturation=None) -> dict:
    """Sanity checks of N charts at once: {flag: (N,) bool}.

    ``saturated``: a value at (within 1e-9 of) the clip level ``saturation`` or, without it,
    two or more values tied at the chart's maximum (> 0). For 24-patch charts (ColorChecker)
    only: ``dark``: with ``sigma``, the grey row's white-black contrast below :data:`DARK_SNR`
    standard deviations in every channel (never raised without ``sigma``); ``patch-order``: a
    grey-row step (:data:`GREY_ROW`, white to black) rises by more than :data:`ORDER_SIGMAS`
    standard deviations (without ``sigma``: by more than :data:`ORDER_FRACTION` of the
    channel's white), in a chart that is not ``dark``. Both are False for other charts.

    Parameters
    ----------
    M : array_like, (N, m, n)
        Patch values of N charts (data units).
    sigma : array_like, (N, m, n), optional
        Standard deviation of every value (data units).
    saturation : array_like, (N,), optional
        The sensor's clip level of every chart (data units).

    Returns
    -------
    dict
        'saturated', 'dark', 'patch-order' -> ndarray of bool, (N,).
    """
    M = np.asarray(M, float)
    N = M.shape[0]
    flat = M.reshape(N, int(np.prod(M.shape[1:])))  # N = 0 too
    top = flat.max(axis=1, initial=-np.inf)
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
    """The sanity flags of one chart ``M`` (m, n) (see :func:`input_flag_table`).

    Parameters
    ----------
    M : array_like, (m, n)
        Patch values (data units).
    sigma : array_like, (m, n), optional
        Standard deviation of every value (data units).
    saturation : float, optional
        The sensor's clip level (data units).

    Returns
    -------
    list of str
        The raised flags among 'saturated', 'dark', 'patch-order', in that order.
    """
    table = input_flag_table(np.asarray(M, float)[None], None if sigma is None else
                             np.asarray(sigma, float)[None],
                             None if saturation is None else np.array([saturation], float))
    return [k for k, v in table.items() if v[0]]


def estimate_flag_table(*, converged, noise_known, p_value, chl, cdom, chl_ci, cdom_ci,
                        ci_codes, free_chl=True, free_cdom=True, scale_p=None) -> dict:
    """The flags of N fits at once (besides :func:`input_flag_table`): {flag: (N,) bool}.

    ``not-converged``; ``noise-unknown``; ``misfit`` (noise known and p-value below
    :data:`MISFIT_P` or NaN); ``scale-mismatch`` (the gain held known, and the test of that
    gain against a free one, ``scale_p``, below :data:`SCALE_P`: the values are not in the
    units the fit was told); without intervals ``no-interval``, else ``interval-failed`` (a
    ``BOUND_FAILED`` end or a non-finite lower end of ``chl_ci`` / ``cdom_ci``),
    ``unbounded-chl`` / ``unbounded-cdom`` (a free parameter whose upper end is open or not
    finite); ``at-bound-chl`` / ``at-bound-cdom`` (a free parameter estimated at 0).

    Parameters
    ----------
    converged : array_like of bool, (N,)
        The fits converged.
    noise_known : bool
        ``sigma`` was given (the p-values are defined).
    p_value : array_like, (N,)
        chi^2 p-values of the fits (see :func:`goodness`).
    chl : array_like, (N,)
        Estimated C, mg m^-3.
    cdom : array_like, (N,)
        Estimated a_CDOM(440), m^-1.
    chl_ci : array_like, (N, 2)
        95 % intervals of C, mg m^-3.
    cdom_ci : array_like, (N, 2)
        95 % intervals of a_CDOM(440), m^-1.
    ci_codes : array_like of int, (N, 4), or None
        The ``BOUND_*`` codes (:mod:`sca.intervals`) of (chl low, chl high, cdom low, cdom
        high), or None (no intervals computed).
    free_chl, free_cdom : bool, optional
        C / a_CDOM was estimated (default True); a fixed one raises no ``unbounded-*`` or
        ``at-bound-*`` flag.
    scale_p : array_like, (N,), optional
        p-values of the known gain's test (:func:`sca.batch.scale_test`; NaN: not tested);
        None: no test (a free gain).

    Returns
    -------
    dict
        Flag name -> ndarray of bool, (N,): 'not-converged', 'noise-unknown', 'misfit',
        'scale-mismatch', then
        'no-interval' or ('interval-failed', 'unbounded-chl', 'unbounded-cdom'), then
        'at-bound-chl', 'at-bound-cdom'.
    """
    from .intervals import BOUND_FAILED, BOUND_OPEN

    converged = np.asarray(converged, bool).reshape(-1)
    N = converged.size
    chl_ci, cdom_ci = np.asarray(chl_ci, float).reshape(N, 2), np.asarray(cdom_ci, float).reshape(N, 2)
    out = {"not-converged": ~converged,
           "noise-unknown": np.full(N, not noise_known),
           "misfit": (~(np.asarray(p_value, float).reshape(N) >= MISFIT_P)) if noise_known
           else np.zeros(N, bool),
           "scale-mismatch": np.zeros(N, bool) if scale_p is None
           else np.asarray(scale_p, float).reshape(N) < SCALE_P}
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
    """The flags of one fit (see :func:`estimate_flag_table`; scalars and one chart's ends).

    Parameters
    ----------
    **kw
        The keywords of :func:`estimate_flag_table` for one fit: ``converged``,
        ``noise_known``, ``p_value``, ``chl`` (mg m^-3), ``cdom`` (m^-1) as scalars, ``chl_ci``
        and ``cdom_ci`` as (lo, hi), ``ci_codes`` (required) as 4 codes or None, and optionally
        ``free_chl``, ``free_cdom``.

    Returns
    -------
    list of str
        The raised flags, in the order of :func:`estimate_flag_table`.
    """
    codes = kw.pop("ci_codes")
    table = estimate_flag_table(ci_codes=None if codes is None else np.array(codes)[None], **kw)
    return [k for k, v in table.items() if v[0]]


def flag_tuples(*tables) -> tuple:
    """Per-chart flag tuples and the (N,) reliable verdict from flag tables.

    Parameters
    ----------
    *tables : dict
        Flag tables {flag: (N,) bool} (e.g. of :func:`input_flag_table` and
        :func:`estimate_flag_table`), all for the same N charts.

    Returns
    -------
    flags : list of tuple of str
        For each chart, its raised flags (in the order of the tables and their keys).
    reliable : ndarray of bool, (N,)
        True where no flag of :data:`BLOCKING` is raised.
    """
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
    """Whether no flag of :data:`BLOCKING` is raised.

    Parameters
    ----------
    flags : iterable of str
        The flags of one estimate.

    Returns
    -------
    bool
        True when none of ``flags`` is in :data:`BLOCKING`.
    """
    return not any(f in BLOCKING for f in flags)
