import os
import tempfile

import matplotlib
import pytest
from hypothesis import settings

matplotlib.use("Agg")

# property tests draw the same examples on every run, so a CI result is reproducible;
# UW3P_HYPOTHESIS=stress draws many fresh examples (a local search for counterexamples)
settings.register_profile("uw3p", derandomize=True, deadline=None, max_examples=12,
                          print_blob=True)
settings.register_profile("stress", derandomize=False, deadline=None, max_examples=300,
                          print_blob=True)
settings.load_profile(os.environ.get("UW3P_HYPOTHESIS", "uw3p"))

def budget_prior_world(seed: int, n: int):
    """``n`` charts of HONESTY.md's budget-prior world (the independent renderer, its own
    ``seed``) fitted by ``sca.estimate_batch`` with the gain free: (estimate, rendered, the
    drawn conditions)."""
    import numpy as np

    import sca
    from experiments import honesty as h

    cond_rng, render_root = np.random.default_rng(seed).spawn(2)
    cond = h.draw_conditions(cond_rng, n)
    worlds = {w.name: w for w in h.worlds()}
    streams = dict(zip(worlds, render_root.spawn(len(worlds)), strict=True))
    r = h.render_set(worlds["priors"], cond, streams["priors"])
    est = sca.estimate_batch(np.maximum(r["rgb"], 0.0), depth=r["depth"],
                             distance=r["distance"], sigma=r["sigma"], gain="free")
    return est, r, cond


# the quadrature rules' disk cache (sca.quadrature.cache_dir) of a test run is its own
os.environ.setdefault("UW3P_CACHE_DIR", tempfile.mkdtemp(prefix="uw3p-test-cache-"))


@pytest.fixture(scope="session")
def chart_photos(tmp_path_factory):
    """The chart photographed by a camera whose channel balance (0.55, 1, 0.7) differs from its
    published curves (360 x 240 px DNGs): in air (``air``) and at 5 m depth, 1.5 m away, in water
    of C = 2 mg m^-3 and CDOM 0.1 m^-1 (``uw``); the profile calibrated from the air photo."""
    import measure
    from measure.synthetic_photo import Scene, default_corners, render_mosaic, write_dng
    from forward import chart_setup

    tmp = tmp_path_factory.mktemp("chart_photos")
    setup, corners = chart_setup(channel_gains=(0.55, 1.0, 0.7)), default_corners(360, 240)
    shots = {name: write_dng(render_mosaic(Scene(width=360, height=240, **scene), corners,
                                           setup=setup), tmp / f"{name}.dng")
             for name, scene in (("air", dict(chl=0, cdom=0, depth=0, distance=0, gain=9000,
                                                  seed=1)),
                                 ("uw", dict(chl=2.0, cdom=0.1, depth=5.0, distance=1.5,
                                             gain=30000, seed=2)))}
    air = measure.read_image(shots["air"])
    profile = measure.calibrate(measure.sample_patches(air, corners), image=air.path)
    return {"dir": tmp, "setup": setup, "corners": corners, "profile": profile, **shots}


@pytest.fixture(scope="session")
def uw_measured(chart_photos):
    """:func:`chart_photos`' underwater photo measured with its profile and the default budget,
    once for the tests that only read the measurement (about 3.5 s each time)."""
    import measure

    return measure.measure(chart_photos["uw"], corners=chart_photos["corners"], depth=5.0,
                           distance=1.5, profile=chart_photos["profile"])


@pytest.fixture(scope="session")
def fast_shot(tmp_path_factory):
    """The underwater chart (360 x 240 px DNG, C = 2 mg m^-3, CDOM 0.1 m^-1, 5 m deep, 1.5 m away,
    the published curves) measured once with the exact model and no light field (fast), for
    the correction's tests that write their own outputs from it: 'dng', 'meas', 'corners'."""
    import measure
    from measure.synthetic_photo import Scene, default_corners, render_mosaic, write_dng

    tmp = tmp_path_factory.mktemp("fast_shot")
    corners = default_corners(360, 240)
    path = write_dng(render_mosaic(Scene(chl=2.0, cdom=0.1, depth=5.0, distance=1.5, gain=30000,
                                         width=360, height=240, seed=2), corners), tmp / "A.dng")
    meas = measure.measure(path, corners=corners, depth=5.0, distance=1.5, uncertain={},
                           light_field="none")
    return {"dng": path, "meas": meas, "corners": corners}


#: Run first, longest first (their node ids, or a module's path for all of its tests): on two
#: workers (``make test``, ``--dist loadfile --no-loadscope-reorder``: each module on one worker,
#: its module fixtures made once, the modules in this order, not in xdist's by number of tests)
#: the longest modules (the reduced figure run of tests/test_experiments.py, the
#: shared dive of tests/test_adversarial_dive.py) and the kernels' cold compile start at once,
#: while the other worker works through the rest, instead of one of them running alone at the
#: end.
LONGEST_FIRST = ("tests/test_experiments.py",
                 "tests/test_adversarial_dive.py",
                 "tests/test_structure.py::test_results_do_not_depend_on_whether_numbas_cache_was_warm")


def _rank(item) -> int:
    """The place of ``item`` in :data:`LONGEST_FIRST` (len for the rest)."""
    nodeid = item.nodeid
    return next((i for i, key in enumerate(LONGEST_FIRST)
                 if nodeid == key or nodeid.startswith(key + "::")), len(LONGEST_FIRST))


def pytest_collection_modifyitems(config, items):
    items.sort(key=_rank)  # stable: the rest in order
