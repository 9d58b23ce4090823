"""Per-chart numerics of the batched solver and of the profile-likelihood intervals.

The attenuation coefficient comes from :class:`forward.WaterTerms` as numbers, not formulas:

    c = base + a_CDOM e_cdom + Phi(C) S,   Phi_j(C) = p_j C^e_j + g_j (1 - exp(-h_j C))

with S (4, q) the spectral shapes and ``tab`` (4, 4) the rows (p, e, g, h) of
:meth:`forward.Water.chl_terms`; the iteration variable is u = C^e0 (e0: eq 10's exponent).
For every chart i, with weights w2 = 1 / sigma^2 (ones where the noise is unknown):

    k = exp(-L_i c),  G = B k / scale_i,  s = max(0, w2-weighted channel means of M - G)
    (or fixed),  r = sqrt(w2) (M - G - s 1^T),  J = dr/d(u, a_CDOM) (s profiled out),
    f = ||r||^2,  g = J^T r,  H = J^T J  (3 entries: h11, h12, h22).

With a free gain (``free_g``: a photograph's unknown exposure) the model is M = gain G + s 1^T:
gain >= 0 and s >= 0 are both linear, so both are profiled out in closed form (a least-squares
problem in m + 1 unknowns, solved by an active set over the channels' s, :func:`linear_part`),
and J's columns are gain dG/d(u, a_CDOM) projected off span{active channel indicators, G}
(Kaufman's variable-projection Jacobian; the gradient J^T r is exact because r is orthogonal
to that span).

A problem is passed as one tuple ``prob = (L, scale, M, W2, fs, has_fs, S, base, ecdom, Bt, m,
n, tab, e0, free_g)`` and work arrays as ``buf = (s, k, kc, ka, G, GC, GA, phi, dphi, gain)``
(see :func:`make_buffers`; ``gain[0]`` is the chart's gain, 1 where it is known). Everything here is plain scalar code: numba compiles it (parallel over
charts) when it is installed, and it runs as ordinary Python otherwise. It contains no physics:
every constant and spectrum arrives as an argument, so numba's on-disk cache (keyed on this
file) cannot hold numbers that a change of ``forward.Water`` made stale.

:func:`evaluate_numpy` is the array-code evaluation of the 'numpy' engine (the reference).
"""

from __future__ import annotations

import math

import numpy as np

try:  # numba is a dependency; without it the same functions run as plain Python
    import os

    import numba
    from numba import njit, prange

    # 'workqueue' is fork-safe (GNU OpenMP is not: numba ends a forked child that uses it, as in
    # a multiprocessing pool started after a batch fit); it is not safe for concurrent launches
    # from several threads, which sca.batch serialises with a lock. A user's
    # NUMBA_THREADING_LAYER still wins.
    if "NUMBA_THREADING_LAYER" not in os.environ:
        numba.config.THREADING_LAYER = "workqueue"
    HAVE_NUMBA = True
except ImportError:  # pragma: no cover
    HAVE_NUMBA = False
    prange = range

    def njit(*args, **kwargs):
        if len(args) == 1 and callable(args[0]) and not kwargs:
            return args[0]
        return lambda f: f

_TINY = np.finfo(np.float64).tiny
#: Result codes of a profile bound: found, at zero (lower end 0), beyond the cap (open), failed.
BOUND_FOUND, BOUND_ZERO, BOUND_OPEN, BOUND_FAILED = 0, 1, 2, 3


