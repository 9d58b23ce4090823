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


#: Tests that take about a minute alone (a compile of the kernels in a private cache): run
#: first, so that on two workers (``make test``) the other worker works through the rest
#: meanwhile, instead of one of these running alone at the end.
LONGEST_FIRST = ("tests/test_structure.py::test_results_do_not_depend_on_whether_numbas_cache_was_warm",)


def pytest_collection_modifyitems(config, items):
    items.sort(key=lambda item: item.nodeid not in LONGEST_FIRST)  # stable: the rest in order
