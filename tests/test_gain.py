"""The free exposure gain (gain="free"): M = gain G(x) + s for data in any units, in every
estimator (the loop, scipy, the batch), its evaluation against finite differences of
forward, its intervals, and sca.precision's gain-free bound against the estimator's spread."""

import numpy as np
import pytest

import forward
import sca
from sca import batch as sca_batch
from sca.charts import ChartProblem as Problem
from sca.lm import evaluate
from sca.model import ChartModel, linear_part

DN = 1234.5  # an arbitrary unit: raw counts per model unit


@pytest.fixture(scope="module")
def chart():
    return forward.simulate_chart(2.0, 0.1, 8.0, 3.0, seed=3)


def _all(rgb, sigma, **kw):
    # every estimator on the grid as given: the same objective (the certified quadrature is
    # tested against it in tests/test_quadrature.py)
    kw.setdefault("quadrature", "full")
    out = {"loop": sca.estimate(rgb, depth=8.0, distance=3.0, sigma=sigma, gain="free", **kw, uncertain={}),
           "scipy": sca.estimate_least_squares(rgb, depth=8.0, distance=3.0, sigma=sigma,
                                               gain="free", **kw, uncertain={})}
    for eng in sca_batch.ENGINES:
        b = sca.estimate_batch(rgb[None], depth=8.0, distance=3.0, sigma=sigma, gain="free",
                               engine=eng, **kw, uncertain={})
        out[eng] = b
    return out


def _get(res, key):
    v = getattr(res, key)
    return np.asarray(v, float).ravel() if not isinstance(v, float) else np.array([v])


def test_every_estimator_reaches_the_same_optimum_in_any_units(chart):
    res = _all(chart.rgb * DN, chart.rgb_sigma * DN)
    ref = res["loop"]
    assert ref.reliable and ref.converged
    for name, r in res.items():
        for key in ("chl", "cdom", "gain"):
            assert _get(r, key)[0] == pytest.approx(_get(ref, key)[0], rel=2e-5), (name, key)
        ci = np.ravel(r.chl_ci)
        assert ci == pytest.approx(np.ravel(ref.chl_ci), rel=1e-4), name
        assert np.ravel(r.gain_ci) == pytest.approx(np.ravel(ref.gain_ci), rel=1e-4), name
    # the truth is inside the intervals, and the gain is the unit
    assert ref.chl_ci[0] <= 2.0 <= ref.chl_ci[1] and ref.cdom_ci[0] <= 0.1 <= ref.cdom_ci[1]
    assert ref.gain_ci[0] <= DN <= ref.gain_ci[1]


def test_the_units_do_not_matter(chart):
    a = sca.estimate(chart.rgb, depth=8.0, distance=3.0, sigma=chart.rgb_sigma, gain="free", uncertain={})
    b = sca.estimate(chart.rgb * DN, depth=8.0, distance=3.0, sigma=chart.rgb_sigma * DN,
                     gain="free", uncertain={})
    assert b.chl == pytest.approx(a.chl, rel=1e-6) and b.gain == pytest.approx(a.gain * DN, rel=1e-6)
    assert b.chl_ci == pytest.approx(a.chl_ci, rel=1e-5)


def test_a_known_gain_with_the_wrong_units_is_a_misfit_not_an_answer(chart):
    r = sca.estimate(chart.rgb * DN, depth=8.0, distance=3.0, sigma=chart.rgb_sigma * DN, uncertain={})
    assert not r.reliable and "misfit" in r.flags


def test_the_free_gain_costs_precision(chart):
    known = sca.estimate(chart.rgb, depth=8.0, distance=3.0, sigma=chart.rgb_sigma, uncertain={})
    free = sca.estimate(chart.rgb, depth=8.0, distance=3.0, sigma=chart.rgb_sigma, gain="free", uncertain={})
    assert free.dof == known.dof - 1
    assert np.diff(free.chl_ci)[0] > np.diff(known.chl_ci)[0]


def test_paper_mode_takes_the_gain_step_too(chart):
    r = sca.estimate(chart.rgb * DN, depth=8.0, distance=3.0, sigma=chart.rgb_sigma * DN,
                     gain="free", mode="paper", uncertain={})
    s = sca.estimate(chart.rgb * DN, depth=8.0, distance=3.0, sigma=chart.rgb_sigma * DN,
                     gain="free", uncertain={})
    assert r.objective >= s.objective * (1 - 1e-9)
    assert r.chl == pytest.approx(s.chl, rel=0.05) and r.gain == pytest.approx(s.gain, rel=0.02)


