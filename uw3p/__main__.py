"""``python -m uw3p``: the same as the ``uw3p`` command."""

import sys

from .cli import main

__all__: list[str] = []

sys.exit(main())
