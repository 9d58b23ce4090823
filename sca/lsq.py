"""Reference method: ``scipy.optimize.least_squares`` on the reduced problem.

Unknowns: the free names of the fit (C, a_CDOM and any of ``free=``), then s (m values) and a
free gain, all bounded below (:func:`sca.model.lower_bound`); w is tied to C by eq 17 exactly
(z = 1). The residual and its analytic Jacobian come from
:meth:`sca.model.ChartModel.predict`; the start is the coarse grid of
:meth:`sca.Estimator.initial_point`. Trust-region reflective ('trf').
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from .loop import MODES, Estimator, over_path_models
from .model import CHL_DERIVATIVE_FLOOR, lower_bound
from .results import Estimate
from .verdict import Settled, settle
from forward.errors import InputError

__all__ = ["estimate_least_squares", "residual_functions"]


def residual_functions(est: Estimator, st):
    """(fun, jac, unpack, lower) of the reduced problem of fit state ``st``: fun(v) = vec(M -
    gain G(x) - s 1^T) whitened by ``st.wt``; jac(v) = d fun / dv; unpack(v) = the loop's point
    dict; lower = the bounds of v = (names, s, [gain]).

    Parameters
    ----------
    est : Estimator
        The estimator (its free names, held values, water and model).
    st : sca.loop._FitState
        The fit state of :meth:`sca.Estimator.prepare`: data M / max M, weights ``st.wt``
        (scale / sigma, or ones), the model in those units and a held backscatter.

    Returns
    -------
    fun : callable
        v -> ndarray, (m n,): the whitened residual st.wt (M - gain G(x) - s), scaled units.
    jac : callable
        v -> ndarray, (m n, len(v)): d fun / dv, analytic (d/dC at C >=
        :data:`sca.model.CHL_DERIVATIVE_FLOOR`, w following C along eq 17).
    unpack : callable
        v -> dict: the loop's point ('chl' mg m^-3, 'cdom' m^-1, every free name, 's' (m,)
        scaled units, 'gain', 'w' (1,) on eq 17).
    lower : ndarray, (len(v),)
        Lower bounds of v = (free names, s (m values if free), gain (if free)).
    """
    mdl = st.mdl
    names = list(est.spec.names)
    free = names + (["backscatter"] if est.free_s else []) + (["gain"] if est.free_gain else [])
    base = {k: est.fixed[k] for k in ("chl", "cdom") if k in est.fixed}
    p = len(names)

    def unpack(v):
        x = dict(base)
        x.update({n: float(v[j]) for j, n in enumerate(names)})
        x["s"] = np.asarray(v[p:p + mdl.m], float) if est.free_s else st.s_fixed
        x["gain"] = float(v[-1]) if est.free_gain else 1.0
        x["w"] = np.array([float(mdl.phyto_scale(x["chl"])) / float(mdl.t440[0])])
        return x

    def params(x):
        out = est.params(x)
        out.pop("w")  # w on eq 17: the model's own phytoplankton term
        return out

    last = {}  # scipy asks for the residual and the Jacobian at the same point: predict once

    def predicted(v):
        key = np.asarray(v, float).tobytes()
        if last.get("key") != key:
            last["key"] = key
            last["pred"] = mdl.predict(params(unpack(v)), free, chl_floor=CHL_DERIVATIVE_FLOOR)
        return last["pred"]

    def fun(v):
        return st.wt * (st.Mv - predicted(v).values)

    def jac(v):
        return -predicted(v).jacobian * st.wt[:, None]

    lower = np.array([lower_bound(n, est.water) for n in names] + [0.0] * (
        mdl.m if est.free_s else 0) + ([0.0] if est.free_gain else []))
    return fun, jac, unpack, lower


def estimate_least_squares(rgb, *, depth, distance, sigma=None, saturation=None,
                           mode: str = "safeguarded", max_iter: int = 500, tol: float = 1e-12,
                           x0=None, gain: str = "known", **kwargs) -> Estimate:
    """Fit one chart with scipy's bounded least squares; fields as :class:`sca.Estimate`.

    Parameters
    ----------
    rgb, depth, distance, sigma, saturation, x0, gain :
        As :func:`sca.estimate`.
    mode : {'safeguarded', 'paper'}
        Accepted for the same call as :func:`sca.estimate`; scipy's trust-region reflective
        method is one algorithm, so it changes nothing but the ``mode`` recorded.
    max_iter : int
        Maximum number of function evaluations (scipy's ``max_nfev``).
    tol : float
        scipy's ftol, xtol and gtol.
    **kwargs :
        Every other keyword of :func:`sca.estimate` (``water=``, ``camera=``, ``fix=``,
        ``free=``, ...).

    Returns
    -------
    Estimate
        ``iterations`` counts scipy's function evaluations; ``eq17_residual`` is 0 (w is on
        eq 17 by construction).

    References
    ----------
    Blasinski & Farrell, "A Three Parameter Underwater Image Formation Model", eqs 15-18;
    M. A. Branch, T. F. Coleman & Y. Li, "A subspace, interior, and conjugate gradient method
    for large-scale bound-constrained minimization problems", SIAM J. Sci. Comput. 21 (1999)
    1-23 (scipy's 'trf').
    """
    if mode not in MODES:
        raise InputError("mode", f"must be one of {MODES}, got {mode!r}")
    if int(max_iter) != max_iter or max_iter < 1:
        raise InputError("max_iter", f"must be a positive integer, got {max_iter!r}")
    path_models = kwargs.pop("path_models", None)
    kw = dict(depth=depth, distance=distance, gain=gain, **kwargs)
    est = Estimator(**kw)
    if est.model.z != 1:
        raise InputError("basis", "estimate_least_squares supports one basis function (z = 1)")
    for key in ("water", "path_model", "cdom_slope"):
        kw.pop(key, None)
    return over_path_models(est, path_models, sigma,
                            lambda e: _fit(e, rgb, sigma, saturation, x0, max_iter, tol), kw)


def _fit(est, rgb, sigma, saturation, x0, max_iter, tol) -> Settled:
    """The scipy fit of one estimator (one path model), settled (:func:`sca.verdict.settle`;
    w on eq 17 by construction: ``eq17_residual`` 0)."""
    st = est.prepare(rgb, sigma)
    fun, jac, unpack, lower = residual_functions(est, st)
    x = est.initial_point(st, x0)
    v0 = np.array([x[n] for n in est.spec.names] + (list(x["s"]) if est.free_s else [])
                  + ([x["gain"] if x["gain"] > 0 else 1.0] if est.free_gain else []), float)
    v0 = np.maximum(v0, lower)
    res = least_squares(fun, v0, jac=jac, bounds=(lower, np.inf), method="trf", x_scale="jac",
                        ftol=tol, xtol=tol, gtol=tol, max_nfev=int(max_iter))
    st.x = unpack(res.x)
    st.f = float(res.fun @ res.fun)
    st.initial = {"chl": x["chl"], "cdom": x["cdom"]}
    st.status = f"scipy least_squares: {res.message}"
    st.converged = bool(res.status > 0)
    st.history = [st.f]
    if saturation is not None:
        from forward import validate
        saturation = validate.scalar("saturation", saturation, positive=True)
    out = settle(est, st, "scipy_least_squares", int(res.nfev), saturation)
    out.fields["eq17_residual"] = 0.0
    return out
