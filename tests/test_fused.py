"""The batch's compiled evaluation from the optical depth's pieces is the model function.

:func:`sca.lm.evaluate` computes charts whose free and fixed names are C, a_CDOM, depth and
distance with :func:`sca.projection.project_pieces` (the (weight, spectrum) pieces of
:meth:`forward.WaterTerms.optical_depth`, ``stacked=True``) instead of
:meth:`sca.ChartModel.predict` + :func:`sca.projection.project`. Both must give the same
objective, gradient, Gauss-Newton matrix, gain, backscatter and attenuation, for every path
model, with and without a free gain or a held backscatter.
"""

import importlib
import zlib

import numpy as np
import pytest

import forward
from sca.lm import Problem, evaluate, fused
from sca.model import TINY, ChartModel

lm = importlib.import_module("sca.lm")
SETUP = forward.chart_setup(wavelengths=np.arange(400.0, 701.0, 10.0))
NAMES = (("chl", "cdom"), ("chl", "cdom", "depth", "distance"), ("cdom",))


def _problem(path_model, names, free_gain, held_s, rng, N=70):
    """N random charts (N >= the kernels' serial threshold: the parallel kernel runs)."""
    mdl = ChartModel(SETUP, water=forward.Water(path_model=path_model))
    mn = mdl.m * mdl.n
    fixed = {"depth": rng.uniform(0.0, 20.0, N), "distance": rng.uniform(0.0, 5.0, N),
             "chl": rng.uniform(0.0, 5.0, N)}
    fixed = {k: v for k, v in fixed.items() if k not in names}
    fs = rng.uniform(0.0, 0.05, (N, mdl.m)) if held_s else None
    return Problem(mdl, rng.uniform(0.01, 1.0, (N, mn)), rng.uniform(0.5, 2.0, (N, mn)),
                   rng.uniform(0.5, 2.0, N), names, fixed, free_gain, fs)


@pytest.mark.parametrize("path_model", ["beam", "absorption", "split"])
@pytest.mark.parametrize("names", NAMES)
@pytest.mark.parametrize("free_gain,held_s", [(False, False), (True, False), (False, True)])
def test_pieces_equal_the_model_function(path_model, names, free_gain, held_s, monkeypatch):
    rng = np.random.default_rng(hash((path_model, names, free_gain, held_s)) % 2**32)
    prob = _problem(path_model, names, free_gain, held_s, rng)
    assert fused(prob)
    theta = rng.uniform(0.0, 2.0, (prob.size, len(names)))
    theta[:3, 0] = 0.0  # C = 0 (u = 0) and a_CDOM = 0 included
    idx = np.arange(prob.size)
    got = evaluate(prob, idx, theta, True)
    monkeypatch.setattr(lm, "fused", lambda p: False)
    ref = evaluate(prob, idx, theta, True)
    for name, a, b in zip(("f", "g", "H", "gain", "s", "ssr", "k"), got, ref):
        scale = np.max(np.abs(b)) + TINY
        assert np.max(np.abs(a - b)) <= 1e-12 * scale, name
    sub = idx[5:9]  # a few charts, serial kernel, values only
    got = evaluate(prob, sub, theta[sub], False)
    ref = evaluate(prob, sub, theta[sub], False)
    assert got[1] is None and got[2] is None
    np.testing.assert_allclose(got[0], ref[0], rtol=1e-12)


def test_stacked_pieces_sum_to_the_optical_depth():
    terms = forward.Water(path_model="split").on_grid(np.arange(400.0, 701.0, 5.0))
    rng = np.random.default_rng(3)
    chl, cdom = np.r_[0.0, rng.uniform(0, 50, 9)], rng.uniform(0, 2, 10)
    depth, distance = rng.uniform(0, 20, 10), rng.uniform(0, 5, 10)
    wrt = ("chl", "cdom", "depth", "distance")
    tau, dtau = terms.optical_depth(chl, cdom, depth, distance, wrt=wrt, floor=TINY)
    weights, spectra, dweights = terms.optical_depth(chl, cdom, depth, distance, wrt=wrt,
                                                     floor=TINY, stacked=True)
    np.testing.assert_allclose(weights @ spectra, tau, rtol=1e-13)
    for name in wrt:
        np.testing.assert_allclose(dweights[name] @ spectra, dtau[name], rtol=1e-13,
                                   atol=1e-15 * np.abs(dtau[name]).max())


