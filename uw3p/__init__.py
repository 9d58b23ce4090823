"""uw3p: the application layer (command line) above ``forward``, ``sca`` and ``experiments``.

Layers, each importing only those below it: ``forward`` (physics, sensor, rendering) <-
``sca`` (estimators) <- ``experiments`` (figures, benchmarks) and ``uw3p`` (the ``uw3p``
command).

Modules: ``console`` (``main``, the console script: ``cli.main`` behind a quiet Ctrl-C), ``cli``
(``main``, the command, and ``build_parser``), one ``cmd_<name>``
module per subcommand (``simulate``, ``estimate``, ``calibrate``, ``measure``, ``design``,
``figures``, ``bench``; each with ``add_parser`` and ``run``), ``common`` (exit codes, shared
options and output helpers) and ``patchfile`` (the patch-value CSV format).
"""

__all__ = ["__version__"]


def __getattr__(name):
    """``__version__``, looked up when first asked for (importing this package stays instant:
    the console script's Ctrl-C handling, :mod:`uw3p.console`, starts at once)."""
    if name != "__version__":
        raise AttributeError(f"module 'uw3p' has no attribute {name!r}")
    from importlib import metadata

    try:
        version = metadata.version("uw3p")
    except metadata.PackageNotFoundError:  # pragma: no cover - running from a source tree
        version = "unknown"
    globals()["__version__"] = version
    return version

