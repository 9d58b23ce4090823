"""One physics, one core: the model function equals the simulator, in value and derivative,
and every estimator goes through it.

For both path models and non-default constants of :class:`forward.Water`,
:meth:`sca.ChartModel.predict` is compared with :mod:`forward` (value) and its Jacobian with
finite differences of :mod:`forward`, for every parameter name (C, a_CDOM, every coefficient
of c(x), the geometry, the gain, the backscatter, the free phytoplankton weights). The cvxpy
loop's linearisation, the scipy residual and the batch's evaluation are checked against the
model function. Changing a constant through ``forward.Water`` must move every estimator with it.
"""

import dataclasses

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import forward
import sca
from forward.water import COEFFICIENT_PARAMS
from sca import batch as sca_batch
from sca.charts import ChartProblem as Problem
from sca.lm import evaluate
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
S = np.array([0.01, 0.02, 0.03])  # a backscatter (model units)


def conditions():
    return dict(chl=st.floats(0.02, 50.0), cdom=st.floats(0.0, 1.5), depth=st.floats(0.5, 20.0),
                distance=st.floats(0.2, 8.0))


def forward_chart(water, chl, cdom, depth, distance, gain=1.0, s=S):
    """vec(gain G + s 1^T) from forward's public functions alone."""
    k = forward.attenuation(WL, chl, cdom, depth, distance, water=water)
    G = forward.camera_response(SETUP.sensitivities, SETUP.illuminant, k, SETUP.reflectances)
    return (gain * G + np.asarray(s)[:, None]).ravel()


def forward_at(water, point, name, value):
    """forward's chart with parameter ``name`` replaced by ``value``."""
    p = dict(point)
    if name in COEFFICIENT_PARAMS:
        water = dataclasses.replace(water, **{name: value})
    else:
        p[name] = value
    return forward_chart(water, **p)


def central(fn, x, h):
    return (fn(x + h) - fn(x - h)) / (2 * h)


# ------------------------------------------------------------------------- the model function
@pytest.mark.parametrize("name", sorted(WATERS))
@given(**conditions())
def test_model_equals_forward(name, chl, cdom, depth, distance):
    water = WATERS[name]
    mdl = sca.ChartModel(SETUP, water=water)
    pred = mdl.predict({"chl": chl, "cdom": cdom, "depth": depth, "distance": distance,
                        "gain": 1.7, "backscatter": S}, jacobian=False)
    ref = forward_chart(water, chl, cdom, depth, distance, gain=1.7)
    assert pred.values == pytest.approx(ref, rel=1e-10, abs=1e-14)


SCALARS = ("chl", "cdom", "depth", "distance", "gain") + COEFFICIENT_PARAMS


@pytest.mark.parametrize("name", sorted(WATERS))
def test_every_parameter_jacobian_equals_finite_differences_of_forward(name):
    """Every name the model differentiates by, against central differences of forward."""
    water = WATERS[name]
    mdl = sca.ChartModel(SETUP, water=water)
    point = dict(chl=1.3, cdom=0.2, depth=6.0, distance=2.0, gain=1.0, s=S)
    params = {"chl": 1.3, "cdom": 0.2, "depth": 6.0, "distance": 2.0, "gain": 1.0,
              "backscatter": S}
    pred = mdl.predict(params, SCALARS + ("backscatter",))
    for j, p in enumerate(SCALARS):
        v = point[p] if p in point else float(getattr(water, p))
        h = 1e-5 * max(abs(v), 1e-2)
        fd = central(lambda x: forward_at(water, point, p, x), v, h)
        col = pred.column(p)[:, 0]
        scale = max(np.max(np.abs(fd)), 1e-300)
        if water.path_model == "absorption" and not np.any(fd):  # a scattering constant
            assert not np.any(col), p
            continue
        assert np.max(np.abs(col - fd)) <= 1e-5 * scale, (name, p)
    E = pred.column("backscatter")
    assert E.shape == (72, 3) and np.all(E.sum(axis=1) == 1)


def test_free_weights_jacobian_equals_finite_differences():
    """'w' (eq 9's weights, the loop's variables): a_phi = T w replaces eq 10."""
    mdl = sca.ChartModel(SETUP)
    w = np.array([0.02])
    p = {"chl": 1.0, "cdom": 0.1, "depth": 5.0, "distance": 1.0, "w": w}
    J = mdl.predict(p, ("w", "chl"), chl_floor=sca.CHL_DERIVATIVE_FLOOR).column("w")[:, 0]

    def f(x):
        return mdl.predict({**p, "w": np.array([x])}, jacobian=False).values
    assert J == pytest.approx(central(f, 0.02, 1e-7), rel=1e-5, abs=1e-12)


def test_scaled_model_builds_its_shift_projection_from_its_own_scale():
    """The camera-shift projection (Dt, [Bt Dt]) is built on first use: a scaled copy's is its
    model's divided by the factor, whether the model built its own before or after the copy."""
    p = {"chl": 1.0, "cdom": 0.1, "depth": 5.0, "distance": 1.0,
         "camera_shift": np.array([1.0, -2.0, 0.5])}
    plain = sca.ChartModel(SETUP).scaled(3.0)
    plain.predict({k: v for k, v in p.items() if k != "camera_shift"}, ("chl",))
    assert "Dt" not in plain.__dict__ and "BDt" not in plain.__dict__  # not built without a shift
    for built_first in (False, True):
        mdl = sca.ChartModel(SETUP)
        if built_first:
            assert mdl.BDt.shape == (WL.size, 2 * 72)
        half = mdl.scaled(2.0)
        quarter = half.scaled(2.0)
        np.testing.assert_array_equal(half.Dt, mdl.Dt / 2.0)
        np.testing.assert_array_equal(quarter.Dt, mdl.Dt / 2.0 / 2.0)
        np.testing.assert_array_equal(quarter.BDt, np.hstack([quarter.Bt, quarter.Dt]))
        full = mdl.predict(p, jacobian=False).values
        np.testing.assert_allclose(half.predict(p, jacobian=False).values * 2.0, full,
                                   rtol=1e-14)


