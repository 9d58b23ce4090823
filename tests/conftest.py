import os
import tempfile

import matplotlib
from hypothesis import settings

matplotlib.use("Agg")

# property tests draw the same examples on every run, so a CI result is reproducible;
# UW3P_HYPOTHESIS=stress draws many fresh examples (a local search for counterexamples)
settings.register_profile("uw3p", derandomize=True, deadline=None, max_examples=12,
                          print_blob=True)
settings.register_profile("stress", derandomize=False, deadline=None, max_examples=300,
                          print_blob=True)
settings.load_profile(os.environ.get("UW3P_HYPOTHESIS", "uw3p"))

# the quadrature rules' disk cache (sca.quadrature.cache_dir) of a test run is its own
os.environ.setdefault("UW3P_CACHE_DIR", tempfile.mkdtemp(prefix="uw3p-test-cache-"))


#: Run first, longest first (their node ids, or a module's path for all of its tests): on two
#: workers (``make test``, ``--dist loadgroup``) the modules held on one worker (their
#: ``xdist_group`` marks: the reduced figure run of tests/test_experiments.py, the shared dive of
#: tests/test_adversarial_dive.py) and the kernels' cold compile start at once, while the other
#: worker works through the rest, instead of one of them running alone at the end.
LONGEST_FIRST = ("tests/test_experiments.py",
                 "tests/test_adversarial_dive.py",
                 "tests/test_structure.py::test_results_do_not_depend_on_whether_numbas_cache_was_warm")


def _rank(item) -> int:
    """The place of ``item`` in :data:`LONGEST_FIRST` (len for the rest); loadgroup's
    ``@group`` suffix ignored."""
    nodeid = item.nodeid.split("@")[0]
    return next((i for i, key in enumerate(LONGEST_FIRST)
                 if nodeid == key or nodeid.startswith(key + "::")), len(LONGEST_FIRST))


def pytest_collection_modifyitems(config, items):
    items.sort(key=_rank)  # stable: the rest in order