def linear_part_numpy(M3, G3, w2, fs=None):
    """Array form of :func:`linear_part`: gain (N,) >= 0 and s (N, m) >= 0 minimising
    sum w2 (M - gain G - s 1^T)^2 for charts M3, G3 (N, m, n) with weights w2 (N or 1, m, n);
    ``fs`` (N, m) fixes s. Returns (gain, s, act), act (N, m) True where s is free and > 0."""
    N, m, _ = G3.shape
    w2 = np.broadcast_to(w2, G3.shape)
    sw, sM, sG = w2.sum(-1), (w2 * M3).sum(-1), (w2 * G3).sum(-1)
    sGG, sGM = (w2 * G3 * G3).sum(-1), (w2 * G3 * M3).sum(-1)
    act = np.full((N, m), fs is None)
    s0 = np.zeros((N, m)) if fs is None else np.broadcast_to(fs, (N, m))
    gain = np.zeros(N)
    for _ in range(m + 1):
        num = np.where(act, sGM - sG * sM / sw, sGM - s0 * sG).sum(-1)
        den = np.where(act, sGG - sG * sG / sw, sGG).sum(-1)
        ok = (den > 0) & (num > 0)
        gain = np.where(ok, num / np.where(ok, den, 1.0), 0.0)
        s = np.where(act, (sM - gain[:, None] * sG) / sw, s0)
        neg = act & (s <= 0)
        if not neg.any():
            break
        act = act & ~neg
    return gain, np.where(act, s, s0), act


def evaluate_numpy(phi, dphi, A, L, S, base, ecdom, Bt, M, W2, scale, fs, has_fs, m, n, grad,
                   free_g=False):
    """f, s, g, H, gain (see the module docstring) for charts with weights ``phi`` (N, 4), their
    derivatives d phi / du ``dphi``, a_CDOM ``A`` (N,) and noise weights ``W2`` (N, m n)."""
    N = phi.shape[0]
    k = np.exp(-L[:, None] * (phi @ S + np.multiply.outer(A, ecdom) + base))
    G = (k @ Bt) / scale[:, None]
    w2 = W2.reshape(N, m, n)
    G3 = G.reshape(N, m, n)
    M3 = M.reshape(N, m, n)
    if free_g:
        gain, s, act = linear_part_numpy(M3, G3, w2, fs if has_fs else None)
    else:
        gain = np.ones(N)
        R0 = M3 - G3
        s = fs.copy() if has_fs else np.maximum((w2 * R0).sum(-1) / w2.sum(-1), 0.0)
        act = np.broadcast_to(s > 0, (N, m)) if not has_fs else np.zeros((N, m), bool)
    r = M3 - gain[:, None, None] * G3 - s[..., None]
    f = np.einsum("ijk,ijk->i", w2 * r, r)
    g = np.zeros((N, 2))
    H = np.zeros((N, 3))
    if grad:
        lk = -L[:, None] * k
        JC = -(((lk * (dphi @ S)) @ Bt) / scale[:, None]).reshape(N, m, n) * gain[:, None, None]
        JA = -(((lk * ecdom) @ Bt) / scale[:, None]).reshape(N, m, n) * gain[:, None, None]
        a = act[..., None]

        def centred(X):
            return X - a * (w2 * X).sum(-1, keepdims=True) / w2.sum(-1, keepdims=True)

        JC, JA = centred(JC), centred(JA)
        if free_g:  # project off the centred G (the gain's column)
            Gc = centred(G3)
            gg = np.einsum("ijk,ijk->i", w2 * Gc, Gc)
            live = ((gain > 0) & (gg > 0))[:, None, None]
            gg = np.where(gg > 0, gg, 1.0)[:, None, None]
            JC = JC - live * Gc * np.einsum("ijk,ijk->i", w2 * Gc, JC)[:, None, None] / gg
            JA = JA - live * Gc * np.einsum("ijk,ijk->i", w2 * Gc, JA)[:, None, None] / gg
        g[:, 0] = np.einsum("ijk,ijk->i", w2 * JC, r)
        g[:, 1] = np.einsum("ijk,ijk->i", w2 * JA, r)
        H[:, 0] = np.einsum("ijk,ijk->i", w2 * JC, JC)
        H[:, 1] = np.einsum("ijk,ijk->i", w2 * JC, JA)
        H[:, 2] = np.einsum("ijk,ijk->i", w2 * JA, JA)
    return f, s, g, H, gain


