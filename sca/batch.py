"""Batched estimation: many charts at once with vectorised variable projection + Levenberg-Marquardt.

Solves the same problem as :func:`sca.estimate` (eqs 15-18, one phytoplankton basis function)
for N charts that share camera, illuminant, chart and grid (path lengths may differ):

* **variable projection**: for a given k, the optimal backscatter has a closed form,
  s_c = max(0, mean_j (M - G(k))_cj), so the nonlinear problem is over (C, a_CDOM) only; with
  z = 1, w is tied to C by eq 17 exactly (w = 0.0378 C^0.627 / t_1(440));
* the reduced residual's Jacobian is exact (the per-channel mean is projected out where
  s_c > 0);
* the iteration runs in u = C^0.627 (proportional to a_phi(440), eq 10) instead of C: every
  C-dependent term is then smooth at C = 0 (C^0.724 = u^1.155, C = u^1.595), where the
  derivative in C itself is infinite; u >= 0 <=> C >= 0, so the optimum is the same;
* a Levenberg-Marquardt step with Marquardt scaling (diag of J^T J) and projected bounds
  (u, a_CDOM >= 0: a variable at its bound whose gradient points outwards is held);
* all charts advance together in array code (a few (N, q) x (q, m n) matrix products per
  iteration); converged charts leave the active set (early exit);
* the start is the best point of a deterministic coarse grid (a coarser version of the one
  of :func:`sca.estimate`), evaluated for all charts at once with one matrix product per
  unique path length.

A chart that does not converge within ``max_iter`` is flagged (``converged`` False, ``status``
says why); nothing is silently wrong.
"""

from __future__ import annotations

import os
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from forward import _validate, water
from forward.imaging import ChartSetup, chart_setup, length
from forward.spectra import DEFAULT_CAMERA

from .estimate import EXACT_FIT
from .model import WaterModel

#: Coarse start grid of the batch (C in mg m^-3, a_CDOM in m^-1).
INIT_CHL = np.concatenate([[0.0], np.logspace(-3, 2, 13)])
INIT_CDOM = np.concatenate([[0.0], np.logspace(-3, np.log10(3.0), 9)])

#: Charts per chunk: keeps the (chunk, q) and (chunk, m n) work arrays in cache.
CHUNK = 4096

#: Exponent of eq 10: the batch iterates in u = C^CHL_EXPONENT.
CHL_EXPONENT = 0.627

STATUS = {
    0: "converged: relative decrease below tol",
    1: "exact fit (objective at rounding level)",
    2: "converged: no further decrease predicted",
    3: "maximum number of iterations reached",
    4: "damping grew without decrease (not stationary)",
}


@dataclass
class BatchEstimate:
    """Arrays (length N) of the fields of :class:`sca.Estimate`."""

    chl: np.ndarray
    cdom: np.ndarray
    w: np.ndarray  # (N, 1)
    backscatter: np.ndarray  # (N, m)
    attenuation: np.ndarray  # (N, q)
    wavelengths: np.ndarray
    objective: np.ndarray
    iterations: np.ndarray
    converged: np.ndarray
    status: np.ndarray  # strings
    status_code: np.ndarray
    elapsed_s: float

    def __len__(self):
        return self.chl.size