def test_unknown_or_inert_names_are_refused():
    mdl = sca.ChartModel(SETUP)
    p = {"chl": 1.0, "depth": 5.0, "distance": 1.0}
    with pytest.raises(ValueError, match="^free:"):
        mdl.predict(p, ("turbidity",))
    with pytest.raises(ValueError, match="^free:"):
        sca.estimate(np.ones((3, 24)), depth=5, distance=1, free=("water_backscatter_fraction",), uncertain={})
    with pytest.raises(ValueError, match="^fix:"):
        sca.estimate(np.ones((3, 24)), depth=5, distance=1, fix={"cdom"}, uncertain={})


# ------------------------------------------------------------------------- every path uses it
@pytest.mark.parametrize("name", sorted(WATERS))
def test_every_estimator_path_equals_the_model_function(name):
    water = WATERS[name]
    sim = forward.simulate_chart(1.3, 0.2, 6.0, 2.0, water=water, seed=1)
    est = sca.Estimator(depth=6.0, distance=2.0, water=water, free=("cdom_slope",), uncertain={})
    st_ = est.prepare(sim.rgb, sim.rgb_sigma)
    mdl = st_.mdl
    x = {"chl": 1.3, "cdom": 0.2, "w": mdl.feasible_w(1.3), "gain": 1.0, "s": S,
         "cdom_slope": 0.016}
    ref = mdl.predict({"chl": 1.3, "cdom": 0.2, "depth": 6.0, "distance": 2.0,
                       "backscatter": S, "cdom_slope": 0.016},
                      ("chl", "cdom", "cdom_slope", "backscatter"),
                      chl_floor=sca.CHL_DERIVATIVE_FLOOR)
    # the scipy residual and its Jacobian
    fun, jac, unpack, _ = residual_functions(est, st_)
    v = np.array([1.3, 0.2, 0.016, *S])
    assert fun(v) == pytest.approx(st_.wt * (st_.Mv - ref.values), rel=1e-12, abs=1e-12)
    assert jac(v) == pytest.approx(-ref.jacobian * st_.wt[:, None], rel=1e-12, abs=1e-12)
    # the loop's linearisation: the same columns, scaled
    st_.x = x
    lin = est._linearise(st_)
    Jw = mdl.predict(est.params(x), est.order, chl_floor=sca.CHL_DERIVATIVE_FLOOR).jacobian
    assert lin.AE[:, :Jw.shape[1]] == pytest.approx(Jw * lin.scales * st_.wt[:, None], rel=1e-12)
    # the batch's evaluation: its objective is the model's residual at the closed-form s
    prob = Problem(mdl, st_.Mv[None], (st_.wt ** 2)[None], np.ones(1), ("chl", "cdom", "cdom_slope"),
                   {"depth": np.array([6.0]), "distance": np.array([2.0])})
    ev = evaluate(prob, np.arange(1), np.array([[1.3 ** mdl.e0, 0.2, 0.016]]))
    f, g, s = ev.f, ev.g, ev.extras["s"]
    pred = mdl.predict({"chl": 1.3, "cdom": 0.2, "depth": 6.0, "distance": 2.0,
                        "backscatter": s[0], "cdom_slope": 0.016}, jacobian=False)
    r = st_.wt * (st_.Mv - pred.values)
    assert f[0] == pytest.approx(r @ r, rel=1e-12)
    # and its gradient is half the derivative of the profiled objective
    for j, h in ((1, 1e-6), (2, 1e-7)):
        th = np.array([[1.3 ** mdl.e0, 0.2, 0.016]])
        hi, lo = th.copy(), th.copy()
        hi[0, j] += h
        lo[0, j] -= h
        d = (evaluate(prob, np.arange(1), hi, False).f - evaluate(prob, np.arange(1), lo, False).f) / (2 * h)
        assert g[0, j] == pytest.approx(d[0] / 2, rel=1e-4, abs=1e-8 * f[0])


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
    for arr in (*w.pure_water_absorption_table, *w.phytoplankton_basis_table):
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
        "sca": sca.estimate(sim.rgb, depth=8.0, distance=3.0, water=water, uncertain={}),
        "scipy": sca.estimate_least_squares(sim.rgb, depth=8.0, distance=3.0, water=water, uncertain={}),
    }
    for engine in sca_batch.ENGINES:
        b = sca.estimate_batch(sim.rgb[None], depth=8.0, distance=3.0, water=water, engine=engine, uncertain={})
        fits[engine] = b
    for name, e in fits.items():
        chl, cdom = float(np.ravel(e.chl)[0]), float(np.ravel(e.cdom)[0])
        assert abs(chl / 2.0 - 1) < 1e-6 and abs(cdom / 0.3 - 1) < 1e-6, (name, chl, cdom)
    # and the paper's constants do not fit this water: the estimators did use `water`
    wrong = sca.estimate(sim.rgb, depth=8.0, distance=3.0, path_model=path_model, uncertain={})
    assert abs(wrong.chl / 2.0 - 1) > 1e-3
    for engine in sca_batch.ENGINES:
        b = sca.estimate_batch(sim.rgb[None], depth=8.0, distance=3.0, path_model=path_model,
                               engine=engine, uncertain={})
        assert abs(b.chl[0] / 2.0 - 1) > 1e-3, engine