@pytest.mark.parametrize("chl,cdom", [(0.5, 0.05), (3.0, 0.4)])
def test_free_gain_evaluation_equals_finite_differences_of_forward(chl, cdom):
    """f and the gradient of the batch's evaluation (gain and s profiled out) against central
    differences of the profiled objective built from forward's signal."""
    sim = forward.simulate_chart(1.0, 0.1, 6.0, 2.0, seed=5)
    M = sim.rgb * DN
    scale = float(M.max())
    w2 = (scale / (sim.rgb_sigma * DN)) ** 2
    st = sim.setup
    mdl = ChartModel(st)
    e0 = mdl.e0

    def profiled(u, a):
        k = forward.attenuation(st.wavelengths, u ** (1 / e0), a, 6.0, 2.0)
        G = (forward.camera_response(st.sensitivities, st.illuminant, k, st.reflectances)
             / scale)[None]
        g, s, _ = linear_part((M / scale)[None], G, w2[None])
        r = (M / scale)[None] - g[:, None, None] * G - s[..., None]
        return float(np.sum(w2 * r * r)), float(g[0])

    u = chl ** e0
    prob = Problem(mdl, (M / scale).reshape(1, -1), w2.reshape(1, -1), np.array([scale]),
                   ("chl", "cdom"), {"depth": np.array([6.0]), "distance": np.array([2.0])},
                   free_gain=True)
    ev = evaluate(prob, np.arange(1), np.array([[u, cdom]]), True)
    f, g, H, gain = ev.f, ev.g, ev.H, ev.extras["gain"]
    f_ref, gain_ref = profiled(u, cdom)
    assert f[0] == pytest.approx(f_ref, rel=1e-9) and gain[0] == pytest.approx(gain_ref, rel=1e-9)
    hu, ha = 1e-6 * u, 1e-6 * cdom
    du = (profiled(u + hu, cdom)[0] - profiled(u - hu, cdom)[0]) / (2 * hu)
    da = (profiled(u, cdom + ha)[0] - profiled(u, cdom - ha)[0]) / (2 * ha)
    # g = J^T r = (1/2) d f / d theta (variable projection: exact for the profiled objective)
    assert g[0, 0] == pytest.approx(du / 2, rel=1e-4, abs=1e-8 * abs(f[0]))
    assert g[0, 1] == pytest.approx(da / 2, rel=1e-4, abs=1e-8 * abs(f[0]))
    h = H[0]
    assert h[0, 0] > 0 and h[1, 1] > 0 and h[0, 0] * h[1, 1] > h[0, 1] ** 2


def test_gain_free_bound_matches_the_free_gain_estimators_spread():
    """Issue 12's gain-free rows of sca.precision, validated against the estimator that fits a
    gain: the spread of 300 noisy charts in arbitrary units."""
    c, a, d, r = 1.0, 0.1, 5.0, 1.0
    p = sca.precision(c, a, depth=d, distance=r, gain="free", uncertain={})
    sims = [forward.simulate_chart(c, a, d, r, seed=s) for s in range(300)]
    b = sca.estimate_batch(np.array([s.rgb for s in sims]) * DN, depth=d, distance=r,
                           sigma=np.array([s.rgb_sigma for s in sims]) * DN, intervals=False,
                           gain="free", uncertain={})
    assert np.all(b.converged)
    assert 0.8 < b.chl.std(ddof=1) / p.chl_sd < 1.25
    assert 0.8 < b.cdom.std(ddof=1) / p.cdom_sd < 1.25


def test_gain_interval_coverage_in_a_batch():
    sims = [forward.simulate_chart(1.0, 0.1, 5.0, 1.0, seed=s) for s in range(200)]
    b = sca.estimate_batch(np.array([s.rgb for s in sims]) * DN, depth=5.0, distance=1.0,
                           sigma=np.array([s.rgb_sigma for s in sims]) * DN, gain="free", uncertain={})
    cover_g = np.mean((b.gain_ci[:, 0] <= DN) & (DN <= b.gain_ci[:, 1]))
    cover_c = np.mean((b.chl_ci[:, 0] <= 1.0) & (1.0 <= b.chl_ci[:, 1]))
    # 95 % nominal; 200 draws: binomial 2-SE band ~ +-3 %
    assert 0.90 <= cover_g <= 0.99 and 0.90 <= cover_c <= 0.99


def test_bad_gain_is_refused(chart):
    with pytest.raises(ValueError, match="gain"):
        sca.estimate(chart.rgb, depth=8.0, distance=3.0, gain="maybe", uncertain={})
    with pytest.raises(ValueError, match="gain"):
        sca.estimate_batch(chart.rgb[None], depth=8.0, distance=3.0, gain="maybe", uncertain={})


def test_linear_part_weights_broadcast_over_the_patches():
    """sca.model.linear_part's weights may be a scalar or one per channel: they count once per
    patch (sum w = n w), as the full (N, m, n) array of the same weights does."""
    rng = np.random.default_rng(2)
    G3 = rng.uniform(0.1, 1.0, (5, 3, 24))
    M3 = 2.0 * G3[:1] + 0.05 + 0.01 * rng.standard_normal((1, 3, 24))
    w_ch = np.array([1.0, 4.0, 0.5])[None, :, None]
    for w, full in ((1.0, np.ones((1, 3, 24))), (w_ch, np.broadcast_to(w_ch, (1, 3, 24)))):
        for got, want in zip(linear_part(M3, G3, w), linear_part(M3, G3, full)):
            np.testing.assert_array_equal(got, want)
