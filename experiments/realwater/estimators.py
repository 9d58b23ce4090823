"""C from a K_d spectrum: the package against the empirical law and a constant (REALWATER.md).

Three kinds of estimator of the in-situ C of a NOMAD station from its measured K_d bands:

* the package: :func:`sca.spectral.fit_spectrum` (as it is, or with a documented choice such as
  the Case-1 relation prior of :mod:`sca.biooptical`);
* a one-parameter inversion of Morel's (1988) Case-1 law K_d = K_w + chi C^e
  (:func:`fit_morel`): C alone fitted to the bands by the same weighted least squares as the
  package (per band sqrt(sigma_rel^2 + model_error^2) relative), through the same core
  (:class:`MorelModel` in the layout :class:`sca.spectral.SpectrumProblem`: :mod:`sca.lm`,
  :mod:`sca.intervals` for its 95 % profile-likelihood interval);
* the constant: the training half's median C, predicted everywhere (no interval).

:func:`score` gives each the median factor error exp(median |ln(C_hat / C)|), the bias (median
ln ratio), log r^2, the coverage of the in-situ C by the 95 % interval and the share of closed
intervals. **An estimate of 0** (the package puts all absorption into CDOM) would have an
infinite factor error: it is floored at :data:`CHL_FLOOR`, the smallest C of the package's
start grid (:data:`sca.spectral.START_CHL`), and counted.

References
----------
A. Morel, "Optical modeling of the upper ocean in relation to its biogenous matter content
(case I waters)", J. Geophys. Res. 93 (1988) 10749-10768, Table 2.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from forward.spectra import read_spectral_table, wavelength_grid
from forward.water import resolve_water
from sca.assess import goodness, profile_delta
from sca.intervals import BOUND_FOUND, BOUND_OPEN, BOUND_ZERO, own_units, profile_intervals
from sca.lm import evaluate, levenberg_marquardt
from sca.model import CHL_MAX
from sca.problem import chl_from_u, u_from_chl
from sca.spectral import (KD_MODEL_ERROR, KD_SIGMA_REL, MAX_ITER, START_CDOM, START_CHL, TOL,
                          SpectrumProblem, scaled_spectra)

__all__ = ["CDOM_FLOOR", "CHL_FLOOR", "MIN_TRAIN_PAIRS", "MOREL_POWER", "MOREL_TABLE", "MorelFit",
           "MorelModel", "fit_morel", "morel_coefficients", "morel_problem", "score",
           "train_morel"]

#: An estimate below this is scored as this (mg m^-3): the package's smallest start-grid C.
CHL_FLOOR = float(START_CHL[0])
#: An a_CDOM(440) estimate below this is scored as this (m^-1): the smallest non-zero a_CDOM of
#: the package's start grid.
CDOM_FLOOR = float(START_CDOM[START_CDOM > 0][0])
#: C is iterated in u = C^MOREL_POWER (Morel's exponents are 0.6-0.7 over 400-700 nm).
MOREL_POWER = 0.65
#: :func:`train_morel` refits a band's chi and e only with at least this many training stations
#: (NOMAD's 619 nm band has 4; a law fitted to a handful is noise; decision
#: 0081-cruise-blocked-realwater).
MIN_TRAIN_PAIRS = 20
#: Morel's (1988) table of ``data/`` (K_w, chi, e).
MOREL_TABLE = "diffuse_attenuation_morel_1988.csv"


def morel_coefficients(wavelengths) -> tuple:
    """Morel's (1988) Table 2 at ``wavelengths`` (linear interpolation): K_w (m^-1), chi
    (m^-1 (mg m^-3)^-e) and e, each (q,).

    Parameters
    ----------
    wavelengths : array_like, (q,)
        nm, within 400-700.

    Returns
    -------
    tuple of ndarray
        (K_w, chi, e).
    """
    wl_t, vals = read_spectral_table(MOREL_TABLE)
    wl = np.asarray(wavelengths, float)
    return tuple(np.interp(wl, wl_t, vals[:, j]) for j in range(3))


class MorelModel:
    """Morel's (1988) K_d = K_w + chi C^e at given wavelengths, in the interface of
    :class:`sca.spectral.KdModel` (so :class:`sca.spectral.SpectrumProblem` fits it): C the one
    parameter, iterated in u = C^:data:`MOREL_POWER`.

    Parameters
    ----------
    wavelengths : array_like, (q,)
        The bands, nm (400-700).
    coefficients : tuple of array_like, optional
        (K_w, chi, e) at the bands (default: Table 2, :func:`morel_coefficients`; a trained
        law: :func:`train_morel`).

    Attributes
    ----------
    wavelengths : ndarray, (q,)
        The bands, nm.
    kw, chi, e : ndarray, (q,)
        Table 2 at the bands (:func:`morel_coefficients`).
    e0 : float
        :data:`MOREL_POWER`.
    water : forward.Water
        The paper's (its lower bound of C, 0, is the fit's).
    """

    def __init__(self, wavelengths, coefficients=None):
        self.wavelengths = wavelength_grid(wavelengths)
        self.kw, self.chi, self.e = (morel_coefficients(self.wavelengths) if coefficients is None
                                     else (np.asarray(c, float) for c in coefficients))
        self.e0 = MOREL_POWER
        self.water = resolve_water(None)

    def kd(self, params: dict, free=(), *, chl_floor: float = 0.0):
        """K_d (S + (q,)), m^-1, at ``params['chl']`` (shape S) and, for 'chl' in ``free``,
        d K_d / d C at max(C, chl_floor)."""
        bad = (set(params) | set(free)) - {"chl"}
        if bad:
            raise ValueError(f"params: Morel's law has C only, not {sorted(bad)}")
        c = np.asarray(params["chl"], float)[..., None]
        kd = self.kw + self.chi * c ** self.e
        d = {}
        if "chl" in free:
            d["chl"] = self.chi * self.e * np.maximum(c, chl_floor) ** (self.e - 1.0)
        return kd, d


def morel_problem(wavelengths, kd, rel: float, coefficients=None) -> SpectrumProblem:
    """N K_d spectra against Morel's law, C the one free parameter: the layout of
    :class:`sca.spectral.SpectrumProblem` with :class:`MorelModel` (``coefficients`` as there)
    and the weights 1 / (rel K_d)^2 of :func:`sca.spectral.scaled_spectra` (NaN: a missing
    band, weight 0)."""
    kd = np.atleast_2d(np.asarray(kd, float))
    M, W2, scale = scaled_spectra(kd, np.isfinite(kd), rel)
    return SpectrumProblem(MorelModel(wavelengths, coefficients), M, W2, scale, ("chl",))


def train_morel(kd, wavelengths, chl) -> tuple:
    """Morel's law given the training stations: chi and e of each band refitted by least squares
    of ln(K_d - K_w) on ln C over the training stations (K_w as published; pairs with
    K_d <= K_w or a missing band left out; a band with fewer than :data:`MIN_TRAIN_PAIRS` pairs
    keeps Table 2).

    Parameters
    ----------
    kd : array_like, (N, q)
        The training stations' measured K_d, m^-1 (NaN: missing).
    wavelengths : array_like, (q,)
        The bands, nm.
    chl : array_like, (N,)
        Their in-situ C, mg m^-3.

    Returns
    -------
    tuple of ndarray
        (K_w, chi, e), each (q,): the ``coefficients`` of :class:`MorelModel`.
    """
    kw, chi, e = (np.array(c) for c in morel_coefficients(wavelengths))
    kd = np.atleast_2d(np.asarray(kd, float))
    x = np.log(np.asarray(chl, float))
    for j in range(kw.size):
        ok = np.isfinite(kd[:, j]) & (kd[:, j] > kw[j])
        if ok.sum() >= MIN_TRAIN_PAIRS:
            e[j], ln_chi = np.polyfit(x[ok], np.log(kd[ok, j] - kw[j]), 1)
            chi[j] = np.exp(ln_chi)
    return kw, chi, e


@dataclass
class MorelFit:
    """C fitted to N K_d spectra by Morel's (1988) law (:func:`fit_morel`).

    Attributes
    ----------
    chl : ndarray, (N,)
        C, mg m^-3.
    chl_ci : ndarray, (N, 2)
        95 % profile-likelihood interval (``inf``: open; NaN: the search failed).
    chi2, p_value : ndarray, (N,)
        The weighted sum of squares at the optimum and P(chi^2_dof > chi2), dof = bands - 1.
    code : ndarray of int, (N,)
        Levenberg-Marquardt status (:data:`sca.lm.STATUS`).
    """

    chl: np.ndarray
    chl_ci: np.ndarray
    chi2: np.ndarray
    p_value: np.ndarray
    code: np.ndarray


def fit_morel(kd, wavelengths, *, sigma_rel: float = KD_SIGMA_REL,
              model_error: float = KD_MODEL_ERROR, coefficients=None) -> MorelFit:
    """Fit C alone to measured K_d spectra by Morel's (1988) K_w + chi C^e, with intervals.

    The weights are :func:`sca.spectral.fit_spectrum`'s (relative sd
    sqrt(sigma_rel^2 + model_error^2) per band); the start is the best C of the package's start
    grid; the fit and the 95 % profile-likelihood interval (chi^2_1 rise of 3.84) are the
    core's (:mod:`sca.lm`, :mod:`sca.intervals`).

    Parameters
    ----------
    kd : array_like, (N, q)
        Measured K_d, m^-1 (> 0, NaN where a band is missing).
    wavelengths : array_like, (q,)
        The bands, nm, within 400-700.
    sigma_rel, model_error : float, optional
        As :func:`sca.spectral.fit_spectrum`.
    coefficients : tuple, optional
        (K_w, chi, e) at the bands (default Table 2; :func:`train_morel`).

    Returns
    -------
    MorelFit
    """
    kd = np.atleast_2d(np.asarray(kd, float))
    rel = float(np.hypot(sigma_rel, model_error))
    prob = morel_problem(wavelengths, kd, rel, coefficients)
    N = prob.size
    grid = prob.model.kd({"chl": START_CHL})[0]  # (g, q)
    k = prob.M * prob.scale[:, None]
    w2 = prob.W2 / prob.scale[:, None] ** 2
    chi2 = np.einsum("nq,gq->ng", w2, grid ** 2) - 2 * np.einsum("nq,gq->ng", w2 * k, grid)
    theta0 = u_from_chl(START_CHL[np.argmin(chi2, axis=1)], MOREL_POWER)[:, None]
    theta, f, _, code = levenberg_marquardt(prob, theta0, max_iter=MAX_ITER, tol=TOL,
                                            f_exact=np.zeros(N))
    ev = evaluate(prob, np.arange(N), theta, True)
    dof = np.isfinite(kd).sum(axis=1) - 1
    _, p_value = goodness(ev.f, dof, True)
    cap = np.array([u_from_chl(CHL_MAX, MOREL_POWER)])
    ends, codes = profile_intervals(prob, theta, ev.f, profile_delta(True, ev.f, dof), ev.H, cap)
    ci = own_units(ends, codes, prob.powers)[:, 0]
    ci = np.where(np.isin(codes[:, 0], (BOUND_FOUND, BOUND_ZERO, BOUND_OPEN)), ci, np.nan)
    return MorelFit(chl=chl_from_u(theta[:, 0], MOREL_POWER), chl_ci=ci, chi2=ev.f,
                    p_value=p_value, code=code)


def score(estimate, reference, lo=None, hi=None, *, floor: float = CHL_FLOOR,
          clusters=None) -> dict:
    """How well estimates of C (or of a_CDOM) match the in-situ values: **the one scoring rule**
    of REALWATER.md's tables.

    Parameters
    ----------
    estimate : array_like, (N,)
        The estimates (values below ``floor``, 0 included, are scored as ``floor`` and counted).
    reference : array_like, (N,)
        The in-situ values (> 0).
    lo, hi : array_like, (N,), optional
        The 95 % interval (``inf``: open upper end); None: the estimator gives none.
    floor : float, optional
        Where an estimate of 0 is scored (default :data:`CHL_FLOOR`, mg m^-3).
    clusters : array_like, (N,), optional
        Each station's cruise: adds cruise-clustered bootstrap 95 % intervals
        (:func:`experiments.realwater.split.cluster_bootstrap`) 'factor_error_ci' and
        'coverage_ci' (NaN, NaN without an interval).

    Returns
    -------
    dict
        'n'; 'n_zero' (estimates of 0); 'factor_error' exp(median |ln(C_hat / C)|);
        'bias_log' (median ln(C_hat / C)) and 'bias_factor' (its exp); 'r2_log' (squared
        correlation of ln C_hat and ln C; 0 for a constant estimate, NaN for a constant C or
        fewer than 3 stations); and with an interval 'coverage' (share with
        lo <= C <= hi), 'closed' (share with lo > 0 and hi finite), 'measured' (closed with
        hi / lo <= :data:`sca.derived.MEASURED_RATIO`, the package's verdict 'measured') and
        'width_factor' (median hi / lo of the closed ones); NaN without.
    """
    from sca.derived import MEASURED_RATIO

    est = np.asarray(estimate, float)
    ref = np.asarray(reference, float)
    e = np.maximum(est, floor)
    r = np.log(e / ref)
    out = {"n": int(ref.size), "n_zero": int(np.sum(est <= 0)),
           "factor_error": float(np.exp(np.median(np.abs(r)))),
           "bias_log": float(np.median(r)), "bias_factor": float(np.exp(np.median(r))),
           "r2_log": np.nan if ref.size < 3 or np.ptp(ref) == 0 else 0.0 if np.ptp(e) == 0
           else float(np.corrcoef(np.log(e), np.log(ref))[0, 1] ** 2),
           "coverage": np.nan, "closed": np.nan, "measured": np.nan, "width_factor": np.nan}
    inside = None
    if lo is not None:
        lo, hi = np.asarray(lo, float), np.asarray(hi, float)
        closed = (lo > 0) & np.isfinite(hi)
        inside = (lo <= ref) & (ref <= hi)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(closed, hi / np.where(closed, lo, 1.0), np.inf)
        out.update(coverage=float(np.mean(inside)), closed=float(np.mean(closed)),
                   measured=float(np.mean(ratio <= MEASURED_RATIO)),
                   width_factor=float(np.median(ratio[closed])) if closed.any() else np.nan)
    if clusters is not None:
        out.update(_intervals(np.abs(r), inside, clusters))
    return out


def _intervals(abs_log, inside, clusters) -> dict:
    """Cruise-clustered bootstrap intervals of the factor error and the coverage."""
    from .split import cluster_bootstrap

    out = {"factor_error_ci": cluster_bootstrap(
        lambda i: np.exp(np.median(abs_log[i])), clusters)}
    out["coverage_ci"] = (np.nan, np.nan) if inside is None else cluster_bootstrap(
        lambda i: np.mean(inside[i]), clusters)
    return out
