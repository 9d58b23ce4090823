"""Outputs follow the user's umask: ``tempfile.mkstemp`` and ``mkdtemp`` make private files
(0600) and folders (0700), which a rename into place would keep; :func:`follow_umask` gives
them the mode ``open`` and ``mkdir`` would have (0666 / 0777 less the umask). Imports nothing
heavy (the command line's refusals load no numpy)."""

from __future__ import annotations

import os
import threading

__all__ = ["follow_umask", "umask"]

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
