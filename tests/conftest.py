import os

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
