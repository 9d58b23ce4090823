"""uw3p: the application layer (command line) above ``forward``, ``sca`` and ``experiments``.

Layers, each importing only those below it: ``forward`` (physics, sensor, rendering) <-
``sca`` (estimators) <- ``experiments`` (figures, benchmarks) and ``uw3p`` (the ``uw3p``
command).

Modules: ``cli`` (``main``, the console entry point, and ``build_parser``), one ``cmd_<name>``
module per subcommand (``simulate``, ``estimate``, ``calibrate``, ``measure``, ``design``,
``figures``, ``bench``; each with ``add_parser`` and ``run``), ``common`` (exit codes, shared
options and output helpers) and ``patchfile`` (the patch-value CSV format).
"""

from importlib import metadata as _metadata

try:
    __version__ = _metadata.version("uw3p")
except _metadata.PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "unknown"

__all__ = ["__version__"]
