"""Files written whole or not at all, in the user's umask: the package's one writer.

Every output (the command line's files, a photo's and a dive's results, the experiments'
tables, figures and caches) is written to a temporary file in its own folder
(``.<name>.<random>.tmp``) that ``os.replace`` renames into place when it is complete, so a
crash, a kill or a full disk leaves the old file or the new, never a part; the temporary file
is removed when the write fails. ``tempfile.mkstemp`` makes private files (0600), which a
rename would keep: :func:`follow_umask` gives them the mode ``open`` would have (0666 less the
umask). Imports nothing heavy (the command line's refusals load no numpy).
"""

from __future__ import annotations

import contextlib
import os
import tempfile
import threading
from pathlib import Path

from .errors import InputError

__all__ = ["TEMP_SUFFIX", "atomic_open", "atomic_path", "follow_umask", "umask", "write_atomic"]

#: A file being written is ``.<name>.<random>`` + this suffix beside its place
TEMP_SUFFIX = ".tmp"

_LOCK = threading.Lock()


def umask() -> int:
    """The process's umask: from /proc/self/status where Linux gives it, else set and restored
    at once (under a lock)."""
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    with _LOCK:
        mask = os.umask(0o077)
        os.umask(mask)
    return mask


def follow_umask(path, folder: bool = False) -> None:
    """Give a file (0666) or folder (0777) made by ``tempfile`` the mode less the umask.

    Parameters
    ----------
    path : str or os.PathLike
    folder : bool, optional
        ``path`` is a folder.
    """
    os.chmod(path, (0o777 if folder else 0o666) & ~umask())


@contextlib.contextmanager
def atomic_path(path, argument: str | None = None):
    """A temporary path beside ``path`` that replaces it when the block ends without error.

    Parameters
    ----------
    path : str or os.PathLike
        The file to write (its folder must exist).
    argument : str, optional
        Where given, an ``OSError`` (making the file, in the block, or renaming it) becomes an
        :class:`~forward.errors.InputError` naming it: ``cannot write <path>: <reason>``.

    Yields
    ------
    pathlib.Path
        The temporary file (``.<name>.<random>.tmp``, mode 0666 less the umask, empty): the
        block writes it; it is removed if the block fails.
    """
    path, tmp = Path(path), None
    try:
        with _as_input_error(path, argument):
            fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.",
                                       suffix=TEMP_SUFFIX)
            os.close(fd)
            follow_umask(tmp)  # renamed into place: the user's umask, not mkstemp's 0600
            yield Path(tmp)
            os.replace(tmp, path)
    finally:
        if tmp is not None and os.path.exists(tmp):
            os.unlink(tmp)


@contextlib.contextmanager
def _as_input_error(path: Path, argument):
    try:
        yield
    except OSError as exc:
        if argument is None:
            raise
        raise InputError(argument, f"cannot write {path}: {exc.strerror or exc}") from None


@contextlib.contextmanager
def atomic_open(path, mode: str = "w", argument: str | None = None, **kwargs):
    """``open(path, mode, **kwargs)`` written whole or not at all (:func:`atomic_path`).

    Parameters
    ----------
    path : str or os.PathLike
    mode : {'w', 'wb'}, optional
    argument : str, optional
        The argument an ``OSError`` names (:func:`atomic_path`).
    **kwargs
        ``open``'s (``encoding``, ``newline``).

    Yields
    ------
    file object
    """
    with atomic_path(path, argument) as tmp, open(tmp, mode, **kwargs) as fh:
        yield fh


def write_atomic(path, data, argument: str | None = None) -> Path:
    """Write ``data`` (str: UTF-8; or bytes) to ``path`` whole or not at all.

    Parameters
    ----------
    path : str or os.PathLike
    data : str or bytes
    argument : str, optional
        The argument an ``OSError`` names (:func:`atomic_path`).

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    with atomic_path(path, argument) as tmp:
        if isinstance(data, bytes):
            tmp.write_bytes(data)
        else:
            tmp.write_text(data, encoding="utf-8", newline="")
    return Path(path)
