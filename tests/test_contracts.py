"""One physics: every estimator's model equals the simulator's, in value and derivative.

For both path models and non-default constants of :class:`forward.Water`, each estimator path
-- the cvxpy loop's model (:class:`sca.WaterModel`), the scipy least-squares residual, and the
numpy and numba engines of the batched solver -- is compared with :mod:`forward` (value) and
with finite differences of :mod:`forward` (Jacobian). Changing a constant through
``forward.Water`` must move every estimator with it.
"""

import dataclasses

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import forward
import sca
from sca import batch as sca_batch
from sca.lsq import residual_functions

WL = forward.wavelength_grid()
SETUP = forward.chart_setup()

#: a water unlike the paper's in every group of constants (eqs 6, 7, 8, 10, 12, b_w)
ODD_WATER = forward.Water(cdom_slope=0.018, nap_slope=0.007, nap_scale=0.03, nap_exponent=0.8,
                          phyto_scale=0.05, phyto_exponent=0.55, c_12=1.2, s_12=0.6,
                          b_p12_star=0.02, b_p3_star=0.004, b_k=0.003, gamma_k=1.2,
                          water_scattering=0.004)
WATERS = {
    "paper-beam": forward.PAPER_WATER,
    "paper-absorption": forward.Water(path_model="absorption"),
    "odd-beam": ODD_WATER,
    "odd-absorption": dataclasses.replace(ODD_WATER, path_model="absorption"),
}


def conditions():
    return dict(chl=st.floats(0.02, 50.0), cdom=st.floats(0.0, 1.5), depth=st.floats(0.5, 20.0),
                distance=st.floats(0.2, 8.0))


def forward_k(water, chl, cdom, depth, distance, a_phi=None):
    """k from forward's public functions, optionally with a_phi given directly."""
    if a_phi is None:
        return forward.attenuation(WL, chl, cdom, depth, distance, water=water)
    a = forward.absorption(WL, chl, cdom, phytoplankton=a_phi, water=water)
    c = a + (forward.scattering(WL, chl, water=water) if water.path_model == "beam" else 0.0)
    return np.exp(-(depth + distance) * c)


def central(fn, x, h):
    return (fn(x + h) - fn(x - h)) / (2 * h)


# ------------------------------------------------------------------------- the cvxpy loop
@pytest.mark.parametrize("name", sorted(WATERS))
@given(**conditions())
def test_loop_model_equals_forward(name, chl, cdom, depth, distance):
    water = WATERS[name]
    mdl = sca.Estimator(depth=depth, distance=distance, water=water).model
    w = np.array([water.phytoplankton_440(chl) / mdl.t440[0]])
    k_fwd = forward_k(water, chl, cdom, depth, distance)
    np.testing.assert_allclose(mdl.attenuation(chl, cdom, w), k_fwd, rtol=1e-12, atol=1e-300)
    # the signal: P^T diag(i) diag(k) R of the simulator
    sim = forward.simulate_chart(chl, cdom, depth, distance, noise=False, backscatter=False,
                                 water=water)
    np.testing.assert_allclose(mdl.signal(mdl.attenuation(chl, cdom, w)).reshape(3, 24), sim.rgb,
                               rtol=1e-12, atol=1e-300)
    # Jacobian columns against finite differences of forward
    k, dk = mdl.attenuation_jacobian(chl, cdom, w)
    h = 1e-6 * chl
    fd_chl_total = central(lambda c: forward_k(water, c, cdom, depth, distance), chl, h)
    dalpha = water.phytoplankton_440(chl, derivative=True)[1]
    np.testing.assert_allclose(dk[:, 0] + dk[:, 2] * dalpha / mdl.t440[0], fd_chl_total,
                               rtol=2e-6, atol=1e-12 * np.max(k) + 1e-300)
    fd_cdom = central(lambda a: forward_k(water, chl, a, depth, distance), max(cdom, 1e-4), 1e-6)
    k_at = mdl.attenuation_jacobian(chl, max(cdom, 1e-4), w)[1]
    np.testing.assert_allclose(k_at[:, 1], fd_cdom, rtol=2e-6, atol=1e-12 * np.max(k) + 1e-300)
    T = mdl.T[:, 0]
    fd_w = central(lambda x: forward_k(water, chl, cdom, depth, distance, a_phi=T * x), w[0],
                   1e-6 * w[0])
    np.testing.assert_allclose(dk[:, 2], fd_w, rtol=2e-6, atol=1e-12 * np.max(k) + 1e-300)


