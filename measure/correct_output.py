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

The folder is replaced whole, so a correction never goes into a folder that holds one of its
inputs (the photo, the water's measurement.json or joint.json, the range map) or a measurement
(a measurement.json: the results of ``uw3p measure`` or of a dive's photo): that is refused,
naming ``out`` (:func:`check_correct_out`), and nothing is written or removed.
"""

from __future__ import annotations

import json
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path


from forward.errors import InputError

from .imagefiles import TIFF_COMPRESSION, write_jpeg, write_srgb_tiff
from .output import MARKER, TIFF_MODES, check_out, strict_json, write_folder

__all__ = ["NOT_MODELLED", "check_correct_out", "write_corrected"]

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


def _inside(path, folder: Path) -> bool:
    """``path`` is ``folder`` or lies in it (symbolic links resolved)."""
    p = Path(path).resolve()
    return p == folder or folder in p.parents


def check_correct_out(outdir, image, inputs=(), overwrite: bool = False) -> None:
    """Refuse an output folder whose replacement would delete an input or a measurement
    (checked before the photo is corrected, too, so that a refusal comes first).

    Parameters
    ----------
    outdir : str or os.PathLike
        The correction's folder.
    image : str or os.PathLike
        The photo.
    inputs : iterable of str or os.PathLike, optional
        The other files the correction reads (the water's file, the range map); paths that do
        not exist (a range given as a number) are skipped.
    overwrite : bool, optional
        Another photo's corrected results may be replaced (:func:`measure.output.check_out`).

    Raises
    ------
    forward.errors.InputError
        Naming ``out``: what :func:`measure.output.check_out` refuses; the folder holds (or is)
        one of the inputs; it holds a measurement.json.
    """
    check_out(outdir, image, overwrite)
    out = Path(outdir)
    folder = out.resolve()
    for src in (image, *inputs):
        if src is not None and Path(src).exists() and _inside(src, folder):
            raise InputError("out", f"{out} holds {src}, an input of this correction (the "
                             "folder is replaced whole); give another folder")
    if (out / "measurement.json").exists():
        raise InputError("out", f"{out} holds a measurement (measurement.json: the results of "
                         "uw3p measure or of a dive's photo), which a correction never replaces; "
                         "give another folder")


def write_corrected(corr, outdir, *, record: dict, version: str = "", tiff: str = "compressed",
                    jpeg: bool = True, overwrite: bool = False, marker: dict | None = None,
                    inputs=()) -> dict:
    """Write a corrected photo's folder, whole or not at all.

    Parameters
    ----------
    corr : measure.correct.Corrected
        With ``srgb`` (and ``linear`` unless ``tiff='none'``).
    outdir : str or os.PathLike
        The folder (replaced when it holds a correction of the same photo; another photo's only
        with ``overwrite``; never when it holds an input or a measurement:
        :func:`check_correct_out`).
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
    inputs : iterable of str or os.PathLike, optional
        The other files the correction read (the water's file, the range map): the folder may
        not hold them.

    Returns
    -------
    dict
        file name -> path.

    Raises
    ------
    forward.errors.InputError
        Naming ``tiff`` or ``out`` (:func:`check_correct_out`).
    """
    if tiff not in TIFF_MODES:
        raise InputError("tiff", f"must be one of {TIFF_MODES}, got {tiff!r}")
    check_correct_out(outdir, corr.photo.path, inputs, overwrite)

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
