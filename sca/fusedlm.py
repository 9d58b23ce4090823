"""Levenberg-Marquardt of a fused problem in compiled code: each chart's whole fit without
returning to Python.

A problem is fused (:func:`sca.lm.fused`) when every free and fixed name is among C, a_CDOM,
depth and distance. Its optical depth is then forward's piece table
(:attr:`forward.WaterTerms.piece_table`), with weights from forward's own functions. This
module compiles those functions unchanged:

* :func:`forward.water.chl_weight`, :func:`~forward.water.chl_weight_derivative`,
  :func:`~forward.water.piece_weights` and :func:`~forward.water.piece_slopes`;
* :func:`sca.model.chl_from_u` and :func:`~sca.model.du_chain` (the coordinate u = C^e0).

The rest is shared with the Python driver of :func:`sca.lm.levenberg_marquardt`:

* the signal and its columns are :func:`sca.projection._columns_one`;
* the variable projection is :func:`sca.projection._project_one`;
* the step is :func:`sca.lm._step_one` and the acceptance :func:`sca.lm._judge_one`.

So this module writes no formula of the water and no step of the iteration: it puts them in
order for one chart. Two lines of bookkeeping are its own, in compiled form: the budget's
Gaussian priors (:func:`sca.lm.evaluate`'s f + sum w (theta - mu)^2, g + w (theta - mu),
H + diag w) and the columns' scale (1 / scale, times dC/du for C, as
:meth:`sca.lm.Problem.column_scales`). It returns what :func:`sca.lm.levenberg_marquardt`
returns; ``tests/test_fused.py`` checks both drivers against each other, priors included.

The step, its linear solve and the acceptance (:mod:`sca.lm`) are compiled inline (numba's
``inline='always'``), and an iteration allocates nothing (DECISIONS.md, "The batched
solver": one chart's iteration at 10 nm about 20 % faster). The evaluation stays a call:
inlined, it gained nothing measurable and cost compile time.
"""

from __future__ import annotations

from dataclasses import fields

import numpy as np

from forward.water import TABLE_NAMES, PieceTable, chl_weight, chl_weight_derivative, piece_slopes, \
    piece_weights

from .compiled import DEPENDENT_CACHE, KERNEL_LOCK, njit, prange
from .lm import LM_MU0, SINGULAR_PIVOT, _judge_one, _step_one, _step_scratch, fused
from .model import TINY, chl_from_u, du_chain
from .projection import FAST, SERIAL_BELOW, _columns_one, _project_one, _scratch

__all__ = ["compiled_fit", "fit_fused"]

_phi = njit(cache=True, error_model="numpy")(chl_weight)
_dphi = njit(cache=True, error_model="numpy")(chl_weight_derivative)
_weights = njit(cache=True, error_model="numpy")(piece_weights)
_slopes = njit(cache=True, error_model="numpy")(piece_slopes)
_chl = njit(cache=True, error_model="numpy")(chl_from_u)
_du = njit(cache=True, error_model="numpy")(du_chain)

#: Wavelengths from which one chart's signal and columns are projected by BLAS (measured:
#: at 31 a loop is 1.7x faster, at 301 BLAS is).
BLAS_FROM = 100
#: Rows of the table argument ``tab`` (:attr:`forward.water.PieceTable.numbers`).
TAB_ROWS = tuple(f.name for f in fields(PieceTable) if f.name != "spectra")
#: Charts per parallel task of :func:`_fit_all` (a whole fit each: small blocks keep both
#: threads busy from a few dozen charts on; the scratch is allocated once per block).
FIT_BLOCK = 16


