"""The dive layout of the inference problem: the photographs of one water, fitted together.

N photographs of the chart share C and a_CDOM(440) (one pair per *group*: all photos one group
for the joint estimate, one group per photo for the heterogeneity test of :mod:`sca.joint`), the
budget's shared nuisances (the water's constants, the camera's ``balance`` and
``camera_shift``) and the chart's per-patch reflectance error e (``patch``: one relative error
per channel and patch, the same chart in every photo, a Gaussian prior of sd sqrt(rho) x the
budget's ``patch``; like the single chart's per-patch term, relative to the measured value).
Each photo keeps its own exposure gain and veiling light (in closed form,
by the chart layout's variable projection), its geometry (depth and distance, free with their
priors where they are uncertain) and its light field (its own chart model). The objective is the
sum of the photos' chart objectives (:class:`sca.charts.ChartProblem`'s) plus the priors:

    f = sum_i ||sqrt(w2_i) (M_i (1 - e) - gain_i G_i(theta) - s_i)||^2 + priors.

The per-patch error enters as a parameter rather than as a correlation of the photos' noise: the
two are the same Gaussian model (profiling or marginalising a linear Gaussian random effect gives
the correlated noise's objective: one photo's is the single chart's sigma^2 + (patch M)^2), and
as a parameter each photo stays a chart of its own, its gain and veiling light solved as every
chart's are.

One unit per problem (:class:`sca.problem.Problem`): the fit, the profile-likelihood ends and
the covariance are the inference layer's, as for every layout.
"""

from __future__ import annotations

import numpy as np

from forward.water import Water

from .model import CAMERA, TINY, lower_bound
from .parameters import PARAMETERS
from .problem import Evaluation, Problem
from .projection import project

__all__ = ["DiveProblem", "PATCH"]

#: The name of the chart's per-patch reflectance error (one relative value per channel and
#: patch, shared by the photos).
PATCH = "patch"