def test_stacked_refuses_point_dependent_spectra():
    terms = forward.PAPER_WATER.on_grid(np.arange(400.0, 701.0, 10.0))
    with pytest.raises(ValueError, match="stacked"):
        terms.path_coefficient(np.ones(3), np.ones(3), values={"cdom_slope": np.full(3, 0.02)},
                               stacked=True)


def test_camera_and_constants_use_the_model_function():
    rng = np.random.default_rng(0)
    prob = _problem("beam", ("chl", "cdom", "cdom_slope"), False, False, rng, N=4)
    assert not fused(prob)


# ------------------------------------------------------------ forward's piece table
@pytest.mark.parametrize("path_model", ["beam", "absorption", "split"])
def test_piece_table_gives_the_terms_own_pieces(path_model, monkeypatch):
    """optical_depth(stacked=True) from the piece table equals, bit for bit, the pieces the
    terms return themselves (the generic stacking), values and derivatives, C = 0 included."""
    import forward.water as water

    terms = forward.Water(path_model=path_model).on_grid(np.arange(400.0, 701.0, 5.0))
    rng = np.random.default_rng(11)
    chl, cdom = np.r_[0.0, rng.uniform(0, 50, 9)], np.r_[rng.uniform(0, 2, 9), 0.0]
    depth, distance = rng.uniform(0, 20, 10), rng.uniform(0, 5, 10)
    for wrt in [(), ("chl", "cdom"), ("chl", "cdom", "depth", "distance"), ("distance",)]:
        for floor in (0.0, TINY):
            got = terms.optical_depth(chl, cdom, depth, distance, wrt=wrt, floor=floor,
                                      stacked=True)
            with monkeypatch.context() as mp:
                mp.setattr(water, "_use_table", lambda *a: False)  # the generic stacking
                ref = terms.optical_depth(chl, cdom, depth, distance, wrt=wrt, floor=floor,
                                          stacked=True)
            assert np.array_equal(got[0], ref[0]) and np.array_equal(got[1], ref[1])
            for name in wrt:
                assert np.array_equal(got[2][name], np.broadcast_to(ref[2][name], got[0].shape),
                                      equal_nan=True), (wrt, floor, name)


def test_piece_table_is_read_only_numbers():
    tb = forward.PAPER_WATER.on_grid(np.arange(400.0, 701.0, 10.0)).piece_table
    P = tb.spectra.shape[0]
    for name in ("const", "cdom", "chl", "p", "e", "g", "h", "depth", "distance"):
        arr = getattr(tb, name)
        assert arr.shape == (P,) and not arr.flags.writeable
    # the paper's 'beam' path: a_w, CDOM, phytoplankton, NAP, b_w, b_k, two particle terms
    assert P == 8 and tb.cdom.sum() == 1.0 and np.count_nonzero(tb.chl) == 4
    np.testing.assert_array_equal(tb.depth, 1.0)