def gain_variance(phi, dphi, A, L, S, base, ecdom, Bt, M, W2, scale, fs, has_fs, m, n, gain, s):
    """Gauss-Newton variance of the gain (in units where the noise variance is 1) at charts'
    optima: the (u, a_CDOM, gain) block of (J^T W J)^-1 with the free s projected out, from the
    same derivatives as :func:`evaluate_numpy`. inf where the information is singular."""
    N = phi.shape[0]
    k = np.exp(-L[:, None] * (phi @ S + np.multiply.outer(A, ecdom) + base))
    lk = -L[:, None] * k
    w2 = W2.reshape(N, m, n)
    act = (s > 0)[..., None] if not has_fs else np.zeros((N, m, 1), bool)
    cols = [((k @ Bt) / scale[:, None]).reshape(N, m, n),
            (((lk * (dphi @ S)) @ Bt) / scale[:, None]).reshape(N, m, n) * gain[:, None, None],
            (((lk * ecdom) @ Bt) / scale[:, None]).reshape(N, m, n) * gain[:, None, None]]
    cols = [X - act * (w2 * X).sum(-1, keepdims=True) / w2.sum(-1, keepdims=True) for X in cols]
    F = np.empty((N, 3, 3))
    for a in range(3):
        for b in range(3):
            F[:, a, b] = np.einsum("ijk,ijk->i", w2 * cols[a], cols[b])
    out = np.full(N, np.inf)
    for i in range(N):
        try:
            inv = np.linalg.inv(F[i])
        except np.linalg.LinAlgError:
            continue
        if np.isfinite(inv[0, 0]) and inv[0, 0] > 0:
            out[i] = inv[0, 0]
    return out


@njit(cache=True)
def make_buffers(q, m, n):
    """Work arrays of one chart: (s, k, kc, ka, G, GC, GA, phi, dphi, gain)."""
    mn = m * n
    return (np.empty(m), np.empty(q), np.empty(q), np.empty(q), np.empty(mn), np.empty(mn),
            np.empty(mn), np.empty(4), np.empty(4), np.ones(1))


@njit(cache=True, fastmath=True, error_model="numpy")
def eval_chart(u, A, i, prob, buf, grad):  # pragma: no cover - compiled
    """Objective, gradient and Gauss-Newton matrix of chart i at (u = C^e0, a_CDOM)."""
    L, scale, M, W2, fs, has_fs, S, base, ecdom, Bt, m, n, tab, e0, free_g = prob
    s_out, k, kc, ka, G, GC, GA, phi, dphi, gbuf = buf
    q = S.shape[1]
    nt = S.shape[0]
    mn = m * n
    # C's weights (at the smallest normal float for C = 0, where every power of C is zero to
    # double precision and d/du stays finite)
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
    if free_g:
        return _free_gain_terms(i, M, W2, fs, has_fs, m, n, G, GC, GA, s_out, gbuf, grad)
    gbuf[0] = 1.0
    # Per channel: s from the weighted mean residual, then f, g = J^T r and H = J^T J. Where s
    # is free (active), J's columns are -dG minus their weighted mean; the weighted residual
    # then sums to zero over the channel, so g needs no centring, and H's centring is a
    # rank-one correction of the raw sums.
    f = 0.0
    g1 = 0.0
    g2 = 0.0
    h11 = 0.0
    h12 = 0.0
    h22 = 0.0
    for ch in range(m):
        o = ch * n
        sw = 0.0
        sr = 0.0
        for p in range(n):
            w = W2[i, o + p]
            sw += w
            sr += w * (M[i, o + p] - G[o + p])
        if has_fs:
            sc = fs[i, ch]
            act = 0.0
        else:
            sc = sr / sw if sr > 0.0 else 0.0
            act = 1.0 if sr > 0.0 else 0.0
        s_out[ch] = sc
        if not grad:
            for p in range(n):
                r = M[i, o + p] - G[o + p] - sc
                f += W2[i, o + p] * r * r
        else:
            gc = 0.0
            ga = 0.0
            cc = 0.0
            ca = 0.0
            aa = 0.0
            sc_ = 0.0
            sa_ = 0.0
            for p in range(n):
                w = W2[i, o + p]
                r = M[i, o + p] - G[o + p] - sc
                x = GC[o + p]
                y = GA[o + p]
                f += w * r * r
                gc += w * x * r
                ga += w * y * r
                cc += w * x * x
                ca += w * x * y
                aa += w * y * y
                sc_ += w * x
                sa_ += w * y
            g1 -= gc
            g2 -= ga
            h11 += cc - act * sc_ * sc_ / sw
            h12 += ca - act * sc_ * sa_ / sw
            h22 += aa - act * sa_ * sa_ / sw
    return f, g1, g2, h11, h12, h22


