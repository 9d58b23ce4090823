"""The single chart's path models in two passes (issue 46): every candidate fitted up to its
objective (:func:`sca.verdict.settle`), then finished (intervals, derived quantities, tests)
only where the data support it, the known gain's test only under the chosen one. An
unsupported candidate's intervals and tests were never read, so :func:`sca.estimate` must give
what finishing every candidate and combining them (:func:`sca.pathmodels.combine_single`)
gives, field by field."""

import dataclasses

import numpy as np
import pytest

import forward
import sca
import sca.verdict
from sca.lsq import _fit as lsq_fit
from sca.pathmodels import candidates, combine_single

#: name -> (C, a_CDOM, depth, distance, simulate_chart's options)
CHARTS = {
    "noisy": (1.0, 0.1, 5.0, 1.5, {}),
    "noise-free": (1.0, 0.1, 5.0, 1.5, {"noise": False}),
    "C = 0": (0.0, 0.2, 3.0, 1.0, {}),
    "dark": (5.0, 0.5, 15.0, 6.0, {}),
    "split water": (2.0, 0.3, 8.0, 3.0, {"path_model": "split"}),
}
#: name -> (sca.estimate's options, the chart's 'cdom' reading or None)
SETTINGS = {
    "gain known": ({}, None),
    "gain free": ({"gain": "free"}, None),
    "reading": ({}, 0.05),
    "gain free, reading": ({"gain": "free"}, 0.05),
}


def _chart(name):
    c, a, d, r, opt = CHARTS[name]
    sim = forward.simulate_chart(c, a, d, r, seed=7, **opt)
    return sim.rgb, sim.rgb_sigma, dict(depth=d, distance=r), a


def _options(setting, cdom):
    opt, offset = SETTINGS[setting]
    if offset is not None:
        opt = dict(opt, auxiliary={"cdom": (cdom + offset, 0.02)})
    return opt


def _every_candidate_finished(est_kw, run):
    """The single pass: every candidate assessed fully (``run(estimator)``: an Estimate),
    then combined."""
    water = forward.Water()
    models = candidates(None, water, True)
    return combine_single({m: run(sca.Estimator(water=dataclasses.replace(water, path_model=m),
                                                **est_kw)) for m in models})


def _same(new, old, where):
    """Every value of ``new`` equals ``old``'s (numbers to rtol 1e-9, the rest exactly)."""
    if isinstance(old, dict):
        assert list(new) == list(old), where
        for k in old:
            _same(new[k], old[k], f"{where}[{k!r}]")
    elif isinstance(old, (str, bool, type(None))) or (
            isinstance(old, (tuple, list)) and any(isinstance(v, str) for v in old)):
        assert new == old, where
    else:
        np.testing.assert_allclose(np.asarray(new, float), np.asarray(old, float), rtol=1e-9,
                                   atol=0, err_msg=where)


def _assert_same(new, old):
    for f in dataclasses.fields(sca.Estimate):
        _same(getattr(new, f.name), getattr(old, f.name), f.name)


@pytest.mark.parametrize("setting", list(SETTINGS))
@pytest.mark.parametrize("chart", list(CHARTS))
def test_estimate_gives_what_finishing_every_path_model_gives(chart, setting):
    rgb, sigma, geometry, cdom = _chart(chart)
    opt = _options(setting, cdom)
    new = sca.estimate(rgb, sigma=sigma, mode="lm", **geometry, **opt)
    old = _every_candidate_finished(dict(geometry, **opt), lambda e: sca.verdict.finish(
        e.settle(rgb, sigma=sigma, mode="lm")))
    assert len(new.path_objective) == 3
    _assert_same(new, old)


@pytest.mark.parametrize("mode", ["safeguarded", "paper"])
def test_the_convex_loops_too(mode):
    rgb, sigma, geometry, cdom = _chart("noisy")
    opt = _options("gain free, reading", cdom)
    new = sca.estimate(rgb, sigma=sigma, mode=mode, **geometry, **opt)
    old = _every_candidate_finished(dict(geometry, **opt), lambda e: sca.verdict.finish(
        e.settle(rgb, sigma=sigma, mode=mode)))
    _assert_same(new, old)


def test_the_scipy_path_too():
    rgb, sigma, geometry, cdom = _chart("C = 0")
    opt = _options("reading", cdom)
    new = sca.estimate_least_squares(rgb, sigma=sigma, **geometry, **opt)
    old = _every_candidate_finished(dict(geometry, **opt), lambda e: sca.verdict.finish(
        lsq_fit(e, rgb, sigma, None, None, 500, 1e-12)))
    assert new.eq17_residual == 0.0
    _assert_same(new, old)


def test_an_unsupported_path_model_is_not_assessed(monkeypatch):
    """The intervals only under the supported candidates, the known gain's test only under
    the chosen one (every candidate had both before)."""
    calls = {"_profile": 0, "_scale_p": 0}
    for name in calls:
        def counted(*a, _f=getattr(sca.verdict, name), _n=name, **k):
            calls[_n] += 1
            return _f(*a, **k)
        monkeypatch.setattr(sca.verdict, name, counted)
    rgb, sigma, geometry, _ = _chart("noisy")
    est = sca.estimate(rgb, sigma=sigma, mode="lm", **geometry)
    assert 1 <= len(est.path_models) < len(est.path_objective)
    assert calls == {"_profile": len(est.path_models), "_scale_p": 1}


def test_without_a_budget_one_path_model_is_finished():
    rgb, sigma, geometry, _ = _chart("noisy")
    new = sca.estimate(rgb, mode="lm", **geometry)
    old = sca.Estimator(**geometry).fit(rgb, mode="lm")
    assert new.path_models == ("beam",) and list(new.path_objective) == ["beam"]
    for name in ("chl", "cdom", "chl_ci", "cdom_ci", "objective", "quantity_intervals"):
        _same(getattr(new, name), getattr(old, name), name)
