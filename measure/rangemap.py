"""The range of every pixel: a constant distance, a range-map file, or a plane.

A correction along each pixel's own path needs the camera-to-object range of every pixel
(:mod:`measure.correct`). :func:`read_range` takes it in the forms photogrammetry and monocular
depth networks write it:

- a number: one range for the whole photo (m);
- a range-map file: a float TIFF in metres (tifffile), a 16-bit PNG in millimetres (Pillow;
  the convention of the Kinect, TUM RGB-D and NYU depth datasets) or a ``.npy`` array in
  metres; 0, NaN, -inf or a negative value marks an unknown range, +inf a range beyond every
  other (corrected as at the cap; :func:`census` counts each kind). A map smaller (or larger)
  than the photo is resampled to the photo's size (bilinear, :func:`scipy.ndimage.zoom`; an
  unknown pixel of the map leaves the photo's pixels it touches unknown, an infinite one
  infinite); its aspect must be the photo's (:data:`ASPECT_TOLERANCE`). Units are checked
  (decision 0063-range-map-checks): a PNG whose ranges are all below
  :data:`PNG_METRES_BELOW_MM` was written in metres, a float map whose median is beyond
  :data:`FLOAT_MM_MEDIAN_M` in millimetres; both are refused, as is a file that is no map of
  its format;
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

__all__ = ["ASPECT_TOLERANCE", "FLOAT_MM_MEDIAN_M", "MM_PER_M", "PLANE_PREFIX",
           "PNG_METRES_BELOW_MM", "RANGE_EXTENSIONS", "VALUE_KINDS", "census", "parse_range",
           "range_and_census", "read_range", "resample_range"]

#: A 16-bit PNG range map is in millimetres (the Kinect / TUM RGB-D / NYU depth convention)
MM_PER_M = 1000.0
#: A plane is given as ``plane:A,B,C`` (metres; see the module)
PLANE_PREFIX = "plane:"
#: The range-map files read, by extension
RANGE_EXTENSIONS = (".tif", ".tiff", ".png", ".npy")
#: A 16-bit PNG (mm) whose known ranges are all below this many mm (5 cm, nearer than a
#: camera sees an object through water) was written in metres: refused (decision
#: 0063-range-map-checks)
PNG_METRES_BELOW_MM = 50
#: A float map (m) whose known ranges' median is beyond this many m (farther than anything is
#: seen through water; 20 cm in mm) was written in millimetres: refused (decision
#: 0063-range-map-checks)
FLOAT_MM_MEDIAN_M = 200.0
#: That median is taken over an even sample of about this many
#: of the map's pixels (every k-th row and column; all of a smaller map): a full-resolution
#: map's median cost a 24 MP correction 0.2-0.7 s for a check that needs no exact value
MEDIAN_PIXELS = 1 << 20
#: A map's width / height may differ from the photo's by this fraction (then it is resampled;
#: beyond it, refused: a portrait map for a landscape photo)
ASPECT_TOLERANCE = 0.01
#: What the correction does with each kind of value of a map that is no plain range
VALUE_KINDS = {"nan": "no range", "zero": "no range", "negative": "no range",
               "-inf": "no range", "+inf": "beyond the cap"}


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


def _read_file(p: Path):
    """A range-map file's array as stored and its units ('mm' or 'm')."""
    suffix = p.suffix.lower()
    try:
        if suffix == ".npy":
            return np.load(p, allow_pickle=False), "m"
        if suffix == ".png":
            from PIL import Image

            with Image.open(p) as im:
                arr = np.asarray(im)
            if arr.dtype != np.uint16 and arr.dtype != np.int32:
                raise InputError("range", f"{p}: a PNG range map must be 16-bit (millimetres), got "
                                 f"{arr.dtype}" + (f" {arr.shape[2]} channels" if arr.ndim == 3
                                                   else ""))
            return arr, "mm"
        import tifffile

        arr = tifffile.imread(p)
        if not np.issubdtype(arr.dtype, np.floating):
            raise InputError("range", f"{p}: a TIFF range map must hold floats in metres, got "
                             f"{arr.dtype} (a 16-bit map in millimetres: save it as PNG)")
        return arr, "m"
    except InputError:
        raise
    except Exception as exc:  # the readers raise many kinds for a bad file
        why = " ".join(str(exc).split())  # one line
        raise InputError("range", f"{p}: not a readable {suffix} range map "
                         f"({type(exc).__name__}: {why})") from None