class DiveProblem(Problem):
    """N photographs of one water as one unit of an inference problem.

    Parameters
    ----------
    models : sequence of ChartModel
        Each photo's chart model (its setup, light field included; one water).
    M : ndarray, (N, m n)
        Each photo's measurements / its scale (0 where a value is left out).
    W2 : ndarray, (N, m n)
        Weights (scale / sigma)^2 (0 where a value is left out: clipped, unmeasured).
    scale : ndarray, (N,)
        Each photo's scale (its largest value, data units).
    groups : array_like of int, (N,)
        Each photo's (C, a_CDOM) group, 0 .. G - 1.
    shared : sequence of str
        The names shared by every photo besides C and a_CDOM: the budget's nuisances (Water
        constants, 'balance', 'camera_shift') and the Water constants estimated freely (a 0
        weight in ``prior_weight``).
    depth, distance : ndarray, (N,)
        Each photo's geometry, m (the priors' centres).
    free_depth, free_distance : ndarray of bool, (N,)
        Which photos' depth and distance are free (uncertain).
    patch : bool
        The shared per-patch error e is a parameter.
    prior_mean, prior_weight : ndarray, (1, p)
        The Gaussian priors of every column (0 weight: none).
    observations : sequence of sca.problem.Observation, optional
        Auxiliary measurements of the dive's water (:mod:`sca.auxiliary`).

    Attributes
    ----------
    layout : dict
        name -> columns for 'chl', 'cdom' (one per group), every shared name, 'depth' and
        'distance' (one per photo, -1 where held) and 'patch'.
    """

    def __init__(self, models, M, W2, scale, groups, shared, depth, distance, free_depth,
                 free_distance, patch: bool, prior_mean, prior_weight, observations=()):
        self.models = list(models)
        self.M, self.W2 = np.asarray(M, float), np.asarray(W2, float)
        self.scale = np.asarray(scale, float)
        self.groups = np.asarray(groups, int)
        self.water: Water = self.models[0].water
        N = self.M.shape[0]
        m, n = self.models[0].m, self.models[0].n
        self.m, self.n = m, n
        G = int(self.groups.max()) + 1
        names = ["chl"] * G + ["cdom"] * G
        for name in shared:
            names += [name] * (m if name in CAMERA else 1)
        self.shared = tuple(shared)
        geo = {}
        for name, free in (("depth", free_depth), ("distance", free_distance)):
            cols = np.full(N, -1)
            for i in np.flatnonzero(np.asarray(free, bool)):
                cols[i] = len(names)
                names.append(name)
            geo[name] = cols
        self.depth, self.distance = np.asarray(depth, float), np.asarray(distance, float)
        if patch:
            names += [PATCH] * (m * n)
        super().__init__(names, {}, prior_mean, prior_weight, observations)
        self.layout = {"chl": np.arange(G), "cdom": np.arange(G, 2 * G), **geo,
                       PATCH: np.array(self.columns(PATCH), int)}
        for name in shared:
            self.layout[name] = np.array(self.columns(name), int)
        # each photo's columns of its own chart: (name of its model function, theta column)
        self._photo_cols = [self._photo_columns(i) for i in range(N)]
        self._photo_block = [np.ix_(cols, cols) for _, cols in self._photo_cols]

    # ------------------------------------------------------------------ the layout's choices
    def lower_bound(self, name: str) -> float:
        return -np.inf if name == PATCH else lower_bound(name, self.water)

    def power(self, name: str) -> float:
        return self.models[0].e0 if name != PATCH and PARAMETERS[name].power else 0.0

    @property
    def size(self) -> int:
        return 1

    def rows(self, idx) -> dict:
        return {}

    # ------------------------------------------------------------------ the photos
    def _photo_columns(self, i):
        """Photo i's free names of the model function and their theta columns."""
        g = self.groups[i]
        free = ["chl", "cdom"]
        cols = [self.layout["chl"][g], self.layout["cdom"][g]]
        for name in self.shared:
            free.append(name)
            cols += list(self.layout[name])
        for name in ("depth", "distance"):
            if self.layout[name][i] >= 0:
                free.append(name)
                cols.append(self.layout[name][i])
        return tuple(free), np.array(cols + list(self.layout[PATCH]), int)

    def photo_params(self, theta_row, i, params=None) -> dict:
        """Photo i's parameters of the model function at ``theta_row`` (p,): C (mg m^-3),
        a_CDOM, the shared nuisances and its geometry (``params``: :meth:`params` of the row,
        when the caller has them)."""
        if params is None:
            params = self.params(np.zeros(1, np.int64), theta_row[None])
        g = self.groups[i]
        out = {"chl": np.atleast_1d(params["chl"])[..., g].reshape(1),
               "cdom": np.atleast_1d(params["cdom"])[..., g].reshape(1)}
        for name in self.shared:
            v = np.asarray(params[name], float)
            out[name] = v.reshape(1, -1) if name in CAMERA else v.reshape(1)
        for name in ("depth", "distance"):
            j = self.layout[name][i]
            out[name] = np.array([theta_row[j] if j >= 0 else getattr(self, name)[i]])
        return out

    def data_terms(self, idx, theta, params, chain, grad: bool) -> Evaluation:
        """The sum of the photos' chart objectives (each photo's signal times 1 + e), with the
        sum of their gradients and Gauss-Newton matrices in theta's columns; ``extras``:
        'gain' (k, N), 's' (k, N, m; each photo's scaled units)."""
        k, p = theta.shape
        N, mn = self.M.shape
        f = np.zeros(k)
        g = np.zeros((k, p)) if grad else None
        H = np.zeros((k, p, p)) if grad else None
        gains, backs = np.zeros((k, N)), np.zeros((k, N, self.m))
        n_e = self.layout[PATCH].size
        for r in range(k):
            e = theta[r, self.layout[PATCH]] if n_e else 0.0
            row_params = self.params(np.zeros(1, np.int64), theta[r][None])
            for i in range(N):
                free, cols = self._photo_cols[i]
                mdl = self.models[i]
                pi = self.photo_params(theta[r], i, row_params)
                pred = mdl.predict(pi, free if grad else (), chl_floor=TINY, jacobian=grad)
                inv = 1.0 / self.scale[i]
                Mi = self.M[i] * (1.0 - e)  # the data less the chart's shared error e M
                if grad:
                    rows = pred.jacobian_rows[0]
                    if n_e:
                        rows = np.concatenate([rows, np.diag(self.M[i])])
                    cs = chain[r, cols][None] * np.where(np.arange(cols.size) < cols.size - n_e,
                                                         inv, 1.0)
                    additive = np.arange(cols.size) >= cols.size - n_e
                else:
                    rows, cs, additive = np.zeros((0, mn)), np.zeros((1, 0)), None
                fi, gi, Hi, gain, s, _ = project(pred.signal * inv, rows[None], Mi[None],
                                                 self.W2[i:i + 1], None, True, self.m, self.n,
                                                 grad, cs, additive)
                f[r] += fi[0]
                gains[r, i], backs[r, i] = gain[0], s[0]
                if grad:  # a photo's columns are distinct: plain indexed sums
                    g[r, cols] += gi[0]
                    H[r][self._photo_block[i]] += Hi[0]
        return Evaluation(f, g, H, {"gain": gains, "s": backs})