# ------------------------------------------------------------------------- the scipy path
@pytest.mark.parametrize("name", sorted(WATERS))
@given(**conditions())
def test_scipy_residual_equals_forward(name, chl, cdom, depth, distance):
    water = WATERS[name]
    sim = forward.simulate_chart(1.0, 0.1, depth, distance, seed=1, water=water)
    est = sca.Estimator(depth=depth, distance=distance, water=water)
    Mv, scale, mdl, _ = est.prepare(sim.rgb)
    fun, jac, _ = residual_functions(mdl, Mv)
    s = np.array([0.001, 0.002, 0.0005])
    x = np.array([chl, cdom, *s])
    G = forward.simulate_chart(chl, cdom, depth, distance, noise=False, backscatter=False,
                               water=water).rgb
    r_fwd = (sim.rgb - G - s[:, None] * scale).ravel() / scale
    np.testing.assert_allclose(fun(x), r_fwd, rtol=1e-9, atol=1e-12)
    # d fun / d(C, a_CDOM) = -dG/dx / scale (G from forward, differenced itself); d/ds = -E
    L = depth + distance
    a = max(cdom, 1e-6)
    J = jac(np.array([chl, a, *s]))
    for j, fn, x0, h in ((0, lambda c: _signal(water, c, a, L), chl, 1e-6 * chl),
                         (1, lambda v: _signal(water, chl, v, L), a, 1e-6)):
        fd = -central(fn, x0, h).ravel() / scale
        np.testing.assert_allclose(J[:, j], fd, rtol=1e-5, atol=1e-7 * np.abs(fd).max() + 1e-300)
    np.testing.assert_array_equal(J[:, 2:], -np.kron(np.eye(3), np.ones((24, 1))))


# ------------------------------------------------------------------------- the batch engines
def _signal(water, chl, cdom, L):
    """G = P^T diag(i) diag(k) R (3, 24) from forward."""
    k = forward.attenuation(WL, chl, cdom, L, 0.0, water=water)
    return forward.camera_response(SETUP.sensitivities, SETUP.illuminant, k, SETUP.reflectances)


def _projected_residual(water, M, w2, scale, chl, cdom, L):
    """r = sqrt(w2) (M - G - s), s the clipped w2-weighted channel mean, from forward, in units
    of scale (w2 = weights in those units, (3, 24))."""
    R0 = (M - _signal(water, chl, cdom, L)) / scale
    s = np.maximum((w2 * R0).sum(axis=1) / w2.sum(axis=1), 0.0)
    return (np.sqrt(w2) * (R0 - s[:, None])).ravel(), s


def _projected_jacobian(water, w2, scale, s, fn, x, h):
    """d r / dx = -sqrt(w2) (dG/dx - its w2-weighted channel mean where s > 0) / scale, with
    dG/dx by central differences of forward's G (differencing G itself: r = M - G loses digits
    where G << M)."""
    dG = central(fn, x, h) / scale
    mean = (w2 * dG).sum(axis=1, keepdims=True) / w2.sum(axis=1, keepdims=True)
    return -(np.sqrt(w2) * (dG - (s > 0)[:, None] * mean)).ravel()