class BatchModel:
    """Vectorised k(C, a_CDOM), the signals and their derivatives (z = 1, w on eq 17)."""

    def __init__(self, setup: ChartSetup, *, basis=None, path_model="beam", cdom_slope=water.CDOM_SLOPE):
        self.mdl = WaterModel(setup, 0.0, 0.0, basis=basis, path_model=path_model,
                              cdom_slope=cdom_slope)
        if self.mdl.z != 1:
            raise ValueError(f"basis: the batched solver supports one basis function (z = 1), got z = {self.mdl.z}")
        self.t = self.mdl.T[:, 0] / float(self.mdl.t440[0])  # a_phi = (T w) = alpha(C) * t
        self.Bt = np.ascontiguousarray(self.mdl.B.T)  # (q, m n)
        self.m, self.n = self.mdl.m, self.mdl.n
        self.wl = self.mdl.wavelengths
        self.beam = path_model == "beam"
        # c = base + Phi(C, a_CDOM) @ S: the spectral terms of eqs 5-12, each from forward.water
        wl = self.wl
        f12, f3, fk = water.particle_scattering_terms(wl)
        self.S = np.stack([self.t, self.mdl.cdom_shape,
                           water.nap_absorption(wl, 1.0) / water.nap_absorption_440(1.0), f12, f3])
        self.base = water.pure_water_absorption(wl)
        if self.beam:
            self.base = self.base + water.pure_water_scattering(wl) + fk

    def weights(self, chl, cdom, derivative=False):
        """Phi (N, 5): the scalar weights of the spectral terms S of c (see ``terms``) and, with
        ``derivative``, dPhi/du with u = C^0.627."""
        chl = np.asarray(chl, float)
        alpha = water.phytoplankton_absorption_440(chl)
        nap = water.nap_absorption_440(chl)
        w12, w3 = water.particle_scattering_weights(chl)
        if not self.beam:
            w12, w3 = np.zeros_like(chl), np.zeros_like(chl)
        phi = np.stack([alpha, np.asarray(cdom, float), nap, w12, w3], axis=-1)
        if not derivative:
            return phi
        # in u = C^0.627 every term's derivative is finite down to C = 0; evaluating the C
        # derivatives at the smallest normal float keeps the products exact in the limit
        cf = np.maximum(chl, np.finfo(float).tiny)
        dchl_du = cf ** (1.0 - CHL_EXPONENT) / CHL_EXPONENT  # C = u^(1/0.627)
        _, dalpha = water.phytoplankton_absorption_440(cf, derivative=True)
        _, dnap = water.nap_absorption_440(cf, derivative=True)
        _, (d12, d3) = water.particle_scattering_weights(cf, derivative=True)
        if not self.beam:
            d12, d3 = np.zeros_like(chl), np.zeros_like(chl)
        dphi = np.stack([dalpha, np.zeros_like(chl), dnap, d12, d3], axis=-1) * dchl_du[:, None]
        return phi, dphi

    def coefficient(self, chl, cdom):
        """c (N, q) in m^-1 (a for the 'absorption' path model)."""
        return self.weights(chl, cdom) @ self.S + self.base

    def reduced(self, M, G, fixed_s=None):
        """Variable projection: s (N, m) and residual r (N, m, n) for signals G (N, m n)."""
        Gm = G.reshape(-1, self.m, self.n)
        R0 = M - Gm
        if fixed_s is not None:
            s = np.broadcast_to(fixed_s, R0.shape[:2])
        else:
            s = np.maximum(R0.mean(axis=-1), 0.0)
        return s, R0 - s[..., None]


def _initial(bm: BatchModel, M, L, fixed_s):
    """Best point of the coarse (C, a_CDOM) grid for every chart (one matmul per unique L)."""
    C, A = np.meshgrid(INIT_CHL, INIT_CDOM, indexing="ij")
    C, A = C.ravel(), A.ravel()
    cgrid = bm.coefficient(C, A)  # (P, q)
    N = M.shape[0]
    Mv = M.reshape(N, -1)
    Mmean = M.mean(axis=-1)  # (N, m)
    best = np.empty(N, dtype=int)
    uniq, inv = np.unique(L, return_inverse=True)
    for u_idx, Lu in enumerate(uniq):
        rows = np.flatnonzero(inv == u_idx)
        G = np.exp(-Lu * cgrid) @ bm.Bt  # (P, m n)
        Gmean = G.reshape(-1, bm.m, bm.n).mean(axis=-1)  # (P, m)
        f = -2.0 * Mv[rows] @ G.T + np.einsum("pk,pk->p", G, G)[None, :]
        if fixed_s is None:
            d = np.maximum(Mmean[rows][:, None, :] - Gmean[None, :, :], 0.0)
            f -= bm.n * np.einsum("ipc,ipc->ip", d, d)
        else:
            # ||M - G - s||^2 = ||M - G||^2 - 2 n s.(mean M - mean G) + n ||s||^2
            f += -2 * bm.n * ((Mmean[rows] @ fixed_s)[:, None] - (Gmean @ fixed_s)[None, :])
        best[rows] = np.argmin(f, axis=1)
    return C[best].copy(), A[best].copy()