@njit(cache=DEPENDENT_CACHE, error_model="numpy")
def _evaluate_one(th, cols, x0, tab, spectra, Bt, inv_scale, e0, M, W2, fs, row, has_fs,
                  free_gain, m, n, pm, pw, has_prior, slot, sc):  # pragma: no cover
    """(objective, unweighted sum of squares, gain) of one chart at LM coordinates ``th``; its
    gradient, Gauss-Newton matrix and s go to row ``slot`` of the scratch's g, H and s, its k
    to row 0 of tau (``sc``: :func:`_chart_scratch`)."""
    W1, DW, CS, s, g, H, tau, KD, wk, xv, GJ = sc
    p = th.shape[0]
    for k in range(4):
        xv[k] = x0[k]
    for a in range(p):
        if cols[a] == 0:  # C, iterated in u = C^e0
            xv[0] = _chl(th[a], e0)
        else:
            xv[cols[a]] = th[a]
    C, A, depth, distance = xv[0], xv[1], xv[2], xv[3]
    Cf = max(C, TINY)
    # piece by piece, in scalars (no arrays per piece): forward's functions, compiled
    for t in range(tab.shape[1]):
        phi = 0.0
        dphi = 0.0
        if tab[2, t] != 0.0:  # the piece has a chlorophyll weight
            phi = _phi(C, tab[3, t], tab[4, t], tab[5, t], tab[6, t])
            dphi = _dphi(Cf, tab[3, t], tab[4, t], tab[5, t], tab[6, t])
        w, base = _weights(tab[0, t], tab[1, t], tab[2, t], tab[7, t], tab[8, t], phi, A,
                           depth, distance)
        slopes = _slopes(tab[1, t], tab[2, t], tab[7, t], tab[8, t], base, dphi, depth,
                         distance)
        W1[0, t] = w
        for a in range(p):
            DW[0, a, t] = slopes[cols[a]]
    du = _du(C, e0)
    for a in range(p):
        CS[slot, a] = inv_scale * du if cols[a] == 0 else inv_scale
    _columns_one(W1, DW, 0, spectra, inv_scale, True, tau, KD, 0)
    _product(KD, Bt, GJ)
    f, ssr, gain = _project_one(GJ, 0, CS, M, W2, fs, row, has_fs, free_gain, m, n, True, p, s,
                                g, H, slot, wk)
    if has_prior:  # the budget's Gaussian priors: f + sum pw (theta - pm)^2
        for a in range(p):
            d = th[a] - pm[row, a]
            f += pw[row, a] * d * d
            g[slot, a] += pw[row, a] * d
            H[slot, a, a] += pw[row, a]
    return f, ssr, gain


@njit(cache=DEPENDENT_CACHE, fastmath=FAST)
def _product(KD, Bt, GJ):  # pragma: no cover
    """GJ = KD @ Bt for one chart's few rows: BLAS on fine grids, a loop on coarse ones
    (below :data:`BLAS_FROM` wavelengths a BLAS call costs more than it saves)."""
    r, q = KD.shape
    mn = Bt.shape[1]
    if q >= BLAS_FROM:
        np.dot(KD, Bt, GJ)
        return
    for a in range(r):
        for j in range(mn):
            GJ[a, j] = 0.0
        for l in range(q):
            kl = KD[a, l]
            for j in range(mn):
                GJ[a, j] += kl * Bt[l, j]


@njit(cache=DEPENDENT_CACHE)
def _chart_scratch(P, p, q, m, mn):  # pragma: no cover
    """Work arrays of one chart: (weights, dweights, column scales, s, g, H (current and
    trial rows), tau, KD, the projection's work matrix, the parameters, GJ)."""
    return (np.zeros((1, P)), np.zeros((1, p, P)), np.zeros((2, p)), np.zeros((2, m)),
            np.zeros((2, p)), np.zeros((2, p, p)), np.zeros((p + 1, q)), np.zeros((p + 1, q)),
            _scratch(m, p), np.zeros(4), np.zeros((p + 1, mn)))


@njit(cache=DEPENDENT_CACHE)
def _keep(i, slot, ssr, gain, sc, out):  # pragma: no cover
    """Chart i's point of row ``slot`` (just evaluated, now its current point): g, H, gain, s,
    ssr and k into the result arrays ``out``."""
    _, _, _, g_out, H_out, gain_out, s_out, ssr_out, k_out = out
    g, H, s, tau = sc[4], sc[5], sc[3], sc[6]
    p = g.shape[1]
    for a in range(p):
        g_out[i, a] = g[slot, a]
        for c in range(p):
            H_out[i, a, c] = H[slot, a, c]
    for ch in range(s.shape[1]):
        s_out[i, ch] = s[slot, ch]
    for l in range(k_out.shape[1]):
        k_out[i, l] = tau[0, l]
    gain_out[i] = gain
    ssr_out[i] = ssr