@njit(cache=True, fastmath=True, error_model="numpy")
def linear_part(sw, sM, sG, sGG, sGM, fs_i, has_fs, act, s_out):  # pragma: no cover
    """gain >= 0 and s >= 0 minimising sum_ch sum_p w (M - gain G - s_ch)^2, from the channel
    sums (sw = sum w, sM = sum w M, sG, sGG = sum w G^2, sGM): an active set over the channels'
    s (a channel whose s would be negative is held at 0 and the gain refitted; at most m + 1
    passes). With ``has_fs`` s is the fixed ``fs_i``. Fills ``s_out`` and ``act`` (1 where s is
    free and positive); returns the gain."""
    m = sw.shape[0]
    for ch in range(m):
        act[ch] = 0.0 if has_fs else 1.0
    gain = 0.0
    for _ in range(m + 1):
        num = 0.0
        den = 0.0
        for ch in range(m):
            if act[ch] > 0.0:
                num += sGM[ch] - sG[ch] * sM[ch] / sw[ch]
                den += sGG[ch] - sG[ch] * sG[ch] / sw[ch]
            else:
                sc = fs_i[ch] if has_fs else 0.0
                num += sGM[ch] - sc * sG[ch]
                den += sGG[ch]
        gain = num / den if (den > 0.0 and num > 0.0) else 0.0
        again = False
        for ch in range(m):
            if act[ch] > 0.0:
                sc = (sM[ch] - gain * sG[ch]) / sw[ch]
                if sc <= 0.0:
                    act[ch] = 0.0
                    sc = 0.0
                    again = True
                s_out[ch] = sc
            else:
                s_out[ch] = fs_i[ch] if has_fs else 0.0
        if not again:
            break
    return gain


@njit(cache=True, fastmath=True, error_model="numpy")
def _free_gain_terms(i, M, W2, fs, has_fs, m, n, G, GC, GA, s_out, gbuf, grad):  # pragma: no cover
    """f, g, H of :func:`eval_chart` for the model M = gain G + s 1^T with gain and s profiled
    out (see the module docstring); G, GC, GA are those of unit gain."""
    sw = np.zeros(m)
    sM = np.zeros(m)
    sG = np.zeros(m)
    sGG = np.zeros(m)
    sGM = np.zeros(m)
    act = np.zeros(m)
    for ch in range(m):
        o = ch * n
        for p in range(n):
            w = W2[i, o + p]
            x = G[o + p]
            y = M[i, o + p]
            sw[ch] += w
            sM[ch] += w * y
            sG[ch] += w * x
            sGG[ch] += w * x * x
            sGM[ch] += w * x * y
    gain = linear_part(sw, sM, sG, sGG, sGM, fs[i], has_fs, act, s_out)
    gbuf[0] = gain
    f = 0.0
    g1 = 0.0
    g2 = 0.0
    xx = 0.0
    xy = 0.0
    yy = 0.0
    gx = 0.0
    gy = 0.0
    gg = 0.0
    for ch in range(m):
        o = ch * n
        sc = s_out[ch]
        rx = 0.0
        ry = 0.0
        cxx = 0.0
        cxy = 0.0
        cyy = 0.0
        sx = 0.0
        sy = 0.0
        cgx = 0.0
        cgy = 0.0
        for p in range(n):
            w = W2[i, o + p]
            r = M[i, o + p] - gain * G[o + p] - sc
            f += w * r * r
            if grad:
                x = gain * GC[o + p]
                y = gain * GA[o + p]
                rx += w * x * r
                ry += w * y * r
                cxx += w * x * x
                cxy += w * x * y
                cyy += w * y * y
                sx += w * x
                sy += w * y
                cgx += w * G[o + p] * x
                cgy += w * G[o + p] * y
        if grad:
            a = act[ch] / sw[ch]
            g1 -= rx
            g2 -= ry
            xx += cxx - a * sx * sx
            xy += cxy - a * sx * sy
            yy += cyy - a * sy * sy
            gx += cgx - a * sG[ch] * sx
            gy += cgy - a * sG[ch] * sy
            gg += sGG[ch] - a * sG[ch] * sG[ch]
    if grad and gain > 0.0 and gg > 0.0:  # project the columns off the (centred) G
        xx -= gx * gx / gg
        xy -= gx * gy / gg
        yy -= gy * gy / gg
    return f, g1, g2, xx, xy, yy


