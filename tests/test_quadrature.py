"""The certified spectral quadrature (sca.quadrature): eq 1's integral on 5 nm nodes agrees with
the 1 nm grid to a small fraction of the sensor's noise over the parameter ranges, every fit's
optimum is checked against the full grid, and the estimates and intervals of the default
configuration are the full grid's to within their own uncertainty."""

import numpy as np
import pytest

import forward
import sca
import sca.batch
import sca.verdict as verdict
from forward.sensor import noise_model
from sca import quadrature as Q
from sca.model import ChartModel

RNG = np.random.default_rng(20261126)


def _conditions(n, rng):
    """Clear to coastal water at 1-30 m, 0.5-8 m from the camera, the budget's nuisances
    within 4 sd."""
    return {"chl": 10 ** rng.uniform(-2, 1.3, n), "cdom": 10 ** rng.uniform(-3, 0.3, n),
            "depth": rng.uniform(1, 30, n), "distance": rng.uniform(0.5, 8, n),
            "cdom_slope": 0.014 + rng.uniform(-0.01, 0.01, n),
            "nap_slope": 0.011 + rng.uniform(-0.01, 0.01, n),
            "camera_shift": rng.uniform(-4, 4, (n, 3)), "balance": rng.uniform(-0.04, 0.04, (n, 3))}


def test_the_rule_is_certified_on_its_validation_snapshots_and_cached_by_content():
    setup = forward.chart_setup()
    rule = Q.quadrature_rule(ChartModel(setup))
    assert rule.error <= Q.CERTIFIED_ERROR
    np.testing.assert_array_equal(setup.wavelengths[rule.index], np.arange(400.0, 701.0, 5.0))
    # the same numbers give the same rule; other numbers another
    assert Q.quadrature_rule(ChartModel(forward.chart_setup())) is rule
    other = forward.chart_setup(channel_gains=(0.5, 1.0, 0.8))
    assert Q.quadrature_rule(ChartModel(other)) is not rule
    # a coarse grid is not reduced
    coarse = ChartModel(forward.chart_setup(wavelengths=np.arange(400.0, 701.0, 10.0)))
    assert Q.quadrature_rule(coarse) is None and coarse.reduced() is coarse


@pytest.mark.parametrize("path_model", forward.PATH_MODELS)
def test_reduced_predictions_are_within_a_twentieth_of_the_sensors_noise(path_model):
    """Over the parameter ranges, at the default sensor's noise (daylight and a dim scene),
    every patch value of every chart the sensor does not call dark."""
    setup = forward.chart_setup()
    full = ChartModel(setup, water=forward.Water(path_model=path_model))
    small = full.reduced()
    params = _conditions(3000, RNG)
    M0 = full.predict(params, jacobian=False).values.reshape(-1, 3, 24)
    for lux in (20000.0, 200.0):
        sensor = forward.SensorSettings(illuminance_lux=lux)
        sigma, _, _, _ = noise_model(M0, setup, sensor)
        err = Q.reduction_error(full, small, params, sigma.reshape(len(M0), -1))
        bright = M0.max(axis=(1, 2)) >= Q.DARKEST
        assert bright.mean() > 0.8
        assert np.max(err[bright]) <= Q.CERTIFY_SIGMA, (lux, np.max(err[bright]))


def _stack(n, seed):
    rng = np.random.default_rng(seed)
    c = _conditions(n, rng)
    sims = [forward.simulate_chart(c["chl"][i], c["cdom"][i], c["depth"][i] / 2,
                                   c["distance"][i] / 2, seed=seed + i) for i in range(n)]
    return (np.array([s.rgb for s in sims]), np.array([s.rgb_sigma for s in sims]),
            np.array([s.depth for s in sims]), np.array([s.distance for s in sims]))