@njit(cache=DEPENDENT_CACHE, error_model="numpy")
def _fit_chart(i, theta, rows, cols, X0, tab, spectra, Bt, inv_scale, e0, M, W2, fs, has_fs,
               free_gain, m, n, PM, PW, has_prior, lower, hold, atol, f_exact, max_iter, tol,
               out, sc):  # pragma: no cover
    """The Levenberg-Marquardt of :func:`sca.lm.levenberg_marquardt` for row i of ``theta``
    alone (the data's row ``rows[i]``); ``out``: :func:`fit_fused`'s result arrays, row i
    written."""
    f_out, it_out, code_out = out[0], out[1], out[2]
    p = theta.shape[1]
    g, H = sc[4], sc[5]
    th = theta[i].copy()
    tn = np.empty(p)
    d = np.empty(p)
    dc = np.empty(p)
    step_scratch = _step_scratch(p)
    r = rows[i]  # the chart's row of the data
    x0 = X0[r]
    fa, ssr, gain = _evaluate_one(th, cols, x0, tab, spectra, Bt, inv_scale[r], e0, M, W2, fs, r,
                                  has_fs, free_gain, m, n, PM, PW, has_prior, 0, sc)
    _keep(i, 0, ssr, gain, sc, out)
    f_out[i] = fa
    it_out[i] = 0
    if fa <= f_exact[i]:
        code_out[i] = 1
        return
    mu = LM_MU0
    code = 3
    for it in range(1, max_iter + 1):
        pred = _step_one(g[0], H[0], mu, th, lower, hold[i], SINGULAR_PIVOT, d, step_scratch)
        it_out[i] = it
        # stationary: the model predicts (relatively) nothing more; stop without a trial
        stat = pred <= max(tol * fa, atol[i])
        for a in range(p):
            tn[a] = max(th[a] + d[a], lower[a])
        fn = np.inf
        ssr = gain = 0.0
        if not stat:
            fn, ssr, gain = _evaluate_one(tn, cols, x0, tab, spectra, Bt, inv_scale[r], e0, M, W2,
                                          fs, r, has_fs, free_gain, m, n, PM, PW, has_prior, 1,
                                          sc)
        ok, mu, fin = _judge_one(fa, fn, stat, g[0], H[0], th, tn, mu, tol, f_exact[i], dc)
        if ok:
            fa = fn
            _keep(i, 1, ssr, gain, sc, out)
            for a in range(p):
                th[a] = tn[a]
                g[0, a] = g[1, a]
                for c in range(p):
                    H[0, a, c] = H[1, a, c]
        if fin >= 0:
            code = fin
            break
    for a in range(p):
        theta[i, a] = th[a]
    f_out[i] = fa
    code_out[i] = code


@njit(parallel=True, cache=DEPENDENT_CACHE)
def _fit_all(theta, rows, cols, X0, tab, spectra, Bt, inv_scale, e0, M, W2, fs, has_fs, free_gain, m,
             n, PM, PW, has_prior, lower, hold, atol, f_exact, max_iter, tol,
             out):  # pragma: no cover
    N, p = theta.shape
    blocks = (N + FIT_BLOCK - 1) // FIT_BLOCK
    for blk in prange(blocks):
        sc = _chart_scratch(tab.shape[1], p, spectra.shape[1], m, Bt.shape[1])
        for i in range(blk * FIT_BLOCK, min(N, (blk + 1) * FIT_BLOCK)):
            _fit_chart(i, theta, rows, cols, X0, tab, spectra, Bt, inv_scale, e0, M, W2, fs, has_fs,
                       free_gain, m, n, PM, PW, has_prior, lower, hold, atol, f_exact, max_iter,
                       tol, out, sc)


@njit(cache=DEPENDENT_CACHE)
def _fit_serial(theta, rows, cols, X0, tab, spectra, Bt, inv_scale, e0, M, W2, fs, has_fs, free_gain,
                m, n, PM, PW, has_prior, lower, hold, atol, f_exact, max_iter, tol,
                out):  # pragma: no cover
    N, p = theta.shape
    sc = _chart_scratch(tab.shape[1], p, spectra.shape[1], m, Bt.shape[1])
    for i in range(N):
        _fit_chart(i, theta, rows, cols, X0, tab, spectra, Bt, inv_scale, e0, M, W2, fs, has_fs,
                   free_gain, m, n, PM, PW, has_prior, lower, hold, atol, f_exact, max_iter,
                   tol, out, sc)


