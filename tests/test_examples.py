"""The Examples sections of the main public functions run as doctests (issue 40): each named
function has one, and every example in it gives the output written there."""

import doctest
import importlib

import pytest

#: The public functions a user starts from; each must carry an Examples section that runs.
EXAMPLED = ["forward.InputError", "forward.simulate_chart", "sca.estimate", "sca.estimate_batch", "sca.precision",
            "measure.measure", "measure.measure_dive", "measure.correct_image"]
SLOW = {"measure.measure", "measure.measure_dive", "measure.correct_image"}
FLAGS = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE


def _resolve(name):
    module, attr = name.rsplit(".", 1)
    return getattr(importlib.import_module(module), attr)


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n in SLOW else n
                                  for n in EXAMPLED])
def test_examples_run(name):
    obj = _resolve(name)
    assert "\n    Examples\n    --------\n" in (obj.__doc__ or ""), f"{name}: no Examples section"
    tests = doctest.DocTestFinder(recurse=False).find(obj, name, globs={})
    runner = doctest.DocTestRunner(optionflags=FLAGS)
    report = []
    for t in tests:
        runner.run(t, out=report.append)
    result = runner.summarize(verbose=False)
    assert result.attempted > 0, f"{name}: no example ran"
    assert result.failed == 0, "".join(report)
