"""Readings tested against the photos (issue 45, item 1; sca.consistency): a wrong water sample
or Secchi depth is flagged, never believed; a right one still narrows the answer; a joint fit
never drops a photo to agree with a reading."""

import numpy as np
import pytest

import forward
import sca
from forward.imaging import resolve_setup
from measure.joint import fit_joint
from measure.statements import statements
from sca.assess import CONFLICT_P
from sca.consistency import PULL_MAX, nuisance_pulls, reading_tests
from sca.joint import estimate_joint

#: The issue's water: C 1.5 mg m^-3, a_CDOM(440) 0.15 m^-1, 5 m deep, 1.5 m away.
CHL, CDOM, DEPTH, DIST = 1.5, 0.15, 5.0, 1.5
SETUP = resolve_setup(None, forward.DEFAULT_CAMERA, None, None, None)


@pytest.fixture(scope="module")
def chart():
    return forward.simulate_chart(CHL, CDOM, depth=DEPTH, distance=DIST, seed=3)


def _fit(sim, aux):
    return sca.estimate(sim.rgb, depth=DEPTH, distance=DIST, sigma=sim.rgb_sigma, gain="free",
                        auxiliary=aux)


@pytest.mark.parametrize("aux, name", [({"cdom": (0.45, 0.02)}, "cdom"),      # 3x the truth
                                       ({"cdom": (1.5, 0.05)}, "cdom"),       # 10x
                                       ({"secchi": (2.0, 0.1)}, "secchi")])   # truth ~30 m
def test_a_reading_that_contradicts_the_photos_is_flagged_not_believed(chart, aux, name):
    e = _fit(chart, aux)
    assert not e.reliable and "reading-conflict" in e.flags
    rec = e.consistency["readings"][name]
    assert rec["conflict"] and rec["p"] < CONFLICT_P and rec["delta_chi2"] > 10.8
    # the user is told which reading and by how much
    said = [s for s in statements(e) if "contradicts" in s]
    assert len(said) == 1 and name in said[0] and "Delta chi^2" in said[0]


def test_the_wrong_reading_was_a_confident_wrong_answer_before_the_test(chart):
    """Without the test the fit is reliable-looking: the truth lies outside the interval of
    a_CDOM (this is what the flag is for, not a property of the flag)."""
    e = _fit(chart, {"cdom": (0.45, 0.02)})
    assert not e.cdom_ci[0] <= CDOM <= e.cdom_ci[1]
    others = [f for f in e.flags if f in sca.assess.BLOCKING
              and f not in ("reading-conflict", "nuisance-pulled")]
    assert others == []  # only the consistency test stands between the user and the wrong answer


def test_a_right_reading_agrees_and_still_narrows(chart):
    bare = _fit(chart, None)
    good = _fit(chart, {"cdom": (0.15, 0.02)})
    assert good.reliable and "reading-conflict" not in good.flags
    assert good.consistency["readings"]["cdom"]["p"] > 0.05
    assert good.cdom_ci[1] - good.cdom_ci[0] < 0.6 * (bare.cdom_ci[1] - bare.cdom_ci[0])
    assert good.cdom_ci[0] <= CDOM <= good.cdom_ci[1]
    # and C, which a sample of a_CDOM separates from it (issue 45: "still narrows C")
    assert good.chl_ci[1] - good.chl_ci[0] < bare.chl_ci[1] - bare.chl_ci[0]
    assert good.chl_ci[0] <= CHL <= good.chl_ci[1]


def test_the_batch_tests_each_charts_own_reading(chart):
    sims = [forward.simulate_chart(CHL, CDOM, depth=DEPTH, distance=DIST, seed=s)
            for s in range(4)]
    M = np.array([s.rgb for s in sims])
    S = np.array([s.rgb_sigma for s in sims])
    value = np.array([0.15, 0.45, np.nan, 2.0])  # right, 3x, none, a Secchi-like absurdity
    sd = np.array([0.02, 0.02, np.nan, 0.05])
    b = sca.estimate_batch(M, depth=DEPTH, distance=DIST, sigma=S, gain="free",
                           auxiliary={"cdom": (value, sd)})
    conflict = np.array(["reading-conflict" in f for f in b.flags])
    np.testing.assert_array_equal(conflict, [False, True, False, True])
    assert not b.reliable[1] and not b.reliable[3]
    assert np.isnan(b.consistency["readings"]["cdom"]["delta_chi2"][2])


def _dive(seed=10, depths=(4.0, 5.0, 6.0)):
    M, S = [], []
    for i, d in enumerate(depths):
        s = forward.simulate_chart(CHL, CDOM, d, DIST, seed=seed + i)
        M.append(s.rgb * (i + 1))
        S.append(s.rgb_sigma * (i + 1))
    return np.array(M), np.array(S), list(depths)


