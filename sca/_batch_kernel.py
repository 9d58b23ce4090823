"""The per-chart evaluation of the batched solver: objective, gradient and Gauss-Newton matrix.

The attenuation coefficient comes from :class:`forward.WaterTerms` as numbers, not formulas:

    c = base + a_CDOM e_cdom + Phi(C) S,   Phi_j(C) = p_j C^e_j + g_j (1 - exp(-h_j C))

with S (4, q) the spectral shapes and ``tab`` (4, 4) the rows (p, e, g, h) of
:meth:`forward.Water.chl_terms`; the iteration variable is u = C^e0 (e0: eq 10's exponent).
For every chart i:

    k = exp(-L_i c),  G = B k / scale_i,  s = max(0, channel means of M - G) (or fixed),
    r = M - G - s 1^T,  J = -(projected dG/d(u, a_CDOM)),
    f = ||r||^2,  g = J^T r,  H = J^T J  (3 entries: h11, h12, h22).

Two engines run the batched Levenberg-Marquardt iteration of :mod:`sca.batch`:

* 'numpy': array code over all active charts, with :func:`evaluate_numpy` below (weights from
  :meth:`forward.Water.chl_weights`); the reference, and the fallback without numba;
* 'numba': :func:`lm_numba`, the same iteration compiled per chart (a parallel loop over
  charts on all cores, no large temporaries, no Python work per iteration). It contains no
  physics: every constant and spectrum arrives as an argument, so its on-disk cache (keyed on
  this file) cannot hold numbers that a change of ``forward.Water`` made stale.
"""

from __future__ import annotations

import numpy as np

try:  # numba is a dependency; the numpy engine keeps the package usable without it
    from numba import njit, prange

    HAVE_NUMBA = True
except ImportError:  # pragma: no cover
    HAVE_NUMBA = False


