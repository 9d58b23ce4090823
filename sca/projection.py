"""Variable projection of the linear unknowns, compiled: the gain and the backscatter of
M = gain G + s 1^T in closed form, and the Kaufman Jacobian, objective, gradient and
Gauss-Newton matrix of the nonlinear parameters.

It contains no physics: it receives the model function's columns (the unit-gain signal G and
its derivatives dG/dtheta, from :meth:`sca.model.ChartModel.predict`), the measurements and
their weights, so numba's on-disk cache (keyed on this file) holds no numbers. For each chart,
with weights w = 1 / sigma^2 per value:

* per channel c the weighted sums sw = sum w, sM = sum w M, sG, sGG = sum w G^2, sGM;
* gain >= 0 (or 1 where it is known) and s >= 0 minimise sum w (M - gain G - s 1^T)^2 by an
  active set over the channels' s (a channel whose s would be negative is held at 0 and the
  gain refitted; at most m + 1 passes);
* r = M - gain G - s, f = sum w r^2;
* the columns x_p = gain dG/dtheta_p, minus their weighted channel mean where s is active, and
  (free gain) projected off the centred G: g_p = -sum w x_p r, H_pq = sum w x_p x_q.

References
----------
L. Kaufman, "A variable projection method for solving separable nonlinear least squares
problems", BIT 15 (1975) 49-57.
"""

from __future__ import annotations

import numpy as np

from .compiled import KERNEL_LOCK, njit, prange, twins

__all__ = ["LINEAR_SERIAL_BELOW", "SERIAL_BELOW", "grid_best", "linear_part_stats", "project"]


#: Rows of the work matrix of :func:`_active_set` and :func:`_project_one`: per channel the
#: weighted sums sw, sM, sG, sGG, sGM, the active flags, sum w r and sum w G r; then per column
#: a of theta sum w dG_a, sum w dG_a G, sum w dG_a r (the unit-gain, unscaled rows; the factor
#: gain CS_a is applied after the sums), and one row of the columns' projection factors.
SW, SM, SG, SGG, SGM, ACT, SWR, SGR, SX = 0, 1, 2, 3, 4, 5, 6, 7, 8


@njit(cache=True)
def _active_set(wk, m, fs, frow, has_fs, free_gain, s, i):  # pragma: no cover
    """gain and s (into ``s[i]``; row ACT of ``wk`` 1 where s is free and positive) of one
    chart from its channel sums (rows SW..SGM of ``wk``; ``fs[frow]`` where s is held); returns
    the gain. Arrays are indexed, never sliced (a view costs a reference count)."""
    for ch in range(m):
        wk[ACT, ch] = 0.0 if has_fs else 1.0
    if not free_gain:
        for ch in range(m):
            if has_fs:
                s[i, ch] = fs[frow, ch]
            else:
                sc = (wk[SM, ch] - wk[SG, ch]) / wk[SW, ch]
                if sc > 0.0:
                    s[i, ch] = sc
                else:
                    s[i, ch] = 0.0
                    wk[ACT, ch] = 0.0
        return 1.0
    gain = 0.0
    for _ in range(m + 1):
        num = 0.0
        den = 0.0
        for ch in range(m):
            sw, sM, sG = wk[SW, ch], wk[SM, ch], wk[SG, ch]
            if wk[ACT, ch] > 0.0:
                num += wk[SGM, ch] - sG * sM / sw
                den += wk[SGG, ch] - sG * sG / sw
            else:
                sc = fs[frow, ch] if has_fs else 0.0
                num += wk[SGM, ch] - sc * sG
                den += wk[SGG, ch]
        gain = num / den if (den > 0.0 and num > 0.0) else 0.0
        again = False
        for ch in range(m):
            if wk[ACT, ch] > 0.0:
                sc = (wk[SM, ch] - gain * wk[SG, ch]) / wk[SW, ch]
                if sc <= 0.0:
                    wk[ACT, ch] = 0.0
                    sc = 0.0
                    again = True
                s[i, ch] = sc
            else:
                s[i, ch] = fs[frow, ch] if has_fs else 0.0
        if not again:
            break
    return gain


