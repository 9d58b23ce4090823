"""No number typed by hand in a generated report (issue 50, items 3 and 8).

Every top-level report is written by a generator; a number in its prose must be one the
generator computed. Two checks:

- the *hand-written text* of each generator (the string literals of its source, format values
  and docstrings excluded) holds no number but references (Fig 9, eq 19, issue 50, a decision
  record's name, a year, a section number), code in backticks, quotations and the values of
  settings held as numeric constants in the package's code;
- REPRODUCTION.md is generated between markers only; its hand-written sections that report
  results ("What the verdicts say", "What the search says ...") hold no number at all but
  references and quotations, and the sentence under the claims table that quotes the untuned
  setting's estimation rows is the generator's own (:func:`experiments.report.setting_sentence`)
  applied to the committed table.
"""

import ast
import re
from functools import lru_cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: Each generated report: the generator its head names, and the module(s) whose literals are
#: its hand-written text
GENERATORS = {
    "HONESTY.md": ("experiments.honesty", ["experiments/honesty.py"]),
    "DIVE.md": ("experiments.dive_honesty", ["experiments/dive_honesty.py"]),
    "DESIGN.md": ("experiments.design_check", ["experiments/design_check.py"]),
    "CORRECTION.md": ("experiments.correct_range", ["experiments/correct_range.py"]),
    "REPRODUCTION.md": ("experiments.report", ["experiments/report.py"]),
    "REALWATER.md": ("experiments.realwater", ["experiments/realwater/report.py"]),
    "INSTRUMENT.md": ("experiments.instrument", ["experiments/instrument.py"]),
    "BENCHMARKS.md": ("experiments.benchmark", ["experiments/benchmark_report.py"]),
}

#: Digits that are not numbers of a result: references, code, quotations, names
NOT_A_RESULT = [
    r"`[^`]*`", r"\{[^}]*\}", r'"[^"]*"', r"“[^”]*”",
    r"\b(?:Figs?|figures?|eqs?|Eqs?|[Ii]ssues?|Table|decisions?|ref\.|section|pass|[Ww]orlds?|"
    r"Deviation)\s*\d+(?:\s*[–-]\s*\d+)?(?:,\s*\d+)*",
    r"\b(?:19|20)\d\d\b", r"\b\d{4}-[a-z][\w-]*", r"\b[A-Za-z_]+\d+\w*",
    r"^#+ \d+\.", r"^\s*[-*]?\s*\d+\. ", r"[⁰¹²³⁴⁵⁶⁷⁸⁹⁻]+",
    r"Nikon \d+", r"neutral \d(?:\.\d)?(?:, \d(?:\.\d)?)*",  # a camera's, a patch's name
    r"\(\d{3}(?:, \d{3})+\)",  # a list of wavelengths in nm, c(443, 490, 555)
    r"\b\d+\s+nm\s+(?:grid|world|estimator)\b",  # a spectral grid's name
]
NUMBER = re.compile(r"\d{1,3}(?:[  ]\d{3})+(?![\d.])|\d+(?:\.\d+)?")


def typed_numbers(text, allowed=frozenset()) -> list:
    """The numbers of ``text`` that are not references, code or quotations and whose value (or
    value / 100, a percentage) is not in ``allowed``."""
    for pattern in NOT_A_RESULT:
        text = re.sub(pattern, "", text, flags=re.M)
    out = []
    for token in NUMBER.findall(text):
        v = float(re.sub(r"[  ]", "", token))
        if not {round(v, 12), round(v / 100, 12)} & allowed:
            out.append(token)
    return out


@lru_cache(maxsize=None)
def code_constants() -> frozenset:
    """Every numeric constant of the package's code: the settings a report may restate."""
    values = set()
    for package in ("forward", "sca", "measure", "experiments"):
        for path in (ROOT / package).rglob("*.py"):
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
                if (isinstance(node, ast.Constant) and isinstance(node.value, (int, float))
                        and not isinstance(node.value, bool)):
                    values.add(round(float(node.value), 12))
    return frozenset(values)


def prose_literals(source: str) -> list:
    """(line, text) of the string literals of ``source`` with a space in them: docstrings and
    f-string format specifications excluded."""
    tree = ast.parse(source)
    skip = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            doc = node.body[0] if node.body else None
            if isinstance(doc, ast.Expr) and isinstance(doc.value, ast.Constant):
                skip.add(id(doc.value))
        if isinstance(node, ast.FormattedValue) and node.format_spec is not None:
            skip.update(id(n) for n in ast.walk(node.format_spec))
    return [(n.lineno, n.value) for n in ast.walk(tree)
            if isinstance(n, ast.Constant) and isinstance(n.value, str) and id(n) not in skip
            and " " in n.value.strip()]


