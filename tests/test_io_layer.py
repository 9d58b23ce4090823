"""Issue 49, item 2: one io layer. Files are written by one helper (forward.files), whole or
not at all, in the user's umask; image formats are a table (measure.image.IMAGE_FORMATS) that
one registration extends; one EXIF reader (measure.exif) serves the photo and the dive."""

import os
import re
import stat
from pathlib import Path

import pytest

from forward.errors import InputError
from forward.files import atomic_open, write_atomic

ROOT = Path(__file__).resolve().parents[1]
#: The one file writer, and the result folder's swap (a folder, renamed whole)
RENAMERS = {"forward/files.py", "measure/output.py"}


def test_a_failed_write_leaves_the_old_file_and_no_temporary(tmp_path):
    """A block that fails replaces nothing and leaves no ``.<name>.*.tmp``."""
    target = tmp_path / "table.csv"
    target.write_text("old\n")
    with pytest.raises(RuntimeError):
        with atomic_open(target) as fh:
            fh.write("half")
            raise RuntimeError("killed")
    assert target.read_text() == "old\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["table.csv"]


def test_a_written_file_follows_the_umask_and_names_the_argument_when_it_cannot(tmp_path):
    """The file is whole, 0644 under umask 022 (not mkstemp's 0600); a missing folder is an
    InputError naming the argument given."""
    old = os.umask(0o022)
    try:
        write_atomic(tmp_path / "a.json", "{}\n")
    finally:
        os.umask(old)
    assert (tmp_path / "a.json").read_text() == "{}\n"
    assert stat.S_IMODE((tmp_path / "a.json").stat().st_mode) == 0o644
    with pytest.raises(InputError, match=r"^out: cannot write .*missing"):
        write_atomic(tmp_path / "missing" / "a.json", b"x", "out")


def test_no_other_module_renames_a_file_into_place():
    """Every writer of the package and of the experiments goes through forward.files: no
    ``os.replace`` / ``mkstemp`` of its own elsewhere (measure.output's is the result
    folder's swap)."""
    pattern = re.compile(r"^[^#]*\b(os\.replace|tempfile\.mkstemp)\(", re.M)
    own = sorted(str(p.relative_to(ROOT)) for d in ("forward", "sca", "measure", "uw3p",
                                                    "experiments")
                 for p in (ROOT / d).rglob("*.py") if pattern.search(p.read_text("utf-8")))
    assert set(own) <= RENAMERS, own