@njit(cache=True)
def _linear_one(sw, sM, sG, sGG, sGM, fs, has_fs, free_gain, i, wk, s, act):  # pragma: no cover
    """Chart i of :func:`linear_part_stats`."""
    m = sw.shape[1]
    for ch in range(m):
        wk[SW, ch], wk[SM, ch], wk[SG, ch] = sw[i, ch], sM[i, ch], sG[i, ch]
        wk[SGG, ch], wk[SGM, ch] = sGG[i, ch], sGM[i, ch]
    gain = _active_set(wk, m, fs, i, has_fs, free_gain, s, i)
    for ch in range(m):
        act[i, ch] = wk[ACT, ch]
    return gain


def _linear_all(sw, sM, sG, sGG, sGM, fs, has_fs, free_gain):  # pragma: no cover
    K, m = sw.shape
    gain = np.empty(K)
    s = np.empty((K, m))
    act = np.empty((K, m))
    for i in prange(K):
        wk = np.empty((SX, m))
        gain[i] = _linear_one(sw, sM, sG, sGG, sGM, fs, has_fs, free_gain, i, wk, s, act)
    return gain, s, act


#: The closed-form (gain, s) of many charts, serial and parallel from one source.
_linear_serial, _linear_many = twins(_linear_all)


#: numba's fast-math flags of the compiled columns: fused multiply-add only. Not 'reassoc',
#: 'arcp' or 'nsz': with them the compiler may reorder a sum or replace a division as it sees
#: fit, and it saw fit differently when a kernel and its callees were compiled in one process
#: than when they were loaded from numba's cache, so the same chart gave results differing in
#: the last bits between a process's first run and the next (decision
#: 0029-deterministic-compiled-sums). Every sum is therefore accumulated in the order the source
#: writes it; the
#: Gauss-Newton matrix's sums over a chart's values (one per pair of columns) keep four
#: partial sums, the others (per channel, and the objective's) one. Not 'nnan'/'ninf': a
#: non-finite value compares as IEEE says.
FAST = {"contract"}
#: Below this many charts the kernels run in the calling thread (a parallel launch costs more
#: than the work).
SERIAL_BELOW = 64
#: Below this many charts the closed-form (gain, s) of :func:`linear_part_stats` runs in the
#: calling thread: about 50 ns a chart, so a parallel launch (and, in a fresh process, loading
#: the parallel kernel, ~0.7 s) pays only for far bigger stacks
LINEAR_SERIAL_BELOW = 1 << 16
#: Charts per block of the parallel projection (its work arrays are allocated once per block).
PROJECT_BLOCK = 256


def linear_part_stats(sw, sM, sG, sGG, sGM, *, fixed_s=None, free_gain: bool = True):
    """The closed-form (gain, s) from each channel's weighted sums (arrays (..., m)).

    Parameters
    ----------
    sw, sM, sG, sGG, sGM : array_like, (..., m)
        sum w, sum w M, sum w G, sum w G^2, sum w G M over each channel's patches.
    fixed_s : array_like, (..., m), optional
        Backscatter held at these values.
    free_gain : bool
        Estimate the gain (else it is 1).

    Returns
    -------
    gain : ndarray, (...,)
    s : ndarray, (..., m)
    active : ndarray of bool, (..., m)
        True where s is free and positive.
    """
    stats = [np.asarray(x, float) for x in (sw, sM, sG, sGG, sGM)]
    shape = stats[0].shape
    if any(x.shape != shape for x in stats):
        shape = np.broadcast_shapes(*(x.shape for x in stats))
        stats = [np.broadcast_to(x, shape) for x in stats]
    m = shape[-1]
    flat = [np.ascontiguousarray(x).reshape(-1, m) for x in stats]
    has_fs = fixed_s is not None
    # without held s the kernels never read fs: a one-row placeholder
    fs = (np.array(np.broadcast_to(np.asarray(fixed_s, float), shape).reshape(-1, m))
          if has_fs else np.zeros((1, m)))  # a writable copy: one compiled signature
    args = (*flat, fs, has_fs, bool(free_gain))
    if flat[0].shape[0] < LINEAR_SERIAL_BELOW:
        gain, s, act = _linear_serial(*args)
    else:
        with KERNEL_LOCK:
            gain, s, act = _linear_many(*args)
    return gain.reshape(shape[:-1]), s.reshape(shape), act.reshape(shape) > 0


