"""The path model decided by the data (sca.pathmodels): the 'split' model's physics through the
one core, the likelihood-ratio choice, and intervals that span what the data cannot decide."""

import numpy as np
import pytest

import forward
import sca
from sca.pathmodels import PATH_MODEL_DELTA, SPAN_FLAG, candidates, supported

SETUP = forward.chart_setup(wavelengths=np.arange(400.0, 701.0, 5.0))
SPLIT = forward.Water(path_model="split")


def test_split_is_kd_down_and_c_along_the_view():
    wl = SETUP.wavelengths
    terms = SPLIT.on_grid(wl)
    chl, cdom, depth, distance = 1.3, 0.2, 6.0, 2.0
    a = terms.absorption(chl, cdom)
    bb = terms.backscattering(chl)
    c = terms.beam_coefficient(chl, cdom)
    kd = (a + bb) / SPLIT.downwelling_cosine
    k = forward.attenuation(wl, chl, cdom, depth, distance, water=SPLIT)
    assert k == pytest.approx(np.exp(-depth * kd - distance * c), rel=1e-12)
    # the paper's model is untouched
    beam = forward.attenuation(wl, chl, cdom, depth, distance)
    assert beam == pytest.approx(np.exp(-(depth + distance) * c), rel=1e-12)


@pytest.mark.parametrize("name", ["chl", "cdom", "depth", "distance", "cdom_slope", "nap_slope",
                                  "b_k", "gamma_12"])
def test_split_jacobian_equals_finite_differences(name):
    mdl = sca.ChartModel(SETUP, water=SPLIT)
    p = dict(chl=1.3, cdom=0.2, depth=6.0, distance=2.0, gain=1.0, backscatter=np.zeros(3))
    col = mdl.predict(p, (name,), chl_floor=1e-9).column(name)[:, 0]
    v = p.get(name, getattr(SPLIT, name, None))
    h = 1e-6 * max(abs(v), 1e-2)
    fd = (mdl.predict({**p, name: v + h}, jacobian=False).values
          - mdl.predict({**p, name: v - h}, jacobian=False).values) / (2 * h)
    assert np.max(np.abs(col - fd)) <= 1e-5 * np.max(np.abs(fd))
    pred = mdl.predict(p, jacobian=False)
    sim = forward.simulate_chart(1.3, 0.2, 6.0, 2.0, water=SPLIT, noise=False, backscatter=False,
                                 setup=SETUP)
    assert pred.values == pytest.approx(sim.rgb_expected.ravel(), rel=1e-12, abs=1e-15)


def test_candidates_and_support():
    w = forward.Water()
    assert candidates(None, w, True) == ("beam", "absorption", "split")
    assert candidates(None, w, False) == ("beam",)
    assert candidates(("split",), w, True) == ("beam", "split")
    with pytest.raises(ValueError, match="path_models"):
        candidates(("straight",), w, True)
    best, ok = supported(np.array([[10.0, 12.0, 10.0 + PATH_MODEL_DELTA + 1e-9]]))
    assert best[0] == 0 and ok[0].tolist() == [True, True, False]


@pytest.mark.parametrize("truth", ["beam", "split"])
def test_the_data_choose_the_path_model_or_the_intervals_span(truth):
    water = forward.Water(path_model=truth)
    s = forward.simulate_chart(2.0, 0.2, 8.0, 1.5, seed=4, water=water, setup=SETUP)
    kw = dict(depth=8.0, distance=1.5, setup=SETUP)
    b = sca.estimate_batch(s.rgb[None], sigma=s.rgb_sigma[None], **kw)
    e = sca.estimate(s.rgb, sigma=s.rgb_sigma, **kw)
    assert truth in b.path_models[0] and truth in e.path_models
    assert b.chl_ci[0, 0] <= 2.0 <= b.chl_ci[0, 1] and e.chl_ci[0] <= 2.0 <= e.chl_ci[1]
    assert e.chl == pytest.approx(b.chl[0], rel=1e-3)
    assert set(e.path_objective) == {"beam", "absorption", "split"}
    if truth == "split":  # the downwelling leg's K_d is far from c: the data decide
        assert e.path_models == ("split",) and SPAN_FLAG not in e.flags
    # one spanned model: the interval is the union of the supported models' intervals
    if len(e.path_models) > 1:
        assert SPAN_FLAG in e.flags
        for m in e.path_models:
            one = sca.estimate(s.rgb, sigma=s.rgb_sigma, path_models=(m,),
                               water=forward.Water(path_model=m), **kw)
            assert e.chl_ci[0] <= one.chl_ci[0] + 1e-12 and one.chl_ci[1] <= e.chl_ci[1] + 1e-12
    # the paper's exact model cannot see the path model: a split world is a misfit for it
    if truth == "split":
        x = sca.estimate_batch(s.rgb[None], sigma=s.rgb_sigma[None], uncertain={}, **kw)
        assert x.path_models[0] == ("beam",) and not x.reliable[0]
