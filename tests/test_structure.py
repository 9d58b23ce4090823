"""Estimators are safe to share between threads; packages import only downwards."""

import ast
import itertools
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

import forward
import sca

ROOT = Path(__file__).resolve().parents[1]
#: Each package and the packages it may import (the layers: forward <- sca <- measure <-
#: experiments, uw3p).
LAYERS = {
    "forward": set(),
    "sca": {"forward"},
    "measure": {"forward", "sca"},
    "experiments": {"forward", "sca", "measure"},
    "uw3p": {"forward", "sca", "measure", "experiments"},
}


def _charts():
    conds = list(itertools.product((0.1, 1.0, 10.0), (0.05, 0.5), (5.0, 20.0), (1.0, 5.0)))
    return [(forward.simulate_chart(c, a, d, r, seed=i).rgb, d, r)
            for i, (c, a, d, r) in enumerate(conds)]


def test_estimate_from_threads_equals_serial():
    charts = _charts()

    def fit(x):
        rgb, d, r = x
        e = sca.estimate(rgb, depth=d, distance=r)
        return e.chl, e.cdom, e.objective, e.converged

    serial = [fit(x) for x in charts]
    for _ in range(2):  # fresh threads each time
        with ThreadPoolExecutor(4) as pool:
            assert list(pool.map(fit, charts)) == serial


def test_shared_estimator_from_threads_equals_serial():
    charts = [c for c in _charts() if c[1] == 5.0 and c[2] == 1.0]
    est = sca.Estimator(depth=5.0, distance=1.0)
    serial = [est.fit(rgb).chl for rgb, _, _ in charts]
    with ThreadPoolExecutor(4) as pool:
        assert list(pool.map(lambda x: est.fit(x[0]).chl, charts)) == serial


def test_estimate_batch_from_threads_equals_serial():
    charts = _charts()
    M = np.array([c[0] for c in charts])
    D = np.array([c[1] for c in charts])
    R = np.array([c[2] for c in charts])
    stacks = [(M[i::3], D[i::3], R[i::3]) for i in range(3)]
    for engine in sca.batch.ENGINES:
        def fit(x, engine=engine):
            return sca.estimate_batch(x[0], depth=x[1], distance=x[2], engine=engine).chl
        serial = [fit(x) for x in stacks]
        with ThreadPoolExecutor(3) as pool:
            for got, want in zip(pool.map(fit, stacks * 2), serial * 2):
                np.testing.assert_array_equal(got, want)


def _imports(path: Path):
    """(module names imported, relative import levels/names) of a source file."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                yield a.name, 0
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            yield base, node.level
            for a in node.names:
                yield (f"{base}.{a.name}" if base else a.name), node.level


def test_layers_import_only_downwards_and_no_private_modules():
    problems = []
    for pkg, allowed in LAYERS.items():
        for path in sorted((ROOT / pkg).glob("*.py")):
            for name, level in _imports(path):
                if level:  # relative: inside the package, anything goes
                    continue
                top = name.split(".")[0]
                if top in LAYERS and top != pkg and top not in allowed:
                    problems.append(f"{path.name} ({pkg}) imports {name}: upward")
                if top in LAYERS and top != pkg and any(p.startswith("_") and not p.startswith("__")
                                                        for p in name.split(".")[1:]):
                    problems.append(f"{path.name} ({pkg}) imports private {name}")
    assert not problems, problems


def test_console_script_is_above_forward():
    text = (ROOT / "pyproject.toml").read_text()
    assert 'uw3p = "uw3p.cli:main"' in text
    assert not (ROOT / "forward" / "cli.py").exists()