# ------------------------------------------------------------ the compiled driver
def _fit_problem(path_model, names, free_gain, held_s, rng, N, priors=False, setup=SETUP):
    """N charts simulated by the model function itself (noisy), and a start near the truth
    (LM coordinates: u = C^e0 for C)."""
    mdl = ChartModel(setup, water=forward.Water(path_model=path_model))
    truth = {"chl": rng.uniform(0.0, 20.0, N), "cdom": rng.uniform(0.0, 1.5, N),
             "depth": rng.uniform(1.0, 20.0, N), "distance": rng.uniform(0.3, 5.0, N)}
    G = mdl.predict(truth, jacobian=False).signal
    s = rng.uniform(0.0, 0.02, (N, mdl.m))
    gain = rng.uniform(0.5, 2.0, N) if free_gain else np.ones(N)
    M = gain[:, None] * G + np.repeat(s, mdl.n, axis=1)
    M = M + rng.normal(0.0, 0.002, M.shape)
    scale = M.max(axis=1)
    fixed = {k: v for k, v in truth.items() if k not in names}
    prior_mean = prior_weight = None
    start = np.stack([truth[n] * rng.uniform(0.5, 1.5, N) for n in names], axis=1)
    if "chl" in names:
        start[:, names.index("chl")] = start[:, names.index("chl")] ** mdl.e0
    if priors:
        prior_mean = start.copy()
        prior_weight = np.full(start.shape, 10.0)
    prob = Problem(mdl, M / scale[:, None], np.full(M.shape, 1.0), scale, names, fixed,
                   free_gain, s / scale[:, None] if held_s else None, prior_mean, prior_weight)
    return prob, start


#: (free names, free gain, held backscatter, priors): identifiable problems (a free gain and a
#: free distance together leave a valley the stopping rule ends anywhere along).
DRIVER_CASES = [(("chl", "cdom"), False, False, False), (("chl", "cdom"), True, False, False),
                (("chl", "cdom", "distance"), False, False, True), (("cdom",), False, True, False),
                (("chl", "cdom", "depth"), False, True, True)]


@pytest.mark.parametrize("path_model", ["beam", "split"])
@pytest.mark.parametrize("names,free_gain,held_s,priors", DRIVER_CASES)
def test_compiled_driver_equals_the_python_driver(path_model, names, free_gain, held_s, priors):
    _drivers_agree(path_model, names, free_gain, held_s, priors, SETUP)


def test_compiled_driver_equals_the_python_driver_on_1nm():
    """The same on the default 1 nm grid (one chart's columns projected by BLAS there)."""
    from sca.fusedlm import BLAS_FROM

    setup = forward.chart_setup(wavelengths=np.arange(400.0, 701.0, 1.0))
    assert setup.wavelengths.size >= BLAS_FROM
    _drivers_agree("beam", ("chl", "cdom"), True, False, False, setup)


def _drivers_agree(path_model, names, free_gain, held_s, priors, setup):
    """sca.fusedlm.fit_fused (each chart's whole fit compiled) and the Python driver of
    sca.lm.levenberg_marquardt (every chart one iteration at a time) reach the same points,
    objectives, iteration counts and stop codes (to rounding), with priors, held coordinates
    and absolute tolerances, in the serial and the parallel kernel."""
    from sca.fusedlm import compiled_fit
    from sca.lm import levenberg_marquardt

    rng = np.random.default_rng(zlib.crc32(repr((path_model, names, free_gain)).encode()))
    prob, start = _fit_problem(path_model, names, free_gain, held_s, rng, N=80, priors=priors,
                               setup=setup)
    assert compiled_fit(prob)
    hold = np.zeros(start.shape, bool)
    hold[::7, 0] = True
    atol = np.where(np.arange(prob.size) % 5 == 0, 1e-6, 0.0)
    kw = dict(max_iter=60, tol=1e-12, f_exact=np.full(prob.size, 1e-30), atol=atol, hold=hold)
    for rows in (np.arange(prob.size), np.arange(10)):  # parallel kernel, then the serial one
        sub = prob.subset(rows)
        a = levenberg_marquardt(sub, start[rows], compiled=True, **kw | {
            "f_exact": kw["f_exact"][rows], "atol": atol[rows], "hold": hold[rows]})
        b = levenberg_marquardt(sub, start[rows], compiled=False, **kw | {
            "f_exact": kw["f_exact"][rows], "atol": atol[rows], "hold": hold[rows]})
        # converged (codes 0-2): the same optimum, within what the stopping rule leaves in
        # the flat valleys of a free gain and a free distance (objective 1e-8 relative)
        conv = b[3] <= 2
        assert conv.mean() >= 0.9
        np.testing.assert_allclose(a[1][conv], b[1][conv], rtol=1e-7)
        np.testing.assert_allclose(a[0][conv], b[0][conv], rtol=1e-4, atol=1e-7)
        same = (a[2] == b[2]) & (a[3] == b[3])
        assert same.mean() >= 0.95, (a[2][~same], b[2][~same], a[3][~same], b[3][~same])
        assert np.all(a[0][hold[rows]] == start[rows][hold[rows]])  # held where they are


