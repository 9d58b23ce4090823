"""The CLI outputs the documentation shows are what the commands print (issue 48 item 6.4):
each output block of docs/ and README.md is preceded by ``<!-- output of: uw3p ... -->``;
the test runs that command and fails when a line of the block is no longer printed. A block
may abridge a line: ``(...)`` or ``...`` stands for any text. A block that looks like a
command's output without the marker fails too (a pasted output cannot go stale unnoticed)."""

import io
import re
import shlex
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: The marker before a block of a command's output
MARKER = re.compile(r"^<!-- output of: (uw3p .+?) -->\n```\n(.*?)```", re.M | re.S)
#: A fenced block without a language (what output blocks are)
BARE_BLOCK = re.compile(r"^```\n(.*?)```", re.M | re.S)
#: A line as uw3p prints its results: a label, two spaces or more, the value
OUTPUT_LINE = re.compile(r"^ *[a-z][a-z0-9 ()_'-]*[a-z)] {2,}\S")
#: What stands for the rest of a line in a block
ELLIPSIS = re.compile(r" ?\(\.\.\.\)|\.\.\.")


def documents():
    return sorted((ROOT / "docs").rglob("*.md")) + [ROOT / "README.md"]


def documented_outputs():
    """(document, command, block) of every marked output block."""
    return [(doc.relative_to(ROOT), m.group(1), m.group(2))
            for doc in documents() for m in MARKER.finditer(doc.read_text(encoding="utf-8"))]


def line_pattern(line: str):
    """The regular expression of a documented line: its text, any text where it abridges."""
    pieces = ELLIPSIS.split(line.rstrip())
    return re.compile(".*".join(re.escape(p) for p in pieces) + "$")


def unmatched(block: str, printed: str) -> list:
    """The block's lines not printed, in the block's order, by the command (one printed line
    per documented line, in order)."""
    lines = printed.splitlines()
    missing, at = [], 0
    for want in filter(str.strip, block.splitlines()):
        pattern = line_pattern(want)
        hit = next((i for i in range(at, len(lines)) if pattern.match(lines[i])), None)
        if hit is None:
            missing.append(want)
        else:
            at = hit + 1
    return missing


def test_the_pattern_reads_abridged_lines():
    printed = "one photo        at 15 m: C ±131 %, c ±25 % (the intervals span)\nplan  wrote"
    assert unmatched("one photo        at 15 m: C ±131 %, c ±25 % (...)", printed) == []
    assert unmatched("one photo        at 15 m: C ±21 %, ...", printed) == [
        "one photo        at 15 m: C ±21 %, ..."]
    assert unmatched("plan  wrote\none photo        at 15 m: ...", printed) == [
        "one photo        at 15 m: ..."]  # out of order


def test_every_output_block_is_marked_with_its_command():
    bare = []
    for doc in documents():
        text = doc.read_text(encoding="utf-8")
        marked = {m.start(2) for m in MARKER.finditer(text)}
        for m in BARE_BLOCK.finditer(text):
            looks = any(OUTPUT_LINE.match(x) for x in m.group(1).splitlines())
            if looks and m.start(1) not in marked:
                bare.append(f"{doc.relative_to(ROOT)}: {m.group(1).splitlines()[0]}")
    assert not bare, "an output block without '<!-- output of: uw3p ... -->':\n" + "\n".join(bare)
    assert len(documented_outputs()) >= 2


@pytest.mark.slow
@pytest.mark.parametrize("doc, command, block", documented_outputs(),
                         ids=lambda v: str(v)[:60] if isinstance(v, str) else str(v))
def test_documented_output_is_what_the_command_prints(doc, command, block, tmp_path,
                                                      monkeypatch):
    from uw3p.cli import main

    monkeypatch.chdir(tmp_path)  # a --plan or --out of the command lands here
    out, err = io.StringIO(), io.StringIO()
    main(shlex.split(command)[1:], out=out, err=err)
    missing = unmatched(block, out.getvalue())
    assert not missing, (f"{doc}: the command `{command}` no longer prints:\n"
                         + "\n".join(missing) + "\n--- it prints:\n" + out.getvalue())