@njit(cache=True)
def _scratch(m, p):  # pragma: no cover
    """The work matrix of :func:`_project_one` (rows SW.. of every channel, then 3 p + 1 rows
    of the columns), allocated once per block of charts."""
    return np.zeros((SX + 3 * p + 1, max(m, p, 1)))


@njit(cache=True, fastmath=FAST)
def _project_one(GJ, o, CS, GF, M, W2, fs, row, has_fs, free_gain, m, n, grad, p, s, g, H, i,
                 wk):  # pragma: no cover
    """One chart of :func:`project`: its unit-gain signal G is row ``o`` of ``GJ`` and its
    p columns dG/dtheta rows o + 1 .. o + p; it reads row ``row`` of ``M``, ``W2`` and ``fs``
    and row i of ``CS``, and writes row i of ``s``, ``g`` and ``H`` (``wk``: :func:`_scratch`).
    Returns (f, ssr, gain).

    The residual r is formed explicitly (f, and g = -J^T r, stay accurate at an exact fit);
    the centring of the columns over an active channel and their projection off the centred G
    are applied to their weighted sums (rank-one corrections), so no column is stored. The
    corrections lose about eps (mean / spread)^2 of a column within a channel relative to
    centring it first (1e-12 at a ratio of 10): a chart's patches, black to white, keep that
    ratio near 1. Arrays are indexed, never sliced: numba counts the references of every
    view."""
    XS, XG, XR, CV = SX, SX + p, SX + 2 * p, SX + 3 * p
    for ch in range(m):
        a0 = a1 = a2 = a3 = a4 = 0.0
        for j in range(ch * n, ch * n + n):
            w = W2[row, j]
            x = GJ[o, j]
            y = M[row, j]
            a0 += w
            a1 += w * y
            a2 += w * x
            a3 += w * x * x
            a4 += w * x * y
        wk[SW, ch], wk[SM, ch], wk[SG, ch], wk[SGG, ch], wk[SGM, ch] = a0, a1, a2, a3, a4
    gi = _active_set(wk, m, fs, row, has_fs, free_gain, s, i)
    fi = 0.0
    si = 0.0
    for ch in range(m):
        a0 = a1 = 0.0
        sc = s[i, ch]
        for j in range(ch * n, ch * n + n):
            rj = M[row, j] - gi * GJ[o, j] - sc
            wr = W2[row, j] * rj
            fi += wr * rj
            si += rj * rj
            a0 += wr
            a1 += wr * GJ[o, j]
        wk[SWR, ch], wk[SGR, ch] = a0, a1
    if not grad:
        return fi, si, gi
    for a in range(p):
        oa = o + 1 + a
        for ch in range(m):
            a0 = a1 = a2 = 0.0
            sc = s[i, ch]
            for j in range(ch * n, ch * n + n):
                wj = W2[row, j] * GJ[oa, j]
                a0 += wj
                a1 += wj * GJ[o, j]
                a2 += wj * (M[row, j] - gi * GJ[o, j] - sc)
            wk[XS + a, ch], wk[XG + a, ch], wk[XR + a, ch] = a0, a1, a2
        for b in range(a + 1):
            ob = o + 1 + b
            # four partial sums (j mod 4) added in a fixed order: independent chains, fast
            # without reassociation, and the same sum however the compiler vectorises
            a0 = a1 = a2 = a3 = 0.0
            mn = m * n
            top = mn - mn % 4
            for j in range(0, top, 4):
                a0 += W2[row, j] * GJ[oa, j] * GJ[ob, j]
                a1 += W2[row, j + 1] * GJ[oa, j + 1] * GJ[ob, j + 1]
                a2 += W2[row, j + 2] * GJ[oa, j + 2] * GJ[ob, j + 2]
                a3 += W2[row, j + 3] * GJ[oa, j + 3] * GJ[ob, j + 3]
            for j in range(top, mn):
                a0 += W2[row, j] * GJ[oa, j] * GJ[ob, j]
            H[i, a, b] = (a0 + a1) + (a2 + a3)
    # the columns x_a = gain CS_a dG_a, centred over the active channels
    for a in range(p):
        fa = (gi if GF[a] else 1.0) * CS[i, a]
        ga = 0.0
        for ch in range(m):
            ga += wk[XR + a, ch]
            if wk[ACT, ch] > 0.0:
                ga -= wk[XS + a, ch] / wk[SW, ch] * wk[SWR, ch]
        g[i, a] = -fa * ga
        for b in range(a + 1):
            hab = H[i, a, b]
            for ch in range(m):
                if wk[ACT, ch] > 0.0:
                    hab -= wk[XS + a, ch] * wk[XS + b, ch] / wk[SW, ch]
            hab *= fa * (gi if GF[b] else 1.0) * CS[i, b]
            H[i, a, b] = hab
            H[i, b, a] = hab
    if free_gain and gi > 0.0:  # project the columns off the centred G (the gain's column)
        gg = 0.0
        gcr = 0.0
        for ch in range(m):
            gg += wk[SGG, ch]
            gcr += wk[SGR, ch]
            if wk[ACT, ch] > 0.0:
                gg -= wk[SG, ch] * wk[SG, ch] / wk[SW, ch]
                gcr -= wk[SG, ch] / wk[SW, ch] * wk[SWR, ch]
        if gg > 0.0:
            for a in range(p):
                acc = 0.0
                for ch in range(m):
                    acc += wk[XG + a, ch]
                    if wk[ACT, ch] > 0.0:
                        acc -= wk[SG, ch] * wk[XS + a, ch] / wk[SW, ch]
                wk[CV, a] = (gi if GF[a] else 1.0) * CS[i, a] * acc / gg
            for a in range(p):
                g[i, a] += wk[CV, a] * gcr
                for b in range(a + 1):
                    hab = H[i, a, b] - wk[CV, a] * wk[CV, b] * gg
                    H[i, a, b] = hab
                    H[i, b, a] = hab
    return fi, si, gi


