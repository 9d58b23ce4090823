"""Outputs follow the user's umask: :func:`follow_umask` and :func:`umask` live in
:mod:`forward.files` (the package's one writer of files whole or not at all); this module
names them where :mod:`measure` has always had them. Imports nothing heavy."""

from __future__ import annotations

from forward.files import follow_umask, umask

__all__ = ["follow_umask", "umask"]