def _engines(bm, M, w2, scale, chl, cdom, L):
    """(f, s, g, H) from the numpy evaluation and the compiled (or plain) kernel."""
    from sca._batch_kernel import eval_chart, make_buffers

    Ms = (M / scale).reshape(1, -1)
    W2 = w2.reshape(1, -1)
    phi, dphi = bm.weights(np.array([chl]), derivative=True)
    f, s, g, H, _ = sca_batch.evaluate_numpy(phi, dphi, np.array([cdom]), np.array([L]), bm.S,
                                             bm.base, bm.ecdom, bm.Bt, Ms, W2, np.array([scale]),
                                             np.zeros((1, 3)), False, bm.m, bm.n, True)
    out = {"numpy": (f[0], s[0], g[0], H[0])}
    prob = (np.array([L]), np.array([scale]), Ms, W2, np.zeros((1, 3)), False, bm.S, bm.base,
            bm.ecdom, bm.Bt, bm.m, bm.n, bm.table, bm.e0, False)
    buf = make_buffers(bm.S.shape[1], bm.m, bm.n)
    f1, g1, g2, h11, h12, h22 = eval_chart(chl ** bm.e0, cdom, 0, prob, buf, True)
    out["kernel"] = (f1, buf[0].copy(), np.array([g1, g2]), np.array([h11, h12, h22]))
    return out


@pytest.mark.parametrize("weighted", [False, True])
@pytest.mark.parametrize("name", sorted(WATERS))
@given(**conditions())
def test_batch_engines_equal_forward(name, weighted, chl, cdom, depth, distance):
    water = WATERS[name]
    L = depth + distance
    sim = forward.simulate_chart(1.0, 0.1, depth, distance, seed=2, water=water)
    M = sim.rgb
    scale = float(M.max())
    w2 = (scale / sim.rgb_sigma) ** 2 if weighted else np.ones_like(M)
    bm = sca_batch.BatchModel(SETUP, water=water)
    r, s = _projected_residual(water, M, w2, scale, chl, cdom, L)
    e0 = water.phyto_exponent
    u = chl ** e0
    # the projected Jacobian J = dr/d(u, a_CDOM) by finite differences of forward
    hu, ha = 1e-6 * u, 1e-6
    a = max(cdom, ha)
    Ju = _projected_jacobian(water, w2, scale, s, lambda x: _signal(water, x ** (1 / e0), cdom, L),
                             u, hu)
    Ja = _projected_jacobian(water, w2, scale, s, lambda x: _signal(water, chl, x, L), a, ha)
    for engine, (f, s_e, g, H) in _engines(bm, M, w2, scale, chl, cdom, L).items():
        assert f == pytest.approx(float(r @ r), rel=1e-9), engine
        np.testing.assert_allclose(s_e, s, rtol=1e-9, atol=1e-15, err_msg=engine)
        tol = 1e-5 * (np.linalg.norm(Ju) * np.linalg.norm(r) + 1e-300)
        assert g[0] == pytest.approx(float(Ju @ r), rel=1e-5, abs=tol), engine
        assert H[0] == pytest.approx(float(Ju @ Ju), rel=1e-5), engine
        if cdom >= ha:
            tol_a = 1e-5 * (np.linalg.norm(Ja) * np.linalg.norm(r) + 1e-300)
            assert g[1] == pytest.approx(float(Ja @ r), rel=1e-5, abs=tol_a), engine
            assert H[2] == pytest.approx(float(Ja @ Ja), rel=1e-5), engine
            assert H[1] == pytest.approx(float(Ju @ Ja), rel=1e-5,
                                         abs=1e-6 * np.sqrt(H[0] * H[2])), engine


# ------------------------------------------------------------------------- Water itself
def test_water_defaults_are_the_papers():
    w = forward.Water()
    assert (w.cdom_slope, w.nap_slope, w.b_k, w.path_model) == (0.014, 0.011, 0.00068, "beam")
    assert (w.nap_scale, w.nap_exponent, w.phyto_scale, w.phyto_exponent) == (0.0124, 0.724, 0.0378, 0.627)
    assert w.table1() == {"C_12": 0.78, "S_12": 1.1449, "b_p12_star": 0.0046,
                          "b_p3_star": 0.0005, "b_k": 0.00068, "gamma_12": 0.7,
                          "gamma_3": -0.2, "gamma_k": 1.9, "lambda_0": 470.0}
    assert w == forward.PAPER_WATER and hash(w) == hash(forward.PAPER_WATER)
    assert forward.Water(b_k=0.001) != w