def test_piece_table_refuses_a_basis_without_weights():
    wl = np.arange(400.0, 701.0, 10.0)
    basis = np.stack([np.exp(-((wl - 440.0) / 40.0) ** 2), np.exp(-((wl - 670.0) / 20.0) ** 2)],
                     axis=1)
    terms = forward.PAPER_WATER.on_grid(wl, basis=basis)
    assert terms.free_only
    with pytest.raises(ValueError, match="weights"):
        terms.optical_depth(1.0, 0.1, 5.0, 1.0, wrt=("chl",), stacked=True)
    with pytest.raises(ValueError, match="weights"):
        terms.piece_table  # noqa: B018


@pytest.mark.parametrize("free_gain,held_s,priors", [(False, False, False), (True, False, True),
                                                     (False, True, False)])
def test_compiled_driver_keeps_what_evaluate_gives(free_gain, held_s, priors):
    """The compiled driver's ``final`` (g, H, gain, s, ssr, k at the returned points, kept
    as it goes) equals sca.lm.evaluate there; the Python driver leaves ``final`` empty."""
    from sca.lm import levenberg_marquardt

    rng = np.random.default_rng(7)
    prob, start = _fit_problem("split", ("chl", "cdom"), free_gain, held_s, rng, N=70,
                               priors=priors)
    kw = dict(max_iter=60, tol=1e-12, f_exact=np.full(prob.size, 1e-30))
    final = {}
    theta, f, *_ = levenberg_marquardt(prob, start, compiled=True, final=final, **kw)
    ref = evaluate(prob, np.arange(prob.size), theta, True)
    np.testing.assert_allclose(f, ref[0], rtol=1e-12)
    for name, r in zip(("g", "H", "gain", "s", "ssr", "k"), ref[1:]):
        scale = np.max(np.abs(r)) + TINY
        assert np.max(np.abs(final[name] - r)) <= 1e-9 * scale, name
    empty = {}
    levenberg_marquardt(prob, start, compiled=False, final=empty, **kw)
    assert empty == {}


@pytest.mark.parametrize("compiled", [True, False])
def test_rows_fit_a_subset_without_copying(compiled):
    """levenberg_marquardt(prob, theta, rows=idx) equals the fit of prob.subset(idx), in both
    drivers and both kernels (the profile points fit their charts this way); f_exact, atol and
    hold are per row of theta, the data per chart."""
    from sca.lm import levenberg_marquardt

    rng = np.random.default_rng(8)
    prob, start = _fit_problem("beam", ("chl", "cdom"), True, False, rng, N=90, priors=True)
    for idx in (np.r_[3, 80, 7, 7, 41], rng.permutation(90)[:70]):  # serial, then parallel
        hold = np.zeros((idx.size, 2), bool)
        hold[::3, 1] = True
        kw = dict(max_iter=60, tol=1e-12, f_exact=rng.uniform(0, 1e-6, idx.size), hold=hold,
                  atol=np.where(np.arange(idx.size) % 2 == 0, 1e-5, 0.0), compiled=compiled)
        a = levenberg_marquardt(prob, start[idx], rows=idx, **kw)
        b = levenberg_marquardt(prob.subset(idx), start[idx], **kw)
        for x, y in zip(a, b):
            np.testing.assert_array_equal(x, y)


def test_compiled_driver_checks_its_arguments():
    from sca.lm import levenberg_marquardt

    prob, start = _fit_problem("beam", ("chl", "cdom"), False, False, np.random.default_rng(9),
                               N=5)
    kw = dict(max_iter=5, tol=1e-12, f_exact=np.zeros(2), compiled=True)
    with pytest.raises(ValueError, match="rows"):
        levenberg_marquardt(prob, start[:2], rows=[0, 5], **kw)
    with pytest.raises(ValueError, match="hold"):
        levenberg_marquardt(prob, start[:2], rows=[0, 1], hold=np.zeros((2, 1), bool), **kw)


