"""Estimators are safe to share between threads; packages import only downwards; no module
shares its name with a function; every module declares its public names (``__all__``)."""

import ast
import importlib
import itertools
import json
import pkgutil
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

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


@pytest.mark.slow
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
        for path in sorted((ROOT / pkg).rglob("*.py")):  # sub-packages too (measure.dive)
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
    import tomllib

    scripts = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]
    assert scripts == {"uw3p": "uw3p.console:main"}  # uw3p.cli.main behind a quiet Ctrl-C
    module, _, func = scripts["uw3p"].partition(":")
    assert callable(getattr(importlib.import_module(module), func))
    assert module.split(".")[0] not in ("forward", "sca", "measure")  # the top layer
    assert not (ROOT / "forward" / "cli.py").exists()


#: The packages whose structure is tested (the layers, lowest first).
PACKAGES = list(LAYERS)

#: Run in a fresh interpreter, so that no earlier import (of a test or of another package) has
#: already replaced a package's function by its same-named submodule or vice versa: each package
#: is imported alone, in layer order, and each name of a submodule that the package binds to
#: anything but that submodule is printed.
_CLASH_SCRIPT = """
import importlib, json, pkgutil, sys
out = {}
for name in sys.argv[1:]:
    pkg = importlib.import_module(name)
    subs = [m.name for m in pkgutil.iter_modules(pkg.__path__) if m.name != "__main__"]
    out[name] = {s: type(vars(pkg)[s]).__name__ for s in subs
                 if s in vars(pkg) and vars(pkg)[s] is not sys.modules.get(f"{name}.{s}")}
print(json.dumps(out))
"""


@pytest.mark.slow
def test_no_submodule_shares_its_name_with_an_attribute_of_its_package():
    """``measure.measure`` must mean one thing: a package's public attribute (a function, a
    class, a constant) never has the name of one of its submodules."""
    proc = subprocess.run([sys.executable, "-c", _CLASH_SCRIPT, *PACKAGES], cwd=ROOT,
                          capture_output=True, text=True, check=True)
    found = json.loads(proc.stdout.strip().splitlines()[-1])
    clashes = [f"{pkg}.{sub} is a submodule and a {kind}"
               for pkg, subs in found.items() for sub, kind in subs.items()]
    assert not clashes, "\n".join(clashes)


def _modules():
    """Every module of PACKAGES (each package itself included, ``__main__`` scripts not)."""
    for name in PACKAGES:
        pkg = importlib.import_module(name)
        yield pkg
        for info in pkgutil.walk_packages(pkg.__path__, prefix=f"{name}."):
            if info.name.rsplit(".", 1)[-1] != "__main__":
                yield importlib.import_module(info.name)


def test_every_module_declares_all_and_every_name_in_it_exists():
    no_all, missing = [], []
    for mod in _modules():
        names = vars(mod).get("__all__")
        if names is None:
            no_all.append(mod.__name__)
            continue
        missing += [f"{mod.__name__}.{n}" for n in names if not hasattr(mod, n)]
    problems = ([f"no __all__: {', '.join(no_all)}"] if no_all else []) + \
        ([f"in __all__ but not defined: {', '.join(missing)}"] if missing else [])
    assert not problems, "\n".join(problems)


def test_no_cached_kernel_contains_another_files_kernels():
    """numba keys a cache entry on its function's own file, yet compiles the compiled functions
    it calls into that entry: a cached kernel that called a compiled function of another file
    would keep that function's old code after the other file changed. So no module's cached
    kernels call another module's (every kernel's cache is keyed on all of its code)."""
    from numba.core.registry import CPUDispatcher

    for pkg in ("sca", "measure"):
        for info in pkgutil.iter_modules([str(ROOT / pkg)]):
            mod = importlib.import_module(f"{pkg}.{info.name}")
            own, foreign = [], set()
            for value in vars(mod).values():
                if isinstance(value, CPUDispatcher):
                    src = Path(value.py_func.__code__.co_filename).resolve()
                    if src == Path(mod.__file__).resolve():
                        own.append(value)
                    else:
                        foreign.add(str(src))
            cached = [d for d in own if d._cache.__class__.__name__ != "NullCache"]
            assert not (cached and foreign), (mod.__name__, foreign)