@njit(cache=True, fastmath=True, error_model="numpy")
def lm_chart(u, A, i, prob, buf, max_iter, tol, f_exact, mu0, down, up):  # pragma: no cover
    """Levenberg-Marquardt of chart i from (u, A): returns (u, A, f, iterations, code); the
    codes are those of :data:`sca.batch.STATUS`."""
    mu = mu0
    f, g1, g2, h11, h12, h22 = eval_chart(u, A, i, prob, buf, True)
    code = 3
    it = 0
    if f <= f_exact:
        return u, A, f, 0, 1
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
        pred = -2.0 * (g1 * d1 + g2 * d2) - (h11 * d1 * d1 + 2.0 * h12 * d1 * d2 + h22 * d2 * d2)
        if pred <= tol * f:
            code = 2
            break
        un = u + d1 if u + d1 > 0.0 else 0.0
        an = A + d2 if A + d2 > 0.0 else 0.0
        fn, n1, n2, n11, n12, n22 = eval_chart(un, an, i, prob, buf, True)
        if fn < f:
            dec = f - fn
            f_prev = f
            u, A, f = un, an, fn
            g1, g2, h11, h12, h22 = n1, n2, n11, n12, n22
            mu = mu / down if mu / down > 1e-12 else 1e-12
            if f <= f_exact:
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
    return u, A, f, it, code


@njit(parallel=True, cache=True, fastmath=True, error_model="numpy")
def lm_numba(C0, A0, prob, max_iter, tol, f_exact, mu0, down, up):  # pragma: no cover
    """:func:`lm_chart` over all charts (in parallel): (C, A, s, k, f, iterations, codes, ssr,
    gain), ssr the unweighted ||M - gain G - s||^2 at the returned point (for fit_rms)."""
    L, scale, M, W2, fs, has_fs, S, base, ecdom, Bt, m, n, tab, e0, free_g = prob
    N = C0.shape[0]
    q = S.shape[1]
    C_out = np.empty(N)
    A_out = np.empty(N)
    f_out = np.empty(N)
    s_out = np.empty((N, m))
    k_out = np.empty((N, q))
    it_out = np.zeros(N, dtype=np.int64)
    code_out = np.full(N, 3, dtype=np.int64)
    ssr_out = np.empty(N)
    gain_out = np.empty(N)
    for i in prange(N):
        buf = make_buffers(q, m, n)
        u, A, f, it, code = lm_chart(C0[i] ** e0, A0[i], i, prob, buf, max_iter, tol,
                                     f_exact[i], mu0, down, up)
        # final values at the returned point
        f, _, _, _, _, _ = eval_chart(u, A, i, prob, buf, False)
        C_out[i] = u ** (1.0 / e0) if u > 0.0 else 0.0
        A_out[i] = A
        f_out[i] = f
        for ch in range(m):
            s_out[i, ch] = buf[0][ch]
        for l in range(q):
            k_out[i, l] = buf[1][l]
        ssr = 0.0  # the final evaluation's G, s and gain are still in the buffers
        gain = buf[9][0]
        for ch in range(m):
            for p in range(n):
                r = M[i, ch * n + p] - gain * buf[4][ch * n + p] - buf[0][ch]
                ssr += r * r
        ssr_out[i] = ssr
        gain_out[i] = gain
        it_out[i] = it
        code_out[i] = code
    return C_out, A_out, s_out, k_out, f_out, it_out, code_out, ssr_out, gain_out


