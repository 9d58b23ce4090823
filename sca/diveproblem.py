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
        # the photos evaluated together: one call of the model function per chart model
        key = np.array([id(mdl) for mdl in self.models])
        self._batches = [self._batch(np.flatnonzero(key == k)) for k in np.unique(key)]

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
    def _batch(self, photos):
        """Photos ``photos`` of one chart model: (photos, the model function's free names,
        (K, P) theta columns of each photo's P derivative rows, -1 where a photo's depth or
        distance is held: its row is computed and dropped)."""
        free = ["chl", "cdom", *self.shared]
        geo = [g for g in ("depth", "distance") if np.any(self.layout[g][photos] >= 0)]
        cols = []
        for i in photos:
            g = self.groups[i]
            c = [self.layout["chl"][g], self.layout["cdom"][g]]
            for name in self.shared:
                c += list(self.layout[name])
            c += [self.layout[name][i] for name in geo]
            cols.append(c + list(self.layout[PATCH]))
        return photos, tuple(free + geo), np.array(cols, int).reshape(len(photos), -1)

    def photo_params(self, theta_row, i, params=None) -> dict:
        """Photo i's parameters of the model function at ``theta_row`` (p,): C (mg m^-3),
        a_CDOM, the shared nuisances and its geometry (``params``: :meth:`params` of the row,
        when the caller has them)."""
        if params is None:
            params = self.params(np.zeros(1, np.int64), theta_row[None])
        return self._batch_params(np.asarray(theta_row, float)[None], params, np.array([i]))

    def _batch_params(self, theta, params, photos) -> dict:
        """The model function's parameters of ``photos`` at every row of ``theta`` (k, p):
        leading axis k K, row by row."""
        k, K = theta.shape[0], len(photos)
        g = self.groups[photos]
        out = {name: np.asarray(params[name], float).reshape(k, -1)[:, g].reshape(-1)
               for name in ("chl", "cdom")}
        for name in self.shared:
            v = np.asarray(params[name], float)
            out[name] = np.repeat(v.reshape(k, -1) if name in CAMERA else v.reshape(k), K,
                                  axis=0)
        for name in ("depth", "distance"):
            j = self.layout[name][photos]
            held = np.broadcast_to(getattr(self, name)[photos], (k, K))
            out[name] = np.where(j >= 0, theta[:, np.maximum(j, 0)], held).reshape(-1)
        return out

    def data_terms(self, idx, theta, params, chain, grad: bool) -> Evaluation:
        """The sum of the photos' chart objectives (each photo's signal times 1 + e), with the
        sum of their gradients and Gauss-Newton matrices in theta's columns; ``extras``:
        'gain' (k, N), 's' (k, N, m; each photo's scaled units). The photos of one chart
        model, at every row of ``theta``, are one call of the model function and one
        projection."""
        k, p = theta.shape
        N, mn = self.M.shape
        f = np.zeros(k)
        g = np.zeros((k, p + 1)) if grad else None  # column p: the held rows, dropped
        H = np.zeros((k, p + 1, p + 1)) if grad else None
        gains, backs = np.zeros((k, N)), np.zeros((k, N, self.m))
        n_e = self.layout[PATCH].size
        e = theta[:, self.layout[PATCH]] if n_e else np.zeros((k, 1))
        for photos, free, cols in self._batches:
            K, P = cols.shape
            pred = self.models[photos[0]].predict(
                self._batch_params(theta, params, photos), free if grad else (),
                chl_floor=TINY, jacobian=grad)
            inv = 1.0 / self.scale[photos]
            Mi = (self.M[photos][None] * (1.0 - e[:, None, :])).reshape(k * K, mn)
            W2 = np.broadcast_to(self.W2[photos], (k, K, mn)).reshape(k * K, mn)
            if grad:
                rows = pred.jacobian_rows
                if n_e:  # the chart's shared error: d (M (1 - e)) / d e, an additive row
                    diag = self.M[photos][:, :, None] * np.eye(mn)
                    rows = np.concatenate([rows, np.broadcast_to(
                        diag, (k, K, mn, mn)).reshape(k * K, mn, mn)], axis=1)
                additive = np.arange(P) >= P - n_e
                ext = np.concatenate([chain, np.zeros((k, 1))], axis=1)  # held: factor 0
                at = np.where(cols >= 0, cols, p)
                cs = ext[:, at] * np.where(additive, 1.0, inv[:, None])[None]
                cs = cs.reshape(k * K, P)
            else:
                rows, cs, additive = np.zeros((k * K, 0, mn)), np.zeros((k * K, 0)), None
            fi, gi, Hi, gain, s, _ = project(pred.signal * np.tile(inv, k)[:, None], rows, Mi,
                                             W2, None, True, self.m, self.n, grad, cs, additive)
            f += fi.reshape(k, K).sum(axis=1)
            gains[:, photos], backs[:, photos] = gain.reshape(k, K), s.reshape(k, K, self.m)
            if grad:  # a photo's columns are distinct (but for the dropped ones)
                gi, Hi = gi.reshape(k, K, P), Hi.reshape(k, K, P, P)
                for j in range(K):
                    g[:, at[j]] += gi[:, j]
                    H[:, at[j][:, None], at[j][None, :]] += Hi[:, j]
        if grad:
            g, H = g[:, :p], H[:, :p, :p]
        return Evaluation(f, g, H, {"gain": gains, "s": backs})
