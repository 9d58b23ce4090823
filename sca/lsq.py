"""Reference method: ``scipy.optimize.least_squares`` on the reduced problem.

Unknowns x = (C, a_CDOM(440), s) with bounds >= 0; w is tied to C by eq 17 exactly (z = 1). The
residual and its analytic Jacobian come from :class:`sca.model.WaterModel` (and so from
:class:`forward.Water`); the start is the coarse grid of :meth:`sca.Estimator.initial_point`.
Trust-region reflective ('trf').
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from .estimate import Estimate, Estimator, _FitState
from .model import WaterModel


def residual_functions(mdl: WaterModel, Mv):
    """(fun, jac, unpack) of the reduced problem for the data ``Mv`` (vec of M, in the units of
    ``mdl``): fun(x) = vec(M - G(x) - s 1^T) (whitened where ``mdl`` knows the noise),
    jac(x) = d fun / dx, unpack(x) = (C, a_CDOM, w, s)."""
    if mdl.z != 1:
        raise ValueError("basis: estimate_least_squares supports one basis function (z = 1)")
    B = mdl.B
    t440 = float(mdl.t440[0])
    E = mdl.E

    def unpack(x):
        C, A = x[0], x[1]
        return C, A, np.array([mdl.phyto_scale(C) / t440]), x[2:]

    def fun(x):
        C, A, w, s = unpack(x)
        return mdl.residual(Mv, mdl.attenuation(C, A, w), s)

    def jac(x):
        C, A, w, s = unpack(x)
        _, dk = mdl.attenuation_jacobian(C, A, w)
        _, dalpha = mdl.phyto_scale(C, derivative=True)
        dk_dC = dk[:, 0] + dk[:, 2] * float(dalpha) / t440  # w follows C along eq 17
        return -np.column_stack([B @ dk_dC, B @ dk[:, 1], E]) * mdl.wt[:, None]

    return fun, jac, unpack


def estimate_least_squares(rgb, *, depth, distance, sigma=None, tol: float = 1e-12,
                           max_nfev: int = 500, **kwargs) -> Estimate:
    """Fit one chart with scipy's bounded least squares; fields as :class:`sca.Estimate`.
    Keyword arguments as :func:`sca.estimate` (``water=``, ``camera=``, ...)."""
    est = Estimator(depth=depth, distance=distance, **kwargs)
    if est.model.z != 1:
        raise ValueError("basis: estimate_least_squares supports one basis function (z = 1)")
    Mv, scale, mdl, _ = est.prepare(rgb, sigma)
    fun, jac, unpack = residual_functions(mdl, Mv)
    C0, A0, w0 = est.initial_point(Mv, mdl=mdl)
    s0 = np.asarray(mdl.best_backscatter(Mv, mdl.signal(mdl.attenuation(C0, A0, w0))), float)
    x0 = np.concatenate([[C0, A0], s0])
    res = least_squares(fun, x0, jac=jac, bounds=(0.0, np.inf), method="trf", x_scale="jac",
                        ftol=tol, xtol=tol, gtol=tol, max_nfev=max_nfev)
    C, A, w, s = unpack(res.x)
    # the same assessment as sca.estimate (goodness of fit, intervals, flags)
    st = _FitState(mdl=mdl, Mv=Mv, s_fixed=None, f_exact=0.0, x=(float(C), float(A), w, s),
                   f=float(res.fun @ res.fun), initial={"chl": C0, "cdom": A0},
                   status=f"scipy least_squares: {res.message}", converged=bool(res.status > 0))
    out = est._result(st, scale, "scipy_least_squares", int(res.nfev))
    out.eq17_residual = 0.0
    return out
