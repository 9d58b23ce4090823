"""Every public name the documents and the code use exists (issue 35): the ``package.name``
references in the Markdown documents' code (README.md, CHANGELOG.md, the reports and the
documentation site's pages, the decision records among them), the
``package.name`` attributes the code itself reads from a package it imported, and each
package's ``__all__`` with its lazy exports (``_HOME``)."""

import ast
import importlib
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: The project's packages (the layers, lowest first).
PACKAGES = ("forward", "sca", "measure", "experiments", "uw3p")
#: Code in Markdown: fenced blocks and inline spans.
CODE = re.compile(r"```.*?```|`[^`]+`", re.S)
#: A dotted name that starts with a package (not part of a path or of a longer name); a
#: trailing ``*`` stands for every name with that prefix (``sca.trust_region.TR_*``).
DOTTED = re.compile(r"(?<![\w./\\-])(?:%s)(?:\.[A-Za-z_]\w*)+\*?" % "|".join(PACKAGES))
#: ``from package.module import a, b`` in code.
FROM_IMPORT = re.compile(r"\bfrom\s+((?:%s)(?:\.\w+)*)\s+import\s+(\w+(?:\s*,\s*\w+)*)"
                         % "|".join(PACKAGES))


def resolve(dotted: str):
    """The object a dotted name means: its longest importable module prefix, then attributes
    (``AttributeError`` or ``ImportError`` when it does not exist). A trailing ``*``: some
    attribute of the parent has that prefix."""
    parts = dotted.rstrip("*").split(".")
    for i in range(len(parts), 0, -1):
        name = ".".join(parts[:i])
        try:
            obj = importlib.import_module(name)
            break
        except ModuleNotFoundError as exc:  # not a module: an attribute, unless it is missing
            if not (exc.name and f"{name}.".startswith(f"{exc.name}.")):  # a dependency
                raise
    for j, part in enumerate(parts[i:], start=i):
        if dotted.endswith("*") and j == len(parts) - 1:
            if not any(a.startswith(part) for a in dir(obj)):
                raise AttributeError(f"no attribute of {'.'.join(parts[:j])} starts with {part}")
            return obj
        obj = getattr(obj, part)
    return obj


def _documented_names(text: str):
    """(line, dotted name) of every package name the code spans of a Markdown text use."""
    for span in CODE.finditer(text):
        line = text.count("\n", 0, span.start()) + 1
        code = span.group(0)
        for m in DOTTED.finditer(code):
            yield line, m.group(0)
        for m in FROM_IMPORT.finditer(code):
            for name in re.split(r"\s*,\s*", m.group(2)):
                yield line, f"{m.group(1)}.{name}"


def _problems(pairs):
    out = []
    for where, name in pairs:
        try:
            resolve(name)
        except (AttributeError, ImportError) as exc:
            out.append(f"{where}: {name}: {exc}")
    return out


def test_every_name_the_documents_use_exists():
    docs = [p for p in sorted((ROOT / "docs").rglob("*.md")) if "_build" not in p.parts
            and p.parts[len(ROOT.parts) + 1] not in ("gallery", "reports", "generated")]
    pairs = [(f"{path.relative_to(ROOT)}:{line}", name)
             for path in sorted(ROOT.glob("*.md")) + docs
             for line, name in _documented_names(path.read_text(encoding="utf-8"))]
    assert len({name for _, name in pairs}) > 100  # the parser found the documents' names
    problems = _problems(pairs)
    assert not problems, "\n".join(problems)


def _expected_to_fail(tree):
    """The nodes inside ``with pytest.raises(...)`` blocks (a test of a missing name)."""
    return {id(inner) for node in ast.walk(tree) if isinstance(node, ast.With)
            and any("raises" in ast.unparse(item.context_expr) for item in node.items)
            for stmt in node.body for inner in ast.walk(stmt)}


def _used_attributes(path: Path):
    """(line, dotted name) of every ``package.attribute`` read in a source file where the
    package is imported as itself (``import measure``), outside ``pytest.raises`` blocks."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    imported = {a.name for node in ast.walk(tree) if isinstance(node, ast.Import)
                for a in node.names if a.asname is None and a.name in PACKAGES}
    skip = _expected_to_fail(tree)
    for node in ast.walk(tree):
        if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
                and node.value.id in imported and id(node) not in skip):
            yield node.lineno, f"{node.value.id}.{node.attr}"


def test_every_package_name_the_code_reads_exists():
    files = [p for d in (*PACKAGES, "tests") for p in sorted((ROOT / d).rglob("*.py"))]
    pairs = [(f"{path.relative_to(ROOT)}:{line}", name) for path in files
             for line, name in _used_attributes(path)]
    assert any(name == "measure.measure" for _, name in pairs)  # the scan sees the code
    problems = _problems(pairs)
    assert not problems, "\n".join(problems)


def test_every_public_and_lazy_name_resolves_to_its_home():
    """Each package's ``__all__`` resolves; a lazily exporting package's ``__all__`` is its
    ``_HOME``, and each name there is defined and public (in ``__all__``) in its submodule."""
    problems = []
    for name in PACKAGES:
        pkg = importlib.import_module(name)
        problems += [f"{name}.{n}: in __all__, does not resolve" for n in pkg.__all__
                     if not hasattr(pkg, n)]
        home = vars(pkg).get("_HOME")
        if home is None:
            continue
        if set(home) != set(pkg.__all__):
            problems.append(f"{name}: __all__ is not _HOME's names")
        for attr, sub in home.items():
            mod = importlib.import_module(f"{name}.{sub}")
            if attr not in vars(mod):
                problems.append(f"{name}._HOME: {attr} -> {sub}, which does not define it")
            elif attr not in getattr(mod, "__all__", ()):
                problems.append(f"{name}._HOME: {attr} -> {sub}, not in its __all__")
            elif getattr(pkg, attr) is not vars(mod)[attr]:
                problems.append(f"{name}.{attr} is not {name}.{sub}.{attr}")
    assert not problems, "\n".join(problems)
