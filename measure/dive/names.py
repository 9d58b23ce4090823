"""Which files of a dive's folder are photos (:func:`dive_files`), the name of each photo's
output folder (:func:`output_names`), and the names of the run's own files.

Output folder names: the photo's whole file name with every ``.`` replaced by ``_``
(``IMG_1.dng`` -> ``IMG_1_dng/``), so the folder says which photo it holds. Names that would
still be alike when compared case-insensitively (``A.b.dng`` and ``A_b.dng``; ``A.dng`` and
``a.DNG``) each get ``-`` and the first :data:`SUFFIX_HEX` hex digits of the SHA-256 of the
file's name (of its absolute path when the names themselves are equal: photos from two
folders). A photo's folder name thus depends on the photo and on which other photos share its
name, never on the order of the listing. A folder name has no ``.``: it can never be one of
the run's own files (:data:`RUN_FILES`, each with an extension), its lock file or a temporary
file (hidden names).
"""

from __future__ import annotations

import hashlib
import os
from collections import Counter
from pathlib import Path

from ..image import RAW_EXTENSIONS, TIFF_EXTENSIONS

__all__ = ["LOCK_FILE", "MANIFEST", "RUN_FILES", "SUFFIX_HEX", "dive_files", "output_names"]

#: The run's manifest: the options that change results (:mod:`measure.dive.manifest`)
MANIFEST = "run.json"
#: The run's own files in the output folder (beside the photos' folders)
RUN_FILES = ("summary.csv", "survey.nc", "survey.png", "joint.json", "ifdo.json", MANIFEST)
#: The lock file a run holds while it writes the output folder (:mod:`measure.dive.files`)
LOCK_FILE = ".uw3p.lock"
#: Hex digits of the disambiguating suffix (32 bits: two names of one dive sharing one is a
#: one-in-four-billion event, and then the full path's digest is used)
SUFFIX_HEX = 8


def dive_files(folder, exclude=()) -> tuple:
    """The files of a dive's folder: the photos, and the others with the reason they are not.

    Hidden files (names starting with '.') and sub-folders are not listed (an output folder
    inside the dive is a sub-folder); nor are the files of ``exclude`` (the metadata CSV). A
    link to a missing file is listed with that reason.

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
        if p.name.startswith("."):
            continue
        if p.is_symlink() and not p.exists():
            others.append((p, f"a link to a missing file ({os.readlink(p)})"))
            continue
        if not p.is_file() or p.resolve() in skip:
            continue
        if p.suffix.lower() in RAW_EXTENSIONS + TIFF_EXTENSIONS:
            photos.append(p)
        else:
            why = (f"not a RAW or linear TIFF ({p.suffix or 'no extension'}; measured: "
                   f"{', '.join(RAW_EXTENSIONS + TIFF_EXTENSIONS)})")
            others.append((p, why))
    return photos, others


def _hex(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8", "surrogateescape")).hexdigest()[:SUFFIX_HEX]


def _alike(names: dict) -> set:
    """The keys whose names another key shares (case-insensitively)."""
    count = Counter(n.casefold() for n in names.values())
    return {k for k, n in names.items() if count[n.casefold()] > 1}


def output_names(photos) -> dict:
    """Each photo's output folder name (the module's scheme): the file name with its dots
    replaced by ``_``, and a digest suffix where two would be alike.

    Parameters
    ----------
    photos : list of path

    Returns
    -------
    dict
        path -> folder name; no two alike case-insensitively, none with a ``.``.
    """
    base = {p: Path(p).name.replace(".", "_") for p in photos}
    names = dict(base)
    for p in _alike(names):
        names[p] = f"{base[p]}-{_hex(Path(p).name)}"
    for p in _alike(names):  # the same file name twice (two folders): the path decides
        names[p] = f"{base[p]}-{_hex(os.path.abspath(p))}"
    return names
