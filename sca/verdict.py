"""The assessment of one finished fit (the cvxpy loop or the scipy path): goodness of fit,
standard errors, intervals of every free parameter, flags and the verdict, as an
:class:`sca.Estimate`.

Intervals: profile likelihood through :mod:`sca.intervals` (the batch's own routine, on the
same reduced problem: w on eq 17, gain and s profiled out), so every estimator's intervals
agree; for z > 1 basis functions Wald intervals from :func:`sca.model.profiled_covariance`
(flag ``interval-approximate``).
"""

from __future__ import annotations

import numpy as np
from scipy import stats

from .assess import CONFIDENCE, estimate_flags, gain_wald, goodness, input_flags, is_reliable, \
    profile_delta
from .intervals import BOUND_OPEN, profile_intervals
from .lm import Problem, evaluate
from .model import CHL_DERIVATIVE_FLOOR, profiled_covariance, u_from_chl, upper_cap
from .results import Estimate

__all__ = ["assess"]


def _covariance(est, st, dof):
    """Gauss-Newton covariance of (free names [, gain]) at the fit, C in its own units (its
    derivative at the loop's floor), w following C along eq 17 (shape held)."""
    mdl, x = st.mdl, st.x
    names = list(est.spec.names)
    with_w = mdl.z > 1 or "chl" not in names
    free = names + (["w"] if with_w and "w" not in names else [])
    params = est.params(x)
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


def _problem(est, st) -> Problem:
    """The fit as a one-chart :class:`sca.lm.Problem` (the model already in the data's units)."""
    fixed = {"depth": np.array([est.depth]), "distance": np.array([est.distance])}
    for k in ("chl", "cdom"):
        if k in est.fixed:
            fixed[k] = np.array([est.fixed[k]])
    fixed = {k: v for k, v in fixed.items() if k not in est.spec.names}
    return Problem(st.mdl, st.Mv[None], (st.wt ** 2)[None], np.ones(1), est.spec.names, fixed,
                   est.free_gain, None if st.s_fixed is None else st.s_fixed[None])


def _profile(est, st, dof):
    """95 % profile-likelihood intervals of every free name (z = 1): {name: (lo, hi)} and the
    BOUND_* codes of (chl low, chl high, cdom low, cdom high)."""
    prob = _problem(est, st)
    names = est.spec.names
    theta = np.array([[u_from_chl(st.x["chl"], st.mdl.e0) if n == "chl" else st.x[n]
                       for n in names]], float)
    f, _, H, *_ = evaluate(prob, np.arange(1), theta, True)
    Mw = st.wt * st.Mv
    delta = profile_delta(st.noise_known, f, np.array([dof]), np.array([Mw @ Mw]))
    caps = np.array([upper_cap(n, est.water) for n in names])
    if "chl" in names:
        caps[names.index("chl")] = u_from_chl(caps[names.index("chl")], st.mdl.e0)
    ends, codes = profile_intervals(prob, theta, f, delta, H, caps)
    out = {}
    for j, n in enumerate(names):
        lo, hi = ends[0, j]
        if n == "chl":
            lo, hi = (max(v, 0.0) ** (1.0 / st.mdl.e0) for v in (lo, hi))
        if codes[0, j, 0] == BOUND_OPEN:
            lo = -np.inf
        if codes[0, j, 1] == BOUND_OPEN:
            hi = np.inf
        out[n] = (float(lo), float(hi))
    ci_codes = []
    for n in ("chl", "cdom"):
        ci_codes += list(codes[0, names.index(n)]) if n in names else [0, 0]
    return out, tuple(int(c) for c in ci_codes)


def assess(est, st, mode, it, saturation=None) -> Estimate:
    """The :class:`sca.Estimate` of a finished fit ``st`` of estimator ``est``.

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
        Recorded as ``Estimate.mode`` ('paper', 'safeguarded', 'scipy_least_squares').
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
        z95 = stats.norm.ppf(0.5 + CONFIDENCE / 2)
        intervals = {n: (max(x[n] - z95 * se_of[n], 0.0) if n in ("chl", "cdom") else
                         x[n] - z95 * se_of[n], x[n] + z95 * se_of[n]) for n in names}
        codes = None
    for n in ("chl", "cdom"):
        if n not in names:
            intervals_n = (float(x[n]), float(x[n]))
            intervals.setdefault(n, intervals_n)
    gain_ci = (float(x["gain"]), float(x["gain"]))
    if est.free_gain:
        var = cov[-1, -1] / (1.0 if st.noise_known else (st.f / max(dof, 1) or 1.0))
        lo, hi = gain_wald([x["gain"]], [var if np.isfinite(var) else np.inf], [st.f], [dof],
                           st.noise_known)[0]
        gain_ci = (float(lo), float(hi))
    flags = estimate_flags(converged=st.converged, noise_known=st.noise_known,
                           p_value=float(chi2_p), chl=x["chl"], cdom=x["cdom"],
                           chl_ci=intervals["chl"], cdom_ci=intervals["cdom"], ci_codes=codes,
                           free_chl=est.free_chl, free_cdom=est.free_cdom)
    if codes is None and "no-interval" in flags:  # Wald intervals (z > 1)
        flags[flags.index("no-interval")] = "interval-approximate"
    sigma = (st.scale / st.wt).reshape(mdl.m, mdl.n) if st.noise_known else None
    flags = input_flags(st.Mv.reshape(mdl.m, mdl.n) * st.scale, sigma, saturation) + flags
    unit = 1.0 if st.noise_known else st.scale ** 2  # objective: chi^2 or data units
    G = est.signal(st, x)
    r = st.Mv - x["gain"] * G - np.repeat(x["s"], mdl.n)
    params = est.params(x)
    pred = mdl.predict(params, jacobian=False)
    values = {n: float(x[n]) for n in names}
    ints = {n: intervals[n] for n in names}
    if est.free_gain:
        values["gain"], ints["gain"] = float(x["gain"]), gain_ci
    return Estimate(
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
    )
