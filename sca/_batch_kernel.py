"""The per-chart evaluation of the batched solver: objective, gradient and Gauss-Newton matrix.

Given the weights Phi (N, 5) of the spectral terms S (5, q) of the attenuation coefficient
(c = base + Phi S, built from :mod:`forward.water` by :class:`sca.batch.BatchModel`) and their
derivatives dPhi/du, for every chart i:

    k = exp(-L_i c),  G = B k / scale_i,  s = max(0, channel means of M - G) (or fixed),
    r = M - G - s 1^T,  J = -(projected dG/d(u, a_CDOM)),
    f = ||r||^2,  g = J^T r,  H = J^T J  (3 entries: h11, h12, h22).

Two engines compute exactly this: :func:`evaluate_numba` (one fused, parallel loop over charts:
no large temporaries, both cores) and :func:`evaluate_numpy` (array code; the reference the
tests compare against, and the fallback without numba). Physics stays in :mod:`forward.water`:
the kernels see only the weights and the spectral terms.
"""

from __future__ import annotations

import numpy as np

try:  # numba is a dependency; the numpy engine keeps the package usable without it
    from numba import njit, prange

    HAVE_NUMBA = True
except ImportError:  # pragma: no cover
    HAVE_NUMBA = False


def evaluate_numpy(phi, dphi, L, S, base, ecdom, Bt, M, scale, fs, has_fs, m, n, grad):
    N = phi.shape[0]
    k = np.exp(-L[:, None] * (phi @ S + base))
    G = (k @ Bt) / scale[:, None]
    R0 = M.reshape(N, m, n) - G.reshape(N, m, n)
    s = fs.copy() if has_fs else np.maximum(R0.mean(axis=-1), 0.0)
    r = R0 - s[..., None]
    f = np.einsum("ijk,ijk->i", r, r)
    g = np.zeros((N, 2))
    H = np.zeros((N, 3))
    if grad:
        lk = -L[:, None] * k
        JC = -(((lk * (dphi @ S)) @ Bt) / scale[:, None]).reshape(N, m, n)
        JA = -(((lk * ecdom) @ Bt) / scale[:, None]).reshape(N, m, n)
        if not has_fs:
            act = (s > 0)[..., None]
            JC = JC - act * JC.mean(axis=-1, keepdims=True)
            JA = JA - act * JA.mean(axis=-1, keepdims=True)
        g[:, 0] = np.einsum("ijk,ijk->i", JC, r)
        g[:, 1] = np.einsum("ijk,ijk->i", JA, r)
        H[:, 0] = np.einsum("ijk,ijk->i", JC, JC)
        H[:, 1] = np.einsum("ijk,ijk->i", JC, JA)
        H[:, 2] = np.einsum("ijk,ijk->i", JA, JA)
    return f, s, g, H


if HAVE_NUMBA:

    @njit(parallel=True, cache=True, fastmath=True)
    def _kernel(phi, dphi, L, S, base, ecdom, Bt, M, scale, fs, has_fs, m, n, grad):  # pragma: no cover - compiled
        N = phi.shape[0]
        q = S.shape[1]
        nt = S.shape[0]
        mn = m * n
        f = np.empty(N)
        s_out = np.empty((N, m))
        g = np.zeros((N, 2))
        H = np.zeros((N, 3))
        for i in prange(N):
            k = np.empty(q)
            kc = np.empty(q)
            ka = np.empty(q)
            Li = L[i]
            for l in range(q):
                c = base[l]
                dc = 0.0
                for a in range(nt):
                    c += phi[i, a] * S[a, l]
                    dc += dphi[i, a] * S[a, l]
                kl = np.exp(-Li * c)
                k[l] = kl
                kc[l] = -Li * kl * dc
                ka[l] = -Li * kl * ecdom[l]
            G = np.zeros(mn)
            GC = np.zeros(mn)
            GA = np.zeros(mn)
            inv = 1.0 / scale[i]
            if grad:  # three axpy's per wavelength (contiguous rows of B^T: vectorised)
                for l in range(q):
                    a0 = k[l] * inv
                    a1 = kc[l] * inv
                    a2 = ka[l] * inv
                    for j in range(mn):
                        b = Bt[l, j]
                        G[j] += b * a0
                        GC[j] += b * a1
                        GA[j] += b * a2
            else:
                for l in range(q):
                    a0 = k[l] * inv
                    for j in range(mn):
                        G[j] += Bt[l, j] * a0
            fi = 0.0
            g1 = 0.0
            g2 = 0.0
            h11 = 0.0
            h12 = 0.0
            h22 = 0.0
            for ch in range(m):
                mean_r = 0.0
                mean_c = 0.0
                mean_a = 0.0
                for p in range(n):
                    j = ch * n + p
                    mean_r += M[i, j] - G[j]
                    mean_c += GC[j]
                    mean_a += GA[j]
                mean_r /= n
                mean_c /= n
                mean_a /= n
                if has_fs:
                    sc = fs[i, ch]
                    active = False
                else:
                    sc = mean_r if mean_r > 0.0 else 0.0
                    active = mean_r > 0.0
                s_out[i, ch] = sc
                for p in range(n):
                    j = ch * n + p
                    r = M[i, j] - G[j] - sc
                    fi += r * r
                    if grad:
                        jc = -(GC[j] - mean_c) if active else -GC[j]
                        ja = -(GA[j] - mean_a) if active else -GA[j]
                        g1 += jc * r
                        g2 += ja * r
                        h11 += jc * jc
                        h12 += jc * ja
                        h22 += ja * ja
            f[i] = fi
            if grad:
                g[i, 0] = g1
                g[i, 1] = g2
                H[i, 0] = h11
                H[i, 1] = h12
                H[i, 2] = h22
        return f, s_out, g, H

    def evaluate_numba(phi, dphi, L, S, base, ecdom, Bt, M, scale, fs, has_fs, m, n, grad):
        return _kernel(np.ascontiguousarray(phi), np.ascontiguousarray(dphi), L, S, base, ecdom,
                       Bt, M, scale, fs, bool(has_fs), int(m), int(n), bool(grad))
else:  # pragma: no cover
    evaluate_numba = evaluate_numpy
