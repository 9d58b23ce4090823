"""Input checks shared by the forward model and the estimator.

Every check raises :class:`ValueError` whose message starts with the argument's name, so a
caller always learns *which* input is wrong and *why*.
"""

from __future__ import annotations

import numpy as np


def scalar(name: str, value, *, nonnegative: bool = True, positive: bool = False) -> float:
    """Return ``value`` as a finite float; raise ``ValueError`` naming ``name`` otherwise."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected a number, got {value!r}") from None
    if arr.ndim != 0:
        raise ValueError(f"{name}: expected a scalar, got an array of shape {arr.shape}")
    x = float(arr)
    if not np.isfinite(x):
        raise ValueError(f"{name}: must be finite, got {x}")
    if positive and x <= 0:
        raise ValueError(f"{name}: must be > 0, got {x}")
    if nonnegative and x < 0:
        raise ValueError(f"{name}: must be >= 0, got {x}")
    return x


def array(name: str, value, *, shape=None, ndim=None, nonnegative: bool = False) -> np.ndarray:
    """Return ``value`` as a finite float array, checking its shape and sign.

    ``shape`` may contain ``None`` for a free axis length.
    """
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected a numeric array, got {type(value).__name__}") from None
    if ndim is not None and arr.ndim != ndim:
        raise ValueError(f"{name}: expected a {ndim}-D array, got shape {arr.shape}")
    if shape is not None:
        ok = arr.ndim == len(shape) and all(
            s is None or s == a for s, a in zip(shape, arr.shape)
        )
        if not ok:
            want = "(" + ", ".join("any" if s is None else str(s) for s in shape) + ")"
            raise ValueError(f"{name}: expected shape {want}, got {arr.shape}")
    if arr.size and not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: contains NaN or infinite values")
    if nonnegative and arr.size and np.any(arr < 0):
        raise ValueError(f"{name}: contains negative values (min {arr.min():g})")
    return arr


def nonnegative(name: str, value, unit: str = "") -> np.ndarray:
    """``value`` (scalar or any-shape array) as floats, finite and >= 0, else ``ValueError``."""
    x = np.asarray(value, dtype=float)
    if x.size and not np.all(np.isfinite(x)):
        raise ValueError(f"{name}: must be finite, got {value!r}")
    if x.size and np.any(x < 0):
        raise ValueError(f"{name}: must be >= 0{(' ' + unit) if unit else ''}, got {value!r}")
    return x