def typed_in_source(source: str) -> list:
    return [(line, text[:80], bad) for line, text in prose_literals(source)
            if (bad := typed_numbers(text, code_constants()))]


@pytest.mark.parametrize("report", sorted(GENERATORS))
def test_every_report_names_its_generator_which_types_no_number(report):
    generator, modules = GENERATORS[report]
    assert f"python -m {generator}" in (ROOT / report).read_text(encoding="utf-8")[:3000], \
        f"{report} does not name its generator {generator}"
    for module in modules:
        typed = typed_in_source((ROOT / module).read_text(encoding="utf-8"))
        assert not typed, f"{module} types numbers into {report}: {typed}"


def test_a_number_typed_into_a_generator_is_found():
    """The check can fail: a result typed into a literal is found, a formatted one is not."""
    typed = typed_in_source('x = 3\nline = f"r² stays {x:.2f} at every depth, RRMSE 0.0173 %"\n')
    assert [bad for *_, bad in typed] == [["0.0173"]]
    assert typed_numbers("Fig 9's k (eq 19, issue 50, decision 0010-uncertainty-budget) in 2017") == []
    assert typed_numbers('the issue\'s "1.14 %" against our 0.93 %') == ["0.93"]


# ---------------------------------------------------------------------------- REPRODUCTION.md
def _between(text, begin, end):
    return text.split(begin, 1)[1].split(end, 1)[0]


def _reproduction():
    return (ROOT / "REPRODUCTION.md").read_text(encoding="utf-8")


#: The hand-written sections of REPRODUCTION.md that report results: numbers only by reference
RESULT_SECTIONS = ("## What the verdicts say", "## What the search says about the paper's simulation")


def _section(text, heading):
    return text.split(heading + "\n", 1)[1].split("\n## ", 1)[0]


@pytest.mark.parametrize("heading", RESULT_SECTIONS)
def test_reproduction_result_prose_types_no_number(heading):
    from experiments.report import END

    hand = _reproduction().split(END, 1)[1]
    assert heading in hand, f"{heading} is not in the hand-written part"
    typed = typed_numbers(_section(hand, heading))
    assert not typed, (f"REPRODUCTION.md, {heading!r}: numbers typed by hand (quote the generated "
                       f"lines or make the generator write them): {typed}")


def claims_table(text):
    """The claims table of REPRODUCTION.md as rows of :func:`experiments.report.claims`
    (claim, words, {setting: text}, {setting: verdict}, rule)."""
    lines = text.split("| claim | the paper says |", 1)[1].split("\n\n", 1)[0].splitlines()
    names = [h.strip().split(" (", 1)[0] for h in lines[0].split(" | ")[:-2]]
    rows = []
    for line in lines[2:]:
        cells = [c.strip() for c in line.strip().strip("|").split(" | ")]
        verdicts = cells[-2].split(" / ")
        rows.append((cells[0], cells[1], dict(zip(names, cells[2:-2])),
                     dict(zip(names, verdicts)), cells[-1]))
    return names, rows


def test_reproduction_quotes_its_table_at_the_untuned_setting():
    """The sentence under the claims table is the generator's, from the committed table's
    numbers: the prose that restated them by hand (and contradicted them) is gone."""
    from experiments.grids import SETTINGS
    from experiments.report import BEGIN, END, ESTIMATION, setting_sentence

    generated = _between(_reproduction(), BEGIN, END)
    names, rows = claims_table(generated)
    assert set(ESTIMATION) <= {r[0] for r in rows}
    untuned = [n for n in names if not (SETTINGS[n].get("machinery_check")
                                        or SETTINGS[n].get("chosen_by_search"))]
    assert untuned == ["default"]
    for n in untuned:
        assert setting_sentence(rows, n) in generated


def test_setting_sentence_quotes_the_estimation_rows_and_only_them():
    from test_rules import _passing_numbers

    from experiments.report import ESTIMATION, claims, setting_sentence

    rows = claims({"default": _passing_numbers()})
    sentence = setting_sentence(rows, "default")
    for claim, _words, texts, verdicts, _rule in rows:
        quoted = f"{claim}: {texts['default']} — {verdicts['default']}" in sentence
        assert quoted == (claim in ESTIMATION), claim