# --------------------------------------------------------------------------- profile likelihood
@njit(cache=True, error_model="numpy")
def profile_point(theta, psi, which, free_other, i, prob, buf, atol):  # pragma: no cover
    """min over psi >= 0 of f with theta fixed (``which`` 0: theta = u, psi = a_CDOM; 1: theta =
    a_CDOM, psi = u), by projected Gauss-Newton steps from ``psi``; returns (f, psi). Stops
    when the predicted decrease is below ``atol`` (absolute, in f's units)."""
    u = theta if which == 0 else psi
    A = psi if which == 0 else theta
    f, g1, g2, h11, h12, h22 = eval_chart(u, A, i, prob, buf, True)
    if not free_other:
        return f, psi
    for _ in range(20):
        g = g2 if which == 0 else g1
        h = h22 if which == 0 else h11
        if not h > 0.0 or (psi <= 0.0 and g > 0.0) or g * g / h <= atol:
            break
        step = -g / h
        t = 1.0
        moved = False
        for _ in range(12):
            pn = psi + t * step
            if pn < 0.0:
                pn = 0.0
            u2 = theta if which == 0 else pn
            A2 = pn if which == 0 else theta
            fn, n1, n2, n11, n12, n22 = eval_chart(u2, A2, i, prob, buf, True)
            if fn < f:
                psi, f = pn, fn
                g1, g2, h11, h12, h22 = n1, n2, n11, n12, n22
                moved = True
                break
            t *= 0.5
        if not moved:
            break
    return f, psi


@njit(cache=True, error_model="numpy")
def profile_bound(theta_hat, psi_hat, f_hat, delta, heff, side, which, free_other, theta_max,
                  i, prob, buf):  # pragma: no cover
    """One end of the profile-likelihood interval of theta: where min_psi f = f_hat + delta.

    Searches from the optimum along ``side`` (+1 up, -1 down) on z(theta) = sqrt(P(theta) -
    f_hat), which is linear in theta for a linear model: a first step from the Gauss-Newton
    curvature ``heff``, secant extrapolation until the target is bracketed, then the Illinois
    method. Returns (theta, code): :data:`BOUND_FOUND`, :data:`BOUND_ZERO` (the profile stays
    below the target down to theta = 0: the lower end is 0), :data:`BOUND_OPEN` (it stays below
    up to ``theta_max``: the upper end is open) or :data:`BOUND_FAILED`.
    """
    if not delta > 0.0:  # an exact fit with the noise estimated from it: a zero-width interval
        return theta_hat, BOUND_FOUND
    zt = math.sqrt(delta)
    atol = 1e-4 * delta
    if side < 0.0 and theta_hat <= 0.0:
        return 0.0, BOUND_ZERO
    step = math.sqrt(delta / heff) if heff > 0.0 else 0.0
    if not (step > 0.0 and step < 1e300):
        step = max(abs(theta_hat), 1e-3)
    t_lo, z_lo, psi = theta_hat, 0.0, psi_hat
    t1 = theta_hat + side * step
    t_hi, z_hi = t1, 0.0
    found = False
    for _ in range(80):
        if side < 0.0 and t1 < 0.0:
            t1 = 0.0
        if side > 0.0 and t1 > theta_max:
            t1 = theta_max
        f1, psi1 = profile_point(t1, psi, which, free_other, i, prob, buf, atol)
        if not (f1 < 1e300):  # NaN or overflow
            return math.nan, BOUND_FAILED
        z1 = math.sqrt(max(f1 - f_hat, 0.0))
        if z1 >= zt:
            t_hi, z_hi = t1, z1
            found = True
            break
        if side < 0.0 and t1 <= 0.0:
            return 0.0, BOUND_ZERO
        if side > 0.0 and t1 >= theta_max:
            return theta_max, BOUND_OPEN
        span = t1 - t_lo
        dz = z1 - z_lo
        tn = t1 + 3.0 * span
        if dz > 0.0:
            tn = t1 + (zt - z1) * span / dz * 1.05  # a little beyond, to bracket
            if abs(tn - t1) > 4.0 * abs(span):
                tn = t1 + 4.0 * span
        t_lo, z_lo, psi = t1, z1, psi1
        t1 = tn
    if not found:
        return math.nan, BOUND_FAILED
    a, fa = t_lo, z_lo - zt
    b, fb = t_hi, z_hi - zt
    for _ in range(60):
        if abs(fb) <= 1e-3 * zt:
            return b, BOUND_FOUND
        if abs(b - a) <= 1e-12 * max(abs(a), abs(b)):
            return b, BOUND_FOUND
        c = b - fb * (b - a) / (fb - fa)
        fc_, psi = profile_point(c, psi, which, free_other, i, prob, buf, atol)
        if not (fc_ < 1e300):
            return math.nan, BOUND_FAILED
        fc = math.sqrt(max(fc_ - f_hat, 0.0)) - zt
        if fc * fb < 0.0:
            a, fa = b, fb
        else:
            fa *= 0.5  # Illinois: halve the retained end's value
        b, fb = c, fc
    return b, BOUND_FOUND


