"""The ``uw3p`` console script (:func:`main`): :func:`uw3p.cli.main`, with a Ctrl-C while
Python imports the command's modules or parses its arguments ending as one during the command
does (``uw3p: interrupted``, exit status 130), not in a traceback. Importing this module
imports nothing heavy (the package's ``__init__`` looks its version up lazily), so the handling
starts at once.
"""

from __future__ import annotations

import sys

__all__ = ["main"]


def main() -> int:
    """Run ``uw3p`` (:func:`uw3p.cli.main`) with a quiet Ctrl-C from the first moment.

    Returns
    -------
    int
        The exit status (130: interrupted).
    """
    try:
        from .cli import main as cli_main

        return cli_main()
    except KeyboardInterrupt:
        sys.stderr.write("uw3p: interrupted\n")
        return 130
