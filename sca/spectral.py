"""A spectral observation model through the one core: diffuse attenuation K_d(lambda) of water.

No camera: the observation is a measured K_d spectrum (m^-1) at a few wavelengths, as a
profiling radiometer gives it (NASA NOMAD; the COPS casts). The model is

    K_d(lambda) = (a(lambda) + b_b(lambda)) / mu_d        (Gordon 1989; Kirk 2011, ch. 6)

with a and b_b the paper's (eqs 5-12) and mu_d ``forward.Water.downwelling_cosine``. The value
and every derivative come from :meth:`forward.WaterTerms.path_coefficient` with the terms
:data:`forward.water.DIFFUSE_TERMS` (the 'split' path model's way down): no formula is restated
here. mu_d itself enters as K_d(mu) = K_d(mu_0) mu_0 / mu (the chain rule of 1 / mu).

:class:`SpectrumProblem` is the inference layer's layout of N spectra (:mod:`sca.problem`: the
residual of each band, no linear unknowns), so :func:`fit_spectrum` fits C and a_CDOM(440) with
the package's one Levenberg-Marquardt (:mod:`sca.lm`) and its profile-likelihood intervals
(:mod:`sca.intervals`), the nuisance parameters carrying Gaussian priors as in :mod:`sca.budget`.

The error model of one spectrum, fixed before any comparison with in-situ data (decision
0041-nomad-kd-evidence): independent relative errors per band, sqrt(sigma_rel^2 + model_error^2),
with
sigma_rel = 5 % (a radiometric K_d from a profile) and ``model_error`` = 15 % (the accuracy of
K_d ~ (a + b_b) / mu_d against radiative transfer, the middle of the 10-20 % range of Gordon
1989 and Lee et al. 2005), and the nuisances: ``cdom_slope`` and ``nap_slope`` with the
budget's sds (:data:`sca.budget.DEFAULT_UNCERTAIN`), ``downwelling_cosine`` 0.75 +- 0.075
(mu_d ~ 0.7-0.9 in the upper ocean, Kirk 2011).

References
----------
H. R. Gordon, "Can the Lambert-Beer law be applied to the diffuse attenuation coefficient of
ocean water?", Limnol. Oceanogr. 34 (1989) 1389-1409. Z.-P. Lee, K.-P. Du and R. Arnone, "A
model for the diffuse attenuation coefficient of downwelling irradiance", J. Geophys. Res.
110 (2005) C02016. J. T. O. Kirk, Light and Photosynthesis in Aquatic Ecosystems, 3rd ed.,
Cambridge University Press (2011), ch. 6.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from forward import validate
from forward.spectra import wavelength_grid
from forward.water import COEFFICIENT_PARAMS, DIFFUSE_TERMS, Water, resolve_water

from .assess import goodness, profile_delta
from .auxiliary import auxiliary_observations
from .biooptical import binds
from .budget import DEFAULT_UNCERTAIN, prior_arrays
from .intervals import BOUND_FOUND, BOUND_ZERO, own_units, profile_intervals
from .lm import evaluate, levenberg_marquardt
from .model import lower_bound, upper_cap
from .problem import TINY, Evaluation, Problem, u_from_chl
from forward.errors import InputError

__all__ = [
    "KD_MODEL_ERROR",
    "KD_PARAMS",
    "KD_SIGMA_REL",
    "KD_UNCERTAIN",
    "MIN_BANDS",
    "MU_D_SD",
    "RELIABLE_P",
    "KdFit",
    "KdModel",
    "SpectrumProblem",
    "fit_spectrum",
    "scaled_spectra",
]

#: Names :class:`KdModel` differentiates by: C (mg m^-3), a_CDOM(440) (m^-1), mu_d and every
#: coefficient field of :class:`forward.Water` (eqs 6-12).
KD_PARAMS = ("chl", "cdom", "downwelling_cosine") + COEFFICIENT_PARAMS
#: Relative standard uncertainty of a radiometric K_d from an in-water profile (per band).
KD_SIGMA_REL = 0.05
#: Relative standard uncertainty of the approximation K_d ~ (a + b_b) / mu_d itself, per band
#: (Gordon 1989; Lee et al. 2005: 10-20 %; the middle taken, fixed before any comparison).
KD_MODEL_ERROR = 0.15
#: Standard deviation of mu_d about 0.75 (mu_d ~ 0.7-0.9 in the upper ocean, Kirk 2011 ch. 6).
MU_D_SD = 0.075
#: The nuisance priors of a K_d fit: the budget's spectral slopes and mu_d.
KD_UNCERTAIN = {"cdom_slope": DEFAULT_UNCERTAIN["cdom_slope"],
                "nap_slope": DEFAULT_UNCERTAIN["nap_slope"],
                "downwelling_cosine": MU_D_SD}
#: A fit is a misfit (not reliable) when its chi^2 p-value is below this.
RELIABLE_P = 0.01
#: Start grid of the fits: C (mg m^-3, log-spaced) and a_CDOM(440) (m^-1).
START_CHL = np.geomspace(0.005, 100.0, 40)
START_CDOM = np.concatenate([[0.0], np.geomspace(0.002, 5.0, 30)])
#: Fewest valid bands of a spectrum (two free parameters and at least one degree of freedom).
MIN_BANDS = 3
#: Levenberg-Marquardt iterations and relative tolerance of a fit.
MAX_ITER, TOL = 200, 1e-10


class KdModel:
    """K_d(lambda) = (a + b_b) / mu_d at given wavelengths, with its analytic Jacobian.

    Parameters
    ----------
    wavelengths : array_like, shape (q,)
        The bands, nm (strictly increasing).
    water : forward.Water, optional
        Constants and tables (default: the paper's); ``downwelling_cosine`` is mu_d's default
        and ``particle_backscatter_fraction`` scales eq 12 into b_bp.

    Attributes
    ----------
    water : forward.Water
        The resolved water.
    wavelengths : ndarray, (q,)
        The bands, nm.
    terms : forward.WaterTerms
        The water's terms on the bands.
    e0 : float
        The exponent of eq 10 (the engine iterates C in u = C^e0).

    References
    ----------
    Gordon 1989 (K_d ~ (a + b_b) / mu_d); Blasinski & Farrell, eqs 5-12.
    """

    def __init__(self, wavelengths, *, water: Water | None = None):
        self.water = resolve_water(water)
        self.wavelengths = wavelength_grid(wavelengths)
        self.terms = self.water.on_grid(self.wavelengths)
        self.e0 = float(self.water.phyto_exponent)

    def kd(self, params: dict, free=(), *, chl_floor: float = 0.0):
        """K_d and its derivatives by the names ``free``.

        Parameters
        ----------
        params : dict
            'chl' (mg m^-3, required), 'cdom' (m^-1, default 0), 'downwelling_cosine' (default
            the water's) and any :data:`forward.water.COEFFICIENT_PARAMS` field; values of
            one leading shape S (or scalars).
        free : sequence of str
            Names of :data:`KD_PARAMS` to differentiate by.
        chl_floor : float, optional
            d/dC is evaluated at max(C, chl_floor), mg m^-3.

        Returns
        -------
        kd : ndarray, S + (q,)
            K_d, m^-1.
        derivatives : dict
            name -> d K_d / d name, S + (q,).

        Raises
        ------
        ValueError
            For a name outside :data:`KD_PARAMS` in ``params`` or ``free``, or no 'chl'.
        """
        bad = (set(params) | set(free)) - set(KD_PARAMS)
        if bad:
            raise InputError("params", f"unknown K_d parameter(s) {sorted(bad)}; choose from "
                             f"{KD_PARAMS}")
        if "chl" not in params:
            raise InputError("params", "'chl' is required")
        consts = {k: v for k, v in params.items() if k in COEFFICIENT_PARAMS}
        wrt = tuple(n for n in free if n != "downwelling_cosine")
        kd, d = self.terms.path_coefficient(params["chl"], params.get("cdom", 0.0),
                                            values=consts, wrt=wrt, floor=chl_floor,
                                            terms=DIFFUSE_TERMS)
        mu0 = self.water.downwelling_cosine
        if "downwelling_cosine" in params:
            mu = np.asarray(params["downwelling_cosine"], float)[..., None]
            kd = kd * (mu0 / mu)
            d = {k: v * (mu0 / mu) for k, v in d.items()}
        else:
            mu = mu0
        if "downwelling_cosine" in free:
            d["downwelling_cosine"] = -kd / mu
        return kd, d


class SpectrumProblem(Problem):
    """N measured K_d spectra as an inference problem (:class:`sca.problem.Problem`): the
    whitened residual of every band, no linear unknowns.

    Parameters
    ----------
    model : KdModel
        The K_d model on the spectra's bands.
    M : ndarray, (N, q)
        Measured K_d / scale (0 where a band is missing).
    W2 : ndarray, (N, q)
        Weights (scale / sigma)^2 (0 where a band is missing).
    scale : ndarray, (N,)
        Each spectrum's largest value, m^-1.
    names : tuple of str
        Free names (:data:`KD_PARAMS`).
    prior_mean, prior_weight : ndarray, (N, p), optional
        The nuisances' Gaussian priors.
    observations : sequence of sca.problem.Observation, optional
        Auxiliary measurements and relation priors (:mod:`sca.auxiliary`).
    """

    def __init__(self, model: KdModel, M, W2, scale, names, prior_mean=None,
                 prior_weight=None, observations=()):
        self.model = model
        self.M, self.W2 = np.asarray(M, float), np.asarray(W2, float)
        self.scale = np.asarray(scale, float)
        super().__init__(names, {}, prior_mean, prior_weight, observations)

    def lower_bound(self, name: str) -> float:
        return 0.0 if name == "downwelling_cosine" else lower_bound(name, self.model.water)

    def power(self, name: str) -> float:
        return self.model.e0 if name == "chl" else 0.0

    @property
    def size(self) -> int:
        return self.M.shape[0]

    def rows(self, idx) -> dict:
        return {"M": self.M[idx], "W2": self.W2[idx], "scale": self.scale[idx]}

    def data_terms(self, idx, theta, params, chain, grad: bool) -> Evaluation:
        """chi^2 of the bands, its half gradient and Gauss-Newton matrix; ``extras``: 'kd'
        (k, q), the fitted K_d in m^-1. (A trial step of mu_d to nearly 0 overflows to an
        infinite objective, which the Levenberg-Marquardt rejects: not warned about.)"""
        with np.errstate(over="ignore"):
            kd, d = self.model.kd(params, self.free if grad else (), chl_floor=TINY)
            inv = 1.0 / self.scale[idx][:, None]
            w2 = self.W2[idx]
            r = self.M[idx] - kd * inv
            f = np.einsum("iq,iq->i", w2, r * r)
            g = H = None
            if grad:
                cols = [self.free.index(n) for n in self.names]
                J = np.stack([d[self.free[c]] for c in cols], axis=1) * inv[:, None, :] \
                    * chain[:, :, None]  # (k, p, q)
                g = -np.einsum("ipq,iq->ip", J, w2 * r)
                H = np.einsum("ipq,irq->ipr", J * w2[:, None, :], J)
        return Evaluation(f, g, H, {"kd": kd})


@dataclass
class KdFit:
    """Fits of N K_d spectra (:func:`fit_spectrum`).

    Attributes
    ----------
    chl, cdom : ndarray, (N,)
        The estimates: C (mg m^-3) and a_CDOM(440) (m^-1).
    chl_ci, cdom_ci : ndarray, (N, 2)
        95 % profile-likelihood intervals (``inf`` upper end where open; NaN where the search
        failed).
    nuisance : dict
        name -> (N,) fitted nuisance values.
    chi2 : ndarray, (N,)
        The objective at the optimum (chi^2 with the priors).
    dof : ndarray, (N,)
        Valid bands minus the two free parameters, plus one for each auxiliary observation
        of the spectrum (a nuisance adds one prior term and one parameter).
    p_value : ndarray, (N,)
        P(chi^2_dof > chi2).
    code : ndarray of int, (N,)
        Levenberg-Marquardt status (:data:`sca.lm.STATUS`).
    ci_codes : ndarray of int, (N, 4)
        :mod:`sca.intervals` codes of (chl low, chl high, cdom low, cdom high).
    reliable : ndarray of bool, (N,)
        p_value >= :data:`RELIABLE_P`, the fit converged (codes 0-2) and both ends of the C
        interval were found (not open, not failed; a lower end at 0 counts as found).
    kd_fit : ndarray, (N, q)
        The fitted K_d, m^-1.
    """

    chl: np.ndarray
    cdom: np.ndarray
    chl_ci: np.ndarray
    cdom_ci: np.ndarray
    nuisance: dict
    chi2: np.ndarray
    dof: np.ndarray
    p_value: np.ndarray
    code: np.ndarray
    ci_codes: np.ndarray
    reliable: np.ndarray
    kd_fit: np.ndarray


def _check_kd(kd, wavelengths):
    wl = wavelength_grid(wavelengths)
    kd = np.array(kd, dtype=float)
    if kd.ndim == 1:
        kd = kd[None]
    if kd.ndim != 2 or kd.shape[1] != wl.size:
        raise InputError("kd", f"expected shape (N, {wl.size}) or ({wl.size},), got {kd.shape}")
    valid = ~np.isnan(kd)
    if np.any(~(kd[valid] > 0)) or np.any(~np.isfinite(kd[valid])):
        raise InputError("kd", "every value must be > 0 and finite, or NaN for a missing band")
    if np.any(valid.sum(axis=1) < MIN_BANDS):
        raise InputError("kd", f"every spectrum needs at least {MIN_BANDS} bands")
    return kd, valid, wl


def _start(model, kd, w2, nuisance_mean, observations=()):
    """Grid start of (u, cdom): the grid point of least objective (chi^2 and the auxiliary
    observations' terms) with the nuisances at their priors' centres."""
    C, G = np.meshgrid(START_CHL, START_CDOM, indexing="ij")
    params = {"chl": C.ravel(), "cdom": G.ravel()}
    params.update({k: float(v) for k, v in nuisance_mean.items()})
    grid = model.kd(params)[0]  # (g, q)
    chi2 = np.einsum("nq,gq->ng", w2, grid ** 2) - 2 * np.einsum("nq,gq->ng", w2 * kd, grid)
    for obs in observations:
        y, sd = np.asarray(obs.value, float), np.asarray(obs.sd, float)
        h = np.broadcast_to(np.asarray(obs.function(params, ())[0], float), (C.size,))
        have = np.isfinite(y)
        r = (h[None, :] - np.where(have, y, 0.0)[:, None]) / np.where(have, sd, 1.0)[:, None]
        chi2 = chi2 + np.where(have[:, None], r * r, 0.0)
    best = np.argmin(chi2, axis=1)
    return u_from_chl(params["chl"][best], model.e0), params["cdom"][best]


def scaled_spectra(kd, valid, rel: float):
    """N K_d spectra as a :class:`SpectrumProblem` takes them: each scaled to its largest value
    1, and the weights 1 / (rel K_d)^2 (a relative sd ``rel`` per band; 0 where not ``valid``).

    Parameters
    ----------
    kd : ndarray, (N, q)
        K_d, m^-1 (NaN allowed where not ``valid``).
    valid : ndarray of bool, (N, q)
        The bands measured.
    rel : float
        The relative sd of each band, > 0.

    Returns
    -------
    M, W2 : ndarray, (N, q)
        The scaled spectra and their weights.
    scale : ndarray, (N,)
        Each spectrum's largest value, m^-1.
    """
    scale = np.nanmax(kd, axis=1)
    M = np.where(valid, kd / scale[:, None], 0.0)
    with np.errstate(divide="ignore"):
        W2 = np.where(valid, 1.0 / (rel * M) ** 2, 0.0)
    return M, W2, scale


def fit_spectrum(kd, wavelengths, *, sigma_rel: float = KD_SIGMA_REL,
                 model_error: float = KD_MODEL_ERROR, uncertain: dict | None = None,
                 water: Water | None = None, intervals: bool = True,
                 auxiliary: dict | None = None) -> KdFit:
    """Fit C and a_CDOM(440) to measured K_d spectra through the one core, with intervals.

    Parameters
    ----------
    kd : array_like, (N, q) or (q,)
        Measured K_d, m^-1: > 0, or NaN where a band is missing (weight 0); at least
        :data:`MIN_BANDS` bands per spectrum.
    wavelengths : array_like, (q,)
        The bands, nm.
    sigma_rel : float, optional
        Relative standard uncertainty of each measured K_d (default :data:`KD_SIGMA_REL`).
    model_error : float, optional
        Relative standard uncertainty of the K_d approximation per band (default
        :data:`KD_MODEL_ERROR`); added in quadrature to ``sigma_rel``.
    uncertain : dict, optional
        Nuisance name -> prior sd (own units): any of 'downwelling_cosine' and the
        :data:`forward.water.COEFFICIENT_PARAMS` fields, centred on the water's value (default
        :data:`KD_UNCERTAIN`; ``{}``: the paper's model exactly).
    water : forward.Water, optional
        The water model (default: the paper's).
    intervals : bool, optional
        Compute the profile-likelihood intervals (default True).
    auxiliary : dict, optional
        What else is known of the water, fused in the fit as in every estimator
        (:func:`sca.auxiliary.auxiliary_observations`): e.g. a sample's a_CDOM(440),
        ``{'cdom': (value, sd)}``, or the Case-1 relation prior ``{'case1': True}`` (or a dict
        of one's own :class:`sca.biooptical.Relation` s)
        (:mod:`sca.biooptical`: a_CDOM(440), a_NAP(440) and a_phi(440) tied to C with their
        scatter measured on NOMAD's even rows; the particle relations act where ``uncertain``
        frees their scales, e.g. ``{**KD_UNCERTAIN, **sca.biooptical.CASE1_UNCERTAIN}``; a
        choice for Case-1-like water, never a default). Values may be (N,) arrays.

    Returns
    -------
    KdFit

    Raises
    ------
    ValueError
        Naming the argument: ``kd`` not positive and finite or of the wrong shape, a negative
        ``sigma_rel`` / ``model_error`` (or both 0), fewer than :data:`MIN_BANDS` bands, an
        unknown name in ``uncertain``, or a malformed ``auxiliary``.

    References
    ----------
    Gordon 1989; Venzon & Moolgavkar 1988 (profile-likelihood intervals); JCGM 100:2008 (the
    nuisance priors).
    """
    kd, valid, wl = _check_kd(kd, wavelengths)
    sigma_rel = validate.scalar("sigma_rel", sigma_rel)
    model_error = validate.scalar("model_error", model_error)
    rel = float(np.hypot(sigma_rel, model_error))
    if rel <= 0:
        raise InputError("sigma_rel", "sigma_rel and model_error cannot both be 0")
    uncertain = dict(KD_UNCERTAIN if uncertain is None else uncertain)
    bad = set(uncertain) - set(KD_PARAMS[2:])
    if bad:
        raise InputError("uncertain", f"not a nuisance of the K_d model: {sorted(bad)}")
    for k, v in uncertain.items():
        uncertain[k] = validate.scalar(f"uncertain['{k}']", v)
    model = KdModel(wl, water=water)
    N = kd.shape[0]
    M, W2, scale = scaled_spectra(kd, valid, rel)
    nuis = tuple(k for k, v in uncertain.items() if v > 0)
    names = ("chl", "cdom") + nuis
    mean = {k: float(getattr(model.water, k)) for k in nuis}
    prior_mean, prior_weight = prior_arrays({k: (mean[k], uncertain[k]) for k in nuis}, names, N)
    observations = [o for o in auxiliary_observations(auxiliary, model.water)
                    if binds(o, names)]
    prob = SpectrumProblem(model, M, W2, scale, names, prior_mean=prior_mean if nuis else None,
                           prior_weight=prior_weight if nuis else None,
                           observations=observations)
    theta0 = prior_mean.copy()
    theta0[:, 0], theta0[:, 1] = _start(model, M * scale[:, None], W2 / scale[:, None] ** 2,
                                        mean, prob.observations)
    f_exact = np.zeros(N)
    theta, f, _, code = levenberg_marquardt(prob, theta0, max_iter=MAX_ITER, tol=TOL,
                                            f_exact=f_exact)
    idx = np.arange(N)
    ev = evaluate(prob, idx, theta, True)
    f, H = ev.f, ev.H
    dof = valid.sum(axis=1) - 2 + sum(np.isfinite(o.value).astype(int)
                                      for o in prob.observations)
    _, p_value = goodness(f, dof, True)
    values = prob.params(idx, theta)
    kd_fit = model.kd({k: values[k] for k in names})[0]
    ends = np.full((N, 2, 2), np.nan)
    codes = np.full((N, 2, 2), 3)
    if intervals:
        delta = profile_delta(True, f, dof)
        caps = np.array([upper_cap(n, model.water) if n in ("chl", "cdom") else np.inf
                         for n in names])
        caps[0] = u_from_chl(caps[0], model.e0)
        e, c = profile_intervals(prob, theta, f, delta, H, caps, which=(0, 1))
        ends, codes = own_units(e[:, :2], c[:, :2], prob.powers[:2]), c[:, :2]
    chl_ok = np.all(np.isin(codes[:, 0], (BOUND_FOUND, BOUND_ZERO)), axis=1)
    reliable = (p_value >= RELIABLE_P) & (code <= 2) & chl_ok
    return KdFit(chl=np.asarray(values["chl"], float), cdom=np.asarray(values["cdom"], float),
                 chl_ci=ends[:, 0], cdom_ci=ends[:, 1],
                 nuisance={k: np.asarray(values[k], float) for k in nuis}, chi2=f, dof=dof,
                 p_value=p_value, code=code, ci_codes=codes.reshape(N, 4), reliable=reliable,
                 kd_fit=kd_fit)