def estimate_batch(rgb_stack, *, depth, distance, camera=DEFAULT_CAMERA, illuminant=None,
                   reflectances=None, wavelengths=None, basis=None, path_model: str = "beam",
                   cdom_slope: float = water.CDOM_SLOPE, fix=None, max_iter: int = 100,
                   tol: float = 1e-12, setup: ChartSetup | None = None,
                   workers: int | None = None) -> BatchEstimate:
    """Estimate C, a_CDOM(440), w and s for a stack of charts ``rgb_stack`` (N, m, n).

    ``depth`` and ``distance`` (m) are scalars or arrays of length N. Other arguments as in
    :func:`sca.estimate`; ``fix`` may hold ``{'backscatter': value}`` (scalar or (m,)).
    Charts are solved in chunks of ``CHUNK`` (cache-sized arrays) on ``workers`` threads
    (default: both cores). Returns a :class:`BatchEstimate` of arrays.
    """
    t0 = time.perf_counter()
    if setup is None:
        setup = chart_setup(camera, illuminant, reflectances, wavelengths)
    bm = BatchModel(setup, basis=basis, path_model=path_model, cdom_slope=cdom_slope)
    M = _validate.array("rgb_stack", rgb_stack, ndim=3)
    if M.shape[1:] != (bm.m, bm.n):
        raise ValueError(f"rgb_stack: expected shape (N, {bm.m}, {bm.n}), got {M.shape}")
    if np.any(M < 0):
        raise ValueError("rgb_stack: contains negative values")
    N = M.shape[0]
    scale = M.reshape(N, -1).max(axis=1)
    if np.any(scale <= 0):
        raise ValueError(f"rgb_stack: chart(s) {np.flatnonzero(scale <= 0)[:5].tolist()} are all zero")
    L = np.broadcast_to(length("depth", depth) + length("distance", distance), (N,)).astype(float)
    if int(max_iter) != max_iter or max_iter < 1:
        raise ValueError(f"max_iter: must be a positive integer, got {max_iter!r}")
    tol = _validate.scalar("tol", tol, positive=True)
    fixed_s = None
    if fix:
        if set(fix) - {"backscatter"}:
            raise ValueError("fix: the batched solver can fix only 'backscatter'")
        fixed_s = _validate.array("fix['backscatter']", np.broadcast_to(fix["backscatter"], (bm.m,)),
                                  nonnegative=True)

    workers = workers or min(2, os.cpu_count() or 1)
    starts = range(0, N, CHUNK)
    args = [(bm, M[i:i + CHUNK], L[i:i + CHUNK], scale[i:i + CHUNK], fixed_s, max_iter, tol)
            for i in starts]
    if workers > 1 and len(args) > 1:
        # chunks on threads (numpy releases the GIL); BLAS itself single-threaded meanwhile,
        # or its threads and ours oversubscribe the cores
        from threadpoolctl import threadpool_limits

        with threadpool_limits(limits=1, user_api="blas"), \
                ThreadPoolExecutor(max_workers=workers) as pool:
            parts = list(pool.map(lambda a: _solve_chunk(*a), args))
    else:
        parts = [_solve_chunk(*a) for a in args]
    chl, cdom, s_final, k_final, f_final, iters, code = (np.concatenate(x) for x in zip(*parts))
    converged = code <= 2
    w = (water.phytoplankton_absorption_440(chl) / float(bm.mdl.t440[0]))[:, None]
    return BatchEstimate(
        chl=chl, cdom=cdom, w=w, backscatter=s_final * scale[:, None], attenuation=k_final,
        wavelengths=bm.wl, objective=f_final * scale**2, iterations=iters, converged=converged,
        status=np.array([STATUS[c] for c in code]), status_code=code,
        elapsed_s=time.perf_counter() - t0,
    )


