"""The uncertainty budget (sca.budget): nuisance parameters with Gaussian priors in the one
engine, the per-patch term in the noise, each source's share of the variance."""

import dataclasses

import numpy as np
import pytest

import forward
import sca
from sca.budget import DEFAULT_UNCERTAIN, parse_sd, resolve_budget, variance_shares

SETUP = forward.chart_setup(wavelengths=np.arange(400.0, 701.0, 10.0))


def central(f, x, h):
    return (f(x + h) - f(x - h)) / (2 * h)


@pytest.mark.parametrize("name", ["balance", "camera_shift"])
def test_camera_nuisance_jacobians_equal_finite_differences(name):
    mdl = sca.ChartModel(SETUP)
    beta, delta = np.array([0.02, -0.01, 0.03]), np.array([0.5, -1.0, 0.3])
    p = dict(chl=1.3, cdom=0.2, depth=6.0, distance=2.0, gain=1.7, backscatter=np.full(3, 0.01),
             balance=beta, camera_shift=delta)
    J = mdl.predict(p, ("chl", "balance", "camera_shift")).column(name)
    for c in range(3):
        def f(x, c=c):
            v = p[name].copy()
            v[c] = x
            return mdl.predict({**p, name: v}, jacobian=False).values
        assert J[:, c] == pytest.approx(central(f, p[name][c], 1e-6), rel=1e-5, abs=1e-12)


def test_camera_shift_is_the_first_order_of_a_shifted_curve():
    """The model's shift of the curves agrees with curves shifted by interpolation to first
    order (the error is second order in the shift)."""
    setup = forward.chart_setup()  # 1 nm: the curves' derivative resolved
    wl = setup.wavelengths
    mdl = sca.ChartModel(setup)
    p = dict(chl=1.0, cdom=0.1, depth=5.0, distance=1.0)
    for d in (0.5, 1.0):
        P = np.column_stack([np.interp(wl - d, wl, setup.sensitivities[:, c]) for c in range(3)])
        shifted = sca.ChartModel(dataclasses.replace(setup, sensitivities=P))
        truth = shifted.predict(p, jacobian=False).values
        model = mdl.predict({**p, "camera_shift": np.full(3, d)}, jacobian=False).values
        base = mdl.predict(p, jacobian=False).values
        assert np.max(np.abs(model - truth)) < 0.1 * np.max(np.abs(truth - base))


def test_balance_multiplies_the_signal_not_the_backscatter():
    mdl = sca.ChartModel(SETUP)
    beta = np.array([0.02, -0.01, 0.03])
    p = dict(chl=1.3, cdom=0.2, depth=6.0, distance=2.0, gain=1.7, backscatter=np.full(3, 0.01),
             balance=beta)
    # balance multiplies each channel's signal, not the backscatter
    base = mdl.predict({**p, "balance": np.zeros(3)}, jacobian=False)
    got = mdl.predict(p, jacobian=False)
    G0, G1 = base.signal.reshape(3, 24), got.signal.reshape(3, 24)
    assert G1 == pytest.approx(G0 * (1 + beta)[:, None], rel=1e-12)


@pytest.mark.parametrize("bad,msg", [({"foo": 1}, "unknown name"), ({"depth": -1}, ">= 0"),
                                     ({"depth": "5"}, "percentage"), ({"cdom_slope": "5%"},
                                                                      "percentage needs"),
                                     ([("depth", 1)], "dict")])
def test_bad_budgets_are_refused_naming_the_argument(bad, msg):
    with pytest.raises(ValueError, match="uncertain") as exc:
        resolve_budget(bad, depth=5.0, distance=1.0, water=forward.Water())
    assert msg in str(exc.value)


def test_percentages_refer_to_the_value_and_free_or_fixed_names_get_no_prior():
    assert parse_sd("distance", "5%", 2.0) == pytest.approx(0.1)
    b = resolve_budget({"distance": "10%", "cdom_slope": 0.002, "depth": 0.0}, depth=5.0,
                       distance=[1.0, 3.0], water=forward.Water())
    assert b.priors["distance"][1] == pytest.approx([0.1, 0.3])
    assert "depth" not in b.priors  # sd 0: exact
    b = resolve_budget(DEFAULT_UNCERTAIN, depth=5.0, distance=1.0, water=forward.Water(),
                       free=("cdom_slope",), fixed=("nap_slope",))
    assert "cdom_slope" not in b.priors and "nap_slope" not in b.priors
    assert resolve_budget({}, depth=5.0, distance=1.0, water=forward.Water()).exact


def _chart(seed=3, depth=6.0, distance=1.5):
    return forward.simulate_chart(1.5, 0.15, depth, distance, seed=seed, setup=SETUP)


