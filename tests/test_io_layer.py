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


def _read_toy(p, black_level, white_level):
    """A toy RGB format: a .npy array under another extension."""
    import numpy as np

    from measure.image import rgb_photo

    with open(p, "rb") as fh:
        return rgb_photo(p, np.load(fh), black_level, white_level)


def test_a_new_photo_format_is_one_entry_in_the_table(tmp_path, monkeypatch):
    """Registering ``.toy`` in measure.image.IMAGE_READERS is all it takes: read_image (what
    ``uw3p measure`` reads with) reads it, and a dive's folder lists it as a photo (it sent
    every unknown extension to LibRaw, which refused it)."""
    import numpy as np

    import measure
    from measure.dive.names import dive_files
    from measure.image import IMAGE_READERS

    rgb = np.random.default_rng(1).integers(0, 60000, (32, 48, 3), dtype=np.uint16)
    with open(tmp_path / "shot.TOY", "wb") as fh:
        np.save(fh, rgb)
    (tmp_path / "notes.txt").write_text("x")
    monkeypatch.setitem(IMAGE_READERS, ".toy", _read_toy)
    photo = measure.read_image(tmp_path / "shot.TOY", black_level=100)
    assert photo.kind == "rgb" and photo.size == (48, 32)
    np.testing.assert_array_equal(photo.data, rgb.astype(np.float32) - 100)
    assert [p.name for p in dive_files(tmp_path)[0]] == ["shot.TOY"]


def test_the_photo_and_the_dive_read_exif_through_one_reader(tmp_path, monkeypatch):
    """read_image's exposure and camera and exif_info's depth and time come from
    measure.exif.read_exif (there were two readers, one per module)."""
    import numpy as np
    import tifffile

    import measure
    from measure import exif
    from measure.dive import exif_info

    path = tmp_path / "tagged.tif"
    tifffile.imwrite(path, np.zeros((8, 8, 3), np.uint16), photometric="rgb",
                     extratags=[(33434, 5, 1, (1, 250), True), (271, 2, 6, "Canon", True),
                                (37891, 10, 1, (55, 10), True),
                                (36867, 2, 20, "2024:05:06 10:11:12", True)])
    seen = []
    real = exif.read_exif
    monkeypatch.setattr(exif, "read_exif", lambda p: seen.append(p) or real(p))
    photo = measure.read_image(path)
    info = exif_info(path)
    assert len(seen) == 2
    assert photo.exposure == {"exposure_s": pytest.approx(0.004)}
    assert photo.camera == {"make": "Canon"}
    assert info == {"depth_m": pytest.approx(5.5), "depth_tag": "WaterDepth",
                    "time": "2024-05-06T10:11:12"}