def evaluate_numpy(phi, dphi, A, L, S, base, ecdom, Bt, M, scale, fs, has_fs, m, n, grad):
    """f, s, g, H (see the module docstring) for charts with weights ``phi`` (N, 4), their
    derivatives d phi / du ``dphi`` and a_CDOM ``A`` (N,)."""
    N = phi.shape[0]
    k = np.exp(-L[:, None] * (phi @ S + np.multiply.outer(A, ecdom) + base))
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
    _TINY = np.finfo(np.float64).tiny

    @njit(cache=True, fastmath=True, error_model="numpy")
    def _eval_one(u, A, i, L, scale, M, fs, has_fs, S, base, ecdom, Bt, m, n, tab, e0,
                  grad, s_out, k, kc, ka, G, GC, GA, phi, dphi):  # pragma: no cover - compiled
        """Objective, gradient and Gauss-Newton matrix of chart i at (u = C^e0, a_CDOM)."""
        q = S.shape[1]
        nt = S.shape[0]
        mn = m * n
        # C's weights (evaluated at the smallest normal float for C = 0, where every power of
        # C is zero to double precision and d/du stays finite)
        C = u ** (1.0 / e0) if u > 0.0 else 0.0
        cf = C if C > _TINY else _TINY
        dcdu = cf / (u * e0) if C > _TINY else cf ** (1.0 - e0) / e0
        for j in range(nt):
            pw = cf ** tab[j, 1]
            ex = np.exp(-tab[j, 3] * cf)
            phi[j] = tab[j, 0] * pw - tab[j, 2] * np.expm1(-tab[j, 3] * cf)
            dphi[j] = (tab[j, 0] * tab[j, 1] * pw / cf + tab[j, 2] * tab[j, 3] * ex) * dcdu
        Li = L[i]
        for l in range(q):
            c = base[l] + A * ecdom[l]
            dc = 0.0
            for j in range(nt):
                c += phi[j] * S[j, l]
                dc += dphi[j] * S[j, l]
            kl = np.exp(-Li * c)
            k[l] = kl
            if grad:
                kc[l] = -Li * kl * dc
                ka[l] = -Li * kl * ecdom[l]
        inv = 1.0 / scale[i]
        for j in range(mn):
            G[j] = 0.0
            GC[j] = 0.0
            GA[j] = 0.0
        if grad:
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
        # Per channel: s from the mean residual, then f, g = J^T r and H = J^T J without
        # branches in the patch loops. Where s is free (active), J's columns are the centred
        # -dG; since the residual then sums to zero over the channel, g needs no centring, and
        # H's centring is a rank-one correction of the raw sums.
        f = 0.0
        g1 = 0.0
        g2 = 0.0
        h11 = 0.0
        h12 = 0.0
        h22 = 0.0
        for ch in range(m):
            o = ch * n
            sum_r0 = 0.0
            for p in range(n):
                sum_r0 += M[i, o + p] - G[o + p]
            if has_fs:
                sc = fs[i, ch]
                act = 0.0
            else:
                sc = sum_r0 / n if sum_r0 > 0.0 else 0.0
                act = 1.0 if sum_r0 > 0.0 else 0.0
            s_out[ch] = sc
            ff = 0.0
            for p in range(n):
                r = M[i, o + p] - G[o + p] - sc
                ff += r * r
            f += ff
            if grad:
                gc = 0.0
                ga = 0.0
                cc = 0.0
                ca = 0.0
                aa = 0.0
                sc_ = 0.0
                sa_ = 0.0
                for p in range(n):
                    r = M[i, o + p] - G[o + p] - sc
                    x = GC[o + p]
                    y = GA[o + p]
                    gc += x * r
                    ga += y * r
                    cc += x * x
                    ca += x * y
                    aa += y * y
                    sc_ += x
                    sa_ += y
                g1 -= gc
                g2 -= ga
                h11 += cc - act * sc_ * sc_ / n
                h12 += ca - act * sc_ * sa_ / n
                h22 += aa - act * sa_ * sa_ / n
        return f, g1, g2, h11, h12, h22

    @njit(parallel=True, cache=True, fastmath=True, error_model="numpy")
    def lm_numba(C0, A0, L, scale, M, fs, has_fs, S, base, ecdom, Bt, m, n, tab, e0,
                 max_iter, tol, f_exact, mu0, down, up):  # pragma: no cover - compiled
        """The Levenberg-Marquardt iteration of :func:`sca.batch._solve_chunk`, per chart."""
        N = C0.shape[0]
        q = S.shape[1]
        mn = m * n
        C_out = np.empty(N)
        A_out = np.empty(N)
        f_out = np.empty(N)
        s_out = np.empty((N, m))
        k_out = np.empty((N, q))
        it_out = np.zeros(N, dtype=np.int64)
        code_out = np.full(N, 3, dtype=np.int64)
        for i in prange(N):
            k = np.empty(q)
            kc = np.empty(q)
            ka = np.empty(q)
            G = np.empty(mn)
            GC = np.empty(mn)
            GA = np.empty(mn)
            s_i = np.empty(m)
            phi = np.empty(S.shape[0])
            dphi = np.empty(S.shape[0])
            u = C0[i] ** e0
            A = A0[i]
            mu = mu0
            f, g1, g2, h11, h12, h22 = _eval_one(u, A, i, L, scale, M, fs, has_fs, S, base, ecdom,
                                                 Bt, m, n, tab, e0, True, s_i, k, kc, ka,
                                                 G, GC, GA, phi, dphi)
            code = 3
            it = 0
            if f <= f_exact[i]:
                code = 1
            else:
                for it in range(1, max_iter + 1):
                    free1 = (not (u <= 0.0 and g1 > 0.0)) and h11 > 0.0
                    free2 = (not (A <= 0.0 and g2 > 0.0)) and h22 > 0.0
                    a11 = h11 * (1.0 + mu) if free1 else 1.0
                    a22 = h22 * (1.0 + mu) if free2 else 1.0
                    a12 = h12 if (free1 and free2) else 0.0
                    b1 = -g1 if free1 else 0.0
                    b2 = -g2 if free2 else 0.0
                    det = a11 * a22 - a12 * a12
                    if det > 1e-14 * a11 * a22:
                        d1 = (b1 * a22 - a12 * b2) / det
                        d2 = (a11 * b2 - a12 * b1) / det
                    else:
                        d1 = b1 / a11
                        d2 = b2 / a22
                    pred = -2.0 * (g1 * d1 + g2 * d2) - (h11 * d1 * d1 + 2.0 * h12 * d1 * d2
                                                         + h22 * d2 * d2)
                    if pred <= tol * f:
                        code = 2
                        break
                    un = u + d1 if u + d1 > 0.0 else 0.0
                    an = A + d2 if A + d2 > 0.0 else 0.0
                    fn, n1, n2, n11, n12, n22 = _eval_one(un, an, i, L, scale, M, fs, has_fs, S,
                                                          base, ecdom, Bt, m, n, tab, e0,
                                                          True, s_i, k, kc, ka, G, GC, GA, phi, dphi)
                    if fn < f:
                        dec = f - fn
                        f_prev = f
                        u, A, f = un, an, fn
                        g1, g2, h11, h12, h22 = n1, n2, n11, n12, n22
                        mu = mu / down if mu / down > 1e-12 else 1e-12
                        if f <= f_exact[i]:
                            code = 1
                            break
                        if dec <= tol * f_prev:
                            code = 0
                            break
                    else:
                        mu *= up
                        if mu > 1e12:
                            code = 4
                            break
            # final values at the returned point
            f, _, _, _, _, _ = _eval_one(u, A, i, L, scale, M, fs, has_fs, S, base, ecdom, Bt, m,
                                         n, tab, e0, False, s_i, k, kc, ka, G, GC, GA, phi, dphi)
            C_out[i] = u ** (1.0 / e0) if u > 0.0 else 0.0
            A_out[i] = A
            f_out[i] = f
            for ch in range(m):
                s_out[i, ch] = s_i[ch]
            for l in range(q):
                k_out[i, l] = k[l]
            it_out[i] = it
            code_out[i] = code
        return C_out, A_out, s_out, k_out, f_out, it_out, code_out
