"""Batched estimation: many charts at once with vectorised variable projection + Levenberg-Marquardt.

Solves the same problem as :func:`sca.estimate` (eqs 15-18, one phytoplankton basis function)
for N charts that share camera, illuminant, chart and grid (path lengths may differ):

* **variable projection**: for a given k, the optimal backscatter has a closed form,
  s_c = max(0, mean_j (M - G(k))_cj), so the nonlinear problem is over (C, a_CDOM) only; with
  z = 1, w is tied to C by eq 17 exactly (w = 0.0378 C^0.627 / t_1(440));
* the reduced residual's Jacobian is exact (the per-channel mean is projected out where
  s_c > 0);
* the iteration runs in u = C^e0 (e0 = 0.627, the exponent of eq 10, so u is proportional to
  a_phi(440)) instead of C: every C-dependent term is then smooth at C = 0 (C^0.724 = u^1.155,
  C = u^1.595), where the derivative in C itself is infinite; u >= 0 <=> C >= 0, so the
  optimum is the same;
* a Levenberg-Marquardt step with Marquardt scaling (diag of J^T J) and projected bounds
  (u, a_CDOM >= 0: a variable at its bound whose gradient points outwards is held);
* engine 'numba' (default): each chart runs this iteration in compiled code, charts spread
  over all cores; engine 'numpy' (the reference): all charts advance together in array code
  and converged charts leave the active set (see :mod:`sca._batch_kernel`);
* the start is the best point of a deterministic coarse grid (a coarser version of the one
  of :func:`sca.estimate`), evaluated for all charts at once with one matrix product per
  unique path length.

A chart that does not converge within ``max_iter`` is flagged (``converged`` False, ``status``
says why); nothing is silently wrong.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass

import numpy as np

from forward import validate
from forward.imaging import ChartSetup, length, resolve_setup
from forward.spectra import DEFAULT_CAMERA
from forward.water import Water, resolve_water

from ._batch_kernel import (
    BOUND_FAILED,
    BOUND_OPEN,
    HAVE_NUMBA,
    evaluate_numpy,
    gain_variance,
    intervals_numba,
    linear_part_numpy,
    lm_numba,
)
from .assess import (
    CDOM_MAX,
    CHL_MAX,
    estimate_flag_table,
    flag_tuples,
    gain_wald,
    goodness,
    input_flag_table,
    profile_delta,
)
from .estimate import EXACT_FIT, GAINS, MAX_RGB
from .model import WaterModel, chl_weights_u

#: Coarse start grid of the batch (C in mg m^-3, a_CDOM in m^-1).
INIT_CHL = np.concatenate([[0.0], np.logspace(-3, 2, 8)])
INIT_CDOM = np.concatenate([[0.0], np.logspace(-3, np.log10(3.0), 6)])

#: Charts per chunk (bounds the memory of the start-grid search: chunk x grid points).
CHUNK = 65536

#: Levenberg-Marquardt damping: start, divisor after a success, factor after a failure.
LM_MU0, LM_DOWN, LM_UP = 1e-4, 10.0, 10.0

DEFAULT_ENGINE = "numba" if HAVE_NUMBA else "numpy"

#: One compiled parallel kernel runs at a time: it already uses every core, and numba's
#: threading layers are not all safe for concurrent launches from several Python threads.
_NUMBA_LOCK = threading.Lock()

STATUS = {
    0: "converged: relative decrease below tol",
    1: "exact fit (objective at rounding level)",
    2: "converged: no further decrease predicted",
    3: "maximum number of iterations reached",
    4: "damping grew without decrease (not stationary)",
}


@dataclass
class BatchEstimate:
    """Arrays (length N) of the fields of :class:`sca.Estimate` (intervals (N, 2))."""

    chl: np.ndarray
    cdom: np.ndarray
    chl_ci: np.ndarray  # (N, 2) 95 % profile-likelihood intervals, mg m^-3 (inf: open)
    cdom_ci: np.ndarray  # (N, 2) m^-1
    reliable: np.ndarray  # (N,) bool
    flags: list  # N tuples of flag names (sca.assess)
    fit_rms: np.ndarray  # ||M - G - s|| / ||M||
    chi2_dof: np.ndarray  # reduced chi^2 (NaN where the noise is unknown)
    chi2_p: np.ndarray
    dof: np.ndarray
    noise_known: bool
    w: np.ndarray  # (N, 1)
    backscatter: np.ndarray  # (N, m)
    #: (N,) the unknown exposure M = gain G + s (gain="free"); ones where it is known
    gain: np.ndarray
    #: (N, 2) 95 % Wald interval of the gain (its Gauss-Newton standard error); the gain itself
    #: where it is known
    gain_ci: np.ndarray
    attenuation: np.ndarray  # (N, q)
    wavelengths: np.ndarray
    objective: np.ndarray  # chi^2 (noise known) or ||M - G - s||^2 in data units
    iterations: np.ndarray
    converged: np.ndarray
    status: np.ndarray  # strings
    status_code: np.ndarray
    elapsed_s: float

    def __len__(self):
        return self.chl.size


class BatchModel:
    """Vectorised k(C, a_CDOM), the signals and their derivatives (z = 1, w on eq 17), with
    every number from :class:`forward.Water` (via :class:`sca.model.WaterModel`)."""

    def __init__(self, setup: ChartSetup, *, basis=None, water: Water | None = None):
        self.mdl = WaterModel(setup, 0.0, 0.0, basis=basis, water=water)
        if self.mdl.z != 1:
            raise ValueError(f"basis: the batched solver supports one basis function (z = 1), got z = {self.mdl.z}")
        self.water = self.mdl.water
        self.terms = terms = self.mdl.terms
        self.Bt = np.ascontiguousarray(self.mdl.B.T)  # (q, m n)
        self.m, self.n = self.mdl.m, self.mdl.n
        self.wl = self.mdl.wavelengths
        # c = base + a_CDOM ecdom + Phi(C) @ S (forward.WaterTerms); the kernels get these arrays
        self.S = np.ascontiguousarray(terms.shapes)
        self.base = np.ascontiguousarray(terms.base)
        self.ecdom = np.ascontiguousarray(terms.cdom_shape)
        self.table = np.ascontiguousarray(self.water.chl_terms())
        #: the iteration variable is u = C^e0 (eq 10's exponent)
        self.e0 = float(self.water.phyto_exponent)

    def weights(self, chl, derivative=False):
        """Phi (N, 4), the weights of the shapes S, and with ``derivative`` dPhi/du, u = C^e0."""
        chl = np.asarray(chl, float)
        if not derivative:
            return self.water.chl_weights(chl)
        return chl_weights_u(self.water, chl)

    def coefficient(self, chl, cdom):
        """c (N, q) in m^-1 (a for the 'absorption' path model)."""
        return self.terms.coefficient(chl, cdom)


def _initial(bm: BatchModel, Ms, W2, L, fs, has_fs, free_g=False):
    """Best point of the coarse (C, a_CDOM) grid for every chart (one matrix product per unique
    L), with the closed-form s, in the charts' scaled units. The grid search weights each
    channel by its mean weight (a start needs no more; the fit itself uses every weight)."""
    C, A = np.meshgrid(INIT_CHL, INIT_CDOM, indexing="ij")
    C, A = C.ravel(), A.ravel()
    cgrid = bm.coefficient(C, A)  # (P, q)
    N, m, n = Ms.shape[0], bm.m, bm.n
    if free_g:
        return _initial_free_gain(bm, Ms, W2, L, fs, has_fs, C, A, cgrid)
    wc = W2.reshape(N, m, n).mean(axis=2)  # (N, m)
    Msum = Ms.reshape(N, m, n).sum(axis=2)  # (N, m)
    WM = (Ms.reshape(N, m, n) * wc[:, :, None]).reshape(N, m * n)
    best = np.empty(N, dtype=int)
    uniq, inv = np.unique(L, return_inverse=True)
    for u_idx, Lu in enumerate(uniq):
        rows = np.flatnonzero(inv == u_idx)
        G = np.exp(-Lu * cgrid) @ bm.Bt  # (P, m n), for scale 1
        G3 = G.reshape(-1, m, n)
        Gsum, GG = G3.sum(axis=2), np.einsum("pcj,pcj->pc", G3, G3)  # (P, m)
        w = wc[rows]
        # sum_c w_c ||M_c - G_c - s_c||^2 up to a constant in G
        f = -2.0 * WM[rows] @ G.T + w @ GG.T
        if has_fs:
            f += 2.0 * (w * fs[rows]) @ Gsum.T
        else:
            for ch in range(m):  # the closed-form s_c removes n w_c s_c^2
                s_c = np.maximum((Msum[rows, ch][:, None] - Gsum[None, :, ch]) / n, 0.0)
                f -= (n * w[:, ch:ch + 1]) * (s_c * s_c)
        best[rows] = np.argmin(f, axis=1)
    return C[best].copy(), A[best].copy()


def _initial_free_gain(bm, Ms, W2, L, fs, has_fs, C, A, cgrid):
    """:func:`_initial` with a free gain: every grid point gets its best gain and s (the
    closed form of :func:`sca._batch_kernel.linear_part_numpy`); per chart (a start)."""
    N, m, n = Ms.shape[0], bm.m, bm.n
    best = np.empty(N, dtype=int)
    wc = W2.reshape(N, m, n).mean(axis=2, keepdims=True)
    for i in range(N):
        G3 = (np.exp(-L[i] * cgrid) @ bm.Bt).reshape(-1, m, n)
        M3 = np.broadcast_to(Ms[i].reshape(1, m, n), G3.shape)
        gain, s, _ = linear_part_numpy(M3, G3, wc[i:i + 1], fs[i:i + 1] if has_fs else None)
        r = M3 - gain[:, None, None] * G3 - s[..., None]
        best[i] = int(np.argmin(np.einsum("pcj,pcj->p", wc[i] * r, r)))
    return C[best].copy(), A[best].copy()


def _sigma_stack(sigma, N, m, n):
    """``sigma`` (scalar, (m, n) or (N, m, n), data units) as (N, m, n), or None."""
    if sigma is None:
        return None
    arr = validate.array("sigma", sigma)
    try:
        arr = np.broadcast_to(arr, (N, m, n)) if arr.ndim in (0, 2, 3) else None
    except ValueError:
        arr = None
    if arr is None:
        raise ValueError(f"sigma: expected a scalar, (m, n) = ({m}, {n}) or (N, m, n) = "
                         f"({N}, {m}, {n}) array, got shape {np.shape(sigma)}")
    if np.any(arr <= 0):
        raise ValueError(f"sigma: standard deviations must be > 0 (min {arr.min():g})")
    return arr


def estimate_batch(rgb_stack, *, depth, distance, sigma=None, saturation=None,
                   camera=DEFAULT_CAMERA, illuminant=None, reflectances=None, wavelengths=None,
                   basis=None, water: Water | None = None, path_model: str | None = None,
                   cdom_slope: float | None = None, fix=None, intervals: bool = True,
                   max_iter: int = 100, tol: float = 1e-12, setup: ChartSetup | None = None,
                   engine: str = DEFAULT_ENGINE, gain: str = "known") -> BatchEstimate:
    """Estimate C, a_CDOM(440), w and s for a stack of charts ``rgb_stack`` (N, m, n).

    ``depth`` and ``distance`` (m) are scalars or arrays of length N. ``sigma``: the standard
    deviation of each value (scalar, (m, n) or (N, m, n); data units): the fit is then weighted
    least squares and its chi^2 tested; without it the noise is estimated from the residual and
    no chart is called reliable (flag ``noise-unknown``). ``saturation``: the sensor's clip level
    in data units (scalar or (N,)), for the ``saturated`` check. ``intervals``: compute the 95 %
    profile-likelihood intervals (default; without them no chart is reliable). Other arguments
    as in :func:`sca.estimate`; ``fix`` may hold ``{'backscatter': value}`` (scalar or (m,)).
    ``engine``: 'numba' (default: the iteration compiled per chart, on all cores) or 'numpy'
    (array code, the reference); both run the same iteration. ``gain``: 'known' (data in model
    units) or 'free' (M = gain G + s with one unknown gain per chart -- a photograph's exposure
    -- profiled out with s; the intervals of C and a_CDOM then include its uncertainty).
    Returns a :class:`BatchEstimate`.
    Safe to call from several threads.
    """
    t0 = time.perf_counter()
    setup = resolve_setup(setup, camera, illuminant, reflectances, wavelengths)
    water = resolve_water(water, path_model=path_model, cdom_slope=cdom_slope)
    bm = BatchModel(setup, basis=basis, water=water)
    M = validate.array("rgb_stack", rgb_stack, ndim=3)
    if M.shape[1:] != (bm.m, bm.n):
        raise ValueError(f"rgb_stack: expected shape (N, {bm.m}, {bm.n}), got {M.shape}")
    if np.any(M < 0):
        raise ValueError("rgb_stack: contains negative values")
    if M.size and M.max() > MAX_RGB:
        raise ValueError(f"rgb_stack: values up to {M.max():g} exceed {MAX_RGB:g}; measurements "
                         "in model units are O(1) (a white reflector in air = 1)")
    N = M.shape[0]
    scale = M.reshape(N, -1).max(axis=1)
    if np.any(scale <= 0):
        raise ValueError(f"rgb_stack: chart(s) {np.flatnonzero(scale <= 0)[:5].tolist()} are all zero")
    sig = _sigma_stack(sigma, N, bm.m, bm.n)
    sat = None if saturation is None else np.broadcast_to(
        validate.array("saturation", saturation), (N,))
    L = np.broadcast_to(length("depth", depth) + length("distance", distance), (N,)).astype(float)
    if int(max_iter) != max_iter or max_iter < 1:
        raise ValueError(f"max_iter: must be a positive integer, got {max_iter!r}")
    tol = validate.scalar("tol", tol, positive=True)
    fixed_s = None
    if fix:
        if set(fix) - {"backscatter"}:
            raise ValueError("fix: the batched solver can fix only 'backscatter'")
        fixed_s = validate.array("fix['backscatter']", np.broadcast_to(fix["backscatter"], (bm.m,)),
                                 nonnegative=True)
    if engine not in ENGINES:
        raise ValueError(f"engine: must be one of {ENGINES}, got {engine!r}")
    if gain not in GAINS:
        raise ValueError(f"gain: must be one of {GAINS}, got {gain!r}")
    free_g = gain == "free"
    parts = []
    for i in range(0, N, CHUNK):
        sl = slice(i, i + CHUNK)
        parts.append(_solve_chunk(bm, M[sl], None if sig is None else sig[sl], L[sl], scale[sl],
                                  fixed_s, max_iter, tol, engine, bool(intervals), free_g))
    out = {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}
    code = out["code"]
    converged = code <= 2
    chl, cdom = out["chl"], out["cdom"]
    noise_known = sig is not None
    flags, reliable = flag_tuples(
        input_flag_table(M, sig, sat),
        estimate_flag_table(converged=converged, noise_known=noise_known, p_value=out["chi2_p"],
                            chl=chl, cdom=cdom, chl_ci=out["chl_ci"], cdom_ci=out["cdom_ci"],
                            ci_codes=out["ci_codes"] if intervals else None))
    w = (water.phytoplankton_440(chl) / float(bm.mdl.t440[0]))[:, None]
    objective = out["f"] * (1.0 if noise_known else scale**2)
    return BatchEstimate(
        chl=chl, cdom=cdom, chl_ci=out["chl_ci"], cdom_ci=out["cdom_ci"], reliable=reliable,
        flags=flags, fit_rms=out["fit_rms"], chi2_dof=out["chi2_dof"], chi2_p=out["chi2_p"],
        dof=out["dof"], noise_known=noise_known, w=w,
        backscatter=out["s"] * scale[:, None], gain=out["gain"], gain_ci=out["gain_ci"],
        attenuation=out["k"], wavelengths=bm.wl,
        objective=objective, iterations=out["it"], converged=converged,
        status=np.array([STATUS[c] for c in code]), status_code=code,
        elapsed_s=time.perf_counter() - t0,
    )


def _solve_chunk(bm: BatchModel, M, sig, L, scale, fixed_s, max_iter, tol, engine, intervals,
                 free_g=False):
    """Levenberg-Marquardt (and the intervals) on one chunk of charts; results in a dict, s and
    f in the chunk's scaled units."""
    N = M.shape[0]
    Ms = np.ascontiguousarray((M / scale[:, None, None]).reshape(N, -1))  # every chart max 1
    W2 = np.ones_like(Ms) if sig is None else np.ascontiguousarray(
        (scale[:, None] / sig.reshape(N, -1)) ** 2)
    has_fs = fixed_s is not None
    fs = np.ascontiguousarray(fixed_s[None, :] / scale[:, None] if has_fs else np.zeros((N, bm.m)))
    L = np.ascontiguousarray(L)
    scale = np.ascontiguousarray(scale)
    prob = (L, scale, Ms, W2, fs, has_fs, bm.S, bm.base, bm.ecdom, bm.Bt, bm.m, bm.n, bm.table,
            bm.e0, bool(free_g))
    chl0, cdom0 = _initial(bm, Ms, W2, L, fs, has_fs, free_g)
    f_exact = EXACT_FIT * np.einsum("ij,ij->i", W2 * Ms, Ms)
    if engine == "numba":
        with _NUMBA_LOCK:
            chl, cdom, s, k, f, it, code, ssr, gain = lm_numba(
                chl0, cdom0, prob, int(max_iter), float(tol), f_exact, LM_MU0, LM_DOWN, LM_UP)
    else:
        chl, cdom, s, k, f, it, code, gain = _lm_numpy(bm, prob, chl0, cdom0, max_iter, tol,
                                                       f_exact)
        r = Ms - gain[:, None] * (k @ bm.Bt) / scale[:, None] - np.repeat(s, bm.n, axis=1)
        ssr = np.einsum("ij,ij->i", r, r)
    res = dict(chl=chl, cdom=cdom, s=s, k=k, f=f, it=it, code=code, gain=gain)
    # goodness of fit (ssr: the unweighted ||M - G - s||^2, scaled units)
    res["fit_rms"] = np.sqrt(ssr / np.einsum("ij,ij->i", Ms, Ms))
    n_s = np.zeros(N, dtype=int) if has_fs else np.sum(s > 0, axis=1)
    dof = bm.m * bm.n - 2 - n_s - int(free_g)
    res["dof"] = dof
    res["chi2_dof"], res["chi2_p"] = goodness(f, dof, sig is not None)
    res["gain_ci"] = np.column_stack([gain, gain])
    if free_g:
        phi, dphi = bm.weights(chl, derivative=True)
        var = gain_variance(phi, dphi, cdom, L, bm.S, bm.base, bm.ecdom, bm.Bt, Ms, W2, scale, fs,
                            has_fs, bm.m, bm.n, gain, s)
        res["gain_ci"] = gain_wald(gain, var, f, dof, sig is not None)
    chl_ci = np.full((N, 2), np.nan)
    cdom_ci = np.full((N, 2), np.nan)
    codes = np.full((N, 4), BOUND_FAILED)
    if intervals:
        delta = profile_delta(sig is not None, f, dof, np.einsum("ij,ij->i", W2 * Ms, Ms))
        U = np.where(chl > 0, chl, 0.0) ** bm.e0
        with _NUMBA_LOCK:
            ends, codes = intervals_numba(U, cdom, np.ascontiguousarray(delta), prob, True, True,
                                          CHL_MAX ** bm.e0, CDOM_MAX)
        chl_ci = np.column_stack([ends[:, 0], ends[:, 1]]) ** (1.0 / bm.e0)
        cdom_ci = ends[:, 2:].copy()
        chl_ci[codes[:, 1] == BOUND_OPEN, 1] = np.inf
        cdom_ci[codes[:, 3] == BOUND_OPEN, 1] = np.inf
    res.update(chl_ci=chl_ci, cdom_ci=cdom_ci, ci_codes=codes)
    return res