def _as_map(arr, name: str, copy: bool = True) -> np.ndarray:
    """A stored map as a (height, width) float32 array (its values as stored; not a copy of a
    float32 array unless ``copy``)."""
    arr = np.squeeze(np.asarray(arr))
    if arr.ndim != 2:
        raise InputError("range", f"{name}: expected one channel (height, width), got shape "
                         f"{arr.shape}")
    if arr.dtype.kind not in "uif":
        raise InputError("range", f"{name}: a range map holds numbers, got {arr.dtype}")
    return arr.astype(np.float32, copy=copy)


def census(arr) -> dict:
    """How many of a map's values are each kind of value that is no plain range.

    Parameters
    ----------
    arr : numpy.ndarray
        A range map as given (any units).

    Returns
    -------
    dict
        ``pixels`` (all), ``known`` (finite and > 0) and, of :data:`VALUE_KINDS`, ``nan``,
        ``zero``, ``negative`` (finite), ``-inf`` and ``+inf``: counts (int).
    """
    from .pixels import census_rows

    a = np.asarray(arr, np.float32)
    a = np.ascontiguousarray(a.reshape(a.shape[0], -1) if a.ndim > 1 else a.reshape(1, -1))
    rows = np.zeros((a.shape[0], 6), np.int64)
    if a.size:
        census_rows(a, rows)  # one compiled pass (numpy took seven)
    total = rows.sum(axis=0)
    return {"pixels": int(a.size)} | {k: int(v) for k, v in zip(
        ("known", "nan", "zero", "negative", "-inf", "+inf"), total)}


def _check_units(arr: np.ndarray, units: str, name: str) -> None:
    """Refuse a map whose values are implausible in its documented units (decision
    0063-range-map-checks)."""
    if units == "mm":
        largest = float(np.max(arr, where=np.isfinite(arr) & (arr > 0), initial=0.0))
        if largest < PNG_METRES_BELOW_MM:
            raise InputError("range", f"{name}: every range of this 16-bit PNG (millimetres) is "
                             f"below {PNG_METRES_BELOW_MM} mm (largest {largest:g}): it looks "
                             "written in metres; multiply it by 1000, or save metres as a float "
                             "TIFF or .npy")
        return
    step = max(1, int(np.sqrt(arr.size / MEDIAN_PIXELS)))  # the median of a sample of the map
    sample = arr[::step, ::step]
    known = sample[np.isfinite(sample) & (sample > 0)]
    if not known.size:  # a map whose known ranges all fall between the sample's pixels
        known = arr[np.isfinite(arr) & (arr > 0)]
    median = float(np.median(known))
    if median > FLOAT_MM_MEDIAN_M:
        raise InputError("range", f"{name}: the median range is {median:g} m (over "
                         f"{FLOAT_MM_MEDIAN_M:g} m): it looks written in millimetres; divide "
                         "it by 1000, or save millimetres as a 16-bit PNG")


def _check_aspect(shape, size, name: str) -> None:
    """Refuse a map whose width / height is not the photo's (within :data:`ASPECT_TOLERANCE`)."""
    (h, w), (W, H) = shape, size
    if abs((w / h) / (W / H) - 1) > ASPECT_TOLERANCE:
        raise InputError("range", f"{name}: a {w}x{h} map (aspect {w / h:.3g}) for a {W}x{H} "
                         f"photo (aspect {W / H:.3g}): a map must have the photo's aspect (within "
                         f"{100 * ASPECT_TOLERANCE:g} %); rotated or transposed?")


def _touched(mask: np.ndarray, zoom) -> np.ndarray:
    """The resampled pixels a pixel of ``mask`` enters (bilinear weight > 0)."""
    from scipy import ndimage

    return ndimage.zoom(mask.astype(np.float32), zoom, order=1, grid_mode=False,
                        mode="nearest") > 0