def test_a_tiny_prior_is_the_exact_model_and_a_wide_one_frees_the_parameter():
    s = _chart()
    kw = dict(depth=6.0, distance=1.5, sigma=s.rgb_sigma, setup=SETUP)
    exact = sca.estimate_batch(s.rgb[None], uncertain={}, **kw)
    tiny = sca.estimate_batch(s.rgb[None], uncertain={"cdom_slope": 1e-9}, **kw)
    assert tiny.chl[0] == pytest.approx(exact.chl[0], rel=1e-5)
    assert tiny.chl_ci[0] == pytest.approx(exact.chl_ci[0], rel=1e-3)
    free = sca.estimate_batch(s.rgb[None], uncertain={}, free=("cdom_slope",), **kw)
    wide = sca.estimate_batch(s.rgb[None], uncertain={"cdom_slope": 10.0}, **kw)
    assert wide.values["cdom_slope"][0] == pytest.approx(free.values["cdom_slope"][0], rel=1e-3)
    assert wide.chl_ci[0] == pytest.approx(free.chl_ci[0], rel=2e-2)


def test_single_and_batch_reach_the_same_penalised_optimum():
    s = _chart(seed=5)
    kw = dict(depth=6.0, distance=1.5, sigma=s.rgb_sigma, setup=SETUP, gain="free")
    b = sca.estimate_batch(s.rgb[None] * 300.0, **{**kw, "sigma": s.rgb_sigma * 300.0})
    for fn in (sca.estimate, sca.estimate_least_squares):
        e = fn(s.rgb * 300.0, **{**kw, "sigma": s.rgb_sigma * 300.0})
        assert e.uncertain == DEFAULT_UNCERTAIN and b.uncertain == DEFAULT_UNCERTAIN
        assert e.chl == pytest.approx(b.chl[0], rel=1e-3), fn
        assert e.chl_ci == pytest.approx(tuple(b.chl_ci[0]), rel=1e-2), fn
        assert e.nuisance["depth"] == pytest.approx(b.values["depth"][0], abs=1e-3)
        assert e.budget["chl"]["sd"] == pytest.approx(b.budget["chl"]["sd"][0], rel=1e-3)


def test_shares_add_up_and_agree_with_the_bound():
    s = _chart()
    e = sca.estimate(s.rgb, depth=6.0, distance=1.5, sigma=s.rgb_sigma, setup=SETUP)
    for name in ("chl", "cdom"):
        assert sum(e.budget[name]["shares"].values()) == pytest.approx(1.0, rel=1e-9)
        assert set(e.budget[name]["shares"]) == {"noise", "patch", "depth", "distance",
                                                 "cdom_slope", "nap_slope", "balance",
                                                 "camera_shift", "daylight"}
    p = sca.precision(1.5, 0.15, depth=6.0, distance=1.5, setup=SETUP)
    assert sum(p.budget["chl"]["shares"].values()) == pytest.approx(1.0, rel=1e-9)
    assert p.limiting in p.budget["chl"]["shares"]
    # the bound's sd is the linearised sd of the budget, larger than the camera's own
    assert p.chl_sd == pytest.approx(p.budget["chl"]["sd"], rel=1e-6)
    assert p.chl_sd > 3 * sca.precision(1.5, 0.15, depth=6.0, distance=1.5, setup=SETUP,
                                        uncertain={}).chl_sd


def test_variance_shares_of_a_linear_model_are_exact():
    """y = a x1 + b x2 with a prior on b: var(a) splits into the noise's and the prior's."""
    rng = np.random.default_rng(0)
    X = rng.normal(size=(1, 50, 2))
    w2 = np.full((1, 50), 4.0)
    out = variance_shares(X, ["a", "b"], w2, w2, np.ones((1, 2), bool), np.array([[0.0, 9.0]]),
                          of=("a",))
    F = X[0].T @ (4.0 * X[0]) + np.diag([0.0, 9.0])
    S = np.linalg.inv(F)
    assert out["a"]["sd"][0] == pytest.approx(np.sqrt(S[0, 0]))
    assert out["a"]["shares"]["b"][0] == pytest.approx(S[0, 1] ** 2 * 9.0 / S[0, 0])
    assert out["a"]["shares"]["patch"][0] == pytest.approx(0.0)


