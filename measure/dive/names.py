"""Which files of a dive's folder are photos (:func:`dive_files`), and the name of each photo's
output folder (:func:`output_names`).

Output folders: a photo's folder is named after its file's stem (``IMG_1.dng`` ->
``IMG_1/``); when several files of the folder share a stem (``IMG_1.dng``, ``IMG_1.tif``),
each of them gets its stem and extension (``IMG_1_dng/``, ``IMG_1_tif/``).
"""

from __future__ import annotations

from pathlib import Path

from ..image import RAW_EXTENSIONS, TIFF_EXTENSIONS

__all__ = ["dive_files", "output_names"]


def dive_files(folder, exclude=()) -> tuple:
    """The files of a dive's folder: the photos, and the others with the reason they are not.

    Hidden files (names starting with '.') and sub-folders are not listed (an output folder
    inside the dive is a sub-folder); nor are the files of ``exclude`` (the metadata CSV).

    Parameters
    ----------
    folder : str or os.PathLike
        The dive's folder.
    exclude : iterable of path, optional
        Files not to list.

    Returns
    -------
    photos : list of pathlib.Path
        RAW (:data:`measure.image.RAW_EXTENSIONS`) and TIFF files, sorted by name.
    others : list of (pathlib.Path, str)
        Every other file and why it is not measured.
    """
    skip = {Path(p).resolve() for p in exclude}
    photos, others = [], []
    for p in sorted(Path(folder).iterdir()):
        if p.name.startswith(".") or not p.is_file() or p.resolve() in skip:
            continue
        if p.suffix.lower() in RAW_EXTENSIONS + TIFF_EXTENSIONS:
            photos.append(p)
        else:
            why = (f"not a RAW or linear TIFF ({p.suffix or 'no extension'}; measured: "
                   f"{', '.join(RAW_EXTENSIONS + TIFF_EXTENSIONS)})")
            others.append((p, why))
    return photos, others


def output_names(photos) -> dict:
    """Each photo's output folder name: its stem, or stem and extension (``IMG_1_dng``) for
    every file whose stem another file shares (compared case-insensitively).

    Parameters
    ----------
    photos : list of path

    Returns
    -------
    dict
        path -> folder name.
    """
    stems = {}
    for p in photos:
        stems.setdefault(Path(p).stem.lower(), []).append(p)
    return {p: Path(p).stem if len(stems[Path(p).stem.lower()]) == 1
            else f"{Path(p).stem}_{Path(p).suffix.lstrip('.')}" for p in photos}
