"""The files of a corrected photo: images people open and the correction's numbers.

- the full-resolution sRGB image with the sRGB ICC profile embedded (the profile is Pillow's
  ``ImageCms.createProfile("sRGB")``), one file in the format asked for (``output_format``,
  decision 0084-output-format): ``corrected.jpg``, 8-bit JPEG (Pillow, quality
  :data:`measure.imagefiles.JPEG_QUALITY`; the default), or ``corrected_srgb.tif``, 16-bit
  TIFF (tag 34675, InterColorProfile), deflate-compressed and lossless unless ``tiff='full'``
  (:data:`measure.imagefiles.TIFF_COMPRESSION`);
- ``corrected.tiff`` on request (``linear``): linear camera RGB, 16-bit;
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

from .imagefiles import submit_images
from .output import MARKER, check_out, image_options, strict_json, write_folder

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
                    output_format: str = "jpeg", overwrite: bool = False,
                    marker: dict | None = None, inputs=()) -> dict:
    """Write a corrected photo's folder, whole or not at all.

    Parameters
    ----------
    corr : measure.correct.Corrected
        With ``srgb``; its ``linear`` image, when made, is written as corrected.tiff.
    outdir : str or os.PathLike
        The folder (replaced when it holds a correction of the same photo; another photo's only
        with ``overwrite``; never when it holds an input or a measurement:
        :func:`check_correct_out`).
    record : dict
        correction.json's content.
    version : str, optional
        uw3p's version.
    tiff : {'compressed', 'full', 'none'}, optional
        The TIFFs deflate-compressed (default) or uncompressed; 'none': no TIFF
        (:func:`measure.output.image_options`).
    output_format : {'jpeg', 'tiff16'}, optional
        The sRGB image: corrected.jpg (default) or corrected_srgb.tif.
    overwrite : bool, optional
    marker : dict, optional
        More entries of complete.json.
    inputs : iterable of str or os.PathLike, optional
        The other files the correction read (the water's file, the range map): the folder may
        not hold them.

    Returns
    -------
    dict
        file name -> path (complete.json records each file's size in bytes).

    Raises
    ------
    forward.errors.InputError
        Naming ``tiff``, ``output_format`` or ``out`` (:func:`check_correct_out`).
    """
    image_options(output_format, corr.linear is not None, tiff, corr.table.method)
    check_correct_out(outdir, corr.photo.path, inputs, overwrite)

    def write(tmp: Path) -> list:
        names = ["correction.json"]
        _json(tmp / "correction.json", record)
        with ThreadPoolExecutor(max_workers=2) as pool:
            for name, job in submit_images(pool, tmp, corr.srgb, corr.linear, output_format,
                                           tiff):
                job.result()
                names.append(name)
        sizes = {n: (tmp / n).stat().st_size for n in names}
        names.append(MARKER)
        _json(tmp / MARKER, {"image": str(corr.photo.path), "version": version, "files": names,
                             "sizes": sizes, "output_format": output_format} | (marker or {}))
        return names
    return write_folder(outdir, corr.photo.path, overwrite, write)
