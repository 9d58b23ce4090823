"""The per-chart evaluation of the batched solver: objective, gradient and Gauss-Newton matrix.

Given the weights Phi (N, 5) of the spectral terms S (5, q) of the attenuation coefficient
(c = base + Phi S, built from :mod:`forward.water` by :class:`sca.batch.BatchModel`) and their
derivatives dPhi/du, for every chart i:

    k = exp(-L_i c),  G = B k / scale_i,  s = max(0, channel means of M - G) (or fixed),
    r = M - G - s 1^T,  J = -(projected dG/d(u, a_CDOM)),
    f = ||r||^2,  g = J^T r,  H = J^T J  (3 entries: h11, h12, h22).

Two engines run the batched Levenberg-Marquardt iteration of :mod:`sca.batch`:

* 'numpy': array code over all active charts, with :func:`evaluate_numpy` below; the
  reference the tests compare against, and the fallback without numba;
* 'numba': :func:`lm_numba`, the same iteration compiled per chart (a parallel loop over
  charts on all cores, no large temporaries, no Python work per iteration). Its physics are
  the formula functions of :mod:`forward.water` (eqs 8, 10, 12) compiled by numba, not copies.
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
    from forward import water as _water

    _CHL_EXP = _water.EQ10_EXPONENT
    _eq10 = njit(cache=True)(_water.eq10)
    _eq10_d = njit(cache=True)(_water.eq10_derivative)
    _eq8 = njit(cache=True)(_water.eq8)
    _eq8_d = njit(cache=True)(_water.eq8_derivative)
    _eq12 = njit(cache=True)(_water.eq12_small)
    _eq12_d = njit(cache=True)(_water.eq12_small_derivative)
    _TINY = np.finfo(np.float64).tiny

    @njit(cache=True, fastmath=True, error_model="numpy")
    def _eval_one(u, A, i, L, scale, M, fs, has_fs, S, base, ecdom, Bt, m, n, c12, s12, beam,
                  grad, s_out, k, kc, ka, G, GC, GA):  # pragma: no cover - compiled
        """Objective, gradient and Gauss-Newton matrix of chart i at (u = C^0.627, a_CDOM)."""
        q = S.shape[1]
        mn = m * n
        # weights of the spectral terms at C (evaluated at the smallest normal float for C = 0,
        # where eq 10's value, ~1e-195, is zero to double precision and d/du stays finite)
        C = u ** (1.0 / _CHL_EXP) if u > 0.0 else 0.0
        cf = C if C > _TINY else _TINY
        small = _eq12(cf, c12, s12) if beam else 0.0
        p0, p1, p2, p3, p4 = _eq10(cf), A, _eq8(cf), small, (cf - small if beam else 0.0)
        q0 = q2 = q3 = q4 = 0.0
        if grad:
            dcdu = cf / (u * _CHL_EXP) if C > _TINY else cf ** (1.0 - _CHL_EXP) / _CHL_EXP
            dsm = _eq12_d(cf, c12, s12) if beam else 0.0
            q0 = _eq10_d(cf) * dcdu
            q2 = _eq8_d(cf) * dcdu
            q3 = dsm * dcdu
            q4 = (1.0 - dsm) * dcdu if beam else 0.0
        Li = L[i]
        for l in range(q):
            c = base[l] + p0 * S[0, l] + p1 * S[1, l] + p2 * S[2, l] + p3 * S[3, l] + p4 * S[4, l]
            kl = np.exp(-Li * c)
            k[l] = kl
            if grad:
                dc = q0 * S[0, l] + q2 * S[2, l] + q3 * S[3, l] + q4 * S[4, l]
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
    def lm_numba(C0, A0, L, scale, M, fs, has_fs, S, base, ecdom, Bt, m, n, c12, s12, beam,
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
            u = C0[i] ** _CHL_EXP
            A = A0[i]
            mu = mu0
            f, g1, g2, h11, h12, h22 = _eval_one(u, A, i, L, scale, M, fs, has_fs, S, base, ecdom,
                                                 Bt, m, n, c12, s12, beam, True, s_i, k, kc, ka,
                                                 G, GC, GA)
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
                                                          base, ecdom, Bt, m, n, c12, s12, beam,
                                                          True, s_i, k, kc, ka, G, GC, GA)
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
                                         n, c12, s12, beam, False, s_i, k, kc, ka, G, GC, GA)
            C_out[i] = u ** (1.0 / _CHL_EXP) if u > 0.0 else 0.0
            A_out[i] = A
            f_out[i] = f
            for ch in range(m):
                s_out[i, ch] = s_i[ch]
            for l in range(q):
                k_out[i, l] = k[l]
            it_out[i] = it
            code_out[i] = code
        return C_out, A_out, s_out, k_out, f_out, it_out, code_out
