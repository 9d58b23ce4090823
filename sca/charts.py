"""The chart layout of the inference problem: N charts, each fitted on its own.

For charts i with weights w2 = 1 / sigma^2 (ones where the noise is unknown), in scaled units
(every chart's largest value is 1):

    G = predict(theta).signal / scale_i,   (gain, s) in closed form (variable projection),
    r = sqrt(w2) (M - gain G - s 1^T),   f = ||r||^2 (+ the priors, :class:`sca.problem.Problem`),
    J = -gain dG/dtheta projected off span{active channel indicators, G (free gain)}
        (Kaufman's variable-projection Jacobian: exact gradient g = J^T r, H = J^T J).

The model function is :meth:`sca.model.ChartModel.predict`; the projection, compiled and
physics-free, :func:`sca.projection.project`. C is iterated in u = C^e0 (eq 10's exponent).
A dive's photographs are sums of these charts (:mod:`sca.diveproblem`).

References
----------
L. Kaufman, "A variable projection method for solving separable nonlinear least squares
problems", BIT 15 (1975) 49-57.
"""

from __future__ import annotations

import numpy as np

from .model import TINY, ChartModel, lower_bound
from .parameters import PARAMETERS
from .problem import Evaluation, Problem
from .projection import project

__all__ = ["ChartProblem"]


class ChartProblem(Problem):
    """N charts in scaled units (every chart's maximum is 1) and what is fixed about them.

    Parameters
    ----------
    model : ChartModel
        The chart model (unscaled units: its signals are divided by ``scale`` here).
    M : ndarray, (N, m n)
        Measurements / scale (row-major over channel, patch).
    W2 : ndarray, (N, m n)
        Weights (scale / sigma)^2, or ones where the noise is unknown.
    scale : ndarray, (N,)
        The data's scales (each chart's maximum, data units).
    names : tuple of str
        Free nonlinear parameters, in the order of theta's columns.
    fixed : dict
        name -> (N,) (or (N, m) for per-channel names) values of everything else the model
        needs ('depth', 'distance' in m, and 'chl' (mg m^-3) / 'cdom' (m^-1) where they are
        held; a held backscatter is ``fixed_s``).
    free_gain : bool, optional
        The exposure gain is estimated (profiled out with s). Default False.
    fixed_s : ndarray, (N, m), optional
        Backscatter held (scaled units); None (default): s free, s >= 0.
    prior_mean, prior_weight : ndarray, (N, p), optional
        The budget's Gaussian priors (:class:`sca.problem.Problem`).
    observations : sequence of sca.problem.Observation, optional
        Auxiliary measurements (:mod:`sca.auxiliary`).

    Attributes
    ----------
    chl_col : int
        The column of C (iterated in u = C^e0), or -1.
    inv_scale : ndarray, (N,)
        1 / scale.
    """

    def __init__(self, model: ChartModel, M, W2, scale, names, fixed, free_gain: bool = False,
                 fixed_s=None, prior_mean=None, prior_weight=None, observations=()):
        self.model = model
        self.M = np.ascontiguousarray(M, float)
        self.W2 = np.ascontiguousarray(W2, float)
        self.scale = np.ascontiguousarray(scale, float)
        self.free_gain = bool(free_gain)
        self.fixed_s = None if fixed_s is None else np.ascontiguousarray(fixed_s, float)
        self.inv_scale = 1.0 / self.scale
        super().__init__(names, fixed, prior_mean, prior_weight, observations)
        self.chl_col = self.names.index("chl") if "chl" in self.names else -1

    # ------------------------------------------------------------------ the layout's choices
    def lower_bound(self, name: str) -> float:
        return lower_bound(name, self.model.water)

    def power(self, name: str) -> float:
        return self.model.e0 if PARAMETERS[name].power else 0.0

    @property
    def size(self) -> int:
        return self.M.shape[0]

    def rows(self, idx) -> dict:
        return {"M": self.M[idx], "W2": self.W2[idx], "scale": self.scale[idx],
                "inv_scale": self.inv_scale[idx],
                "fixed_s": None if self.fixed_s is None else self.fixed_s[idx]}

    def data_terms(self, idx, theta, params, chain, grad: bool) -> Evaluation:
        """||r||^2, J^T r and J^T J of charts ``idx`` by variable projection; ``extras``:
        'gain' (k,), 's' (k, m; scaled units), 'ssr' (k,: unweighted), 'k' (k, q: the
        attenuation on the model's grid)."""
        mdl = self.model
        pred = mdl.predict(params, self.free if grad else (), chl_floor=TINY, jacobian=grad)
        inv = self.inv_scale[idx][:, None]
        fs = None if self.fixed_s is None else self.fixed_s[idx]
        if grad:
            JR, col_scale = pred.jacobian_rows, chain * inv
        else:
            JR, col_scale = np.zeros((len(idx), 0, mdl.m * mdl.n)), np.zeros((len(idx), 0))
        f, g, H, gain, s, ssr = project(pred.signal * inv, JR, self.M[idx], self.W2[idx], fs,
                                        self.free_gain, mdl.m, mdl.n, grad, col_scale)
        return Evaluation(f, g, H, {"gain": gain, "s": s, "ssr": ssr, "k": pred.attenuation})