def _solve_chunk(bm: BatchModel, M, L, scale, fixed_s, max_iter, tol):
    """Levenberg-Marquardt on one chunk of charts; returns (C, a_CDOM, s, k, f, iterations,
    status codes) with s and f in the chunk's scaled units."""
    N = M.shape[0]
    Ms = M / scale[:, None, None]  # every chart scaled to max 1
    fs = None if fixed_s is None else fixed_s[None, :] / scale[:, None]
    chl, cdom = _initial(bm, M, L, fixed_s)
    e_cdom = bm.mdl.cdom_shape
    f_exact = EXACT_FIT * np.einsum("ijk,ijk->i", Ms, Ms)

    def evaluate(idx, C, A, derivative):
        Li = L[idx][:, None]
        sc = scale[idx][:, None]
        if not derivative:
            k = np.exp(-Li * (bm.weights(C, A) @ bm.S + bm.base))
            G = (k @ bm.Bt) / sc
            s, r = bm.reduced(Ms[idx], G, None if fs is None else fs[idx])
            return np.einsum("ijk,ijk->i", r, r), s, k
        phi, dphi = bm.weights(C, A, derivative=True)
        k = np.exp(-Li * (phi @ bm.S + bm.base))
        lk = -Li * k
        n_ = k.shape[0]
        # one matrix product for G, dG/du and dG/da_CDOM
        out = np.concatenate([k, lk * (dphi @ bm.S), lk * e_cdom]) @ bm.Bt
        out /= np.concatenate([sc, sc, sc])
        G, JC, JA = out[:n_], out[n_:2 * n_], out[2 * n_:]
        s, r = bm.reduced(Ms[idx], G, None if fs is None else fs[idx])
        f = np.einsum("ijk,ijk->i", r, r)
        JC = JC.reshape(-1, bm.m, bm.n)
        JA = JA.reshape(-1, bm.m, bm.n)
        if fs is None:  # project out the channel mean where s is free (s > 0)
            act = (s > 0)[..., None]
            JC = JC - act * JC.mean(axis=-1, keepdims=True)
            JA = JA - act * JA.mean(axis=-1, keepdims=True)
        # r = M - G - s: dr/dtheta = -(projected dG/dtheta)
        return f, s, k, -JC, -JA, r

    idx = np.arange(N)
    f = np.empty(N)
    iters = np.zeros(N, dtype=int)
    code = np.full(N, 3)
    # state of the active charts: objective, residual and Jacobian at the current point
    fa, _, _, JC, JA, r = evaluate(idx, chl, cdom, True)
    f[:] = fa
    mu = np.full(N, 1e-3)
    done = fa <= f_exact
    code[done] = 1
    keep = ~done
    active, fa, JC, JA, r = idx[keep], fa[keep], JC[keep], JA[keep], r[keep]
    for it in range(1, int(max_iter) + 1):
        if active.size == 0:
            break
        C, A = chl[active], cdom[active]
        U = C ** CHL_EXPONENT
        # gradient and Gauss-Newton matrix of 1/2 ||r||^2
        g1 = np.einsum("ijk,ijk->i", JC, r)
        g2 = np.einsum("ijk,ijk->i", JA, r)
        h11 = np.einsum("ijk,ijk->i", JC, JC)
        h22 = np.einsum("ijk,ijk->i", JA, JA)
        h12 = np.einsum("ijk,ijk->i", JC, JA)
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
        Cn = np.maximum(U + d1, 0.0) ** (1.0 / CHL_EXPONENT)
        An = np.maximum(A + d2, 0.0)
        # evaluate the trial point with its Jacobian: most LM steps are accepted, and an
        # accepted point's Jacobian is then already there for the next step
        fn, _, _, JCn, JAn, rn = evaluate(active, Cn, An, True)
        ok = fn < fa
        iters[active] = it
        acc = active[ok]
        chl[acc], cdom[acc], f[acc] = Cn[ok], An[ok], fn[ok]
        mu[acc] = np.maximum(mu[acc] / 3.0, 1e-12)
        mu[active[~ok]] *= 4.0
        decrease = np.where(ok, fa - fn, 0.0)
        stat = pred <= tol * fa
        conv_dec = ok & (decrease <= tol * fa) & (pred <= 10 * tol * fa)
        exact = np.where(ok, fn, fa) <= f_exact[active]
        fin = np.zeros(active.size, dtype=int) - 1
        fin[conv_dec] = 0
        fin[~ok & stat] = 2
        fin[exact] = 1
        fin[~ok & ~stat & (mu[active] > 1e12)] = 4
        stop = fin >= 0
        code[active[stop]] = fin[stop]
        # new state: accepted charts take the trial's residual and Jacobian
        fa[ok] = fn[ok]
        r[ok] = rn[ok]
        JC[ok] = JCn[ok]
        JA[ok] = JAn[ok]
        if stop.any():
            go = ~stop
            active, fa, r, JC, JA = active[go], fa[go], r[go], JC[go], JA[go]
    f_final, s_final, k_final = evaluate(np.arange(N), chl, cdom, False)
    return chl, cdom, s_final, k_final, f_final, iters, code