def test_judge_one_is_nielsens_rule():
    """The acceptance shared by both drivers, against hand-computed updates: a step whose
    decrease the model predicted exactly (rho = 1) divides the damping by LM_DOWN, one that
    achieved a quarter of it (rho = 1/4) multiplies it by 1 - (2/4 - 1)^3 = 1.125, a failed
    trial multiplies it by LM_UP, and the stop codes."""
    from sca.lm import LM_DOWN, LM_UP, _judge_one

    g, H = np.array([-1.0]), np.array([[1.0]])  # predicted decrease of d: 2 d - d^2
    th, dc = np.array([0.0]), np.empty(1)
    for d, actual, factor in ((1.0, 1.0, 1.0 / LM_DOWN), (1.0, 0.25, 1.125)):
        ok, mu, fin = _judge_one(10.0, 10.0 - actual, False, g, H, th, np.array([d]), 1e-3,
                                 1e-12, 0.0, dc)
        assert ok and fin == -1 and mu == pytest.approx(1e-3 * factor, rel=1e-12)
    ok, mu, fin = _judge_one(10.0, 11.0, False, g, H, th, np.array([1.0]), 1e-3, 1e-12, 0.0, dc)
    assert not ok and fin == -1 and mu == pytest.approx(1e-3 * LM_UP)
    assert _judge_one(10.0, np.inf, True, g, H, th, th, 1e-3, 1e-12, 0.0, dc)[2] == 2
    assert _judge_one(10.0, 10.0 - 1e-12, False, g, H, th, np.array([1.0]), 1e-3, 1e-12, 0.0,
                      dc)[2] == 0
    assert _judge_one(10.0, 1e-31, False, g, H, th, np.array([1.0]), 1e-3, 1e-12, 1e-30,
                      dc)[2] == 1
    assert _judge_one(10.0, 11.0, False, g, H, th, np.array([1.0]), 1e12, 1e-12, 0.0,
                      dc)[2] == 4


def test_u_coordinate_functions_agree_compiled_and_on_arrays():
    """sca.model.chl_from_u and du_chain, the same functions numba compiles for the fused
    driver: C = u^(1/e0) for u > 0 and 0 for u <= 0 or NaN, dC/du at max(C, TINY). Compiled
    and on Python scalars they are the same scalar arithmetic (equal); on arrays numpy may use
    a vectorised power (within a few ulp)."""
    from sca.fusedlm import _chl, _du
    from sca.model import chl_from_u, du_chain

    e0 = 0.627
    u = np.array([-np.inf, -1.0, -0.0, 0.0, np.nan, 1e-100, 0.3, 2.0, 1e100, np.inf])
    scalar = np.array([chl_from_u(float(x), e0) for x in u])
    np.testing.assert_array_equal([_chl(float(x), e0) for x in u], scalar)
    np.testing.assert_array_equal(scalar[:5], 0.0)  # u <= 0 and NaN: C = 0
    assert scalar[-1] == np.inf and np.all(scalar[5:-1] > 0)
    np.testing.assert_allclose(chl_from_u(u, e0), scalar, rtol=1e-14, atol=0)
    np.testing.assert_allclose(scalar[5:-1], u[5:-1] ** (1 / e0), rtol=1e-14)
    c = np.array([0.0, 1e-320, 0.5, 40.0])
    scalar = np.array([du_chain(float(x), e0) for x in c])
    np.testing.assert_array_equal([_du(float(x), e0) for x in c], scalar)
    np.testing.assert_allclose(du_chain(c, e0), scalar, rtol=1e-14)
    np.testing.assert_allclose(scalar, np.maximum(c, TINY) ** (1 - e0) / e0, rtol=1e-14)
    assert scalar[0] == scalar[1] > 0  # below TINY: the slope at TINY, finite