def _project_all(GJ, nr, CS, GF, M, W2, fs, has_fs, free_gain, m, n, grad):  # pragma: no cover
    N, p = M.shape[0], nr - 1
    f, ssr, gain = np.empty(N), np.empty(N), np.empty(N)
    g, H, s = np.zeros((N, p)), np.zeros((N, p, p)), np.empty((N, m))
    blocks = (N + PROJECT_BLOCK - 1) // PROJECT_BLOCK
    for b in prange(blocks):
        wk = _scratch(m, p)
        for i in range(b * PROJECT_BLOCK, min(N, (b + 1) * PROJECT_BLOCK)):
            f[i], ssr[i], gain[i] = _project_one(GJ, i * nr, CS, GF, M, W2, fs, i, has_fs,
                                                 free_gain, m, n, grad, p, s, g, H, i, wk)
    return f, g, H, gain, s, ssr


#: The projection of many charts, serial and parallel from one source.
_project_serial, _project = twins(_project_all)


def project(G, JR, M, W2, fixed_s, free_gain: bool, m: int, n: int, grad: bool = True,
            col_scale=None, gain_free_rows=None):
    """The variable projection of N charts (see the module docstring).

    Parameters
    ----------
    G : ndarray, (N, m n)
        Unit-gain signals (the data's units).
    JR : ndarray, (N, p, m n)
        dG/dtheta as rows (unit gain), p >= 0.
    M, W2 : ndarray, (N, m n)
        Measurements and weights 1 / sigma^2.
    fixed_s : ndarray, (N, m) or None
        Backscatter held (None: estimated, s >= 0).
    free_gain : bool
        Estimate the gain.
    m, n : int
        Channels and patches.
    grad : bool
        Also the gradient and Gauss-Newton matrix (else zeros).
    col_scale : ndarray, (N, p), optional
        Factors of the rows of ``JR`` (a change of units or coordinates; default ones).
    gain_free_rows : array_like of bool, (p,), optional
        Rows of ``JR`` that are derivatives of the prediction itself, not of the unit-gain
        signal (an additive term: not multiplied by the gain; default none).

    Returns
    -------
    f, g (N, p), H (N, p, p), gain (N,), s (N, m), ssr (N,): the weighted and unweighted sums
    of squares.
    """
    N = G.shape[0]
    has_fs = fixed_s is not None
    fs = np.ascontiguousarray(fixed_s, float) if has_fs else np.zeros((N, m))
    p = JR.shape[1]
    CS = np.ones((N, p)) if col_scale is None else np.ascontiguousarray(col_scale, float)
    GF = np.ones(p, np.bool_) if gain_free_rows is None else ~np.asarray(gain_free_rows, bool)
    # each chart's G and its p rows dG/dtheta, one after another
    GJ = np.concatenate([np.asarray(G, float)[:, None, :], np.asarray(JR, float)], axis=1)
    args = (np.ascontiguousarray(GJ.reshape(N * (p + 1), GJ.shape[2])), p + 1, CS,
            np.ascontiguousarray(GF), np.ascontiguousarray(M, float), np.ascontiguousarray(W2, float), fs, has_fs,
            bool(free_gain), int(m), int(n), bool(grad))
    if N < SERIAL_BELOW:
        return _project_serial(*args)
    with KERNEL_LOCK:
        return _project(*args)


