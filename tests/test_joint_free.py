"""The NAP slope as a free unknown of the joint dive fit (issue 46 item 3):
``sca.estimate_joint(..., free=("nap_slope",))`` and the parameter table it reads
(:mod:`sca.parameters`, decision 0077-parameter-table)."""

import dataclasses

import numpy as np
import pytest
from scipy import stats

import forward
from forward.errors import InputError
from forward.imaging import resolve_setup
from forward.water import resolve_water
from sca.joint import estimate_joint

SETUP = resolve_setup(None, forward.DEFAULT_CAMERA, None, None, None)
#: Five photos whose paths (depth + distance, 4-19 m) spread so the slope is identifiable.
DEPTHS = np.array([3.0, 5.0, 8.0, 11.0, 14.0])
DISTANCES = np.array([1.0, 2.0, 3.0, 4.0, 5.0])
GAINS = np.array([2.0, 1.0, 5.0, 3.0, 1.5])  # each photo's own exposure
#: The simulated water's NAP slope (nm^-1), not the model's default 0.011.
TRUE_SLOPE = 0.014
DIVES = 20


def _dive(seed, water):
    M, sig = [], []
    for i, (d, r) in enumerate(zip(DEPTHS, DISTANCES)):
        s = forward.simulate_chart(1.0, 0.1, d, r, seed=100 * seed + i, noise=True, water=water)
        M.append(s.rgb * GAINS[i])
        sig.append(s.rgb_sigma * GAINS[i])
    return np.array(M), np.array(sig)


def _fit(seed, **kw):
    true = dataclasses.replace(resolve_water(None), nap_slope=TRUE_SLOPE)
    M, sig = _dive(seed, true)
    kw = {"uncertain": {}, "path_models": ("beam",), **kw}
    return estimate_joint(M, depth=DEPTHS, distance=DISTANCES, sigma=sig, setup=SETUP, **kw)


def test_free_nap_slope_interval_covers_the_truth_at_its_level():
    default = resolve_water(None).nap_slope
    assert default != TRUE_SLOPE
    ends = np.array([_fit(seed, free=("nap_slope",)).intervals["nap_slope"]
                     for seed in range(DIVES)])
    covered = int(np.sum((ends[:, 0] <= TRUE_SLOPE) & (TRUE_SLOPE <= ends[:, 1])))
    p = stats.binomtest(covered, DIVES, 0.95).pvalue
    assert p > 0.01, f"{covered}/{DIVES} intervals cover the true slope (binomial p = {p:.3g})"
    widths = ends[:, 1] - ends[:, 0]
    assert np.isfinite(np.median(widths)) and np.median(widths) > 0
    # the data, not the start, place the slope: the intervals leave the default out mostly
    assert np.mean((ends[:, 0] <= default) & (default <= ends[:, 1])) < 0.5


def test_free_slope_is_reported_like_chl_and_drops_its_budget_prior():
    j = _fit(0, uncertain=None, free=("nap_slope",))
    assert set(j.values) == {"chl", "cdom", "nap_slope"}
    assert j.intervals["chl"] == j.chl_ci and j.intervals["cdom"] == j.cdom_ci
    lo, hi = j.intervals["nap_slope"]
    assert lo < j.values["nap_slope"] < hi
    assert "nap_slope" not in j.nuisance  # an unknown, not a nuisance with a prior
    assert "nap_slope" not in j.consistency["pulls"]
    assert j.to_dict()["units"]["nap_slope"] == "nm^-1"


def test_default_free_is_the_fit_of_before():
    j = _fit(1)
    assert set(j.values) == {"chl", "cdom"}
    assert j.values["chl"] == j.chl and j.intervals["chl"] == j.chl_ci


@pytest.mark.parametrize("free", [("nonsense",), ("chl",), ("depth",), 3])
def test_free_names_outside_the_table_name_the_argument(free):
    M, sig = _dive(0, resolve_water(None))
    with pytest.raises(InputError) as err:
        estimate_joint(M, depth=DEPTHS, distance=DISTANCES, sigma=sig, setup=SETUP,
                       uncertain={}, free=free)
    assert err.value.argument == "free"
