"""Reading photographs: camera RAW through rawpy (LibRaw) and linear 16-bit TIFF (tifffile).

A RAW file is read as its colour-filter-array (CFA) mosaic: linear raw values with the black
level of each CFA channel subtracted, no white balance, no demosaic; every pixel keeps the
channel (0 red, 1 green, 2 blue) of its filter, so each patch value is measured from its own
channel's pixels. Pixels at or above the white level are marked clipped. A TIFF is taken as
demosaiced, linear camera RGB (black level 0 unless given; clipped at the type's maximum unless
a white level is given). Exposure time, ISO and f-number are read from the file's EXIF/TIFF
tags where it has them (tifffile: DNG and most RAW formats are TIFF containers).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sca.compiled import KERNEL_LOCK

from .exif import photo_tags
from .pixels import bilinear_all, unpack
from forward.errors import InputError

# numba's fork-safe threading layer and the kernel lock: one place (sca.compiled)
_KERNEL_LOCK = KERNEL_LOCK

__all__ = ["IMAGE_READERS", "Photo", "photo_extensions", "read_image", "rgb_photo", "demosaic",
           "RAW_EXTENSIONS", "TIFF_EXTENSIONS", "UINT16_MAX"]

#: Extensions read as TIFF (demosaiced RGB); everything else goes to LibRaw.
TIFF_EXTENSIONS = (".tif", ".tiff")
#: Common RAW extensions (informative: LibRaw decides what it can read).
RAW_EXTENSIONS = (".dng", ".nef", ".cr2", ".cr3", ".arw", ".orf", ".rw2", ".raf", ".pef", ".srw")
#: LibRaw's colour letters -> the model's channel index (both greens of a Bayer CFA are green)
CHANNEL_OF_LETTER = {"R": 0, "G": 1, "B": 2}
#: Full scale of a 16-bit image (the ``uint16`` output of :func:`demosaic`)
UINT16_MAX = 65535


@dataclass
class Photo:
    """A photograph in linear raw units (black level subtracted).

    Attributes
    ----------
    path : str
        The file read.
    kind : {'raw', 'rgb'}
        'raw': a colour-filter-array mosaic; 'rgb': a demosaiced (TIFF) image.
    data : numpy.ndarray, float32
        (H, W) the mosaic for 'raw', (H, W, 3) for 'rgb'; raw units (DN above the black level).
    channel : numpy.ndarray or None
        (H, W) the channel index (0 red, 1 green, 2 blue) of every pixel for 'raw'; None for
        'rgb'.
    clipped : numpy.ndarray, bool, (H, W)
        Pixels (any channel for 'rgb') at or above the white level.
    white : numpy.ndarray, (3,)
        The clip level after black subtraction per channel, raw units.
    black : numpy.ndarray, (3,)
        The black level that was subtracted per channel, raw units.
    exposure : dict
        ``exposure_s`` (s), ``f_number``, ``iso`` where the file has them.
    camera : dict
        ``make`` and ``model`` (TIFF/EXIF Make and Model) where the file has them.
    """

    path: str
    kind: str
    data: np.ndarray
    channel: np.ndarray | None
    clipped: np.ndarray
    white: np.ndarray
    black: np.ndarray
    exposure: dict = field(default_factory=dict)
    camera: dict = field(default_factory=dict)

    @property
    def size(self) -> tuple:
        """(width, height) in pixels."""
        return (int(self.data.shape[1]), int(self.data.shape[0]))


def read_image(path, *, black_level=None, white_level=None) -> Photo:
    """Read a camera RAW (any LibRaw format, DNG included) or a linear 16-bit TIFF.

    Parameters
    ----------
    path : str or os.PathLike
        The image, read by its extension's reader in :data:`IMAGE_READERS`: ``.tif`` /
        ``.tiff`` as demosaiced linear RGB (tifffile); RAW, and any extension not in the
        table, by rawpy (LibRaw).
    black_level : float or array_like, (3,), optional
        Black level in raw units (DN), scalar or per channel (R, G, B); default the file's
        (a TIFF: 0).
    white_level : float, optional
        White (clip) level in raw units (DN); default the file's (a TIFF: its type's maximum).

    Returns
    -------
    Photo
        The image in raw units with the black level subtracted, its clip mask, exposure and
        camera (EXIF Make and Model).

    Raises
    ------
    ValueError
        Naming the file (``image: ...``) when it is missing or cannot be read, or the
        argument when a level is negative or not finite.
    """
    p = Path(path)
    if not p.is_file():
        raise InputError("image", f"{p}: no such file")
    return IMAGE_READERS.get(p.suffix.lower(), _read_raw)(p, black_level, white_level)


def _levels(name, value, n):
    arr = np.broadcast_to(np.asarray(value, float), (n,)).astype(float)
    if not np.all(np.isfinite(arr)) or np.any(arr < 0):
        raise InputError(name, f"must be finite and >= 0, got {value!r}")
    return arr


def _read_raw(p: Path, black_level, white_level) -> Photo:
    import rawpy

    try:
        raw = rawpy.imread(str(p))
    except (rawpy.LibRawError, OSError) as exc:
        raise InputError("image", f"{p}: not a RAW file LibRaw can read, nor a .tif/.tiff "
                         f"({type(exc).__name__})") from None
    with raw:
        try:
            mosaic = raw.raw_image_visible.copy()
            colors = raw.raw_colors_visible.copy()
        except rawpy.LibRawError as exc:
            raise InputError("image", f"{p}: LibRaw cannot unpack it ({type(exc).__name__})") from None
        desc = raw.color_desc.decode("ascii", "replace")
        blacks = np.asarray(raw.black_level_per_channel, float)
        white = float(raw.white_level)
    letters = [desc[i] if i < len(desc) else "?" for i in range(4)]
    top = int(colors.max(initial=0))
    if top >= len(letters):
        raise InputError("image", f"{p}: colour index {top} outside LibRaw's 4 colours")
    # the colour indices present (a comparison each: np.unique sorts all 24 M of them)
    used = [c for c in range(top + 1) if (colors == c).any()]
    if any(letters[c] not in CHANNEL_OF_LETTER for c in used):
        raise InputError("image", f"{p}: colour filter array {desc!r} is not red/green/blue")
    lut = np.array([CHANNEL_OF_LETTER.get(letter, 0) for letter in letters], dtype=np.int8)
    if black_level is not None:  # per model channel -> per colour index
        blacks = _levels("black_level", black_level, 3)[lut]
    if white_level is not None:
        white = float(_levels("white_level", white_level, 1)[0])
    data = np.empty(mosaic.shape, np.float32)
    channel = np.empty(mosaic.shape, np.int8)
    clipped = np.empty(mosaic.shape, bool)
    with _KERNEL_LOCK:
        unpack(mosaic, colors, lut, blacks.astype(np.float32), white, data, channel, clipped)
    black3 = np.array([blacks[[i for i in used if lut[i] == c]].mean()
                       if any(lut[i] == c for i in used) else np.nan for c in range(3)])
    return Photo(str(p), "raw", data, channel, clipped, white - black3, black3, *photo_tags(p))


def _read_tiff(p: Path, black_level, white_level) -> Photo:
    import tifffile

    try:
        arr = tifffile.imread(str(p))
    except Exception as exc:  # tifffile raises many kinds for a bad file
        raise InputError("image", f"{p}: not a readable TIFF ({type(exc).__name__}: {exc})") from None
    return rgb_photo(p, arr, black_level, white_level)


def rgb_photo(p: Path, arr, black_level=None, white_level=None) -> Photo:
    """The :class:`Photo` of a demosaiced linear RGB image read from ``p`` (what a reader of
    :data:`IMAGE_READERS` for an RGB format returns): clipped at the type's maximum (a float
    image: never) unless ``white_level``, black level 0 unless ``black_level``, exposure and
    camera from the file's EXIF (:func:`measure.exif.photo_tags`) where it has them.

    Parameters
    ----------
    p : pathlib.Path
        The file read.
    arr : numpy.ndarray, (H, W, 3 or 4)
        Its pixels (integer or float; a 4th channel is dropped).
    black_level, white_level : optional
        As :func:`read_image`'s.

    Returns
    -------
    Photo
        Of kind 'rgb'.
    """
    if arr.ndim != 3 or arr.shape[-1] not in (3, 4):
        raise InputError("image", f"{p}: expected an RGB TIFF (height, width, 3), got shape {arr.shape}")
    if not np.issubdtype(arr.dtype, np.integer) and not np.issubdtype(arr.dtype, np.floating):
        raise InputError("image", f"{p}: unsupported sample type {arr.dtype}")
    rgb = arr[..., :3]
    top = float(np.iinfo(rgb.dtype).max) if np.issubdtype(rgb.dtype, np.integer) else np.inf
    white = top if white_level is None else float(_levels("white_level", white_level, 1)[0])
    black = _levels("black_level", 0.0 if black_level is None else black_level, 3)
    clipped = np.any(rgb >= white, axis=-1)
    data = rgb.astype(np.float32) - black.astype(np.float32)
    return Photo(str(p), "rgb", data, None, clipped, white - black, black, *photo_tags(p))


#: Extension (lower case, with the dot) -> reader(path, black_level, white_level) -> Photo:
#: how :func:`read_image` reads a photo, as colour-science's ``READ_IMAGE_METHODS``; a new
#: format is one entry (an RGB format's reader loads the pixels and returns
#: :func:`rgb_photo`). An extension not here goes to LibRaw, which decides what it can read;
#: the dive measures the files whose extension is here (:func:`photo_extensions`).
IMAGE_READERS = {**{ext: _read_raw for ext in RAW_EXTENSIONS},
                 **{ext: _read_tiff for ext in TIFF_EXTENSIONS}}


def photo_extensions() -> tuple:
    """The extensions :data:`IMAGE_READERS` reads (a dive's photos), as registered now."""
    return tuple(IMAGE_READERS)


def demosaic(photo: Photo, gains=None, offset=None, *, uint16: bool = False,
             step: int = 1) -> np.ndarray:
    """Linear camera RGB of a photo, with a per-channel affine map applied first.

    A RAW mosaic is demosaiced by bilinear interpolation: normalised convolution of each
    channel's pixels with the 3 x 3 kernel [1 2 1] x [1 2 1], edges mirrored (exact on a smooth
    image; it works for any CFA whose every 3 x 3 neighbourhood holds all three channels),
    compiled (numba, parallel over rows). An RGB photo is only mapped.

    Parameters
    ----------
    photo : Photo
        The photograph (raw units).
    gains : array_like, (3,), optional
        Per-channel factors (dimensionless; default 1).
    offset : array_like, (3,), optional
        Per-channel offsets subtracted before the gains, raw units (default 0).
    uint16 : bool, optional
        Round and clip the result to 0..UINT16_MAX.
    step : int, optional
        Only every ``step``-th row and column (a preview): the full result's ``[::step,
        ::step]``, computed there alone.

    Returns
    -------
    numpy.ndarray, (H, W, 3) (or (ceil(H / step), ceil(W / step), 3))
        gains * (value - offset): float32 in (mapped) raw units, or uint16.

    References
    ----------
    R. Ramanath, W. E. Snyder, G. L. Bilbro and W. A. Sander, "Demosaicking methods for Bayer
    color arrays", J. Electron. Imaging 11(3), 306-315, 2002 (bilinear interpolation).
    """
    gains = np.ones(3) if gains is None else np.asarray(gains, float)
    offset = np.zeros(3) if offset is None else np.asarray(offset, float)
    if photo.kind == "rgb":
        out = (photo.data[::step, ::step] - offset.astype(np.float32)) * gains.astype(np.float32)
        return np.clip(np.rint(out), 0, UINT16_MAX).astype(np.uint16) if uint16 else out
    H, W = photo.data.shape
    out = np.empty((-(-H // step), -(-W // step), 3), np.uint16 if uint16 else np.float32)
    with _KERNEL_LOCK:
        bilinear_all(photo.data, photo.channel, gains.astype(np.float32),
                     offset.astype(np.float32), out, uint16, step)
    return out