#: :func:`_active_set` compiled into its caller (the start grid calls it for every chart and
#: candidate: inlined there, with the channel-major products of :func:`grid_best`, the grid
#: took half the time; elsewhere a call costs less to compile). Under NUMBA_DISABLE_JIT
#: ``njit`` returns the plain function, which has no ``py_func``.
_active_set_inline = njit(cache=True, inline="always")(
    getattr(_active_set, "py_func", _active_set))


@njit(parallel=True, cache=True, error_model="numpy")
def _grid(sw, sM, sMM, sumG, sumGG, MG, w, inv, fs, has_fs, free_gain):  # pragma: no cover
    m, R, P = MG.shape
    best = np.empty(R, dtype=np.int64)
    for r in prange(R):
        wk = np.empty((SX, m))
        s = np.empty((1, m))
        f_best = np.inf
        j_best = 0
        for ch in range(m):
            wk[SW, ch], wk[SM, ch] = sw[r, ch], sM[r, ch]
        for p in range(P):
            for ch in range(m):
                wk[SG, ch] = w[r, ch] * sumG[p, ch] * inv[r]
                wk[SGG, ch] = w[r, ch] * sumGG[p, ch] * inv[r] * inv[r]
                wk[SGM, ch] = w[r, ch] * MG[ch, r, p] * inv[r]
            g = _active_set_inline(wk, m, fs, r, has_fs, free_gain, s, 0)
            f = 0.0
            for ch in range(m):
                sc = s[0, ch]
                f += (sMM[r, ch] - 2.0 * g * wk[SGM, ch] - 2.0 * sc * sM[r, ch]
                      + g * g * wk[SGG, ch] + 2.0 * g * sc * wk[SG, ch] + sc * sc * sw[r, ch])
            if f < f_best:
                f_best = f
                j_best = p
        best[r] = j_best
    return best


def grid_best(M3, w, scale, G, fixed_s, free_gain: bool):
    """The best of P candidate signals for each of R charts, gain and s in closed form.

    Parameters
    ----------
    M3 : ndarray, (R, m, n)
        Measurements (scaled units).
    w : ndarray, (R, m)
        One weight per channel (its mean 1 / sigma^2).
    scale : ndarray, (R,)
        The charts' scales (G is divided by them).
    G : ndarray, (P, m, n)
        Candidate unit-gain signals (unscaled).
    fixed_s : ndarray, (R, m) or None
        Backscatter held.
    free_gain : bool
        Estimate the gain.

    Returns
    -------
    ndarray of int, (R,)
        Index of the candidate with the least weighted sum of squares.
    """
    R, m, n = M3.shape
    MG = np.empty((m, R, G.shape[0]))  # channel-major: each channel's product written in place
    for c in range(m):
        np.matmul(M3[:, c], G[:, c].T, out=MG[c])
    sw = n * w
    sM = w * M3.sum(-1)
    sMM = w * np.einsum("rcj,rcj->rc", M3, M3)
    has_fs = fixed_s is not None
    fs = np.ascontiguousarray(fixed_s, float) if has_fs else np.zeros((R, m))
    args = (np.ascontiguousarray(sw), np.ascontiguousarray(sM), np.ascontiguousarray(sMM),
            np.ascontiguousarray(G.sum(-1)), np.ascontiguousarray(np.einsum("pcj,pcj->pc", G, G)),
            np.ascontiguousarray(MG), np.ascontiguousarray(w, float),
            np.ascontiguousarray(1.0 / scale, float), fs, has_fs, bool(free_gain))
    with KERNEL_LOCK:
        return _grid(*args)
