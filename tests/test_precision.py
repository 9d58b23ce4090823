"""The precision bound (sca.precision): against the estimator's spread and its own covariance."""

import numpy as np
import pytest

import forward
import sca


@pytest.mark.parametrize("cond", [(1.0, 0.1, 5.0, 1.0), (0.2, 0.05, 10.0, 1.0)])
def test_bound_matches_the_estimators_spread(cond):
    c, a, d, r = cond
    p = sca.precision(c, a, d, r)
    assert p.attained[0] and p.flags[0] == ()
    sims = [forward.simulate_chart(c, a, d, r, seed=s) for s in range(300)]
    b = sca.estimate_batch(np.array([s.rgb for s in sims]), depth=d, distance=r,
                           sigma=np.array([s.rgb_sigma for s in sims]), intervals=False)
    # 300 draws: the sample SD is within ~8 % (2 SE) of the truth
    assert 0.8 < b.chl.std(ddof=1) / p.chl_sd[0] < 1.25
    assert 0.8 < b.cdom.std(ddof=1) / p.cdom_sd[0] < 1.25
    assert abs(np.corrcoef(b.chl, b.cdom)[0, 1] - p.correlation[0]) < 0.05


def test_bound_equals_the_gauss_newton_covariance_of_a_noise_free_fit():
    for cond in [(1.0, 0.1, 10.0, 5.0), (5.0, 0.5, 3.0, 1.0)]:
        sim = forward.simulate_chart(*cond, noise=False)
        est = sca.estimate(sim.rgb, depth=cond[2], distance=cond[3], sigma=sim.rgb_sigma)
        p = sca.precision(*cond)
        assert est.chl_se == pytest.approx(p.chl_sd[0], rel=1e-6)
        assert est.cdom_se == pytest.approx(p.cdom_sd[0], rel=1e-6)


def test_vectorised_equals_one_by_one_and_options_cost_what_they_should():
    conds = [(0.1, 0.01, 2.0, 1.0), (1.0, 0.1, 10.0, 5.0), (10.0, 0.5, 20.0, 1.0)]
    many = sca.precision(*map(np.array, zip(*conds)))
    for j, c in enumerate(conds):
        one = sca.precision(*c)
        assert one.chl_sd[0] == pytest.approx(many.chl_sd[j], rel=1e-10)
    known = sca.precision(1.0, 0.1, 10.0, 5.0)
    free = sca.precision(1.0, 0.1, 10.0, 5.0, gain="free")
    channels = sca.precision(1.0, 0.1, 10.0, 5.0, gain="channels")
    fixed = sca.precision(1.0, 0.1, 10.0, 5.0, fix={"cdom"})
    assert known.chl_sd[0] <= free.chl_sd[0] <= channels.chl_sd[0]
    assert fixed.chl_sd[0] < known.chl_sd[0] and fixed.cdom_sd[0] == 0
    dim = sca.precision(1.0, 0.1, 10.0, 5.0, sensor=forward.SensorSettings(illuminance_lux=20))
    assert dim.chl_sd[0] > 3 * known.chl_sd[0]


def test_flags_where_the_bound_is_not_attained():
    p = sca.precision([0.0, 100.0], [0.1, 1.0], [5.0, 20.0], [1.0, 5.0])
    assert "near-bound-chl" in p.flags[0] and not p.attained[0]
    assert "dark" in p.flags[1] or "near-bound-chl" in p.flags[1]


@pytest.mark.parametrize("kw,name", [(dict(gain="maybe"), "gain"), (dict(fix={"chl"}), "fix"),
                                     (dict(chl=-1.0), "chl"), (dict(depth=np.nan), "depth"),
                                     (dict(sensor="bright"), "sensor")])
def test_bad_input(kw, name):
    args = dict(chl=1.0, cdom=0.1, depth=5.0, distance=1.0)
    args.update(kw)
    with pytest.raises(ValueError, match=f"^{name}:"):
        sca.precision(**args)
