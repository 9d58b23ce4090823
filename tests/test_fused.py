"""The batch's compiled evaluation from the optical depth's pieces is the model function.

:func:`sca.lm.evaluate` computes charts whose free and fixed names are C, a_CDOM, depth and
distance with :func:`sca.projection.project_pieces` (the (weight, spectrum) pieces of
:meth:`forward.WaterTerms.optical_depth`, ``stacked=True``) instead of
:meth:`sca.ChartModel.predict` + :func:`sca.projection.project`. Both must give the same
objective, gradient, Gauss-Newton matrix, gain, backscatter and attenuation, for every path
model, with and without a free gain or a held backscatter.
"""

import importlib

import numpy as np
import pytest

import forward
from sca.lm import Problem, evaluate, fused
from sca.model import TINY, ChartModel

lm = importlib.import_module("sca.lm")
SETUP = forward.chart_setup(wavelengths=np.arange(400.0, 701.0, 10.0))
NAMES = (("chl", "cdom"), ("chl", "cdom", "depth", "distance"), ("cdom",))


def _problem(path_model, names, free_gain, held_s, rng, N=70):
    """N random charts (N >= the kernels' serial threshold: the parallel kernel runs)."""
    mdl = ChartModel(SETUP, water=forward.Water(path_model=path_model))
    mn = mdl.m * mdl.n
    fixed = {"depth": rng.uniform(0.0, 20.0, N), "distance": rng.uniform(0.0, 5.0, N),
             "chl": rng.uniform(0.0, 5.0, N)}
    fixed = {k: v for k, v in fixed.items() if k not in names}
    fs = rng.uniform(0.0, 0.05, (N, mdl.m)) if held_s else None
    return Problem(mdl, rng.uniform(0.01, 1.0, (N, mn)), rng.uniform(0.5, 2.0, (N, mn)),
                   rng.uniform(0.5, 2.0, N), names, fixed, free_gain, fs)


@pytest.mark.parametrize("path_model", ["beam", "absorption", "split"])
@pytest.mark.parametrize("names", NAMES)
@pytest.mark.parametrize("free_gain,held_s", [(False, False), (True, False), (False, True)])
def test_pieces_equal_the_model_function(path_model, names, free_gain, held_s, monkeypatch):
    rng = np.random.default_rng(hash((path_model, names, free_gain, held_s)) % 2**32)
    prob = _problem(path_model, names, free_gain, held_s, rng)
    assert fused(prob)
    theta = rng.uniform(0.0, 2.0, (prob.size, len(names)))
    theta[:3, 0] = 0.0  # C = 0 (u = 0) and a_CDOM = 0 included
    idx = np.arange(prob.size)
    got = evaluate(prob, idx, theta, True)
    monkeypatch.setattr(lm, "fused", lambda p: False)
    ref = evaluate(prob, idx, theta, True)
    for name, a, b in zip(("f", "g", "H", "gain", "s", "ssr", "k"), got, ref):
        scale = np.max(np.abs(b)) + TINY
        assert np.max(np.abs(a - b)) <= 1e-12 * scale, name
    sub = idx[5:9]  # a few charts, serial kernel, values only
    got = evaluate(prob, sub, theta[sub], False)
    ref = evaluate(prob, sub, theta[sub], False)
    assert got[1] is None and got[2] is None
    np.testing.assert_allclose(got[0], ref[0], rtol=1e-12)


def test_stacked_pieces_sum_to_the_optical_depth():
    terms = forward.Water(path_model="split").on_grid(np.arange(400.0, 701.0, 5.0))
    rng = np.random.default_rng(3)
    chl, cdom = np.r_[0.0, rng.uniform(0, 50, 9)], rng.uniform(0, 2, 10)
    depth, distance = rng.uniform(0, 20, 10), rng.uniform(0, 5, 10)
    wrt = ("chl", "cdom", "depth", "distance")
    tau, dtau = terms.optical_depth(chl, cdom, depth, distance, wrt=wrt, floor=TINY)
    weights, spectra, dweights = terms.optical_depth(chl, cdom, depth, distance, wrt=wrt,
                                                     floor=TINY, stacked=True)
    np.testing.assert_allclose(weights @ spectra, tau, rtol=1e-13)
    for name in wrt:
        np.testing.assert_allclose(dweights[name] @ spectra, dtau[name], rtol=1e-13,
                                   atol=1e-15 * np.abs(dtau[name]).max())


def test_stacked_refuses_point_dependent_spectra():
    terms = forward.PAPER_WATER.on_grid(np.arange(400.0, 701.0, 10.0))
    with pytest.raises(ValueError, match="stacked"):
        terms.path_coefficient(np.ones(3), np.ones(3), values={"cdom_slope": np.full(3, 0.02)},
                               stacked=True)


def test_camera_and_constants_use_the_model_function():
    rng = np.random.default_rng(0)
    prob = _problem("beam", ("chl", "cdom", "cdom_slope"), False, False, rng, N=4)
    assert not fused(prob)