def _lm_numpy(bm, prob, chl, cdom, max_iter, tol, f_exact):
    """The numpy engine: the Levenberg-Marquardt iteration of :func:`sca._batch_kernel.lm_chart`
    as array code over the active charts (the reference)."""
    L, scale, Ms, W2, fs, has_fs = prob[:6]
    free_g = prob[14]
    N = Ms.shape[0]
    chl, cdom = chl.copy(), cdom.copy()

    def evaluate(idx, C, A, grad):
        phi, dphi = bm.weights(C, derivative=True)
        return evaluate_numpy(phi, dphi, A, L[idx], bm.S, bm.base, bm.ecdom, bm.Bt, Ms[idx],
                              W2[idx], scale[idx], fs[idx], has_fs, bm.m, bm.n, grad, free_g)

    iters = np.zeros(N, dtype=int)
    code = np.full(N, 3)
    mu = np.full(N, LM_MU0)
    # state of the active charts: objective, gradient and Gauss-Newton matrix at their point
    fa, _, g, H, _ = evaluate(np.arange(N), chl, cdom, True)
    f = fa.copy()
    done = fa <= f_exact
    code[done] = 1
    active = np.flatnonzero(~done)
    fa, g, H = fa[active], g[active], H[active]
    for it in range(1, int(max_iter) + 1):
        if active.size == 0:
            break
        C, A = chl[active], cdom[active]
        U = C ** bm.e0
        g1, g2 = g[:, 0], g[:, 1]
        h11, h12, h22 = H[:, 0], H[:, 1], H[:, 2]
        # projected bounds: hold a variable at 0 whose descent direction points below 0;
        # a variable that does not move the residual (zero Jacobian column) is held too
        free1 = ~((U <= 0) & (g1 > 0)) & (h11 > 0)
        free2 = ~((A <= 0) & (g2 > 0)) & (h22 > 0)
        m_ = mu[active]
        a11 = np.where(free1, h11 * (1 + m_), 1.0)
        a22 = np.where(free2, h22 * (1 + m_), 1.0)
        a12 = np.where(free1 & free2, h12, 0.0)
        b1 = np.where(free1, -g1, 0.0)
        b2 = np.where(free2, -g2, 0.0)
        # 2 x 2 solve; with mu > 0 and both diagonals positive det > 0 (Cauchy-Schwarz), but
        # guard against underflow by solving the diagonal system instead
        det = a11 * a22 - a12 * a12
        good = det > 1e-14 * a11 * a22
        det = np.where(good, det, 1.0)
        d1 = np.where(good, (b1 * a22 - a12 * b2) / det, b1 / a11)
        d2 = np.where(good, (a11 * b2 - a12 * b1) / det, b2 / a22)
        # predicted decrease of the Gauss-Newton model for the step
        pred = -2 * (g1 * d1 + g2 * d2) - (h11 * d1 * d1 + 2 * h12 * d1 * d2 + h22 * d2 * d2)
        iters[active] = it
        # stationary: the model predicts (relatively) nothing more; stop without a trial
        stat = pred <= tol * fa
        Cn = np.maximum(U + d1, 0.0) ** (1.0 / bm.e0)
        An = np.maximum(A + d2, 0.0)
        # evaluate the trial point with its gradient: most LM steps are accepted, and an
        # accepted point's gradient is then already there for the next step
        trial = ~stat
        ti = active[trial]
        fn = np.full(active.size, np.inf)
        gn = np.zeros((active.size, 2))
        Hn = np.zeros((active.size, 3))
        if ti.size:
            fn[trial], _, gn[trial], Hn[trial], _ = evaluate(ti, Cn[trial], An[trial], True)
        ok = trial & (fn < fa)
        acc = active[ok]
        chl[acc], cdom[acc], f[acc] = Cn[ok], An[ok], fn[ok]
        mu[acc] = np.maximum(mu[acc] / LM_DOWN, 1e-12)
        mu[active[trial & ~ok]] *= LM_UP
        decrease = np.where(ok, fa - fn, 0.0)
        conv_dec = ok & (decrease <= tol * fa)
        exact = np.where(ok, fn, fa) <= f_exact[active]
        fin = np.zeros(active.size, dtype=int) - 1
        fin[conv_dec] = 0
        fin[stat] = 2
        fin[exact] = 1
        fin[trial & ~ok & (mu[active] > 1e12)] = 4
        stop = fin >= 0
        code[active[stop]] = fin[stop]
        fa[ok], g[ok], H[ok] = fn[ok], gn[ok], Hn[ok]
        if stop.any():
            go = ~stop
            active, fa, g, H = active[go], fa[go], g[go], H[go]
    # final values: s (and f once more, consistently) at the returned point, and k on the grid
    f_final, s_final, _, _, gain = evaluate(np.arange(N), chl, cdom, False)
    k_final = np.exp(-L[:, None] * bm.coefficient(chl, cdom))
    return chl, cdom, s_final, k_final, f_final, iters, code, gain


ENGINES = ("numba", "numpy") if HAVE_NUMBA else ("numpy",)
