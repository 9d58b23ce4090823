"""The run's own files in the output folder: written whole or not at all (:func:`atomic`), and
the temporary files a killed run left removed (:func:`clean_temp`)."""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from pathlib import Path

from ..output import TEMP_PREFIX

__all__ = ["atomic", "clean_temp"]


@contextlib.contextmanager
def atomic(path: Path):
    """A temporary path beside ``path`` that replaces it when the block ends without error."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    os.close(fd)
    try:
        yield Path(tmp)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)



def clean_temp(root: Path) -> None:
    """Remove temporary folders an interrupted or killed run left in ``root``."""
    for p in root.glob(f"{TEMP_PREFIX}*"):
        if p.is_dir():
            shutil.rmtree(p, ignore_errors=True)
        else:
            p.unlink(missing_ok=True)
