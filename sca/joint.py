"""One water, many charts: the joint fit of a dive.

N photographs of the chart in one water share C and a_CDOM(440), and the uncertainty budget's
shared nuisances: the water's constants (``cdom_slope``, ``nap_slope``, ...), the camera's
``balance`` and ``camera_shift``, and the chart's per-patch systematic error (the same chart in
every photo). Each photo keeps its own exposure gain, veiling light s, geometry (depth and
distance with their priors) and light field (its own :class:`forward.ChartSetup`). The model of
photo i is the one model function (:meth:`sca.model.ChartModel.predict`):

    M_i = gain_i G(x; depth_i, distance_i, camera) + s_i 1^T + e (.) M_i + noise_i,

with e the per-patch relative error shared by every photo (sd sqrt(rho) x ``patch``, rho =
``patch_correlation``, the correlation of the term between photos; the independent remainder
sqrt(1 - rho) x ``patch`` joins each value's own noise). e is not a parameter: for one value (channel, patch) across the photos the noise
covariance is D + t t^T, and the residuals are whitened by its exact inverse square root
(rank one, Sherman-Morrison). The objective is chi^2 plus the priors' terms, minimised by
:func:`scipy.optimize.least_squares` (trust-region reflective, analytic Jacobian; C in the
batch's coordinate u = C^e0). Intervals are 95 % profile likelihood of C and a_CDOM (every
other parameter re-optimised); path models are compared as in :mod:`sca.pathmodels`.

Heterogeneity: are these photos one water? The likelihood-ratio statistic of "one (C, a_CDOM)"
against "one (C, a_CDOM) per photo" (the shared nuisances shared in both) is chi^2 with
2 (N - 1) degrees of freedom; below :data:`HETEROGENEITY_ALPHA` the joint estimate is flagged
``heterogeneous`` (not reliable) and each photo is tested alone against the rest (Bonferroni).

:func:`dive_precision` is the Cramér-Rao bound of the same model: what a dive design (depths,
distances, number of photos) buys (``sca.precision(..., dive=True)``).

References
----------
Blasinski & Farrell, "A Three Parameter Underwater Image Formation Model", eqs 15-18.
S. S. Wilks, "The large-sample distribution of the likelihood ratio for testing composite
hypotheses", Ann. Math. Statist. 9 (1938) 60-62.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np
from scipy import optimize, stats

from forward.imaging import ChartSetup
from forward.water import Water, resolve_water

from .assess import BLOCKING, MISFIT_P, goodness
from .budget import DEFAULT_UNCERTAIN, NUISANCE, parse_sd
from .model import (
    CAMERA,
    CDOM_MAX,
    CHL_MAX,
    TINY,
    ChartModel,
    chl_from_u,
    du_chain,
    lower_bound,
    u_from_chl,
)
from .pathmodels import PATH_MODEL_DELTA, SPAN_FLAG, candidates, supported

__all__ = [
    "HETEROGENEITY_ALPHA",
    "JOINT_MAX_NFEV",
    "JOINT_TOL",
    "PATCH_CORRELATION",
    "PROFILE_XTOL",
    "JointEstimate",
    "dive_precision",
    "estimate_joint",
]

#: Level of the heterogeneity test (one water or not) and of each photo's test against the rest
#: (Bonferroni over the photos).
HETEROGENEITY_ALPHA = 0.01
#: Default correlation of the per-patch systematic error between photos: 1, the same chart
#: (reflectance tolerance and ageing) and the same camera in every photo (DECISIONS.md).
PATCH_CORRELATION = 1.0
#: least_squares' evaluation cap and tolerances (ftol = xtol = gtol) of every joint fit.
JOINT_MAX_NFEV, JOINT_TOL = 1000, 1e-8
#: Relative precision of a profile-likelihood end (in u = C^e0 for C, in a_CDOM for a_CDOM).
PROFILE_XTOL = 1e-3
#: A profile point below the optimum by more than this (relative) means the fit was not at its
#: minimum: the estimate is flagged not-converged.
PROFILE_BELOW = 1e-6
#: An unconverged profile point counts (flag not-converged) only where its objective is less
#: than this many delta above the optimum: far beyond the interval it cannot move an end.
PROFILE_UNSURE = 4.0
#: Steps of the continuation that re-solves a profile point whose direct solve failed.
PROFILE_CONTINUATION = 4
#: Doublings of the first step (twice the Wald sd) before a profile end is called open.
PROFILE_EXPAND = 40
#: The largest per-photo relative scatter the joint fit adds beyond the budget (10 %: the
#: calibration refuses a camera above PATCH_SD_MAX = 3 %; a dive's photos that scatter more
#: than this are not one measurement).
PHOTO_SCATTER_MAX = 0.10
#: Flags of a joint estimate that make it not reliable.
JOINT_BLOCKING = tuple(BLOCKING) + ("heterogeneous",)


@dataclass
class JointEstimate:
    """The joint estimate of one water from N photographs.

    Attributes
    ----------
    chl, cdom : float
        C (mg m^-3) and a_CDOM(440) (m^-1).
    chl_ci, cdom_ci : tuple of float
        95 % profile-likelihood intervals (``inf``: open), the union over supported path models.
    reliable : bool
        No blocking flag (:data:`JOINT_BLOCKING`).
    flags : tuple of str
        'misfit', 'not-converged', 'unbounded-chl', 'unbounded-cdom', 'heterogeneous',
        'path-model-span' (information).
    chi2, dof, chi2_p : float, int, float
        Goodness of fit of the joint model (priors' terms included in chi2).
    heterogeneity : dict
        'statistic', 'dof', 'p_value', 'one_water' (bool), 'alpha', 'disagree' (names of the
        photos that differ from the rest), 'per_photo' (name -> Bonferroni p, where tested).
    path_model : str
        The best path model; ``path_models`` name -> chi2 of every candidate.
    photos : dict
        Per photo (keyed by name): 'gain', 'backscatter', 'depth', 'distance' at the fit.
    nuisance : dict
        The shared nuisances at the fit.
    uncertain : dict
        The budget used (name -> sd).
    notes : list of str
        Sentences for the user.
    """

    chl: float
    cdom: float
    chl_ci: tuple
    cdom_ci: tuple
    reliable: bool
    flags: tuple
    chi2: float
    dof: int
    chi2_p: float
    heterogeneity: dict
    path_model: str
    path_models: dict
    photos: dict
    nuisance: dict
    uncertain: dict
    converged: bool = True
    notes: list = field(default_factory=list)
    #: the per-photo, per-value relative scatter added beyond the budget (0: none needed;
    #: :func:`_photo_scatter`)
    photo_scatter: float = 0.0
    #: photos left out of the fit: name -> reason (:func:`measure.joint.fit_joint`)
    excluded: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        """joint.json's content (plain numbers; ``inf`` for open interval ends)."""
        d = dataclasses.asdict(self)
        d["chl_ci"], d["cdom_ci"] = list(self.chl_ci), list(self.cdom_ci)
        d["flags"] = list(self.flags)
        d["n_photos"] = len(self.photos)
        d["units"] = {"chl": "mg m^-3", "cdom": "m^-1 at 440 nm", "depth": "m",
                      "distance": "m", "gain": "data units per model unit",
                      "backscatter": "data units"}
        return d


# --------------------------------------------------------------------------- the layout
class _Layout:
    """Where each parameter lives in the vector theta; ``groups[i]`` is the (C, a_CDOM) group
    of photo i (all 0: one water; arange(N): one per photo)."""

    def __init__(self, N, m, n, groups, shared, geometry):
        self.N, self.m, self.n = N, m, n
        self.groups = np.asarray(groups, int)
        G = int(self.groups.max()) + 1
        k = 0
        self.u = np.arange(k, k + G)
        k += G
        self.cdom = np.arange(k, k + G)
        k += G
        self.shared = {}
        for name in shared:
            size = m if name in CAMERA else 1
            self.shared[name] = np.arange(k, k + size)
            k += size
        self.geometry = {}
        for name in ("depth", "distance"):
            idx = np.full(N, -1)
            for i in range(N):
                if geometry[name][i]:
                    idx[i] = k
                    k += 1
            self.geometry[name] = idx
        self.gain = np.arange(k, k + N)
        k += N
        self.s = np.arange(k, k + N * m).reshape(N, m)
        k += N * m
        self.size = k


@dataclass
class _Data:
    """The photos in scaled units (each photo's largest value is 1)."""

    models: list
    M: np.ndarray  # (N, m n) scaled
    inv_sigma: np.ndarray  # (N, m n); 0 where a value is left out
    scale: np.ndarray  # (N,)
    depth: np.ndarray
    distance: np.ndarray
    priors: dict  # name -> (mean, sd): shared nuisances ('balance', 'camera_shift': per channel)
    geo_sd: dict  # 'depth', 'distance' -> (N,) sd (0: held)
    shared_dir: np.ndarray  # (N, m n) unit vectors v^ of the shared per-patch term (whitened)
    shared_beta: np.ndarray  # (m n,) 1 - 1 / sqrt(1 + |v|^2)
    water: Water


def _free_names(data, lay, i):
    geo = [g for g in ("depth", "distance") if lay.geometry[g][i] >= 0]
    return ["chl", "cdom"] + list(lay.shared) + geo + ["gain", "backscatter"]


def _params(data, lay, theta, i):
    g = lay.groups[i]
    mdl = data.models[i]
    p = {"chl": chl_from_u(theta[lay.u[g]], mdl.e0), "cdom": theta[lay.cdom[g]],
         "gain": theta[lay.gain[i]], "backscatter": theta[lay.s[i]]}
    for name, idx in lay.shared.items():
        p[name] = theta[idx] if name in CAMERA else theta[idx[0]]
    for name in ("depth", "distance"):
        j = lay.geometry[name][i]
        p[name] = theta[j] if j >= 0 else getattr(data, name)[i]
    return p


def _column_index(lay, i, columns):
    """theta index of each Jacobian column of photo i's prediction."""
    g = lay.groups[i]
    seen = {}
    out = []
    for c in columns:
        k = seen.get(c, 0)
        seen[c] = k + 1
        if c == "chl":
            out.append(lay.u[g])
        elif c == "cdom":
            out.append(lay.cdom[g])
        elif c in lay.shared:
            out.append(lay.shared[c][k])
        elif c in lay.geometry:
            out.append(lay.geometry[c][i])
        elif c == "gain":
            out.append(lay.gain[i])
        elif c == "backscatter":
            out.append(lay.s[i][k])
        else:  # pragma: no cover - the names are chosen above
            raise KeyError(c)
    return np.array(out)


def _prior_rows(data, lay):
    """(indices, means, sds) of every Gaussian prior (shared nuisances, geometry, e)."""
    idx, mean, sd = [], [], []
    for name, cols in lay.shared.items():
        mu, s = data.priors[name]
        idx += list(cols)
        mean += list(np.broadcast_to(mu, cols.shape))
        sd += list(np.broadcast_to(s, cols.shape))
    for name in ("depth", "distance"):
        for i, j in enumerate(lay.geometry[name]):
            if j >= 0:
                idx.append(j)
                mean.append(getattr(data, name)[i])
                sd.append(data.geo_sd[name][i])
    return np.array(idx, int), np.array(mean, float), np.array(sd, float)


def _blocks(data, lay):
    """Photos that share a chart model and free names: one call of the model function each."""
    out = {}
    for i in range(lay.N):
        key = (id(data.models[i]), tuple(_free_names(data, lay, i)))
        out.setdefault(key, []).append(i)
    return [(data.models[idx[0]], list(key[1]), np.array(idx)) for key, idx in out.items()]


def _residuals(theta, data, lay, jac=True):
    """Whitened residuals (data rows, then prior rows) and their Jacobian (dense)."""
    N, mn = data.M.shape
    pidx, pmean, psd = _prior_rows(data, lay)
    r = np.empty(N * mn + pidx.size)
    J = np.zeros((r.size, lay.size)) if jac else None
    for mdl, names, idx in _blocks(data, lay):
        each = [_params(data, lay, theta, i) for i in idx]
        p = {k: np.array([np.broadcast_to(e[k], np.shape(each[0][k])) for e in each], float)
             for k in each[0]}
        pred = mdl.predict(p, names, chl_floor=TINY, jacobian=jac)
        for b, i in enumerate(idx):
            w = data.inv_sigma[i]
            rows = slice(i * mn, (i + 1) * mn)
            r[rows] = w * (pred.values[b] - data.M[i])
            if jac:
                cols = _column_index(lay, i, pred.columns)
                Ji = pred.jacobian[b] * w[:, None]
                Ji[:, list(pred.columns).index("chl")] *= du_chain(p["chl"][b], mdl.e0)
                for j, c in enumerate(cols):
                    J[rows, c] += Ji[:, j]
    _whiten_shared(r[:N * mn].reshape(N, mn), data)
    if jac:
        _whiten_shared(J[:N * mn].reshape(N, mn, -1), data)
    r[N * mn:] = (theta[pidx] - pmean) / psd
    if jac:
        J[N * mn + np.arange(pidx.size), pidx] = 1.0 / psd
    return r, J


def _whiten_shared(a, data):
    """In place: rows already whitened by each value's own noise, whitened for the per-patch
    term shared by the photos too. For one value (channel, patch) across the photos the
    covariance is D + t t^T (t_i = shared sd x M_i); with v = D^-1/2 t its inverse square root
    is I - beta v^ v^T, beta = 1 - 1 / sqrt(1 + |v|^2) (Sherman-Morrison)."""
    vhat, beta = data.shared_dir, data.shared_beta
    if a.ndim == 2:
        a -= beta * vhat * np.einsum("ik,ik->k", vhat, a)
    else:
        a -= (beta[:, None] * np.einsum("ik,ikp->kp", vhat, a))[None] * vhat[..., None]


def _bounds(data, lay):
    lo = np.full(lay.size, -np.inf)
    lo[lay.u] = 0.0
    lo[lay.cdom] = 0.0
    for name, cols in lay.shared.items():
        lo[cols] = lower_bound(name, data.water)
    for name in ("depth", "distance"):
        j = lay.geometry[name]
        lo[j[j >= 0]] = 0.0
    lo[lay.gain] = 0.0
    lo[lay.s] = 0.0
    return lo, np.full(lay.size, np.inf)


def _solve(data, lay, theta0, hold=None):
    """Minimise chi^2 + priors from ``theta0``, with ``hold`` {index: value} fixed.
    Returns (theta, f, converged)."""
    hold = hold or {}
    keep = np.array([k not in hold for k in range(lay.size)])
    lo, hi = _bounds(data, lay)
    base = np.array(theta0, float)
    for k, v in hold.items():
        base[k] = v
    x0 = np.clip(base[keep], lo[keep], hi[keep])
    x0 = np.where(x0 <= lo[keep], lo[keep] + 1e-12 * np.maximum(1.0, np.abs(x0)), x0)

    def full(x):
        t = base.copy()
        t[keep] = x
        return t

    def fun(x):
        return _residuals(full(x), data, lay, jac=False)[0]

    def jac(x):
        return _residuals(full(x), data, lay, jac=True)[1][:, keep]

    # far along a profile (C or a_CDOM held near its cap) the trust region's arithmetic can
    # overflow; such a solve ends unconverged and is handled as such (_profile_end)
    with np.errstate(over="ignore", invalid="ignore"):
        res = optimize.least_squares(fun, x0, jac=jac, bounds=(lo[keep], hi[keep]),
                                     method="trf", x_scale="jac", ftol=JOINT_TOL, xtol=JOINT_TOL,
                                     gtol=JOINT_TOL, max_nfev=JOINT_MAX_NFEV)
    return full(res.x), 2.0 * float(res.cost), bool(res.status > 0)


def _dof(data, lay, theta) -> int:
    n_ok = int(np.count_nonzero(data.inv_sigma))
    n_groups = int(lay.groups.max()) + 1
    active_s = int(np.count_nonzero(theta[lay.s] > 0))
    return n_ok - 2 * n_groups - lay.N - active_s


# --------------------------------------------------------------------------- intervals
def _profile_end(data, lay, theta, f_min, k, sd, side, cap, delta, issues):
    """One end of the profile-likelihood interval of theta[k] (side -1: lower, +1: upper):
    the first trial at the Wald end, doubling outwards until the profile crosses
    f_min + delta, then regula falsi (Illinois) on the bracket; every solve is warm-started
    from the nearest solved point, and one that did not converge is solved again from the
    optimum (the lower objective kept). ``issues`` (a list) receives 'not-converged' where a
    profile point stays unconverged, lies below the optimum (the fit was not at its minimum)
    or the root is not found."""
    x_hat = theta[k]
    solved = {x_hat: (theta.copy(), -delta)}
    starts = {x_hat: theta.copy()}  # converged points only: the warm starts

    def solve_at(v):
        """Solve with theta[k] held at v from the nearest converged point; where that fails,
        by continuation (the hold moved there in PROFILE_CONTINUATION steps)."""
        near = min(starts, key=lambda x: abs(x - v))
        t, f, ok = _solve(data, lay, starts[near], {k: v})
        if not ok:
            t2 = starts[near]
            for frac in np.linspace(0.0, 1.0, PROFILE_CONTINUATION + 1)[1:]:
                t2, f2, ok = _solve(data, lay, t2, {k: near + frac * (v - near)})
            if f2 < f or ok:
                t, f = t2, f2
        if ok:
            starts[v] = t
        return t, f, ok

    def excess(v):
        t, f, ok = solve_at(v)
        # an unconverged point only matters where it could lie inside the interval (its
        # objective is an upper bound of the profile's there)
        if (not ok and f - f_min < PROFILE_UNSURE * delta) or \
                f < f_min - PROFILE_BELOW * max(1.0, f_min):
            issues.append("not-converged")
        solved[v] = (t, f - f_min - delta)
        return solved[v][1]

    step = np.sqrt(delta) * sd if np.isfinite(sd) and sd > 0 else 0.0
    step = max(step, 1e-3 * max(abs(x_hat), 1e-3))
    inner, v = x_hat, None
    for _ in range(PROFILE_EXPAND):
        v = x_hat + side * step
        if side < 0 and v <= 0.0:
            if excess(0.0) <= 0:
                return 0.0
            v = 0.0
            break
        if side > 0 and v >= cap:
            if excess(cap) <= 0:
                return np.inf
            v = cap
            break
        if excess(v) > 0:
            break
        inner = v
        step *= 2.0
    else:
        return -np.inf if side < 0 else np.inf
    a, b = inner, v
    fa, fb = solved[a][1], solved[b][1]
    tol = PROFILE_XTOL * max(abs(x_hat), abs(b - a) * 1e-3, 1e-9)
    side_kept = 0
    for _ in range(60):
        c = b - fb * (b - a) / (fb - fa)
        fc = excess(c)
        if abs(fc) < 1e-3 * delta or abs(b - a) < tol:
            return c
        if np.sign(fc) == np.sign(fb):
            b, fb = c, fc
            if side_kept == 1:
                fa *= 0.5
            side_kept = 1
        else:
            a, fa = c, fc
            if side_kept == -1:
                fb *= 0.5
            side_kept = -1
    issues.append("not-converged")  # the root was not found to its tolerance
    return c


def _wald_sd(data, lay, theta, k):
    _, J = _residuals(theta, data, lay)
    H = J.T @ J
    try:
        cov = np.linalg.pinv(H)
    except np.linalg.LinAlgError:  # pragma: no cover
        return np.inf
    return float(np.sqrt(max(cov[k, k], 0.0)))


def _intervals(data, lay, theta, f_min):
    """95 % profile-likelihood intervals of C and a_CDOM (group 0), and open-end flags."""
    delta = PATH_MODEL_DELTA  # the chi^2_1 95 % point
    e0 = data.models[0].e0
    out, flags = {}, []
    for name, k, cap in (("chl", lay.u[0], u_from_chl(CHL_MAX, e0)), ("cdom", lay.cdom[0], CDOM_MAX)):
        sd = _wald_sd(data, lay, theta, k)
        issues = []
        lo = _profile_end(data, lay, theta, f_min, k, sd, -1, cap, delta, issues)
        hi = _profile_end(data, lay, theta, f_min, k, sd, +1, cap, delta, issues)
        flags += issues[:1]
        if name == "chl":
            lo = float(chl_from_u(lo, e0)) if np.isfinite(lo) else lo
            hi = float(chl_from_u(hi, e0)) if np.isfinite(hi) else hi
        if not np.isfinite(hi) or not np.isfinite(lo):
            flags.append(f"unbounded-{name}")
        out[name] = (float(lo), float(hi))
    return out, flags


# --------------------------------------------------------------------------- set-up
def _budget(uncertain, water, depth, distance, depth_sd, distance_sd, patch_correlation):
    """(shared priors, geometry sds, shared patch sd, independent patch sd, budget dict)."""
    if uncertain is None:
        uncertain = DEFAULT_UNCERTAIN
    if not isinstance(uncertain, dict):
        raise ValueError("uncertain: expected a dict name -> standard deviation, or {} for the "
                         "paper's exact model")
    bad = set(uncertain) - set(NUISANCE) - {"patch"}
    if bad:
        raise ValueError(f"uncertain: unknown name(s) {sorted(bad)}")
    priors = {}
    for name, value in uncertain.items():
        if name in ("depth", "distance", "patch"):
            continue
        sd = float(parse_sd(name, value))
        if sd > 0:
            mean = 0.0 if name in CAMERA else float(getattr(water, name))
            priors[name] = (mean, sd)
    geo = {}
    for name, given, ref in (("depth", depth_sd, depth), ("distance", distance_sd, distance)):
        if given is not None:
            sd = np.broadcast_to(np.asarray(given, float), ref.shape).astype(float)
            if np.any(~np.isfinite(sd)) or np.any(sd < 0):
                raise ValueError(f"{name}_sd: standard deviations must be finite and >= 0")
        elif name in uncertain:
            sd = np.broadcast_to(parse_sd(name, uncertain[name], ref), ref.shape).astype(float)
        else:
            sd = np.zeros(ref.shape)
        geo[name] = sd
    patch = float(parse_sd("patch", uncertain.get("patch", 0.0)))
    rho = float(patch_correlation)
    if not 0.0 <= rho <= 1.0:
        raise ValueError(f"patch_correlation: must lie in [0, 1], got {patch_correlation!r}")
    # correlation rho between photos: a shared part of variance rho patch^2, an independent
    # part (1 - rho) patch^2
    return priors, geo, np.sqrt(rho) * patch, np.sqrt(1.0 - rho) * patch, dict(uncertain)


def _data(M, sigma, setups, water, depth, distance, priors, geo, patch_shared, patch_indep):
    N = M.shape[0]
    built = {}
    models = [built.setdefault(id(s), ChartModel(s, water=water)) for s in setups]
    Mv = M.reshape(N, -1)
    sig = sigma.reshape(N, -1)
    scale = np.nanmax(np.where(np.isfinite(Mv), Mv, 0.0), axis=1)
    if np.any(~(scale > 0)):
        raise ValueError("rgb: every chart needs a positive value")
    ok = np.isfinite(sig) & (sig > 0) & np.isfinite(Mv)
    Ms = np.where(ok, Mv, 0.0) / scale[:, None]
    total = np.sqrt((np.where(ok, sig, 1.0) / scale[:, None]) ** 2 + (patch_indep * Ms) ** 2)
    inv = np.where(ok, 1.0 / total, 0.0)
    v = patch_shared * Ms * inv  # the shared term in each value's own whitened units
    norm = np.sqrt(np.sum(v * v, axis=0))
    vhat = np.divide(v, norm, out=np.zeros_like(v), where=norm > 0)
    beta = 1.0 - 1.0 / np.sqrt(1.0 + norm ** 2)
    return _Data(models, Ms, inv, scale, depth, distance, priors, geo, vhat, beta, water)


def _starts(data, lay, start):
    """theta0 from per-photo starting values (chl, cdom, gain, backscatter in data units)."""
    theta = np.zeros(lay.size)
    e0 = data.models[0].e0
    G = int(lay.groups.max()) + 1
    for g in range(G):
        members = lay.groups == g
        theta[lay.u[g]] = u_from_chl(np.median(start["chl"][members]), e0)
        theta[lay.cdom[g]] = np.median(start["cdom"][members])
    for name, cols in lay.shared.items():
        theta[cols] = data.priors[name][0]
    for name in ("depth", "distance"):
        j = lay.geometry[name]
        theta[j[j >= 0]] = getattr(data, name)[j >= 0]
    theta[lay.gain] = start["gain"] / data.scale
    theta[lay.s] = np.maximum(start["backscatter"], 0.0) / data.scale[:, None]
    return theta


def _single_starts(M, sigma, setups, water, depth, distance):
    """Per-photo starting values: the batch's fit of each photo alone (exact model)."""
    from .batch import estimate_batch

    out = {k: [] for k in ("chl", "cdom", "gain", "backscatter")}
    for i in range(M.shape[0]):
        sig = np.where(np.isfinite(sigma[i]), sigma[i], 1e6 * np.nanmax(M[i]))
        b = estimate_batch(M[i][None], depth=depth[i], distance=distance[i], sigma=sig,
                           setup=setups[i], water=water, gain="free", intervals=False,
                           uncertain={}, path_models=(water.path_model,))
        for k in out:
            out[k].append(np.asarray(getattr(b, k))[0])
    return {k: np.array(v, float) for k, v in out.items()}


def _check(M, sigma, depth, distance, setups):
    M = np.asarray(M, float)
    if M.ndim != 3 or M.shape[0] < 1:
        raise ValueError(f"rgb: expected (N, m, n) patch values of N >= 1 photos, got shape "
                         f"{M.shape}")
    sigma = np.asarray(sigma, float)
    if sigma.shape != M.shape:
        raise ValueError(f"sigma: expected the shape of rgb {M.shape}, got {sigma.shape}")
    N = M.shape[0]
    out = []
    for name, v in (("depth", depth), ("distance", distance)):
        a = np.broadcast_to(np.asarray(v, float), (N,)).astype(float)
        if np.any(~np.isfinite(a)) or np.any(a < 0):
            raise ValueError(f"{name}: expected N finite lengths >= 0 (m)")
        out.append(a)
    if isinstance(setups, ChartSetup):
        setups = [setups] * N
    setups = list(setups)
    if len(setups) != N or not all(isinstance(s, ChartSetup) for s in setups):
        raise ValueError("setup: expected one forward.ChartSetup, or one per photo")
    return M, sigma, out[0], out[1], setups


# --------------------------------------------------------------------------- the estimator
def estimate_joint(rgb, *, depth, distance, sigma, setup, water: Water | None = None,
                   uncertain=None, depth_sd=None, distance_sd=None, names=None,
                   path_models=None, patch_correlation: float = PATCH_CORRELATION,
                   start=None) -> JointEstimate:
    """Estimate one water (C, a_CDOM(440)) from N photographs of the chart.

    Parameters
    ----------
    rgb : array_like, (N, m, n)
        Patch values of each photo (any units: each photo's exposure gain is free).
    depth, distance : float or array_like, (N,)
        Each photo's chart depth and camera-to-chart distance, m (the priors' centres).
    sigma : array_like, (N, m, n)
        Standard errors of the values (same units); ``inf`` or NaN leaves a value out
        (clipped).
    setup : forward.ChartSetup or sequence of them
        The camera (its calibrated balance applied), illuminant and chart; one per photo where
        the light over the chart differs (:mod:`measure.lightfield`).
    water : forward.Water, optional
        The water model (default the paper's).
    uncertain : dict, optional
        The uncertainty budget (:mod:`sca.budget`); None: the default. The water's constants,
        'balance' and 'camera_shift' are shared by every photo; 'depth' and 'distance' are
        each photo's; 'patch' is split by ``patch_correlation``.
    depth_sd, distance_sd : array_like, (N,), optional
        Each photo's own sd (m), replacing the budget's 'depth' / 'distance'.
    names : sequence of str, optional
        Photo names for the report (default 'photo 1', ...).
    path_models : sequence of str, optional
        Path models to compare (default: every candidate where a budget applies).
    patch_correlation : float, optional
        Correlation of the per-patch systematic error between photos (default 1: the same
        chart and camera).
    start : dict, optional
        Per-photo starting values 'chl', 'cdom', 'gain', 'backscatter' ((N,), (N, m); data
        units); default: each photo's own fit.

    Returns
    -------
    JointEstimate

    Raises
    ------
    ValueError
        Naming the argument for bad shapes, lengths, budgets or path models.
    """
    M, sigma, depth, distance, setups = _check(rgb, sigma, depth, distance, setup)
    N, m, n = M.shape
    water = resolve_water(water)
    names = [f"photo {i + 1}" for i in range(N)] if names is None else [str(x) for x in names]
    if len(names) != N:
        raise ValueError(f"names: expected {N} names, got {len(names)}")
    priors, geo, p_shared, p_indep, budget = _budget(uncertain, water, depth, distance,
                                                     depth_sd, distance_sd, patch_correlation)
    exact = not priors and not np.any(geo["depth"]) and not np.any(geo["distance"]) \
        and p_shared == 0 and p_indep == 0
    models = candidates(path_models, water, not exact)
    if start is None:
        start = _single_starts(M, sigma, setups, water, depth, distance)
    start = {k: np.asarray(v, float) for k, v in start.items()}
    geometry = {g: geo[g] > 0 for g in ("depth", "distance")}

    def fit(pm, indep, groups=None):
        w = dataclasses.replace(water, path_model=pm)
        data = _data(M, sigma, setups, w, depth, distance, priors, geo, p_shared, indep)
        lay = _Layout(N, m, n, np.zeros(N, int) if groups is None else groups, tuple(priors),
                      geometry)
        theta, f, ok = _solve(data, lay, _starts(data, lay, start))
        return data, lay, theta, f, ok

    scatter = 0.0
    if N > 1 and not exact:
        scatter = _photo_scatter(lambda indep: fit(models[0], indep, np.arange(N)), p_indep)
        p_indep = float(np.hypot(p_indep, scatter))
    fits = {pm: fit(pm, p_indep) for pm in models}
    objectives = np.array([[fits[pm][3] for pm in models]])
    best_i, ok_mask = supported(objectives)
    best = models[int(best_i[0])]
    data, lay, theta, f, converged = fits[best]
    flags, notes = [], []
    cis = {"chl": [np.inf, -np.inf], "cdom": [np.inf, -np.inf]}
    for j, pm in enumerate(models):
        if not ok_mask[0, j]:
            continue
        d_, l_, t_, f_, _ = fits[pm]
        ints, fl = _intervals(d_, l_, t_, f_)
        flags += fl
        for k in cis:
            cis[k] = [min(cis[k][0], ints[k][0]), max(cis[k][1], ints[k][1])]
    if ok_mask.sum() > 1:
        flags.append(SPAN_FLAG)
        notes.append("the intervals span the path models the data cannot tell apart: "
                     + ", ".join(pm for j, pm in enumerate(models) if ok_mask[0, j]))
    dof = _dof(data, lay, theta)
    _, p = goodness(f, dof, True)
    if scatter >= PHOTO_SCATTER_MAX:
        flags.append("misfit")
        notes.append(f"the photos disagree patch by patch by more than {100 * PHOTO_SCATTER_MAX:g} "
                     "% beyond their noise: not one measurement")
    if scatter > 0:
        flags.append("photo-scatter")
        notes.append(f"the photos disagree patch by patch beyond their noise and the shared chart "
                     f"term: a per-photo term of {100 * scatter:.2g} % per value was added (its "
                     "size from the joint fit's chi^2)")
    if not converged:
        flags.append("not-converged")
    if float(p) < MISFIT_P:
        flags.append("misfit")
    het = _heterogeneity(data, lay, theta, f, names, start)
    if not het["one_water"]:
        flags.append("heterogeneous")
        which = ", ".join(het["disagree"]) or "no single photo stands out"
        notes.append(f"these photos are not one water (likelihood-ratio p = {het['p_value']:.2g}); "
                     f"photos that disagree with the rest: {which}")
    e0 = data.models[0].e0
    flags = tuple(dict.fromkeys(flags))
    photos = {}
    for i, nm in enumerate(names):
        p_i = _params(data, lay, theta, i)
        photos[nm] = {"gain": float(p_i["gain"] * data.scale[i]),
                      "backscatter": (np.asarray(p_i["backscatter"]) * data.scale[i]).tolist(),
                      "depth": float(p_i["depth"]), "distance": float(p_i["distance"])}
    nuisance = {k: (theta[c].tolist() if k in CAMERA else float(theta[c[0]]))
                for k, c in lay.shared.items()}
    return JointEstimate(
        chl=float(chl_from_u(theta[lay.u[0]], e0)), cdom=float(theta[lay.cdom[0]]),
        chl_ci=tuple(float(v) for v in cis["chl"]), cdom_ci=tuple(float(v) for v in cis["cdom"]),
        reliable=not any(fl in JOINT_BLOCKING for fl in flags), flags=flags, chi2=float(f),
        dof=int(dof), chi2_p=float(p), heterogeneity=het, path_model=best,
        path_models={pm: float(fits[pm][3]) for pm in models}, photos=photos,
        photo_scatter=float(scatter),
        nuisance=nuisance, uncertain=budget, converged=converged, notes=notes)


def _photo_scatter(fit, base) -> float:
    """The per-photo relative scatter s (added in quadrature to the budget's independent
    per-patch term) at which the fit with one (C, a_CDOM) *per photo* has chi^2 equal to its
    degrees of freedom: the photos' own disagreement beyond their noise and the shared chart
    term, measured where a difference of water cannot be absorbed (so the heterogeneity test
    keeps its power). 0 where that fit is good without it (chi^2 p >= MISFIT_P),
    PHOTO_SCATTER_MAX where even that is not enough (the joint estimate is then flagged
    misfit). Method of moments, as the calibration's per-patch term
    (:func:`measure.camera.patch_systematic`); ``fit(indep)`` fits with that independent
    term."""
    def excess(s):
        data, lay, theta, f, _ = fit(float(np.hypot(base, s)))
        return f - _dof(data, lay, theta)

    data, lay, theta, f, _ = fit(base)
    if float(goodness(f, _dof(data, lay, theta), True)[1]) >= MISFIT_P:
        return 0.0
    if excess(PHOTO_SCATTER_MAX) > 0:
        return PHOTO_SCATTER_MAX
    lo, hi = PHOTO_SCATTER_MAX * 1e-3, PHOTO_SCATTER_MAX
    if excess(lo) <= 0:
        return lo
    return float(np.exp(optimize.brentq(lambda t: excess(np.exp(t)), np.log(lo), np.log(hi),
                                        xtol=0.05)))


def _heterogeneity(data, lay, theta, f_joint, names, start) -> dict:
    """The likelihood-ratio test of one (C, a_CDOM) against one per photo; where it rejects,
    the photos that disagree, found one at a time: the photo whose own (C, a_CDOM) lowers
    chi^2 most is set apart (Bonferroni p over the photos still shared) and the rest is tested
    again, until the rest is one water (or two photos remain)."""
    N = lay.N
    out = {"alpha": HETEROGENEITY_ALPHA, "statistic": 0.0, "dof": 2 * (N - 1), "p_value": 1.0,
           "one_water": True, "disagree": [], "per_photo": {}}
    if N < 2:
        return out
    geometry = {g: lay.geometry[g] >= 0 for g in ("depth", "distance")}

    def fit(groups):
        """The fit with (C, a_CDOM) per group, from the photos' own starts and from the joint
        optimum (each group at the joint C and a_CDOM): the lower of the two."""
        lay_g = _Layout(N, lay.m, lay.n, groups, tuple(lay.shared), geometry)
        from_joint = _starts(data, lay_g, start)
        tail = lay_g.size - (lay_g.u.size + lay_g.cdom.size)
        from_joint[lay_g.u] = theta[lay.u[0]]
        from_joint[lay_g.cdom] = theta[lay.cdom[0]]
        from_joint[-tail:] = theta[-tail:]
        f = min(_solve(data, lay_g, t0)[1] for t0 in (_starts(data, lay_g, start), from_joint))
        return min(f, f_joint)  # more freedom never fits worse than the joint optimum

    f_sep = fit(np.arange(N))
    stat = max(f_joint - f_sep, 0.0)
    p = float(stats.chi2.sf(stat, 2 * (N - 1)))
    out.update(statistic=float(stat), p_value=p, one_water=bool(p >= HETEROGENEITY_ALPHA))
    apart = []  # photos set apart, in order
    f_now = f_joint
    while True:
        rest = [i for i in range(N) if i not in apart]
        if len(rest) < 3:
            break
        stat_rest = max(f_now - f_sep, 0.0)
        if stats.chi2.sf(stat_rest, 2 * (len(rest) - 1)) >= HETEROGENEITY_ALPHA:
            break
        trials = {}
        for i in rest:
            groups = np.zeros(N, int)
            for k, j in enumerate(apart + [i]):
                groups[j] = k + 1
            trials[i] = fit(groups)
        i = min(trials, key=trials.get)
        p_i = min(1.0, len(rest) * float(stats.chi2.sf(max(f_now - trials[i], 0.0), 2)))
        out["per_photo"][names[i]] = p_i
        if p_i >= HETEROGENEITY_ALPHA:
            break
        apart.append(i)
        f_now = trials[i]
    out["disagree"] = [names[i] for i in apart]
    return out


# --------------------------------------------------------------------------- the bound
def dive_precision(chl, cdom, *, depth, distance, sigma, setup, water: Water | None = None,
                   uncertain=None, patch_correlation: float = PATCH_CORRELATION,
                   gain=None, backscatter=None) -> dict:
    """The Cramér-Rao bound of C and a_CDOM(440) from N photographs of one water.

    Parameters
    ----------
    chl, cdom : float
        The water: C (mg m^-3), a_CDOM(440) (m^-1).
    depth, distance : array_like, (N,)
        The dive's photos: chart depths and camera-to-chart distances, m.
    sigma : array_like, (N, m, n)
        Each photo's noise sd at its noise-free values (the same units as the model with
        ``gain``).
    setup : forward.ChartSetup or sequence of them
        The camera, illuminant and chart.
    water, uncertain, patch_correlation :
        As :func:`estimate_joint`.
    gain : array_like, (N,), optional
        Each photo's exposure gain (default 1).
    backscatter : array_like, (N, m), optional
        Each photo's veiling light (default 0).

    Returns
    -------
    dict
        'chl_sd', 'cdom_sd' (the bound's standard deviations), 'correlation', 'n_photos'.
    """
    depth = np.atleast_1d(np.asarray(depth, float))
    distance = np.atleast_1d(np.asarray(distance, float))
    N = max(depth.size, distance.size)
    depth, distance = np.broadcast_to(depth, (N,)).copy(), np.broadcast_to(distance, (N,)).copy()
    water = resolve_water(water)
    setups = [setup] * N if isinstance(setup, ChartSetup) else list(setup)
    priors, geo, p_shared, p_indep, _ = _budget(uncertain, water, depth, distance, None, None,
                                                patch_correlation)
    mdl = ChartModel(setups[0], water=water)
    m, n = mdl.m, mdl.n
    gain = np.ones(N) if gain is None else np.broadcast_to(np.asarray(gain, float), (N,))
    s = np.zeros((N, m)) if backscatter is None else np.broadcast_to(
        np.asarray(backscatter, float), (N, m))
    M0 = np.stack([ChartModel(setups[i], water=water).predict(
        {"chl": chl, "cdom": cdom, "depth": depth[i], "distance": distance[i], "gain": gain[i],
         "backscatter": s[i]}, jacobian=False).values.reshape(m, n) for i in range(N)])
    sigma = np.broadcast_to(np.asarray(sigma, float), M0.shape)
    data = _data(M0, sigma, setups, water, depth, distance, priors, geo, p_shared, p_indep)
    lay = _Layout(N, m, n, np.zeros(N, int), tuple(priors),
                  {g: geo[g] > 0 for g in ("depth", "distance")})
    theta = _starts(data, lay, {"chl": np.full(N, float(chl)), "cdom": np.full(N, float(cdom)),
                                "gain": gain, "backscatter": s})
    _, J = _residuals(theta, data, lay)
    # the information of C itself (not u): d/dC = d/du du/dC
    J[:, lay.u[0]] /= float(du_chain(chl, mdl.e0))
    H = J.T @ J
    k, c = lay.u[0], lay.cdom[0]
    if np.linalg.matrix_rank(H) < H.shape[0]:  # a direction the data do not determine
        return {"chl_sd": np.inf, "cdom_sd": np.inf, "correlation": np.nan, "n_photos": N}
    cov = np.linalg.inv(H)
    sd_c, sd_a = float(np.sqrt(cov[k, k])), float(np.sqrt(cov[c, c]))
    return {"chl_sd": sd_c, "cdom_sd": sd_a, "correlation": float(cov[k, c] / (sd_c * sd_a)),
            "n_photos": N}
