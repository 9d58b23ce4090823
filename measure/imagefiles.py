"""Image files people open: 16-bit sRGB TIFF and 8-bit JPEG with the sRGB ICC profile
embedded, and the deflate options of every TIFF the package writes.

- TIFF: tifffile, the ICC profile in tag 34675 (InterColorProfile), deflate-compressed and
  lossless by default (:data:`TIFF_COMPRESSION`);
- JPEG: Pillow, quality :data:`JPEG_QUALITY`, the ICC profile embedded;
- the profile: Pillow's ``ImageCms.createProfile("sRGB")`` (LittleCMS).

Used by ``uw3p measure``'s folder (:mod:`measure.output`) and ``uw3p correct``'s
(:mod:`measure.correct_output`).
"""

from __future__ import annotations

import functools
import os

import numpy as np

__all__ = ["JPEG_QUALITY", "JPEG_ROWS", "LINEAR_FILE", "OUTPUT_FORMATS", "SRGB_BITS", "SRGB_FILES",
           "TIFF_COMPRESSION", "srgb_icc", "submit_images", "to_8bit", "write_jpeg",
           "write_srgb_tiff"]

#: tifffile's options for a compressed corrected.tiff: Adobe deflate with the
#: horizontal-differencing predictor (TIFF 6.0 section 14), lossless, any TIFF reader; zlib
#: level 1 and the strips compressed on every core. tifffile encodes it with imagecodecs (a
#: dependency: its zlib-ng, the same format) where Python's zlib took 2.6-4.3 s on a 24 MP photo
#: (2 cores); `uw3p measure` of that photo went from 9.8 to 6.9 s (issue 21). Level 6 on one
#: worker had taken 11.5 s for a file 3 % smaller (111 against 114 MB; 144 MB uncompressed: a
#: photo's noise leaves deflate little to find)
TIFF_COMPRESSION = {"compression": "zlib", "compressionargs": {"level": 1}, "predictor": True,
                    "maxworkers": os.cpu_count() or 1}
#: The full-resolution sRGB image of a corrected photo, the file a photographer keeps
#: (``output_format``): 8-bit JPEG (the default: about 10 MB for 24 MP) or 16-bit deflated
#: TIFF (about 100 MB: a photo's noise leaves deflate little to find); decision
#: 0084-output-format
OUTPUT_FORMATS = ("jpeg", "tiff16")
#: Its file name per format
SRGB_FILES = {"jpeg": "corrected.jpg", "tiff16": "corrected_srgb.tif"}
#: Its bits per channel per format (``srgb_bits`` of :func:`measure.correct_image`)
SRGB_BITS = {"jpeg": 8, "tiff16": 16}
#: The linear camera-RGB 16-bit TIFF, written only on request (``linear``)
LINEAR_FILE = "corrected.tiff"
#: JPEG quality (Pillow's scale; 92: artefacts below visibility at normal viewing, the files
#: about a quarter of quality 100's)
JPEG_QUALITY = 92
#: Rows converted from 16 to 8 bits at a time (bounds the temporaries at 24 MP)
JPEG_ROWS = 512


@functools.lru_cache(maxsize=1)
def srgb_icc() -> bytes:
    """The sRGB ICC profile (Pillow / LittleCMS ``createProfile("sRGB")``), bytes."""
    from PIL import ImageCms

    return ImageCms.ImageCmsProfile(ImageCms.createProfile("sRGB")).tobytes()


def to_8bit(srgb16) -> np.ndarray:
    """16-bit sRGB codes to 8-bit: round(v 255 / 65535), a block of rows at a time.

    Parameters
    ----------
    srgb16 : numpy.ndarray, uint16

    Returns
    -------
    numpy.ndarray, uint8, same shape
    """
    out = np.empty(srgb16.shape, np.uint8)
    for lo in range(0, srgb16.shape[0], JPEG_ROWS):
        block = srgb16[lo:lo + JPEG_ROWS].astype(np.uint32)
        out[lo:lo + JPEG_ROWS] = (block * 255 + 32767) // 65535
    return out


def write_srgb_tiff(path, srgb16, *, compressed: bool = True) -> None:
    """A 16-bit sRGB TIFF with the sRGB ICC profile embedded.

    Parameters
    ----------
    path : str or os.PathLike
    srgb16 : numpy.ndarray, uint16, (H, W, 3)
    compressed : bool, optional
        Deflate (:data:`TIFF_COMPRESSION`; default) or uncompressed.
    """
    import tifffile

    tifffile.imwrite(path, srgb16, photometric="rgb", iccprofile=srgb_icc(),
                     **(TIFF_COMPRESSION if compressed else {}))


def write_jpeg(path, srgb16, quality: int = JPEG_QUALITY) -> None:
    """An 8-bit sRGB JPEG (Pillow) with the sRGB ICC profile embedded.

    Parameters
    ----------
    path : str or os.PathLike
    srgb16 : numpy.ndarray, uint16 or uint8 (taken as it is), (H, W, 3)
    quality : int, optional
    """
    from PIL import Image

    codes = srgb16 if srgb16.dtype == np.uint8 else to_8bit(srgb16)
    Image.fromarray(codes).save(path, format="JPEG", quality=int(quality),
                                          icc_profile=srgb_icc())


def submit_images(pool, folder, srgb16, linear16, output_format: str, tiff: str) -> list:
    """Start writing a corrected photo's images on ``pool``: the sRGB image in
    ``output_format`` (:data:`SRGB_FILES`) and, when ``linear16`` is given, the linear TIFF
    (:data:`LINEAR_FILE`); TIFFs deflated unless ``tiff`` is 'full'.

    Parameters
    ----------
    pool : concurrent.futures.Executor
    folder : pathlib.Path
    srgb16, linear16 : numpy.ndarray, uint16, (H, W, 3), or None
        Not written when None.
    output_format : {'jpeg', 'tiff16'}
    tiff : {'compressed', 'full'}

    Returns
    -------
    list of (str, concurrent.futures.Future)
        The file names and their writes (``result()`` raises a write's error).
    """
    import tifffile

    jobs = []
    if srgb16 is not None:
        name = SRGB_FILES[output_format]
        jobs.append((name, pool.submit(write_jpeg, folder / name, srgb16)
                     if output_format == "jpeg" else
                     pool.submit(write_srgb_tiff, folder / name, srgb16,
                                 compressed=tiff != "full")))
    if linear16 is not None:
        jobs.append((LINEAR_FILE, pool.submit(
            tifffile.imwrite, folder / LINEAR_FILE, linear16, photometric="rgb",
            **(TIFF_COMPRESSION if tiff != "full" else {}))))
    return jobs