@pytest.mark.slow
def test_a_dive_with_a_wrong_sample_is_flagged():
    M, S, depths = _dive()
    j = estimate_joint(M, depth=depths, distance=DIST, sigma=S, setup=SETUP,
                       path_models=("beam",), auxiliary={"cdom": (0.45, 0.02)})
    assert not j.reliable and "reading-conflict" in j.flags
    assert any("contradicts the photos" in n for n in j.notes)
    ok = estimate_joint(M, depth=depths, distance=DIST, sigma=S, setup=SETUP,
                        path_models=("beam",), auxiliary={"cdom": (0.15, 0.02)})
    assert ok.reliable and ok.cdom_ci[0] <= CDOM <= ok.cdom_ci[1]


def test_the_joint_fit_keeps_a_photo_whose_own_misfit_is_the_readings():
    """A photo whose own fit is flagged misfit because of a wrong reading (its flags say
    reading-conflict) stays in the dive: the dive tests the reading itself."""
    M, S, depths = _dive(depths=(4.0, 6.0))

    def record(i, flags):
        return {"patches": {"rgb": M[i].tolist(), "sigma": S[i].tolist(),
                            "clipped": np.zeros(M[i].shape).tolist()},
                "inputs": {"depth_m": depths[i], "distance_m": DIST, "depth_sd": None,
                           "distance_sd": None, "uncertain": {}},
                "estimate": {"chl": CHL, "cdom": CDOM, "gain": float(i + 1),
                             "backscatter": [0.0, 0.0, 0.0], "flags": list(flags)},
                "light_field": {"model": "none"}, "image": {"path": f"/dive/IMG_{i}.dng"}}
    recs = [record(0, ()), record(1, ("misfit", "reading-conflict"))]
    j = fit_joint(recs, setup=SETUP, path_models=("beam",), auxiliary={})
    assert list(j.photos) == ["IMG_0.dng", "IMG_1.dng"] and not j.excluded
    recs[1]["estimate"]["flags"] = ["misfit"]  # a misfit of its own: left out, as before
    assert "IMG_1.dng" in fit_joint(recs, setup=SETUP, path_models=("beam",),
                                    auxiliary={}).excluded


def test_nuisance_pulls_and_the_likelihood_ratio_statistic():
    """The building blocks on a problem whose answer is known: one Gaussian unknown x with a
    prior N(0, 1) and two readings of it; the test is the deleted residual squared."""
    from sca.problem import Observation, Problem

    class Line(Problem):
        @property
        def size(self):
            return 1

        def data_terms(self, idx, theta, params, chain, grad):
            from sca.problem import Evaluation
            k = len(idx)
            return Evaluation(np.zeros(k), np.zeros((k, 1)) if grad else None,
                              np.zeros((k, 1, 1)) if grad else None)

    def h(params, wrt):
        x = np.asarray(params["x"], float)
        return x, ({"x": np.ones_like(x)} if "x" in wrt else {})
    obs = [Observation("a", 0.0, 1.0, h), Observation("b", 6.0, 1.0, h)]
    prob = Line(("x",), {}, np.zeros((1, 1)), np.ones((1, 1)), obs)
    x_hat = 2.0  # (0 + 0 + 6) / 3: prior and both readings, each of sd 1
    f = np.array([x_hat ** 2 + x_hat ** 2 + (x_hat - 6) ** 2])
    from sca.consistency import objectives_alone
    alone = objectives_alone(prob, np.array([[x_hat]]))
    tests = reading_tests(f[:, None], {k: v[:, None] for k, v in alone.items()})
    # reading b against the prior and reading a (their mean 0, sd 1/sqrt(2)): (6 - 0)^2 / 1.5
    np.testing.assert_allclose(tests["b"][0], [36.0 / 1.5], rtol=1e-6)
    np.testing.assert_allclose(tests["a"][0], [(0 - 3.0) ** 2 / 1.5], rtol=1e-6)
    np.testing.assert_allclose(nuisance_pulls(prob, np.array([[x_hat]]))["x"], [2.0])
    assert PULL_MAX > 2.0


def test_the_estimators_own_fit_tests_its_readings_too(chart):
    """sca.Estimator(...).fit, one path model, runs the same test as sca.estimate."""
    aux = {"cdom": (0.45, 0.02)}
    e = sca.Estimator(depth=DEPTH, distance=DIST, gain="free", auxiliary=aux).fit(
        chart.rgb, sigma=chart.rgb_sigma)
    assert not e.reliable and "reading-conflict" in e.flags
    assert set(e.consistency) == {"readings", "pulls", "pull_max", "conflict_p"}