def compiled_fit(prob) -> bool:
    """True where :func:`fit_fused` can fit ``prob``: a :func:`sca.lm.fused` problem whose C,
    depth and distance are each free or given (a_CDOM defaults to 0).

    Parameters
    ----------
    prob : sca.lm.Problem

    Returns
    -------
    bool
    """
    known = set(prob.names) | set(prob.fixed)
    return fused(prob) and {"chl", "depth", "distance"} <= known


def fit_fused(prob, theta0, *, max_iter: int, tol: float, f_exact, atol=None, hold=None,
              final: dict | None = None, rows=None):
    """:func:`sca.lm.levenberg_marquardt` of a :func:`compiled_fit` problem, each chart's
    whole fit in compiled code (the same parameters and results).

    Parameters
    ----------
    prob : sca.lm.Problem
        The charts (:func:`compiled_fit`).
    theta0 : ndarray, (N, p)
        The start, LM coordinates.
    max_iter, tol, f_exact, atol, hold, final, rows :
        As :func:`sca.lm.levenberg_marquardt` (keyword-only); ``final`` receives 'g', 'H',
        'gain', 's', 'ssr' and 'k' at the returned points (as :func:`sca.lm.evaluate`).

    Returns
    -------
    theta, f, iterations, code :
        As :func:`sca.lm.levenberg_marquardt`.
    """
    N, p = theta0.shape
    K = prob.size
    if p != len(prob.names):
        raise ValueError(f"theta0: expected {len(prob.names)} columns, got {p}")
    rows = np.arange(N) if rows is None else np.ascontiguousarray(rows, np.int64)
    if rows.shape != (N,) or (N and (rows.min() < 0 or rows.max() >= K)):
        raise ValueError(f"rows: expected {N} chart indices in 0..{K - 1}")
    hold = np.zeros((N, p), bool) if hold is None else np.ascontiguousarray(hold, bool)
    atol = np.zeros(N) if atol is None else np.ascontiguousarray(
        np.broadcast_to(np.asarray(atol, float), (N,)))
    if hold.shape != (N, p):
        raise ValueError(f"hold: expected shape {(N, p)}, got {hold.shape}")
    theta = np.array(theta0, float)
    f = np.zeros(N)
    iters = np.zeros(N, dtype=np.int64)
    code = np.full(N, 3, dtype=np.int64)
    if N == 0:
        return theta, f, iters, code
    mdl = prob.model
    tb = mdl.terms.piece_table
    tab = tb.numbers
    cols = np.array([TABLE_NAMES.index(n) for n in prob.names], np.int64)
    X0 = np.zeros((K, len(TABLE_NAMES)))
    for k, name in enumerate(TABLE_NAMES):
        if name in prob.fixed:
            X0[:, k] = np.broadcast_to(np.asarray(prob.fixed[name], float), (K,))
    has_fs = prob.fixed_s is not None
    has_prior = prob.prior_mean is not None
    # placeholders of one row where the kernels never read them (no priors, s free)
    PM = np.ascontiguousarray(prob.prior_mean, float) if has_prior else np.zeros((1, p))
    PW = np.ascontiguousarray(prob.prior_weight, float) if has_prior else np.zeros((1, p))
    args = (theta, rows, cols, X0, tab, np.ascontiguousarray(tb.spectra), np.ascontiguousarray(mdl.Bt),
            np.ascontiguousarray(prob.inv_scale, float), float(mdl.e0),
            np.ascontiguousarray(prob.M, float), np.ascontiguousarray(prob.W2, float),
            np.ascontiguousarray(prob.fixed_s, float) if has_fs else np.zeros((1, mdl.m)),
            has_fs, bool(prob.free_gain), int(mdl.m), int(mdl.n), PM, PW, has_prior,
            np.ascontiguousarray(prob.lower, float), hold, atol,
            np.ascontiguousarray(np.broadcast_to(np.asarray(f_exact, float), (N,))),
            int(max_iter), float(tol))
    m, q = mdl.m, tb.spectra.shape[1]
    out = (f, iters, code, np.zeros((N, p)), np.zeros((N, p, p)), np.zeros(N), np.zeros((N, m)),
           np.zeros(N), np.zeros((N, q)))
    if N < SERIAL_BELOW:
        _fit_serial(*args, out)
    else:
        with KERNEL_LOCK:
            _fit_all(*args, out)
    if final is not None:
        final.update(zip(("g", "H", "gain", "s", "ssr", "k"), out[3:]))
    return theta, f, iters, code
