"""The output folder of a dive: prepared and locked for one run at a time (:func:`locked`),
the run's own files written whole or not at all (:func:`atomic`), and the temporary files a
killed run left removed (:func:`clean_temp`).

The lock is ``fcntl.flock`` on :data:`measure.dive.names.LOCK_FILE` in the folder, held while
the run lasts: a second run into the folder is refused at once, and a killed run's lock goes
with its process (the kernel releases it), so a stale lock file never blocks. A run removes the
file before it releases the lock, so no ``.uw3p.lock`` is left after it; a run that opened the
file before that removal and locks it after finds it no longer linked, and is refused like a
run that found it locked. Every failure
to create or write the folder is a ``ValueError`` naming ``out``.
"""

from __future__ import annotations

import contextlib
import os
import shutil
from pathlib import Path

from forward.files import TEMP_SUFFIX, atomic_path
from ..output import TEMP_PREFIX
from .names import LOCK_FILE, RUN_FILES
from forward.errors import InputError

__all__ = ["TEMP_SUFFIX", "atomic", "clean_temp", "locked"]


def _why(exc: OSError) -> str:
    return exc.strerror or str(exc)


def atomic(path: Path):
    """A temporary path beside ``path`` that replaces it when the block ends without error
    (:func:`forward.files.atomic_path`).

    Parameters
    ----------
    path : pathlib.Path
        The file to write.

    Returns
    -------
    context manager yielding pathlib.Path
        The temporary file (``.<name>.<random>.tmp``, which :func:`clean_temp` removes if a
        kill leaves it).

    Raises
    ------
    ValueError
        Naming ``out``: the file cannot be written (an ``OSError`` in the block included).
    """
    return atomic_path(path, "out")


def clean_temp(root: Path) -> None:
    """Remove what an interrupted or killed run left half-written in ``root``: the photos'
    temporary folders (:data:`measure.output.TEMP_PREFIX`) and the run's own temporary files
    (``.<run file>.*.tmp``, :data:`measure.dive.names.RUN_FILES`); nothing else.

    Parameters
    ----------
    root : pathlib.Path
        The output folder (locked by this run).
    """
    patterns = [f"{TEMP_PREFIX}*"] + [f".{name}.*{TEMP_SUFFIX}" for name in RUN_FILES]
    for pattern in patterns:
        for p in root.glob(pattern):
            if p.is_dir() and not p.is_symlink():
                shutil.rmtree(p, ignore_errors=True)
            else:
                p.unlink(missing_ok=True)


@contextlib.contextmanager
def locked(root: Path):
    """Create the output folder if missing and hold its lock while the block runs.

    Parameters
    ----------
    root : pathlib.Path
        The output folder.

    Yields
    ------
    pathlib.Path
        ``root``.

    Raises
    ------
    ValueError
        Naming ``out``: the folder cannot be created or written (a read-only file system, no
        permission), or another uw3p run holds its lock.
    """
    import fcntl  # POSIX (Linux, macOS); the dive's workers are POSIX processes too

    try:
        root.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError("out", f"cannot create {root}: {_why(exc)}") from None
    try:
        fd = os.open(root / LOCK_FILE, os.O_RDWR | os.O_CREAT, 0o644)
    except OSError as exc:
        raise InputError("out", f"cannot create the lock file {root / LOCK_FILE}: {_why(exc)}") \
            from None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise InputError("out", f"another uw3p run is writing {root}; wait for it to end, or "
                             "give another --out") from None
        except OSError as exc:
            raise InputError("out", f"cannot lock {root}: {_why(exc)}") from None
        if not _still_linked(fd, root / LOCK_FILE):  # a run that ended removed it meanwhile
            raise InputError("out", f"another uw3p run is writing {root}; wait for it to end, "
                             "or give another --out")
        try:
            yield root
        finally:
            (root / LOCK_FILE).unlink(missing_ok=True)  # held: no run waits on this file
    finally:
        os.close(fd)  # releases the lock


def _still_linked(fd: int, path: Path) -> bool:
    """The locked file is still the one at ``path`` (a run that ended may have removed it
    between our open and our lock: then a later run locks a new file, not ours)."""
    try:
        return os.path.samestat(os.fstat(fd), os.stat(path))
    except OSError:
        return False
