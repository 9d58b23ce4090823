"""``python -m uw3p``: the same as the ``uw3p`` command."""

import sys

from .cli import main
from .console import ending

__all__: list[str] = []

sys.exit(ending(main()))
