"""numba's settings for the package's compiled kernels (sca's variable projection, measure's
demosaic), in one place.

numba's 'workqueue' threading layer is fork-safe; GNU OpenMP (numba's default here) is not:
after a parallel kernel, a process pool forked from the same process (the figure sweeps,
``uw3p measure FOLDER``) loses its workers. 'workqueue' is not safe for concurrent launches
from several Python threads, so every parallel kernel runs under :data:`KERNEL_LOCK`. A user's
``NUMBA_THREADING_LAYER`` still wins.
"""

from __future__ import annotations

import hashlib
import os
import threading
from pathlib import Path

import numba
from numba import njit, prange
from numba.core import caching

__all__ = ["CACHE_DEPENDS", "DEPENDENT_CACHE", "KERNEL_LOCK", "DependentLocator", "njit",
           "prange"]

if "NUMBA_THREADING_LAYER" not in os.environ:
    numba.config.THREADING_LAYER = "workqueue"

#: One parallel compiled kernel runs at a time (it already uses every core).
KERNEL_LOCK = threading.Lock()


# ----------------------------------------------------------------- caches of several files
_SCA = Path(__file__).resolve().parent
#: Source files whose compiled functions call compiled functions of other files (numba
#: compiles the callees into the caller's cache entry, but keys that entry on the caller's
#: file alone): file -> the other files its entries contain.
CACHE_DEPENDS = {
    str(_SCA / "fusedlm.py"): tuple(str(p) for p in (
        _SCA.parent / "forward" / "water.py", _SCA / "lm.py", _SCA / "model.py",
        _SCA / "projection.py", _SCA / "compiled.py")),
}


class DependentLocator(caching._CacheLocator):
    """numba's cache locator for the files of :data:`CACHE_DEPENDS`: where numba's own locator
    would put the cache, but stamped with the content of every file the entries contain, so
    that editing a callee (forward's weights, the Levenberg-Marquardt step, the projection, a
    constant) invalidates the cache of its callers too. (numba keys an entry on its caller's
    file only: numba issue #1833.)"""

    def __init__(self, inner, depends):
        self._inner, self._depends = inner, depends

    def ensure_cache_path(self):
        self._inner.ensure_cache_path()

    def get_cache_path(self):
        return self._inner.get_cache_path()

    def get_disambiguator(self):
        return self._inner.get_disambiguator()

    def get_source_stamp(self):
        digest = hashlib.sha256()
        for path in self._depends:
            digest.update(Path(path).read_bytes())
        return self._inner.get_source_stamp(), digest.hexdigest()

    @classmethod
    def from_function(cls, py_func, py_file):
        depends = CACHE_DEPENDS.get(str(Path(py_file).resolve()))
        if not depends:
            return None
        for other in _IMPL._locator_classes:
            if other is not cls:
                inner = other.from_function(py_func, py_file)
                if inner is not None:
                    return cls(inner, depends)
        return None


#: numba's cache implementation (CacheImpl in numba 0.68, _CacheImpl before)
_IMPL = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl", None)
#: True where the files of :data:`CACHE_DEPENDS` may cache their compiled functions (the
#: locator is registered); else they compile in every process, never stale.
DEPENDENT_CACHE = isinstance(getattr(_IMPL, "_locator_classes", None), list)
if DEPENDENT_CACHE and DependentLocator not in _IMPL._locator_classes:
    _IMPL._locator_classes.insert(0, DependentLocator)
