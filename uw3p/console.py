"""The ``uw3p`` console script (:func:`main`): :func:`uw3p.cli.main`, with a Ctrl-C while
Python imports the command's modules or parses its arguments ending as one during the command
does (``uw3p: interrupted``, exit status 130), not in a traceback. Importing this module
imports nothing heavy (the package's ``__init__`` looks its version up lazily), so the handling
starts at once. The process's objects are frozen for the garbage collector as it ends
(:func:`ending`).
"""

from __future__ import annotations

import gc
import sys

__all__ = ["ending", "main"]


def main() -> int:
    """Run ``uw3p`` (:func:`uw3p.cli.main`) with a quiet Ctrl-C from the first moment.

    Returns
    -------
    int
        The exit status (130: interrupted).
    """
    try:
        from .cli import main as cli_main

        return ending(cli_main())
    except KeyboardInterrupt:
        sys.stderr.write("uw3p: interrupted\n")
        return 130


def ending(code: int) -> int:
    """``code``, with every object of the process moved out of the garbage collector's sight
    (:func:`gc.freeze`), for a process that ends now: the interpreter's exit then does not
    traverse them once more (after a fit, numba's ~110 000 objects: ~0.15 s of every command's
    time). Exit handlers, the standard streams and objects freed by their reference counts end
    as before; never called where the process goes on (``uw3p.cli.main`` in a test).

    Parameters
    ----------
    code : int
        The exit status.

    Returns
    -------
    int
        ``code``.
    """
    gc.freeze()
    return code
