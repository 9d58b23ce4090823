"""The range of every pixel: a constant distance, a range-map file, or a plane.

A correction along each pixel's own path needs the camera-to-object range of every pixel
(:mod:`measure.correct`). :func:`read_range` takes it in the forms photogrammetry and monocular
depth networks write it:

- a number: one range for the whole photo (m);
- a range-map file: a float TIFF in metres (tifffile), a 16-bit PNG in millimetres (Pillow;
  the convention of the Kinect, TUM RGB-D and NYU depth datasets) or a ``.npy`` array in
  metres; 0 or NaN (or a negative value) marks an unknown range. A map smaller (or larger) than
  the photo is resampled to the photo's size (bilinear, :func:`scipy.ndimage.zoom`; an unknown
  pixel of the map leaves the photo's pixels it touches unknown);
- a plane, ``"plane:A,B,C"``: range = A + B u + C v with u, v the pixel's position in
  [-1, 1] across the photo's width and height (a seafloor or a wall seen obliquely; e.g.
  ``plane:4,0,-3`` recedes from 7 m at the bottom to 1 m at the top).

Ranges are the distance along the line of sight from the camera (not the depth along the
optical axis that some networks give: multiply those by 1 / cos of the pixel's angle first).
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
from forward.errors import InputError

__all__ = ["MM_PER_M", "PLANE_PREFIX", "RANGE_EXTENSIONS", "parse_range", "read_range",
           "resample_range"]

#: A 16-bit PNG range map is in millimetres (the Kinect / TUM RGB-D / NYU depth convention)
MM_PER_M = 1000.0
#: A plane is given as ``plane:A,B,C`` (metres; see the module)
PLANE_PREFIX = "plane:"
#: The range-map files read, by extension
RANGE_EXTENSIONS = (".tif", ".tiff", ".png", ".npy")


def parse_range(value):
    """What a range argument is: a number, a plane or a file.

    Parameters
    ----------
    value : float, str or os.PathLike or numpy.ndarray
        A range in m (a number or its text), ``"plane:A,B,C"``, a range-map file or an array.

    Returns
    -------
    tuple
        ('constant', float m), ('plane', (A, B, C)), ('file', Path) or ('array', ndarray).

    Raises
    ------
    ValueError
        Naming ``range``: a number that is not > 0 and finite, a malformed plane, a missing
        file or one of another kind than :data:`RANGE_EXTENSIONS`.
    """
    if isinstance(value, np.ndarray):
        return "array", value
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return "constant", _positive(float(value))
    text = os.fspath(value) if isinstance(value, os.PathLike) else str(value)
    if text.lower().startswith(PLANE_PREFIX):
        try:
            coef = tuple(float(v) for v in text[len(PLANE_PREFIX):].split(","))
        except ValueError:
            coef = ()
        if len(coef) != 3 or not all(math.isfinite(c) for c in coef):
            raise InputError("range", f"a plane is 'plane:A,B,C' (three numbers, m), got {text!r}")
        return "plane", coef
    try:
        return "constant", _positive(float(text))
    except ValueError as exc:
        if "range:" in str(exc):
            raise
    p = Path(text)
    if p.suffix.lower() not in RANGE_EXTENSIONS:
        raise InputError("range", f"a distance in m, 'plane:A,B,C' or a range map "
                         f"({', '.join(RANGE_EXTENSIONS)}), got {text!r}")
    if not p.is_file():
        raise InputError("range", f"{p}: no such file")
    return "file", p


def _positive(x: float) -> float:
    if not (math.isfinite(x) and x > 0):
        raise InputError("range", f"a distance must be finite and > 0 m, got {x!r}")
    return x


def _load(p: Path) -> np.ndarray:
    """A range-map file as float32 metres (unknown: NaN)."""
    suffix = p.suffix.lower()
    try:
        if suffix == ".npy":
            arr = np.load(p, allow_pickle=False)
            scale = 1.0
        elif suffix == ".png":
            from PIL import Image

            with Image.open(p) as im:
                arr = np.asarray(im)
            if arr.dtype != np.uint16 and arr.dtype != np.int32:
                raise InputError("range", f"{p}: a PNG range map must be 16-bit (millimetres), got "
                                 f"{arr.dtype}")
            scale = 1.0 / MM_PER_M
        else:
            import tifffile

            arr = tifffile.imread(p)
            if not np.issubdtype(arr.dtype, np.floating):
                raise InputError("range", f"{p}: a TIFF range map must hold floats in metres, got "
                                 f"{arr.dtype} (a 16-bit map in millimetres: save it as PNG)")
            scale = 1.0
    except ValueError:
        raise
    except Exception as exc:  # the readers raise many kinds for a bad file
        raise InputError("range", f"{p}: not a readable range map ({type(exc).__name__}: "
                         f"{exc})") from None
    arr = np.squeeze(np.asarray(arr))
    if arr.ndim != 2:
        raise InputError("range", f"{p}: expected one channel (height, width), got shape "
                         f"{arr.shape}")
    out = arr.astype(np.float32) * np.float32(scale)
    out[~(out > 0)] = np.nan  # 0, negative or NaN: unknown
    return out


def resample_range(ranges, size) -> np.ndarray:
    """A range map at the photo's size.

    Parameters
    ----------
    ranges : numpy.ndarray, (h, w)
        Ranges in m, NaN unknown.
    size : tuple of int
        The photo's (width, height), pixels.

    Returns
    -------
    numpy.ndarray, float32, (height, width)
        Bilinear resampling (:func:`scipy.ndimage.zoom`, order 1, the corners aligned); a
        pixel touched by an unknown one of the map is unknown (NaN).
    """
    W, H = size
    arr = np.asarray(ranges, np.float32)
    if arr.shape == (H, W):
        return arr
    from scipy import ndimage

    unknown = ~np.isfinite(arr)
    filled = np.where(unknown, 0.0, arr).astype(np.float32)
    zoom = (H / arr.shape[0], W / arr.shape[1])
    out = ndimage.zoom(filled, zoom, order=1, grid_mode=False, mode="nearest")
    if unknown.any():
        bad = ndimage.zoom(unknown.astype(np.float32), zoom, order=1, grid_mode=False,
                           mode="nearest") > 0
        out[bad] = np.nan
    return out[:H, :W]


def read_range(value, size) -> np.ndarray | float:
    """Every pixel's range (m) for a photo of ``size``.

    Parameters
    ----------
    value : float, str, os.PathLike or numpy.ndarray
        See :func:`parse_range` and the module.
    size : tuple of int
        The photo's (width, height), pixels.

    Returns
    -------
    float or numpy.ndarray
        A constant range (float, m), or float32 (height, width) ranges in m (NaN: unknown).

    Raises
    ------
    ValueError
        Naming ``range``: see :func:`parse_range`; a file that cannot be read, has more than
        one channel or knows no range at all; a plane negative somewhere in the photo.
    """
    kind, v = parse_range(value)
    if kind == "constant":
        return v
    W, H = size
    if kind == "plane":
        a, b, c = v
        u = np.linspace(-1.0, 1.0, W, dtype=np.float32)[None, :]
        w = np.linspace(-1.0, 1.0, H, dtype=np.float32)[:, None]
        out = np.float32(a) + np.float32(b) * u + np.float32(c) * w
        if not np.all(out > 0):
            raise InputError("range", f"the plane {a:g} + {b:g} u + {c:g} v is <= 0 m in a part "
                             "of the photo (u, v in [-1, 1])")
        return out
    arr = _load(v) if kind == "file" else np.asarray(v, np.float32).copy()
    if kind == "array":
        if arr.ndim != 2:
            raise InputError("range", f"expected a (height, width) array, got shape {arr.shape}")
        arr[~(arr > 0)] = np.nan
    if not np.isfinite(arr).any():
        raise InputError("range", f"{v if kind == 'file' else 'the array'} holds no known range "
                         "(every value is 0 or NaN)")
    return resample_range(arr, size)
