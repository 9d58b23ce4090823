"""The precision bound (sca.precision): against the estimator's spread and its own covariance."""

import numpy as np
import pytest

import forward
import sca


@pytest.mark.parametrize("cond", [(1.0, 0.1, 5.0, 1.0), (0.2, 0.05, 10.0, 1.0)])
def test_bound_matches_the_estimators_spread(cond):
    c, a, d, r = cond
    p = sca.precision(c, a, depth=d, distance=r, uncertain={})
    assert p.attained and p.flags == ()
    sims = [forward.simulate_chart(c, a, d, r, seed=s) for s in range(300)]
    b = sca.estimate_batch(np.array([s.rgb for s in sims]), depth=d, distance=r,
                           sigma=np.array([s.rgb_sigma for s in sims]), intervals=False, uncertain={})
    # 300 draws: the sample SD's standard error is 1 / sqrt(2 * 299) = 4.1 %, so the ratio
    # lies within 3 SE (12 %) of 1 where the bound is attained
    assert 0.88 < b.chl.std(ddof=1) / p.chl_sd < 1.12
    assert 0.88 < b.cdom.std(ddof=1) / p.cdom_sd < 1.12
    assert abs(np.corrcoef(b.chl, b.cdom)[0, 1] - p.correlation) < 0.05


def test_bound_equals_the_gauss_newton_covariance_of_a_noise_free_fit():
    for cond in [(1.0, 0.1, 10.0, 5.0), (5.0, 0.5, 3.0, 1.0)]:
        sim = forward.simulate_chart(*cond, noise=False)
        est = sca.estimate(sim.rgb, depth=cond[2], distance=cond[3], sigma=sim.rgb_sigma, uncertain={})
        p = sca.precision(cond[0], cond[1], depth=cond[2], distance=cond[3], uncertain={})
        assert est.chl_se == pytest.approx(p.chl_sd, rel=1e-6)
        assert est.cdom_se == pytest.approx(p.cdom_sd, rel=1e-6)


def test_vectorised_equals_one_by_one_and_options_cost_what_they_should():
    conds = [(0.1, 0.01, 2.0, 1.0), (1.0, 0.1, 10.0, 5.0), (10.0, 0.5, 20.0, 1.0)]
    c, a, d, r = map(np.array, zip(*conds))
    many = sca.precision(c, a, depth=d, distance=r, uncertain={})
    for j, c in enumerate(conds):
        one = sca.precision(c[0], c[1], depth=c[2], distance=c[3], uncertain={})
        assert isinstance(one.chl_sd, float)  # a scalar condition gives scalars
        assert one.chl_sd == pytest.approx(many.chl_sd[j], rel=1e-10)
    kw = dict(depth=10.0, distance=5.0)
    known = sca.precision(1.0, 0.1, **kw, uncertain={})
    free = sca.precision(1.0, 0.1, gain="free", **kw, uncertain={})
    channels = sca.precision(1.0, 0.1, gain="channels", **kw, uncertain={})
    fixed = sca.precision(1.0, 0.1, fix={"cdom": None}, **kw, uncertain={})
    assert known.chl_sd <= free.chl_sd <= channels.chl_sd
    assert fixed.chl_sd < known.chl_sd and fixed.cdom_sd == 0
    # a fixed value is used, not ignored: another a_CDOM gives another bound
    other = sca.precision(1.0, 0.1, fix={"cdom": 0.5}, **kw, uncertain={})
    assert other.cdom == 0.5 and other.chl_sd != pytest.approx(fixed.chl_sd, rel=1e-3)
    dim = sca.precision(1.0, 0.1, sensor=forward.SensorSettings(illuminance_lux=20), **kw, uncertain={})
    assert dim.chl_sd > 3 * known.chl_sd


def test_flags_where_the_bound_is_not_attained():
    p = sca.precision([0.0, 100.0], [0.1, 1.0], depth=[5.0, 20.0], distance=[1.0, 5.0], uncertain={})
    assert "near-bound-chl" in p.flags[0] and not p.attained[0]
    assert "dark" in p.flags[1] or "near-bound-chl" in p.flags[1]


@pytest.mark.parametrize("kw,name", [(dict(gain="maybe"), "gain"), (dict(fix={"cdom"}), "fix"),
                                     (dict(fix={"chl": 1.0}), "fix"),
                                     (dict(chl=-1.0), "chl"), (dict(depth=np.nan), "depth"),
                                     (dict(sensor="bright"), "sensor")])
def test_bad_input(kw, name):
    args = dict(chl=1.0, cdom=0.1, depth=5.0, distance=1.0)
    args.update(kw)
    with pytest.raises(ValueError, match=f"^{name}:"):
        sca.precision(**args, uncertain={})