def resample_range(ranges, size, name: str = "the range map") -> np.ndarray:
    """A range map at the photo's size.

    Parameters
    ----------
    ranges : numpy.ndarray, (h, w)
        Ranges in m, NaN unknown, +inf beyond every range.
    size : tuple of int
        The photo's (width, height), pixels.
    name : str, optional
        The map, as an error names it.

    Returns
    -------
    numpy.ndarray, float32, (height, width)
        Bilinear resampling (:func:`scipy.ndimage.zoom`, order 1, the corners aligned); a
        pixel touched by an unknown one of the map is unknown (NaN), else one touched by an
        infinite one is infinite.

    Raises
    ------
    ValueError
        Naming ``range``: the map's width / height differs from the photo's by more than
        :data:`ASPECT_TOLERANCE` (a portrait map for a landscape photo).
    """
    W, H = size
    arr = np.asarray(ranges, np.float32)
    _check_aspect(arr.shape, size, name)
    if arr.shape == (H, W):
        return arr
    from scipy import ndimage

    unknown, far = np.isnan(arr), np.isposinf(arr)
    filled = np.where(unknown | far, 0.0, arr).astype(np.float32)
    zoom = (H / arr.shape[0], W / arr.shape[1])
    out = ndimage.zoom(filled, zoom, order=1, grid_mode=False, mode="nearest")
    for mask, value in ((far, np.inf), (unknown, np.nan)):  # unknown last: it wins
        if mask.any():
            out[_touched(mask, zoom)] = value
    return out[:H, :W]


def range_and_census(value, size):
    """Every pixel's range (m) for a photo of ``size``, and what the map held.

    Parameters
    ----------
    value : float, str, os.PathLike or numpy.ndarray
        See :func:`parse_range` and the module.
    size : tuple of int
        The photo's (width, height), pixels.

    Returns
    -------
    ranges : float or numpy.ndarray
        A constant range (float, m), or float32 (height, width) ranges in m (NaN: unknown,
        +inf: beyond every range).
    counts : dict or None
        A map's :func:`census` as given (None for a constant or a plane).

    Raises
    ------
    ValueError
        Naming ``range``: see :func:`parse_range`; a file that is not a readable map of its
        format, has more than one channel, knows no range at all, or whose values are
        implausible in its units (:data:`PNG_METRES_BELOW_MM`, :data:`FLOAT_MM_MEDIAN_M`); a
        map of another aspect than the photo's; a plane negative somewhere in the photo.
    """
    kind, v = parse_range(value)
    if kind == "constant":
        return v, None
    if kind == "plane":
        return _plane(v, size), None
    name = str(v) if kind == "file" else "the array"
    arr, units = _read_file(v) if kind == "file" else (v, "m")
    arr = _as_map(arr, name, copy=kind != "file")  # a file's array is ours to change
    counts = census(arr)
    if not counts["known"]:
        raise InputError("range", f"{name} holds no known range (every value is 0, negative, "
                         "infinite or NaN)")
    _check_units(arr, units, name)
    if units == "mm":
        arr /= np.float32(MM_PER_M)
    arr[~(arr > 0)] = np.nan  # 0, negative, -inf or NaN: unknown (+inf stays: beyond the cap)
    return resample_range(arr, size, name), counts


def _plane(coef, size) -> np.ndarray:
    """The ranges of a plane A + B u + C v over the photo (u, v in [-1, 1])."""
    (a, b, c), (W, H) = coef, size
    u = np.linspace(-1.0, 1.0, W, dtype=np.float32)[None, :]
    w = np.linspace(-1.0, 1.0, H, dtype=np.float32)[:, None]
    out = np.float32(a) + np.float32(b) * u + np.float32(c) * w
    if not np.all(out > 0):
        raise InputError("range", f"the plane {a:g} + {b:g} u + {c:g} v is <= 0 m in a part "
                         "of the photo (u, v in [-1, 1])")
    return out


def read_range(value, size) -> np.ndarray | float:
    """Every pixel's range (m) for a photo of ``size`` (:func:`range_and_census` without the
    census).

    Parameters
    ----------
    value : float, str, os.PathLike or numpy.ndarray
        See :func:`parse_range` and the module.
    size : tuple of int
        The photo's (width, height), pixels.

    Returns
    -------
    float or numpy.ndarray
        A constant range (float, m), or float32 (height, width) ranges in m (NaN: unknown,
        +inf: beyond every range).

    Raises
    ------
    ValueError
        Naming ``range``: see :func:`range_and_census`.
    """
    return range_and_census(value, size)[0]
