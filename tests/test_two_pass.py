"""The path models' two passes (issue 46: the path-model union where it decides): every chart
fitted under every candidate, then each candidate assessed only where the data support it.
An unsupported candidate's intervals and tests were never read, so the result must be the one
of assessing every candidate on every chart, field by field."""

import dataclasses
import itertools

import numpy as np
import pytest

import forward
import sca
from sca.batch import _estimate_batch
from sca.consistency import finalize_batch
from sca.pathmodels import combine_batch
from forward.water import PATH_MODELS


def _charts():
    conds = list(itertools.product((0.001, 1.0, 20.0), (0.0, 0.5), (1.0, 10.0), (0.5, 5.0)))
    sims = [forward.simulate_chart(c, a, d, r, seed=i) for i, (c, a, d, r) in enumerate(conds)]
    return (np.array([s.rgb for s in sims]), np.array([s.rgb_sigma for s in sims]),
            np.array([c[2] for c in conds]), np.array([c[3] for c in conds]),
            np.array([c[1] for c in conds]))


@pytest.mark.parametrize("kw", [{}, {"gain": "free"}], ids=["gain known", "gain free"])
def test_two_passes_give_what_assessing_every_model_everywhere_gives(kw):
    rgb, sig, depth, dist, cdom = _charts()
    kw = dict(kw, auxiliary={"cdom": (cdom + 0.05, 0.02)})
    new = sca.estimate_batch(rgb, depth=depth, distance=dist, sigma=sig, **kw)
    # the single pass: every candidate assessed on every chart, then combined
    full = dict(depth=depth, distance=dist, sigma=sig, saturation=None,
                camera=forward.DEFAULT_CAMERA, illuminant=None, reflectances=None,
                wavelengths=None, basis=None, fix=None, free=(), intervals=True, max_iter=100,
                tol=sca.lm.LM_TOL, setup=None, engine=sca.batch.ENGINES[0],
                gain=kw.get("gain", "known"), uncertain=None, quadrature="reduced",
                auxiliary=kw["auxiliary"])
    water = forward.Water()
    each = {m: _estimate_batch(rgb, water=dataclasses.replace(water, path_model=m), **full)
            for m in PATH_MODELS}
    old = combine_batch(each)
    best = np.array([list(PATH_MODELS).index(m) for m in old.path_model])
    old.consistency, _ = finalize_batch(list(each.values()), best)
    assert list(new.path_model) == list(old.path_model)
    np.testing.assert_allclose(new.objective, old.objective, rtol=1e-12)
    for name in ("chl", "cdom", "chl_ci", "cdom_ci", "gain", "beam_attenuation_ci"):
        np.testing.assert_allclose(getattr(new, name), getattr(old, name), rtol=1e-9,
                                   err_msg=name)
    for k, v in old.quantity_intervals.items():
        np.testing.assert_allclose(new.quantity_intervals[k], v, rtol=1e-9, err_msg=k)
    np.testing.assert_allclose(new.consistency["readings"]["cdom"]["delta_chi2"],
                               old.consistency["readings"]["cdom"]["delta_chi2"], rtol=1e-9)
    # the flags but the consistency test's (added by estimate_batch after combining)
    extra = ("reading-conflict", "nuisance-pulled")
    assert [tuple(f for f in x if f not in extra) for x in new.flags] == old.flags
