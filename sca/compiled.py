"""numba's settings for the package's compiled kernels (sca's variable projection, measure's
demosaic), in one place.

numba's 'workqueue' threading layer is fork-safe; GNU OpenMP (numba's default here) is not:
after a parallel kernel, a process pool forked from the same process (the figure sweeps,
``uw3p measure FOLDER``) loses its workers. 'workqueue' is not safe for concurrent launches
from several Python threads, so every parallel kernel runs under :data:`KERNEL_LOCK`. A user's
``NUMBA_THREADING_LAYER`` still wins.
"""

from __future__ import annotations

import os
import threading
import types

import numba
from numba import njit, prange

__all__ = ["KERNEL_LOCK", "njit", "prange", "twins"]

if "NUMBA_THREADING_LAYER" not in os.environ:
    numba.config.THREADING_LAYER = "workqueue"

#: One parallel compiled kernel runs at a time (it already uses every core).
KERNEL_LOCK = threading.Lock()


def twins(func, **options):
    """A serial and a parallel compiled kernel from one Python function.

    numba compiles ``prange`` as ``range`` where ``parallel`` is off, so one source serves
    both; the serial twin is a copy of the function under another name, since numba's on-disk
    cache is keyed on a function's name and file (one function compiled both ways would share,
    and overwrite, one cache entry).

    Parameters
    ----------
    func : function
        The kernel's Python source (may call ``prange``).
    **options
        numba's options for both (``cache=True`` is the default).

    Returns
    -------
    serial, parallel : numba dispatchers
    """
    options.setdefault("cache", True)
    copy = types.FunctionType(func.__code__, func.__globals__, f"{func.__name__}_serial",
                              func.__defaults__, func.__closure__)
    copy.__qualname__ = f"{func.__qualname__}_serial"
    copy.__doc__ = func.__doc__
    return njit(**options)(copy), njit(parallel=True, **options)(func)