@pytest.mark.slow
def test_the_default_configuration_is_the_full_grids_within_its_own_uncertainty():
    """The batch at its defaults (the budget, three path models, intervals): every estimate
    within 0.05 of its standard error (the 95 % interval's half-width / 1.96) of the same fit on
    the 1 nm grid, every interval end within 1 % of the interval's width."""
    M, S, D, R = _stack(24, 300)
    red = sca.estimate_batch(M, depth=D, distance=R, sigma=S)
    full = sca.estimate_batch(M, depth=D, distance=R, sigma=S, quadrature="full")
    assert np.array_equal(red.reliable, full.reliable)
    for name in ("chl", "cdom"):
        a, b = red.intervals[name], full.intervals[name]
        closed = np.all(np.isfinite(b), axis=1)
        width = b[closed, 1] - b[closed, 0]
        se = width / (2 * 1.959964)
        assert np.all(np.abs(red.values[name][closed] - full.values[name][closed])
                      <= 0.05 * se + 1e-12), name
        assert np.all(np.abs(a[closed] - b[closed]) <= 0.01 * width[:, None] + 1e-12), name
        assert np.array_equal(np.isfinite(a), np.isfinite(b)), name


def test_one_chart_is_the_full_grids_within_its_own_uncertainty():
    M, S, D, R = _stack(3, 500)
    for i in range(3):
        kw = dict(depth=D[i], distance=R[i], sigma=S[i], mode="lm")
        red, full = sca.estimate(M[i], **kw), sca.estimate(M[i], **kw, quadrature="full")
        assert red.reliable == full.reliable
        for name in ("chl", "cdom"):
            lo, hi = full.intervals[name]
            if np.isfinite(hi):
                assert abs(red.values[name] - full.values[name]) <= 0.05 * (hi - lo) / 3.92
                np.testing.assert_allclose(red.intervals[name], full.intervals[name], rtol=0,
                                           atol=0.01 * (hi - lo))
        # the spectrum is reported on the full grid
        assert red.attenuation.shape == full.attenuation.shape == (301,)


def test_a_failed_certificate_is_a_fit_on_the_full_grid(monkeypatch):
    """Where the reduced optimum is not certified, the chart is fitted again on the full grid:
    with a certificate no fit can pass, every result is the full grid's."""
    M, S, D, R = _stack(4, 700)
    full = sca.estimate_batch(M, depth=D, distance=R, sigma=S, uncertain={}, quadrature="full")
    one = sca.estimate(M[0], depth=D[0], distance=R[0], sigma=S[0], uncertain={}, mode="lm",
                       quadrature="full")
    monkeypatch.setattr(sca.batch, "CERTIFY_SIGMA", -1.0)
    monkeypatch.setattr(verdict, "CERTIFY_SIGMA", -1.0)
    red = sca.estimate_batch(M, depth=D, distance=R, sigma=S, uncertain={})
    np.testing.assert_allclose(red.chl, full.chl, rtol=1e-9)
    np.testing.assert_allclose(red.chl_ci, full.chl_ci, rtol=1e-9)
    e = sca.estimate(M[0], depth=D[0], distance=R[0], sigma=S[0], uncertain={}, mode="lm")
    # the one chart's refit starts from the reduced optimum: the same minimum, reached from
    # another start (to the Levenberg-Marquardt's tolerance)
    assert e.objective == pytest.approx(one.objective, rel=1e-10)
    assert e.chl == pytest.approx(one.chl, rel=1e-5)
    np.testing.assert_allclose(e.chl_ci, one.chl_ci, rtol=1e-5)


def test_noise_free_charts_are_fitted_exactly():
    """A chart far better fitted than its noise is held to its own residual: a noise-free chart
    (its sensor noise given or not) is the full grid's exact fit."""
    sims = [forward.simulate_chart(c, a, d, r, noise=False)
            for c, a, d, r in ((2.0, 0.3, 10.0, 5.0), (0.1, 0.02, 3.0, 1.0))]
    M = np.array([s.rgb for s in sims])
    for sigma in (None, np.array([s.rgb_sigma for s in sims])):
        b = sca.estimate_batch(M, depth=[10.0, 3.0], distance=[5.0, 1.0], sigma=sigma,
                               uncertain={})
        np.testing.assert_allclose(b.chl, [2.0, 0.1], rtol=1e-6)
        np.testing.assert_allclose(b.cdom, [0.3, 0.02], rtol=1e-6)


