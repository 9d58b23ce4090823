"""Input checks shared by the forward model and the estimator.

Every check raises :class:`InputError`, a :class:`ValueError` that carries the argument's name
(``argument``) and the reason (``reason``); its message is ``"<argument>: <reason>"``, so a
caller always learns *which* input is wrong and *why*, and the command line names its option
from ``argument`` without reading the message.
"""

from __future__ import annotations

import numpy as np

from .errors import InputError

__all__ = ["InputError", "array", "nonnegative", "scalar", "real"]


def _is_complex(value) -> bool:
    """Whether ``value`` holds complex numbers (a complex dtype, or Python complex objects)."""
    if isinstance(value, complex) or np.iscomplexobj(value):
        return True
    if isinstance(value, (list, tuple)):
        try:
            return np.asarray(value).dtype.kind == "c"
        except (TypeError, ValueError):  # ragged: the float conversion reports it
            return False
    return False


def real(name: str, value) -> None:
    """Refuse complex numbers: a float conversion would silently drop the imaginary part.

    Parameters
    ----------
    name : str
        The argument's name; the error message starts with it.
    value : object
        Anything ``numpy.asarray`` accepts.

    Returns
    -------
    None

    Raises
    ------
    ValueError
        If ``value`` holds complex numbers (even with a zero imaginary part).
    """
    if _is_complex(value):
        raise InputError(name, "complex values are not accepted (the imaginary part would be "
                         "dropped); give real numbers")


def scalar(name: str, value, *, nonnegative: bool = True, positive: bool = False) -> float:
    """Return ``value`` as a finite float; raise ``ValueError`` naming ``name`` otherwise.

    Parameters
    ----------
    name : str
        The argument's name; every error message starts with it.
    value : float or array_like of dimension 0
        The value to check (any unit; the check is unit-free).
    nonnegative : bool, optional
        Require ``value >= 0`` (default True).
    positive : bool, optional
        Require ``value > 0`` (default False).

    Returns
    -------
    float
        ``value`` as a Python float.

    Raises
    ------
    ValueError
        If ``value`` is not a number (complex included), not a scalar, not finite, or has the
        wrong sign.
    """
    real(name, value)
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(name, f"expected a number, got {value!r}") from None
    if arr.ndim != 0:
        raise InputError(name, f"expected a scalar, got an array of shape {arr.shape}")
    x = float(arr)
    if not np.isfinite(x):
        raise InputError(name, f"must be finite, got {x}")
    if positive and x <= 0:
        raise InputError(name, f"must be > 0, got {x}")
    if nonnegative and x < 0:
        raise InputError(name, f"must be >= 0, got {x}")
    return x


def array(name: str, value, *, shape=None, ndim=None, nonnegative: bool = False) -> np.ndarray:
    """Return ``value`` as a finite float array, checking its shape and sign.

    Parameters
    ----------
    name : str
        The argument's name; every error message starts with it.
    value : array_like
        The values to check (any unit).
    shape : tuple of int or None, optional
        Required shape; ``None`` inside the tuple leaves that axis length free. Default: any.
    ndim : int, optional
        Required number of dimensions. Default: any.
    nonnegative : bool, optional
        Require every element ``>= 0`` (default False).

    Returns
    -------
    numpy.ndarray
        ``value`` as a float array (not copied when it already is one).

    Raises
    ------
    ValueError
        If ``value`` is not numeric (complex included), has the wrong shape or dimension,
        contains NaN or infinite values, or (with ``nonnegative``) negative values.
    """
    real(name, value)
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(name, f"expected a numeric array, got {type(value).__name__}") from None
    if ndim is not None and arr.ndim != ndim:
        raise InputError(name, f"expected a {ndim}-D array, got shape {arr.shape}")
    if shape is not None:
        ok = arr.ndim == len(shape) and all(
            s is None or s == a for s, a in zip(shape, arr.shape)
        )
        if not ok:
            want = "(" + ", ".join("any" if s is None else str(s) for s in shape) + ")"
            raise InputError(name, f"expected shape {want}, got {arr.shape}")
    if arr.size and not np.all(np.isfinite(arr)):
        raise InputError(name, "contains NaN or infinite values")
    if nonnegative and arr.size and np.any(arr < 0):
        raise InputError(name, f"contains negative values (min {arr.min():g})")
    return arr


def nonnegative(name: str, value, unit: str = "") -> np.ndarray:
    """Return ``value`` (scalar or any-shape array) as floats, finite and >= 0.

    Parameters
    ----------
    name : str
        The argument's name; every error message starts with it.
    value : float or array_like
        The values to check, e.g. C in mg m^-3, a_CDOM(440 nm) in m^-1 or a length in m.
    unit : str, optional
        Unit named in the error message (e.g. ``'m'``). Default: none.

    Returns
    -------
    numpy.ndarray
        ``value`` as a float array (0-d for a scalar).

    Raises
    ------
    ValueError
        If any element is complex, NaN, infinite or negative.
    """
    real(name, value)
    x = np.asarray(value, dtype=float)
    if x.size and not np.all(np.isfinite(x)):
        raise InputError(name, f"must be finite, got {value!r}")
    if x.size and np.any(x < 0):
        raise InputError(name, f"must be >= 0{(' ' + unit) if unit else ''}, got {value!r}")
    return x