@pytest.mark.slow
def test_geometry_told_wrong_within_its_sd_is_covered():
    """Depth told 0.3 m off with sd 0.3 m, distance told 10 % off with sd 10 %: the budget
    covers the truth at about the nominal rate where the exact model has no usable answer."""
    rng = np.random.default_rng(7)
    n = 40
    C = 10 ** rng.uniform(-1, 1, n)
    A = 10 ** rng.uniform(-2, 0, n)
    D = rng.uniform(2, 12, n)
    R = rng.uniform(0.5, 3, n)
    sims = [forward.simulate_chart(C[i], A[i], D[i], R[i], seed=i, setup=SETUP) for i in range(n)]
    M = np.array([s.rgb for s in sims])
    S = np.array([s.rgb_sigma for s in sims])
    told = dict(depth=D + 0.3, distance=R * 1.1)
    unc = {"depth": 0.3, "distance": "10%"}
    b = sca.estimate_batch(M, sigma=S, setup=SETUP, uncertain=unc, **told)
    x = sca.estimate_batch(M, sigma=S, setup=SETUP, uncertain={}, **told)

    def covered(r):
        return (r.chl_ci[:, 0] <= C) & (C <= r.chl_ci[:, 1]) & (r.cdom_ci[:, 0] <= A) & (
            A <= r.cdom_ci[:, 1])
    # two 95 % intervals: >= 90 % expected; 80 % is 3 binomial sd below it for n = 40
    assert covered(b)[b.reliable].mean() >= 0.8 and b.reliable.mean() >= 0.8
    # the exact model either misses the truth or (in forward's own world) calls the fit a
    # misfit: it cannot give a usable answer; the budget does
    assert b.reliable.mean() > x.reliable.mean()


@pytest.mark.parametrize("options,reliable", [
    ({}, True),
    ({"reflectance_sd": 0.005, "camera_shift_nm_sd": 0.5, "camera_gain_sd": 0.01}, True),
    ({"yellowing": 0.03}, True),
    ({"illuminant": "A"}, False),  # calibrated as D65
    ({"camera": "Sigma SDMerill (NPL)"}, False),  # calibrated as the Nikon 5100
])
def test_independent_calibrations_measure_their_systematic_term(options, reliable):
    """In-air calibrations rendered by the independent renderer: realistic charts and cameras
    give a small per-patch term and a reliable profile; the wrong illuminant or the wrong camera
    curves do not (the photon-only chi^2 is far above 1 in every case)."""
    import types

    import measure
    from experiments import independent_world as iw

    out = iw.render_calibration(rng=1, **options)
    sample = types.SimpleNamespace(rgb=out["rgb"] * 1000, sigma=out["sigma"] * 1000,
                                   clipped=np.zeros((3, 24)))
    prof = measure.calibrate(sample)
    assert prof.reliable == reliable and ("systematic" in prof.flags) != reliable
    assert (prof.patch_sd < 0.01) == reliable


def test_a_measured_prior_may_hold_one_centre_per_chart():
    """A batch's charts each with its own measured light (one reference shot each): the
    priors hold them chart by chart; a count that is neither 1 nor the charts' is refused,
    naming the entry, and a dive (one light) refuses a per-chart prior."""
    import numpy as np
    import pytest
    from forward.errors import InputError
    from forward.water import PAPER_WATER
    from sca.budget import resolve_budget

    centres, sds = np.array([10.0, -5.0, 30.0]), np.array([8.0, 9.0, 10.0])
    b = resolve_budget({"daylight": {"centre": centres, "sd": sds}},
                       depth=np.array([2.0, 5.0, 9.0]), distance=1.0, water=PAPER_WATER)
    np.testing.assert_array_equal(b.priors["daylight"][0], centres)
    np.testing.assert_array_equal(b.priors["daylight"][1], sds)
    with pytest.raises(InputError, match="daylight"):
        resolve_budget({"daylight": {"centre": centres[:2], "sd": 8.0}},
                       depth=np.array([2.0, 5.0, 9.0]), distance=1.0, water=PAPER_WATER)
    from sca.joint import _budget
    with pytest.raises(InputError, match="one light"):
        _budget({"daylight": {"centre": centres, "sd": sds}}, PAPER_WATER, np.array([2.0, 5.0, 9.0]),
                np.ones(3), None, None, 0.5)


def test_prior_arrays_put_each_prior_on_every_column_of_its_name():
    """sca.budget.prior_arrays, the one builder of a problem's prior arrays: a name of several
    columns ('balance', one per channel) gets its prior on each, an (N,) prior row by row, a
    name without a prior none (weight 0)."""
    from sca.budget import prior_arrays

    priors = {"balance": (0.0, 0.02), "depth": (np.array([4.0, 9.0]), np.array([0.2, 0.5]))}
    mean, weight = prior_arrays(priors, ("chl", "balance", "balance", "depth"), 2)
    assert mean.shape == weight.shape == (2, 4)
    assert np.all(weight[:, 0] == 0) and np.all(mean[:, 0] == 0)
    assert np.allclose(weight[:, 1:3], 1 / 0.02 ** 2) and np.all(mean[:, 1:3] == 0)
    assert np.allclose(mean[:, 3], [4.0, 9.0]) and np.allclose(weight[:, 3], [25.0, 4.0])