_SAME_RUN = """
import numpy as np, forward, sca
setup = forward.chart_setup(wavelengths=np.arange(400.0, 701.0, 10.0))
sims = [forward.simulate_chart(c, a, d, r, seed=i) for i, (c, a, d, r) in
        enumerate([(1.0, 0.5, 10.0, 5.0), (20.0, 0.05, 30.0, 0.5), (0.05, 0.0, 1.0, 0.5)])]
e = sca.estimate(sims[0].rgb, depth=10.0, distance=5.0, sigma=sims[0].rgb_sigma, setup=setup,
                 uncertain={}, mode="lm")
b = sca.estimate_batch(np.array([s.rgb for s in sims]), depth=np.array([10.0, 30.0, 1.0]),
                       distance=np.array([5.0, 0.5, 0.5]),
                       sigma=np.array([s.rgb_sigma for s in sims]), setup=setup, uncertain={})
print(repr((e.chl, e.cdom, tuple(e.chl_ci), tuple(e.cdom_ci), e.objective, b.chl.tolist(),
            b.cdom.tolist(), b.chl_ci.tolist(), b.cdom_ci.tolist(), b.objective.tolist())))
"""


@pytest.mark.slow
def test_results_do_not_depend_on_whether_numbas_cache_was_warm(tmp_path):
    """A process that compiles the kernels and one that loads them from numba's cache give the
    same numbers to the last bit (one chart and a batch of three, intervals included; 10 nm).
    The serial kernels only: the parallel ones run the same per-chart functions, and compiling
    them too would add half a minute to ``make test``. With
    reassociation among the kernels' fast-math flags they did not: the compiler ordered the
    sums differently when it compiled a kernel with its callees than in the code it cached
    (decision 0029-deterministic-compiled-sums)."""
    import os

    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "numba"), OPENBLAS_NUM_THREADS="1")
    runs = [subprocess.run([sys.executable, "-c", _SAME_RUN], env=env, cwd=ROOT, check=True,
                           capture_output=True, text=True).stdout for _ in range(2)]
    assert any((tmp_path / "numba").rglob("*.nbi")), "the first run cached nothing"
    assert runs[0] == runs[1]


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _project_imports(path: Path, modules: set, top_level_only: bool = False) -> set:
    """The project modules a file imports, anywhere in it (functions included) or at its top
    level only, never under ``if TYPE_CHECKING:`` (annotations only)."""
    me = _module_name(path)
    package = me if path.name == "__init__.py" else me.rpartition(".")[0]
    tree = ast.parse(path.read_text(encoding="utf-8"))
    skip = {id(n) for node in ast.walk(tree) if isinstance(node, ast.If)
            and "TYPE_CHECKING" in ast.unparse(node.test) for n in ast.walk(node)}
    found = set()
    nodes = tree.body if top_level_only else ast.walk(tree)
    for node in nodes:
        if id(node) in skip:
            continue
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names if a.name in modules}
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                up = package.split(".")[:len(package.split(".")) - (node.level - 1)]
                base = ".".join(up + ([node.module] if node.module else []))
            for a in node.names:
                full = f"{base}.{a.name}"
                found.add(full if full in modules else base)
    return (found & modules) - {me}


#: Knots of imports made by imports inside functions (each module still imports at load time
#: only downwards): the strongly connected components of the import graph, known debts listed
#: so that a new one fails. ``forward.water.model``'s ``Water.on_grid`` builds its evaluator
#: from ``forward.water.grid``, which is built on the model (a convenience method of the public
#: API). Cut in issue 40: ``sca.model`` <-> ``sca.quadrature`` (the model passes its type), the
#: six of ``measure``'s correction and output (``measure.imagefiles``; ``WHITE_TARGET`` in
#: ``measure.correct``), the benchmark cluster (``experiments.chartset``) and the real-water
#: studies (``experiments.realwater.nomad_data``).
KNOWN_KNOTS = {
    frozenset({"forward.water.model", "forward.water.grid", "forward.water.terms"}),
}


def _graph(top_level_only: bool):
    files = {_module_name(p): p for pkg in LAYERS for p in (ROOT / pkg).rglob("*.py")}
    modules = set(files)
    return {m: _project_imports(p, modules, top_level_only) for m, p in files.items()}


def _knots(graph) -> set:
    """The strongly connected components of ``graph`` with more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), set()

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = set()
            while True:
                w = stack.pop()
                on.discard(w)
                comp.add(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.add(frozenset(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_no_module_imports_itself_in_a_circle_at_load_time():
    """No circle of the imports a module makes when it is loaded (its top level, not under
    ``if TYPE_CHECKING:``): every file's dependencies run one way (issue 40)."""
    knots = _knots(_graph(top_level_only=True))
    assert not knots, [sorted(k) for k in knots]


def test_no_new_knot_through_imports_inside_functions():
    """Counting the imports inside functions too, the only knots are the known ones
    (:data:`KNOWN_KNOTS`); a cut one must leave the list (so the list stays true)."""
    knots = _knots(_graph(top_level_only=False))
    assert not knots - KNOWN_KNOTS, [sorted(k) for k in knots - KNOWN_KNOTS]
    assert not KNOWN_KNOTS - knots, [sorted(k) for k in KNOWN_KNOTS - knots]
