"""The files of a corrected photo: images people open and the correction's numbers.

- ``corrected_srgb.tif``: full resolution, 16-bit sRGB with the sRGB ICC profile embedded (TIFF
  tag 34675, InterColorProfile; the profile is Pillow's ``ImageCms.createProfile("sRGB")``),
  deflate-compressed and lossless by default (:data:`measure.output.TIFF_COMPRESSION`);
- ``corrected.jpg``: the same image, 8-bit JPEG (Pillow, quality :data:`JPEG_QUALITY`, the ICC
  profile embedded);
- ``corrected.tiff``: linear camera RGB, 16-bit (as ``uw3p measure`` writes it);
- ``correction.json``: the correction's per-channel coefficients in Sea-thru's form, its table
  of ranges, the range used, the water, the cap, what is not modelled, and (when computed) its
  uncertainty;
- ``complete.json`` last: the folder is written whole (a temporary folder renamed into place,
  as :func:`measure.write_outputs` does) or not at all.
"""

from __future__ import annotations

import functools
import json
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from .output import MARKER, TIFF_COMPRESSION, TIFF_MODES, strict_json, write_folder

__all__ = ["JPEG_QUALITY", "JPEG_ROWS", "NOT_MODELLED", "srgb_icc", "to_8bit", "write_corrected",
           "write_jpeg", "write_srgb_tiff"]

#: JPEG quality (Pillow's scale; 92: artefacts below visibility at normal viewing, the files
#: about a quarter of quality 100's)
JPEG_QUALITY = 92
#: Rows converted from 16 to 8 bits at a time (bounds the temporaries at 24 MP)
JPEG_ROWS = 512
#: TIFF tag InterColorProfile (TIFF/EP, ICC.1 annex B)
ICC_TAG = 34675
#: What the correction does not model (recorded in correction.json)
NOT_MODELLED = (
    "the object's own depth where it differs from the photo's (the light reaching it is that "
    "at the camera's depth)",
    "forward scattering (blur, the glow around bright objects)",
    "the daylight's angle (it comes straight down: no shading or shadow)",
    "artificial light (strobes, video lights)",
    "a veiling light that varies across the frame otherwise than with the range",
)


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
        Deflate (:data:`measure.output.TIFF_COMPRESSION`; default) or uncompressed.
    """
    import tifffile

    tifffile.imwrite(path, srgb16, photometric="rgb", iccprofile=srgb_icc(),
                     **(TIFF_COMPRESSION if compressed else {}))


def write_jpeg(path, srgb16, quality: int = JPEG_QUALITY) -> None:
    """An 8-bit sRGB JPEG (Pillow) with the sRGB ICC profile embedded.

    Parameters
    ----------
    path : str or os.PathLike
    srgb16 : numpy.ndarray, uint16, (H, W, 3)
    quality : int, optional
    """
    from PIL import Image

    Image.fromarray(to_8bit(srgb16)).save(path, format="JPEG", quality=int(quality),
                                          icc_profile=srgb_icc())


def _json(path: Path, data) -> None:
    path.write_text(json.dumps(strict_json(data), indent=1, allow_nan=False) + "\n",
                    encoding="utf-8")


def write_corrected(corr, outdir, *, record: dict, version: str = "", tiff: str = "compressed",
                    jpeg: bool = True, overwrite: bool = False, marker: dict | None = None) -> dict:
    """Write a corrected photo's folder, whole or not at all.

    Parameters
    ----------
    corr : measure.correct.Corrected
        With ``srgb`` (and ``linear`` unless ``tiff='none'``).
    outdir : str or os.PathLike
        The folder (replaced when it holds results of the same photo; another photo's only
        with ``overwrite``).
    record : dict
        correction.json's content.
    version : str, optional
        uw3p's version.
    tiff : {'compressed', 'full', 'none'}, optional
        corrected.tiff and corrected_srgb.tif deflate-compressed (default), uncompressed, or
        not written.
    jpeg : bool, optional
        Write corrected.jpg.
    overwrite : bool, optional
    marker : dict, optional
        More entries of complete.json.

    Returns
    -------
    dict
        file name -> path.

    Raises
    ------
    ValueError
        Naming ``tiff`` or ``out``.
    """
    if tiff not in TIFF_MODES:
        raise ValueError(f"tiff: must be one of {TIFF_MODES}, got {tiff!r}")

    def write(tmp: Path) -> list:
        names = ["correction.json"]
        _json(tmp / "correction.json", record)
        # the TIFFs are compressed by imagecodecs outside the GIL while the JPEG is encoded
        with ThreadPoolExecutor(max_workers=2) as pool:
            jobs = []
            if tiff != "none":
                if corr.srgb is not None:
                    jobs.append(("corrected_srgb.tif", pool.submit(
                        write_srgb_tiff, tmp / "corrected_srgb.tif", corr.srgb,
                        compressed=tiff == "compressed")))
                if corr.linear is not None:
                    import tifffile

                    jobs.append(("corrected.tiff", pool.submit(
                        tifffile.imwrite, tmp / "corrected.tiff", corr.linear, photometric="rgb",
                        **(TIFF_COMPRESSION if tiff == "compressed" else {}))))
            if jpeg and corr.srgb is not None:
                write_jpeg(tmp / "corrected.jpg", corr.srgb)
                names.append("corrected.jpg")
            for name, job in jobs:
                job.result()
                names.append(name)
        names.append(MARKER)
        _json(tmp / MARKER, {"image": str(corr.photo.path), "version": version, "files": names}
              | (marker or {}))
        return names
    return write_folder(outdir, corr.photo.path, overwrite, write)
