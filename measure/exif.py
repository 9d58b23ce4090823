"""The one EXIF reader: a photo's TIFF/EXIF tags (:func:`read_exif`) and their values
(:func:`tag_value`), for the exposure and camera of :func:`measure.read_image`
(:func:`photo_tags`) and the depth and time of a dive's photo
(:func:`measure.dive.exif_info`).

Read with tifffile from TIFF containers (TIFF, DNG, NEF, ARW, CR2, PEF, ...): the first page's
tags (IFD0) and its Exif and GPS IFDs. A file that is not a TIFF container has no tags here,
which is allowed (its exposure is then given or not needed).

References
----------
CIPA DC-008-2016, Exchangeable image file format for digital still cameras: Exif Version 2.31.
"""

from __future__ import annotations

__all__ = ["CAMERA_TAGS", "EXIF_TAGS", "photo_tags", "read_exif", "tag_value"]

#: EXIF tags of the exposure (TIFF tag codes): ExposureTime, FNumber, ISOSpeedRatings
EXIF_TAGS = {33434: "exposure_s", 33437: "f_number", 34855: "iso"}
#: TIFF tags naming the camera that took the photo (TIFF tag codes; text): Make, Model
CAMERA_TAGS = {271: "make", 272: "model"}


def read_exif(path) -> tuple:
    """A photo's tags: IFD0 of its first page, then its Exif IFD and GPS IFD.

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    tuple of dict
        (IFD0, Exif IFD, GPS IFD): IFD0 keyed by tag code and by tifffile's tag name, the
        others as tifffile gives them (by name); an IFD the file lacks is {}. () for a file
        that is not a TIFF container.
    """
    import tifffile

    try:
        with tifffile.TiffFile(path) as tf:
            ifd0 = {}
            for tag in tf.pages[0].tags.values():
                ifd0[tag.code] = ifd0[tag.name] = tag.value
    except Exception:  # noqa: BLE001 - not a TIFF container (tifffile raises many kinds): no EXIF, allowed
        return ()
    return (ifd0, *(ifd0[sub] if isinstance(ifd0.get(sub), dict) else {}
                    for sub in ("ExifTag", "GPSTag")))


def tag_value(value):
    """A tag's value: text stripped of NULs and spaces, a rational divided out (None for a
    zero denominator), a sequence's first value, a number as float; None for anything else."""
    if isinstance(value, bytes):
        value = value.decode("ascii", "replace")
    if isinstance(value, str):
        return value.strip("\x00 ")
    if isinstance(value, tuple) and len(value) == 2:
        return value[0] / value[1] if value[1] else None
    if isinstance(value, tuple) and value:
        return tag_value(value[0])
    try:
        return float(value)
    except (TypeError, ValueError):
        return None


def _first(ifds, code: int):
    """The value of tag ``code`` (by code or name) in the first IFD that has it, or None."""
    from tifffile import TIFF

    name = TIFF.TAGS.get(code, "")
    return next((ifd.get(code, ifd.get(name)) for ifd in ifds
                 if ifd.get(code, ifd.get(name)) is not None), None)


def photo_tags(path) -> tuple:
    """(exposure, camera) of a photo, where its tags have them.

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    exposure : dict
        ``exposure_s`` (s), ``f_number``, ``iso`` (:data:`EXIF_TAGS`; IFD0 before the Exif
        IFD).
    camera : dict
        ``make`` and ``model`` (:data:`CAMERA_TAGS`), text, where not empty.
    """
    ifds = read_exif(path)
    out = {name: tag_value(_first(ifds, code)) for code, name in (EXIF_TAGS | CAMERA_TAGS).items()}
    return ({n: out[n] for n in EXIF_TAGS.values() if isinstance(out[n], float)},
            {n: out[n] for n in CAMERA_TAGS.values() if isinstance(out[n], str) and out[n]})
