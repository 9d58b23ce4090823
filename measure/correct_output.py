"""The files of a corrected photo: images people open and the correction's numbers.

- ``corrected_srgb.tif``: full resolution, 16-bit sRGB with the sRGB ICC profile embedded (TIFF
  tag 34675, InterColorProfile; the profile is Pillow's ``ImageCms.createProfile("sRGB")``),
  deflate-compressed and lossless by default (:data:`measure.imagefiles.TIFF_COMPRESSION`);
- ``corrected.jpg``: the same image, 8-bit JPEG (Pillow, quality
  :data:`measure.imagefiles.JPEG_QUALITY`, the ICC profile embedded);
- ``corrected.tiff``: linear camera RGB, 16-bit (as ``uw3p measure`` writes it);
- ``correction.json``: the correction's per-channel coefficients in Sea-thru's form, its table
  of ranges, the range used, the water, the cap, what is not modelled, and (when computed) its
  uncertainty;
- ``complete.json`` last: the folder is written whole (a temporary folder renamed into place,
  as :func:`measure.write_outputs` does) or not at all.
"""

from __future__ import annotations

import json
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path


from forward.errors import InputError

from .imagefiles import TIFF_COMPRESSION, write_jpeg, write_srgb_tiff
from .output import MARKER, TIFF_MODES, strict_json, write_folder

__all__ = ["NOT_MODELLED", "write_corrected"]

#: What the correction does not model (recorded in correction.json)
NOT_MODELLED = (
    "the object's own depth where it differs from the photo's (the light reaching it is that "
    "at the camera's depth)",
    "forward scattering (blur, the glow around bright objects)",
    "the daylight's angle (it comes straight down: no shading or shadow)",
    "artificial light (strobes, video lights)",
    "a veiling light that varies across the frame otherwise than with the range",
)


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
        raise InputError("tiff", f"must be one of {TIFF_MODES}, got {tiff!r}")

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
