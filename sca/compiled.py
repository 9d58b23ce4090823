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

import numba
from numba import njit, prange

__all__ = ["KERNEL_LOCK", "njit", "prange"]

if "NUMBA_THREADING_LAYER" not in os.environ:
    numba.config.THREADING_LAYER = "workqueue"

#: One parallel compiled kernel runs at a time (it already uses every core).
KERNEL_LOCK = threading.Lock()
