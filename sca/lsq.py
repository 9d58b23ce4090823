"""Reference method: ``scipy.optimize.least_squares`` on the reduced problem.

Unknowns x = (C, a_CDOM(440), s[, gain]) with bounds >= 0; w is tied to C by eq 17 exactly (z = 1). The
residual and its analytic Jacobian come from :class:`sca.model.WaterModel` (and so from
:class:`forward.Water`); the start is the coarse grid of :meth:`sca.Estimator.initial_point`.
Trust-region reflective ('trf').
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from .estimate import Estimate, Estimator, _FitState
from .model import WaterModel


def residual_functions(mdl: WaterModel, Mv, free_gain: bool = False):
    """(fun, jac, unpack) of the reduced problem for the data ``Mv`` (vec of M, in the units of
    ``mdl``): fun(x) = vec(M - gain G(x) - s 1^T) (whitened where ``mdl`` knows the noise),
    jac(x) = d fun / dx, unpack(x) = (C, a_CDOM, w, s, gain); x = (C, a_CDOM, s, [gain])."""
    m = mdl.m
    if mdl.z != 1:
        raise ValueError("basis: estimate_least_squares supports one basis function (z = 1)")
    B = mdl.B
    t440 = float(mdl.t440[0])
    E = mdl.E

    def unpack(x):
        C, A = x[0], x[1]
        gain = x[2 + m] if free_gain else 1.0
        return C, A, np.array([mdl.phyto_scale(C) / t440]), x[2:2 + m], gain

    def fun(x):
        C, A, w, s, gain = unpack(x)
        return mdl.residual(Mv, gain * mdl.attenuation(C, A, w), s)

    def jac(x):
        C, A, w, s, gain = unpack(x)
        k, dk = mdl.attenuation_jacobian(C, A, w)
        _, dalpha = mdl.phyto_scale(C, derivative=True)
        dk_dC = dk[:, 0] + dk[:, 2] * float(dalpha) / t440  # w follows C along eq 17
        cols = [gain * (B @ dk_dC), gain * (B @ dk[:, 1]), E]
        if free_gain:
            cols.append(B @ k)
        return -np.column_stack(cols) * mdl.wt[:, None]

    return fun, jac, unpack


def estimate_least_squares(rgb, *, depth, distance, sigma=None, tol: float = 1e-12,
                           max_nfev: int = 500, gain: str = "known", **kwargs) -> Estimate:
    """Fit one chart with scipy's bounded least squares; fields as :class:`sca.Estimate`.
    Keyword arguments as :func:`sca.estimate` (``water=``, ``camera=``, ``gain=``, ...)."""
    if "fix" in kwargs:
        raise ValueError("fix: estimate_least_squares fits every parameter; use sca.estimate")
    est = Estimator(depth=depth, distance=distance, gain=gain, **kwargs)
    if est.model.z != 1:
        raise ValueError("basis: estimate_least_squares supports one basis function (z = 1)")
    Mv, scale, mdl, _ = est.prepare(rgb, sigma)
    fun, jac, unpack = residual_functions(mdl, Mv, est.free_gain)
    C0, A0, w0 = est.initial_point(Mv, mdl=mdl)
    g0, s0 = est.linear_part(mdl, Mv, mdl.signal(mdl.attenuation(C0, A0, w0)))
    x0 = np.concatenate([[C0, A0], s0, [float(g0)] if est.free_gain else []])
    if est.free_gain and not x0[-1] > 0:
        x0[-1] = 1.0
    res = least_squares(fun, x0, jac=jac, bounds=(0.0, np.inf), method="trf", x_scale="jac",
                        ftol=tol, xtol=tol, gtol=tol, max_nfev=max_nfev)
    C, A, w, s, g = unpack(res.x)
    # the same assessment as sca.estimate (goodness of fit, intervals, flags)
    st = _FitState(mdl=mdl, Mv=Mv, s_fixed=None, f_exact=0.0,
                   x=(float(C), float(A), w, s, float(g)),
                   f=float(res.fun @ res.fun), initial={"chl": C0, "cdom": A0},
                   status=f"scipy least_squares: {res.message}", converged=bool(res.status > 0))
    out = est._result(st, scale, "scipy_least_squares", int(res.nfev))
    out.eq17_residual = 0.0
    return out