def test_water_is_immutable_and_tables_read_only():
    w = forward.Water()
    with pytest.raises(dataclasses.FrozenInstanceError):
        w.b_k = 0.0
    for arr in (*w.pure_water_absorption_table, *w.phytoplankton_basis_table, w.chl_terms()):
        assert not arr.flags.writeable
    terms = w.on_grid()
    for f in dataclasses.fields(terms):
        v = getattr(terms, f.name)
        if isinstance(v, np.ndarray):
            assert not v.flags.writeable, f.name
    # what a caller gets back is theirs: changing it changes nothing else
    t = forward.table1()
    t["b_k"] = 0.0
    assert forward.table1()["b_k"] == 0.00068
    a_w = forward.pure_water_absorption()
    a_w[:] = 0.0
    assert forward.pure_water_absorption()[0] == pytest.approx(0.0171)
    names, rows = forward.spectra.read_table("particle_scattering_table1.csv")
    assert isinstance(rows, tuple) and all(isinstance(r, tuple) for r in rows)


@pytest.mark.parametrize("kw,name", [(dict(path_model="fog"), "path_model"),
                                     (dict(cdom_slope=np.nan), "cdom_slope"),
                                     (dict(b_k=-1.0), "b_k"), (dict(phyto_scale=0.0), "phyto_scale"),
                                     (dict(pure_water_absorption_table=([400, 300], [1, 2])),
                                      "pure_water_absorption_table")])
def test_water_bad_input(kw, name):
    with pytest.raises(ValueError, match=f"^{name}:"):
        forward.Water(**kw)
    with pytest.raises(ValueError, match="^water:"):
        forward.simulate_chart(1, 0.1, 5, 1, water={"b_k": 0})


def test_every_term_changes_with_its_constant():
    base = forward.attenuation_coefficient(WL, 2.0, 0.3)
    for field_name, value in (("cdom_slope", 0.019), ("nap_slope", 0.006), ("b_k", 0.002),
                              ("nap_scale", 0.02), ("phyto_scale", 0.05), ("c_12", 1.0),
                              ("gamma_3", 0.3), ("water_scattering", 0.004)):
        water = forward.Water(**{field_name: value})
        assert not np.allclose(forward.attenuation_coefficient(WL, 2.0, 0.3, water=water), base,
                               rtol=1e-9), field_name


# ------------------------------------------------------------------------- every estimator follows
@pytest.mark.parametrize("path_model", ["beam", "absorption"])
def test_every_estimator_follows_a_changed_constant(path_model):
    water = dataclasses.replace(ODD_WATER, path_model=path_model)
    truth = (2.0, 0.3, 8.0, 3.0)
    sim = forward.simulate_chart(*truth, noise=False, water=water)
    fits = {
        "sca": sca.estimate(sim.rgb, depth=8.0, distance=3.0, water=water),
        "scipy": sca.estimate_least_squares(sim.rgb, depth=8.0, distance=3.0, water=water),
    }
    for engine in sca_batch.ENGINES:
        b = sca.estimate_batch(sim.rgb[None], depth=8.0, distance=3.0, water=water, engine=engine)
        fits[engine] = b
    for name, e in fits.items():
        chl, cdom = float(np.ravel(e.chl)[0]), float(np.ravel(e.cdom)[0])
        assert abs(chl / 2.0 - 1) < 1e-6 and abs(cdom / 0.3 - 1) < 1e-6, (name, chl, cdom)
    # and the paper's constants do not fit this water: the estimators did use `water`
    wrong = sca.estimate(sim.rgb, depth=8.0, distance=3.0, path_model=path_model)
    assert abs(wrong.chl / 2.0 - 1) > 1e-3
    for engine in sca_batch.ENGINES:
        b = sca.estimate_batch(sim.rgb[None], depth=8.0, distance=3.0, path_model=path_model,
                               engine=engine)
        assert abs(b.chl[0] / 2.0 - 1) > 1e-3, engine