@njit(cache=True, error_model="numpy")
def interval_chart(i, U, A, delta, prob, free_u, free_a, u_max, a_max, ends, codes):  # pragma: no cover
    """The four profile ends of chart i (see :func:`intervals_numba`) into ``ends[i]``,
    ``codes[i]``."""
    m, n = prob[10], prob[11]
    q = prob[6].shape[1]
    buf = make_buffers(q, m, n)
    f, g1, g2, h11, h12, h22 = eval_chart(U[i], A[i], i, prob, buf, True)
    for which in range(2):
        free = free_u if which == 0 else free_a
        other = free_a if which == 0 else free_u
        th = U[i] if which == 0 else A[i]
        ps = A[i] if which == 0 else U[i]
        htt = h11 if which == 0 else h22
        hpp = h22 if which == 0 else h11
        heff = htt - (h12 * h12 / hpp if (other and hpp > 0.0) else 0.0)
        cap = u_max if which == 0 else a_max
        for k in range(2):
            side = -1.0 if k == 0 else 1.0
            col = 2 * which + k
            if not free:
                ends[i, col] = th
                codes[i, col] = BOUND_FOUND
                continue
            b, c = profile_bound(th, ps, f, delta[i], heff, side, which, other, cap, i, prob, buf)
            ends[i, col] = b
            codes[i, col] = c


@njit(parallel=True, cache=True, error_model="numpy")
def intervals_numba(U, A, delta, prob, free_u, free_a, u_max, a_max):  # pragma: no cover
    """Profile-likelihood intervals of every chart at its optimum (U = C^e0, A), in parallel:
    the ends where the profile objective has risen by ``delta`` -- (N, 4) ends (u_lo, u_hi,
    a_lo, a_hi) -- and (N, 4) codes (BOUND_*)."""
    N = U.shape[0]
    ends = np.empty((N, 4))
    codes = np.zeros((N, 4), dtype=np.int64)
    for i in prange(N):
        interval_chart(i, U, A, delta, prob, free_u, free_a, u_max, a_max, ends, codes)
    return ends, codes


@njit(cache=True, error_model="numpy")
def intervals_serial(U, A, delta, prob, free_u, free_a, u_max, a_max):  # pragma: no cover
    """:func:`intervals_numba` in one thread (single charts: no parallel runtime, so it is safe
    in threads and in processes forked from a parent that ran the parallel kernels)."""
    N = U.shape[0]
    ends = np.empty((N, 4))
    codes = np.zeros((N, 4), dtype=np.int64)
    for i in range(N):
        interval_chart(i, U, A, delta, prob, free_u, free_a, u_max, a_max, ends, codes)
    return ends, codes
