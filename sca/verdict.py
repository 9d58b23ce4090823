"""The assessment of one finished fit (the cvxpy loop, the scipy path or the one-chart 'lm'
engine, :func:`fit_lm`): goodness of fit,
standard errors, intervals of every free parameter, flags and the verdict, as an
:class:`sca.Estimate`.

Intervals: profile likelihood through :mod:`sca.intervals` (the batch's own routine, on the
same reduced problem: w on eq 17, gain and s profiled out), so every estimator's intervals
agree; for z > 1 basis functions Wald intervals from :func:`sca.model.profiled_covariance`
(flag ``interval-approximate``).

In two steps (issue 46): :func:`settle` fixes the objective (the budget's refinement, the
quadrature's certificate, the readings' objectives alone), which decides the path models'
support; :func:`finish` computes the rest, only for the supported path models
(:func:`sca.loop.over_path_models`). :func:`assess` is both.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field as dataclass_field

import numpy as np

from .assess import estimate_flags, gain_wald, wald, goodness, input_flags, is_reliable, \
    profile_delta
from .budget import prior_arrays, variance_shares
from .intervals import own_units, profile_intervals
from .batch import scale_test
from .charts import ChartProblem
from .consistency import nuisance_pulls, objectives_alone, tested
from .derived import derived_from_fit, verdict
from .lm import LM_TOL, STATUS, evaluate, levenberg_marquardt
from .model import CAMERA, CHL_DERIVATIVE_FLOOR, profiled_covariance, u_from_chl
from .parameters import lm_cap
from .quadrature import CERTIFY_SIGMA, reduction_error
from .results import Estimate
from forward.errors import InputError

__all__ = ["assess", "settle", "finish", "Settled", "REFINE_MAX_ITER", "REFINE_TOL"]

#: Levenberg-Marquardt iterations and relative tolerance of the budget's refinement (the
#: nuisances moved within their priors from the loop's point).
REFINE_MAX_ITER, REFINE_TOL = 100, 1e-12


def _priors(est, st) -> dict:
    """The budget's priors that apply to this fit: name -> (mean (1,), sd (1,)); none where
    the noise is unknown or the basis has z > 1 functions (no eq-17 reduction)."""
    if not st.noise_known or st.mdl.z != 1:
        return {}
    return est.budget.priors


def _params(est, st, x) -> dict:
    """The model's parameters at ``x`` with the budget's nuisances at their fitted values."""
    params = est.params(x)
    params.update(st.nuisance)
    return params


def _covariance(est, st, dof):
    """Gauss-Newton covariance of (free names [, gain]) at the fit, C in its own units (its
    derivative at the loop's floor), w following C along eq 17 (shape held)."""
    mdl, x = st.mdl, st.x
    names = list(est.spec.names)
    with_w = mdl.z > 1 or "chl" not in names
    free = names + (["w"] if with_w and "w" not in names else [])
    params = _params(est, st, x)
    if not with_w:
        params.pop("w")
    pred = mdl.predict(params, free, chl_floor=CHL_DERIVATIVE_FLOOR)
    J = pred.jacobian
    if with_w:
        Jw = pred.column("w")
        J = J[..., [i for i, c in enumerate(pred.columns) if c != "w"]]
        if "chl" in names:
            alpha, dalpha = mdl.phyto_scale(x["chl"], derivative=True)
            dw = (np.asarray(x["w"], float) * (float(dalpha) / float(alpha)) if alpha > 0
                  else np.full(mdl.z, float(dalpha) / float(np.sum(mdl.t440))))
            J[..., names.index("chl")] += Jw @ dw
    r = st.wt * (st.Mv - pred.values)
    sigma2 = 1.0 if st.noise_known else float(r @ r) / max(dof, 1)
    active = (x["s"] > 0) if est.free_s else np.zeros(mdl.m, bool)
    shape = (1, mdl.m, mdl.n)
    G = (pred.values - np.repeat(x["s"], mdl.n)) / (x["gain"] if x["gain"] > 0 else 1.0)
    cov = profiled_covariance(J.reshape(shape + (-1,)), (st.wt ** 2).reshape(shape),
                              active[None], sigma2,
                              gain_column=G.reshape(shape) if est.free_gain else None)[0]
    if dof <= 0:
        cov = np.full(cov.shape, np.inf)
    return cov


def _problem(est, st, priors: bool = True) -> ChartProblem:
    """The fit as a one-chart :class:`sca.charts.ChartProblem` (the model already in the data's units),
    with the budget's nuisances after the free names and their Gaussian priors (``priors``
    False: the paper's model, the free names alone; the auxiliary measurements with the
    priors)."""
    observations = est.observations if priors and st.noise_known else ()
    priors = _priors(est, st) if priors else {}
    names = tuple(est.spec.names) + tuple(
        n for n in priors for _ in range(st.mdl.m if n in CAMERA else 1))
    mean = weight = None
    if priors:
        mean, weight = prior_arrays(priors, names)
    fixed = {"depth": np.array([est.depth]), "distance": np.array([est.distance])}
    for k in ("chl", "cdom"):
        if k in est.fixed:
            fixed[k] = np.array([est.fixed[k]])
    fixed = {k: v for k, v in fixed.items() if k not in names}
    return ChartProblem(st.fit_mdl, st.Mv[None], (st.wt ** 2)[None], np.ones(1), names, fixed,
                        est.free_gain, None if st.s_fixed is None else st.s_fixed[None], mean,
                        weight, observations)


def _theta(est, st, prob) -> np.ndarray:
    """The fit's point in the problem's LM coordinates (1, p): nuisances at their fitted values
    (or their priors' centres)."""
    row, seen = [], {}
    for j, n in enumerate(prob.names):
        if n == "chl":
            row.append(u_from_chl(st.x["chl"], st.mdl.e0))
        elif n in est.spec.names:
            row.append(st.x[n])
        else:
            k = seen[n] = seen.get(n, -1) + 1
            if n not in st.nuisance:
                row.append(prob.prior_mean[0, j])
            else:
                row.append(np.asarray(st.nuisance[n], float).reshape(-1)[k])
    return np.array([row], float)


def fit_lm(est, st, max_iter: int, x0=None) -> int:
    """The batch's engine on one chart (:mod:`sca.lm`: variable projection and
    Levenberg-Marquardt, no cvxpy) from the loop's start point, the paper's model (the
    budget's nuisances are released afterwards by :func:`assess`, as after the loop); ``st``
    is updated (x, f, initial, history, status). Returns the iterations.

    Parameters
    ----------
    est : sca.Estimator
        The estimator (one basis function).
    st : sca.loop._FitState
        The prepared fit.
    max_iter : int
        Iteration limit.
    x0 : dict, optional
        Start values (as :meth:`sca.Estimator.initial_point`).

    Returns
    -------
    int
        Levenberg-Marquardt iterations.
    """
    if st.mdl.z != 1:
        raise InputError("mode", "'lm' supports one basis function (z = 1); use 'safeguarded'")
    prob = _problem(est, st, priors=False)
    st.x = est.initial_point(st, x0)
    st.initial = {"chl": st.x["chl"], "cdom": st.x["cdom"]}
    st.f = est.objective(st, st.x)
    st.history.append(st.f)
    theta, f, it, code = levenberg_marquardt(prob, _theta(est, st, prob), max_iter=max_iter,
                                             tol=LM_TOL, f_exact=np.array([st.f_exact]))
    _take_point(est, st, prob, theta, f)
    st.history.append(st.f)
    st.stop(f"lm: {STATUS[int(code[0])]}", bool(code[0] <= 2))
    return int(it[0])


def _take_point(est, st, prob, theta, f) -> dict:
    """Set ``st``'s point to LM coordinates ``theta`` (1, p) of ``prob`` with objective ``f``
    (1,): the free names, w on eq 17, the closed-form gain and backscatter. Returns the
    model's parameters there (name -> (1,) values, nuisances included)."""
    ev = evaluate(prob, np.arange(1), theta, False)
    gain, s = ev.extras["gain"], ev.extras["s"]
    values = prob.params(np.arange(1), theta)
    x = dict(st.x)
    for n in est.spec.names:
        x[n] = float(values[n][0])
    x["w"] = st.mdl.feasible_w(x["chl"])
    x["gain"] = float(gain[0]) if est.free_gain else x["gain"]
    x["s"] = np.array(s[0], float) if est.free_s else x["s"]
    st.x, st.f = x, float(f[0])
    return values


def _refine(est, st, always: bool = False):
    """With the budget's priors: move C, a_CDOM, the free names and every nuisance from the
    loop's point to the penalised optimum (chi^2 + the priors' terms) with the one
    Levenberg-Marquardt engine; ``st`` is updated (x, f, nuisance, status). ``always``: also
    without priors (the optimum on another model of the same data)."""
    prob = _problem(est, st)
    if prob.prior_mean is None and not prob.observations and not always:
        return
    theta, f, _, code = levenberg_marquardt(prob, _theta(est, st, prob), max_iter=REFINE_MAX_ITER,
                                            tol=REFINE_TOL, f_exact=np.array([st.f_exact]))
    values = _take_point(est, st, prob, theta, f)
    st.nuisance = {n: (np.array(values[n][0], float) if n in CAMERA else float(values[n][0]))
                   for n in prob.free if n not in est.spec.names}
    if code[0] > 2:
        st.converged = False
        st.status = f"{st.status}; budget refinement: {STATUS[int(code[0])]}"


def _certify(est, st):
    """The reduced quadrature's certificate at the optimum (:mod:`sca.quadrature`): where the
    reduced prediction differs from the full grid's by more than CERTIFY_SIGMA of a value's
    noise, the fit (and what follows: the intervals) is moved to the full grid."""
    if st.fit_mdl is st.mdl:
        return
    params = _params(est, st, st.x)
    params.update(gain=st.x["gain"], backscatter=np.asarray(st.x["s"], float))
    # the sensor's noise, or the noise the residual shows where that is smaller (a fit far
    # better than its noise, or an exact one, is held to its own residual: the full grid)
    pred = st.fit_mdl.predict(params, jacobian=False).values
    shown = np.sqrt(np.mean((st.Mv - pred) ** 2))
    noise = np.full(st.Mv.size, shown)
    if st.noise_known:
        noise = np.minimum(noise, 1.0 / (st.wt_photon if st.wt_photon is not None else st.wt))
    st.quadrature_error = float(reduction_error(st.mdl, st.fit_mdl, params, noise))
    if not st.quadrature_error <= CERTIFY_SIGMA:
        st.fit_mdl = st.mdl
        st.quadrature_error = 0.0
        _refine(est, st, always=True)


def _derived(est, st, dof, intervals) -> dict:
    """What the photo measures (:func:`sca.derived.derived_from_fit`) and every verdict, as
    :class:`sca.Estimate`'s fields (one basis function; none otherwise)."""
    out = {"verdicts": {n: verdict(*intervals[n]) for n in ("chl", "cdom") if n in intervals}}
    if st.mdl.z != 1:
        return out
    prob = _problem(est, st)
    theta = _theta(est, st, prob)
    H = evaluate(prob, np.arange(1), theta, True).H
    sigma2 = 1.0 if st.noise_known else st.f / max(dof, 1)
    ends = {}  # the upper ends of C and a_CDOM, LM coordinates (sca.derived.bound_points)
    for n in ("chl", "cdom"):
        if n in est.spec.names and n in intervals and np.isfinite(intervals[n][1]):
            hi = intervals[n][1]
            ends[prob.names.index(n)] = np.array([u_from_chl(hi, st.mdl.e0) if n == "chl"
                                                  else hi])
    d = derived_from_fit(prob, theta, H, est.water, st.mdl.wavelengths, sigma2, ends=ends)
    out.update(quantities={k: float(v[0]) for k, (v, _) in d["quantities"].items()},
               quantity_intervals={k: tuple(float(a) for a in ci[0])
                                   for k, (_, ci) in d["quantities"].items()},
               beam_attenuation=d["c"][0], beam_attenuation_ci=d["c_ci"][0])
    out["verdicts"].update({k: verdict(*v, k) for k, v in out["quantity_intervals"].items()})
    return out


def _scale_p(est, st):
    """The known gain's test (:func:`sca.charts.scale_test`) where the gain is held and the
    noise known (one basis function); None otherwise."""
    if est.free_gain or not st.noise_known or st.mdl.z != 1:
        return None
    prob = _problem(est, st)
    geometry = {"depth": np.array([est.depth]), "distance": np.array([est.distance])}
    p, _ = scale_test(prob, _theta(est, st, prob), np.array([st.f]), geometry)
    return float(p[0])


def _shares(est, st, x) -> dict:
    """Each source's share of the variance of C and a_CDOM at the fit
    (:func:`sca.budget.variance_shares`): {} where no budget applies."""
    if not st.noise_known or est.budget.exact or st.mdl.z != 1 or st.wt_photon is None:
        return {}
    prob = _problem(est, st)
    params = _params(est, st, x)
    params.pop("w")
    free = prob.free + (("gain",) if est.free_gain else ()) + ("backscatter",)
    pred = st.mdl.predict(params, free, chl_floor=CHL_DERIVATIVE_FLOOR)
    names = list(pred.columns)
    active = np.array([(x["s"][names[:j].count("backscatter")] > 0 and est.free_s)
                       if n == "backscatter" else True for j, n in enumerate(names)])
    weight = np.zeros(len(names))
    if prob.prior_weight is not None:
        weight[:len(prob.names)] = prob.prior_weight[0]
    out = variance_shares(pred.jacobian[None], names, (st.wt ** 2)[None],
                          (st.wt_photon ** 2)[None], active[None], weight[None],
                          of=("chl", "cdom", "gain"))
    return {n: {"sd": float(v["sd"][0]), "shares": {k: float(a[0]) for k, a in v["shares"].items()}}
            for n, v in out.items()}


def _consistency(est, st, start) -> dict:
    """What :mod:`sca.consistency` needs of this fit under its path model: the objective
    without each auxiliary reading ('alone', from the optimum and from the fit of the photos
    alone, ``start``) and each prior's pull ('pulls'); the path models' union decides
    (:func:`sca.consistency.finalize_single`)."""
    prob = _problem(est, st)
    if prob.prior_mean is None and not prob.observations:
        return {}
    theta = _theta(est, st, prob)
    alone = objectives_alone(prob, theta, () if start is None else (start,))
    return {"alone": {k: float(v[0]) for k, v in alone.items()},
            "pulls": {k: float(v[0]) for k, v in nuisance_pulls(prob, theta).items()}}


def _profile(est, st, dof):
    """95 % profile-likelihood intervals of every free name (z = 1), the budget's nuisances
    profiled: {name: (lo, hi)} and the BOUND_* codes of (chl low, chl high, cdom low, cdom
    high)."""
    prob = _problem(est, st)
    names = est.spec.names
    theta = _theta(est, st, prob)
    ev = evaluate(prob, np.arange(1), theta, True)
    f, H = ev.f, ev.H
    Mw = st.wt * st.Mv
    delta = profile_delta(st.noise_known, f, np.array([dof]), np.array([Mw @ Mw]))
    caps = np.array([lm_cap(n, est.water, st.mdl.e0) for n in prob.names])
    ends, codes = profile_intervals(prob, theta, f, delta, H, caps, which=range(len(names)))
    own = own_units(ends, codes, prob.powers)
    out = {n: (float(own[0, j, 0]), float(own[0, j, 1])) for j, n in enumerate(names)}
    ci_codes = []
    for n in ("chl", "cdom"):
        ci_codes += list(codes[0, names.index(n)]) if n in names else [0, 0]
    return out, tuple(int(c) for c in ci_codes)


def assess(est, st, mode, it, saturation=None) -> Estimate:
    """The :class:`sca.Estimate` of a finished fit ``st`` of estimator ``est``: :func:`settle`
    then :func:`finish` (the known gain's test included), its readings and priors tested
    (:func:`sca.consistency.tested`).

    Goodness of fit (:func:`sca.assess.goodness`), standard errors from the profiled
    Gauss-Newton covariance, 95 % intervals of every free parameter (profile likelihood for
    z = 1, Wald otherwise; Wald for a free gain), the flags and the verdict.

    Parameters
    ----------
    est : Estimator
        The estimator that ran the fit.
    st : sca.loop._FitState
        The finished fit: its point ``st.x``, objective ``st.f``, status, history and the
        data in scaled units.
    mode : str
        Recorded as ``Estimate.mode`` ('paper', 'safeguarded', 'lm', 'scipy_least_squares').
    it : int
        Recorded as ``Estimate.iterations``.
    saturation : float, optional
        The sensor's clip level in data units, for the ``saturated`` check.

    Returns
    -------
    Estimate
        In data units (backscatter and objective rescaled by ``st.scale``).

    References
    ----------
    D. J. Venzon & S. H. Moolgavkar, "A method for computing profile-likelihood-based
    confidence intervals", Applied Statistics 37 (1988) 87-94.
    """
    return tested(finish(settle(est, st, mode, it, saturation)))


@dataclass
class Settled:
    """A fit whose objective is fixed (:func:`settle`): what decides the path models' support
    (:func:`sca.pathmodels.supported`) and their consistency, before the intervals.

    Attributes
    ----------
    est, st, mode, it, saturation :
        As :func:`assess`.
    consistency : dict
        The 'alone' objectives and 'pulls' (:func:`_consistency`).
    fields : dict
        :class:`sca.Estimate` fields the engine sets itself (:func:`finish` writes them).
    """

    est: object
    st: object
    mode: str
    it: int
    saturation: float | None
    consistency: dict
    fields: dict = dataclass_field(default_factory=dict)

    @property
    def objective(self) -> float:
        """The objective in :attr:`sca.Estimate.objective`'s units (chi^2, or data units)."""
        return self.st.f * (1.0 if self.st.noise_known else self.st.scale ** 2)


def settle(est, st, mode, it, saturation=None) -> Settled:
    """The part of :func:`assess` that fixes the objective: the budget's refinement
    (:func:`_refine`), the quadrature's certificate (:func:`_certify`) and the objectives
    without each auxiliary reading (:func:`_consistency`, needed of every path model)."""
    start = _theta(est, st, _problem(est, st)) if est.observations else None
    _refine(est, st)
    _certify(est, st)
    return Settled(est, st, mode, it, saturation, _consistency(est, st, start))


def finish(settled: Settled, scale_test: bool = True) -> Estimate:
    """The rest of :func:`assess` on a :func:`settle`'d fit (``st`` is only read): the
    covariance, intervals, budget shares, derived quantities, flags and verdicts;
    ``scale_test`` False: without the known gain's test (a path model that is not the chosen
    one: its flag is never read, :func:`sca.pathmodels.combine_single`)."""
    est, st, mode, it, saturation = (settled.est, settled.st, settled.mode, settled.it,
                                     settled.saturation)
    consistency = settled.consistency
    mdl, x = st.mdl, st.x
    names = est.spec.names
    n_s = 0 if not est.free_s else int(np.sum(np.asarray(x["s"]) > 0))
    dof = mdl.m * mdl.n - len(names) - n_s - (mdl.z - 1 if est.free_w else 0) - int(est.free_gain)
    chi2_dof, chi2_p = goodness(st.f, dof, st.noise_known)
    cov = _covariance(est, st, dof)
    se = np.sqrt(np.maximum(np.diagonal(cov), 0.0))
    se_of = {n: float(se[j]) for j, n in enumerate(names)}
    if not names:  # nothing nonlinear is free: C and a_CDOM are known, no interval to find
        intervals, codes = {}, (0, 0, 0, 0)
    elif mdl.z == 1:
        intervals, codes = _profile(est, st, dof)
    else:  # Wald intervals (z > 1)
        intervals = {n: tuple(float(v) for v in wald(
            x[n], se_of[n], 0.0 if n in ("chl", "cdom") else -np.inf)) for n in names}
        codes = None
    for n in ("chl", "cdom"):
        if n not in names:
            intervals_n = (float(x[n]), float(x[n]))
            intervals.setdefault(n, intervals_n)
    gain_ci = (float(x["gain"]), float(x["gain"]))
    shares = _shares(est, st, x)
    if est.free_gain:
        var = cov[-1, -1] / (1.0 if st.noise_known else (st.f / max(dof, 1) or 1.0))
        if "gain" in shares:  # with the budget: the gain's variance with every nuisance in it
            var = shares["gain"]["sd"] ** 2
        lo, hi = gain_wald([x["gain"]], [var if np.isfinite(var) else np.inf], [st.f], [dof],
                           st.noise_known)[0]
        gain_ci = (float(lo), float(hi))
    flags = estimate_flags(converged=st.converged, noise_known=st.noise_known,
                           p_value=float(chi2_p), chl=x["chl"], cdom=x["cdom"],
                           chl_ci=intervals["chl"], cdom_ci=intervals["cdom"], ci_codes=codes,
                           free_chl=est.free_chl, free_cdom=est.free_cdom,
                           scale_p=_scale_p(est, st) if scale_test else None)
    if codes is None and "no-interval" in flags:  # Wald intervals (z > 1)
        flags[flags.index("no-interval")] = "interval-approximate"
    sigma = (st.scale / st.wt).reshape(mdl.m, mdl.n) if st.noise_known else None
    flags = input_flags(st.Mv.reshape(mdl.m, mdl.n) * st.scale, sigma, saturation) + flags
    unit = 1.0 if st.noise_known else st.scale ** 2  # objective: chi^2 or data units
    params = _params(est, st, x)
    pred = mdl.predict(params, jacobian=False)
    r = st.Mv - pred.values
    values = {n: float(x[n]) for n in names}
    ints = {n: intervals[n] for n in names}
    if est.free_gain:
        values["gain"], ints["gain"] = float(x["gain"]), gain_ci
    out = Estimate(
        chl=float(x["chl"]), cdom=float(x["cdom"]),
        chl_se=se_of.get("chl", 0.0), cdom_se=se_of.get("cdom", 0.0),
        chl_ci=tuple(intervals["chl"]), cdom_ci=tuple(intervals["cdom"]),
        reliable=is_reliable(flags), flags=tuple(flags),
        fit_rms=float(np.linalg.norm(r) / np.linalg.norm(st.Mv)),
        chi2_dof=float(chi2_dof), chi2_p=float(chi2_p), dof=int(dof),
        noise_known=bool(st.noise_known), w=np.array(x["w"], float),
        backscatter=np.asarray(x["s"], float) * st.scale,
        attenuation=pred.attenuation, attenuation_coefficient=pred.coefficient,
        wavelengths=mdl.wavelengths, objective=st.f * unit, iterations=it,
        converged=bool(st.converged), status=st.status,
        history=[f * unit for f in st.history], mode=mode, initial=st.initial,
        fixed=dict(est.fixed), eq17_residual=float(mdl.t440 @ x["w"] - mdl.phyto_scale(x["chl"])),
        trials=[f * unit for f in st.trials], path_model=est.water.path_model,
        gain=float(x["gain"]), gain_ci=gain_ci, values=values, intervals=ints,
        uncertain=dict(est.budget.sd) if st.noise_known and not est.budget.exact else {},
        budget=shares, nuisance=dict(st.nuisance), consistency=consistency,
        **_derived(est, st, dof, intervals),
    )
    return dataclasses.replace(out, **settled.fields) if settled.fields else out
