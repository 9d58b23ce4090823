"""PEP 562 lazy exports: a package's public names loaded from their submodules on first use.

Used by :mod:`forward`, :mod:`sca` and :mod:`measure` so that importing any of them costs
nothing until a name is asked for (decision 0007-start-up). Imports nothing heavy itself.
"""

from __future__ import annotations

import importlib
import importlib.util

__all__ = ["lazy_exports"]


def lazy_exports(package: str, namespace: dict, home: dict, names):
    """The ``__getattr__`` and ``__dir__`` of a package whose public names load lazily.

    Parameters
    ----------
    package : str
        The package's name (its ``__name__``).
    namespace : dict
        The package's ``globals()``: a loaded name is stored there, so it loads once.
    home : dict
        Public name -> the submodule (relative to ``package``) that defines it.
    names : sequence of str
        The package's ``__all__``.

    Returns
    -------
    getattr_, dir_ : callable
        For ``__getattr__`` (a public name from its submodule, or a submodule itself, e.g.
        ``sca.budget``; ``AttributeError`` otherwise) and ``__dir__`` (the loaded names and
        every public one).
    """
    def getattr_(name):
        sub = home.get(name)
        if sub is None:
            if name.startswith("_") or importlib.util.find_spec(f"{package}.{name}") is None:
                raise AttributeError(f"module {package!r} has no attribute {name!r}")
            return importlib.import_module(f".{name}", package)  # binds <package>.<name> itself
        value = getattr(importlib.import_module(f".{sub}", package), name)
        namespace[name] = value
        return value

    def dir_():
        return sorted(set(namespace) | set(names))

    return getattr_, dir_
