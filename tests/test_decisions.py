"""The decision records (``docs/decisions/``, issue 40 item 4): each record has its sections,
the index lists every record, every citation of a decision in the code, the tests and the
documents names a record that exists, and nothing cites the old notebook's sections."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RECORDS = ROOT / "docs" / "decisions"
#: A record's file: four digits, a lowercase slug.
RECORD_NAME = re.compile(r"^(\d{4})-([a-z0-9]+(?:-[a-z0-9]+)*)\.md$")
#: The sections every record has, in this order ("Parameter" may sit between them).
SECTIONS = ("Context", "Decision", "Evidence", "Consequences")
#: A citation: ``decision NNNN-slug`` (or ``decisions NNNN-slug and NNNN-slug``), or a link to a
#: record's file.
RECORD_STEM = re.compile(r"(?<![\w-])00\d\d-[a-z][a-z0-9]*(?:-[a-z0-9]+)*")
CITING = re.compile(r"\bdecisions?\s+(\d{4})\b(-[a-z0-9-]+)?", re.I)
LINK = re.compile(r"decisions/(\d{4}-[a-z0-9-]+?)\.md")
#: Where citations live: the packages, the tests, the documents and the data's notes.
CODE_DIRS = ("forward", "sca", "measure", "experiments", "uw3p", "tests", "docs", "data")


def records() -> dict[str, Path]:
    out = {}
    for path in sorted(RECORDS.glob("*.md")):
        if path.name == "index.md":
            continue
        assert RECORD_NAME.match(path.name), f"{path.name}: not NNNN-slug.md"
        out[path.stem] = path
    return out


#: Folders of docs/ that the site's build writes (gitignored): not sources.
GENERATED_DOCS = ("_build", "gallery", "reports", "generated")


def sources():
    """Every text file that may cite a decision (the records themselves included)."""
    for name in CODE_DIRS:
        for path in sorted((ROOT / name).rglob("*")):
            rel = path.relative_to(ROOT).parts
            generated = rel[0] == "docs" and len(rel) > 2 and rel[1] in GENERATED_DOCS
            if path.is_file() and path.suffix in (".py", ".md", ".csv", ".txt", ".toml") \
                    and not generated:
                yield path
    for path in sorted(ROOT.glob("*.md")):
        yield path
    for name in ("Makefile", "pyproject.toml"):
        if (ROOT / name).exists():
            yield ROOT / name


def test_numbers_are_unique_and_consecutive():
    numbers = [int(stem[:4]) for stem in records()]
    assert numbers == list(range(1, len(numbers) + 1))


def test_every_record_has_a_title_and_the_four_sections_in_order():
    for stem, path in records().items():
        text = path.read_text(encoding="utf-8")
        first = text.splitlines()[0]
        assert first.startswith(f"# {stem[:4]} "), f"{path.name}: title must be '# {stem[:4]} …'"
        headings = re.findall(r"^## (.+?)\s*$", text, re.M)
        found = [h for h in headings if h in SECTIONS]
        assert found == list(SECTIONS), f"{path.name}: sections {headings}"
        extra = set(headings) - set(SECTIONS) - {"Parameter"}
        assert not extra, f"{path.name}: unexpected sections {extra}"
        for section in SECTIONS:
            body = text.split(f"## {section}", 1)[1].split("\n## ", 1)[0]
            assert body.strip(), f"{path.name}: empty {section}"


def test_every_record_is_in_the_index_table_and_its_toctree():
    index = (RECORDS / "index.md").read_text(encoding="utf-8")
    toctree = index.split("```{toctree}", 1)[1].split("```", 1)[0]
    entries = [line.strip() for line in toctree.splitlines()
               if line.strip() and not line.strip().startswith(":")]
    assert entries == list(records()), "the toctree must list every record, in order"
    for stem in records():
        assert f"]({stem}.md)" in index, f"{stem} missing from the index's table"


def test_every_citation_resolves_to_a_record():
    known = records()
    numbers = {stem[:4]: stem for stem in known}
    bad = []
    for path in sources():
        text = path.read_text(encoding="utf-8", errors="replace")
        rel = path.relative_to(ROOT)
        for m in CITING.finditer(text):
            line = text.count("\n", 0, m.start()) + 1
            number, slug = m.group(1), m.group(2)
            if number not in numbers:
                bad.append(f"{rel}:{line}: decision {number} does not exist")
            elif slug and f"{number}{slug}".rstrip("-.") != numbers[number]:
                bad.append(f"{rel}:{line}: {number}{slug} is not {numbers[number]}")
        for m in LINK.finditer(text):
            if m.group(1) not in known:
                line = text.count("\n", 0, m.start()) + 1
                bad.append(f"{rel}:{line}: no record {m.group(1)}")
        # every record name anywhere (a citation broken over a comment's lines, a list of them)
        for c in RECORD_STEM.finditer(text):
            if c.group(0) not in known:
                line = text.count("\n", 0, c.start()) + 1
                bad.append(f"{rel}:{line}: no record {c.group(0)}")
    assert not bad, "\n".join(bad)


def test_every_citation_names_the_record_not_only_its_number():
    """The convention is ``decision NNNN-slug``: a bare number is easy to mistype unnoticed."""
    bad = []
    for path in sources():
        if path.parent == RECORDS and path.name == "index.md":
            continue
        text = path.read_text(encoding="utf-8", errors="replace")
        for m in CITING.finditer(text):
            if not m.group(2) and "NNNN" not in text[m.start():m.end() + 5]:
                line = text.count("\n", 0, m.start()) + 1
                bad.append(f"{path.relative_to(ROOT)}:{line}: {m.group(0)}")
    assert not bad, "\n".join(bad)


def test_nothing_cites_the_old_notebook():
    """DECISIONS.md is a pointer to the records; no file cites it, least of all by a section."""
    bad = []
    for path in sources():
        if path.name in ("DECISIONS.md", "CHANGELOG.md") or path == Path(__file__):
            continue
        text = path.read_text(encoding="utf-8", errors="replace")
        for m in re.finditer(r"DECISIONS(?:\.md)?", text):
            line = text.count("\n", 0, m.start()) + 1
            bad.append(f"{path.relative_to(ROOT)}:{line}")
    assert not bad, "cite a record (decision NNNN-slug) instead:\n" + "\n".join(bad)
    pointer = (ROOT / "DECISIONS.md").read_text(encoding="utf-8")
    assert len(pointer.splitlines()) <= 12 and "docs/decisions/index.md" in pointer