def test_bad_quadrature_is_refused():
    sim = forward.simulate_chart(1.0, 0.1, 5.0, 1.0)
    with pytest.raises(ValueError, match="^quadrature"):
        sca.estimate_batch(sim.rgb[None], depth=5.0, distance=1.0, quadrature="coarse")
    with pytest.raises(ValueError, match="^quadrature"):
        sca.estimate(sim.rgb, depth=5.0, distance=1.0, quadrature="coarse")


def test_the_disk_cache_holds_the_same_rule_and_is_rebuilt_when_unreadable(tmp_path,
                                                                          monkeypatch):
    monkeypatch.setenv(Q.CACHE_ENV, str(tmp_path))
    setup = forward.chart_setup(channel_gains=(0.6, 1.0, 0.9))
    key = Q._fingerprint(setup)
    Q._rule.cache_clear()
    built = Q.quadrature_rule(ChartModel(setup))
    files = list((tmp_path / "quadrature").glob("*.npz"))
    assert [f.name for f in files] == [f"{key}.npz"]
    Q._rule.cache_clear()
    loaded = Q.quadrature_rule(ChartModel(setup))
    assert loaded is not built
    for name in ("index", "B", "D"):
        np.testing.assert_array_equal(getattr(loaded, name), getattr(built, name))
    files[0].write_bytes(b"not a rule")
    Q._rule.cache_clear()
    again = Q.quadrature_rule(ChartModel(setup))
    np.testing.assert_array_equal(again.B, built.B)
    Q._rule.cache_clear()


def test_a_chart_scaled_patch_by_patch_reuses_its_shapes_rule_and_stays_certified(tmp_path,
                                                                                monkeypatch):
    """Issue 46 item 5: a light field (a factor per patch, measure.lightfield) builds no rule of
    its own -- the chart's shape's rule, each patch's rows times its factor -- and the reduced
    model of the lit chart is still within a twentieth of the sensor's noise of its full grid."""
    import dataclasses

    monkeypatch.setenv(Q.CACHE_ENV, str(tmp_path))
    builds = []
    real = Q._build
    monkeypatch.setattr(Q, "_build", lambda *a: builds.append(a) or real(*a))
    Q._rule.cache_clear()
    Q._scaled.cache_clear()
    setup = forward.chart_setup(channel_gains=(0.55, 1.0, 0.7))
    base = Q.quadrature_rule(ChartModel(setup))
    rng = np.random.default_rng(46)
    for spread in (1e-3, 0.3):  # a fit step's trial field, and a strong gradient
        field = 1.0 + rng.uniform(-spread, spread, 24)
        lit = dataclasses.replace(setup, reflectances=setup.reflectances * field)
        full = ChartModel(lit)
        rule = full.reduced().rule
        np.testing.assert_allclose(rule.B, base.B * np.tile(field, 3)[:, None], rtol=1e-12)
        np.testing.assert_allclose(rule.D, base.D * np.tile(field, 3)[:, None], rtol=1e-12)
        params = _conditions(1000, rng)
        M0 = full.predict(params, jacobian=False).values.reshape(-1, 3, 24)
        sigma = noise_model(M0, lit, forward.SensorSettings())[0].reshape(len(M0), -1)
        err = Q.reduction_error(full, full.reduced(), params, sigma)
        assert np.max(err[M0.max(axis=(1, 2)) >= Q.DARKEST]) <= Q.CERTIFY_SIGMA
    assert len(builds) == 1
    assert len(list((tmp_path / "quadrature").glob("*.npz"))) == 1
    Q._rule.cache_clear()
    Q._scaled.cache_clear()
