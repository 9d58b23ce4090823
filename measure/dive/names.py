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
file (hidden names). A name longer than :data:`MAX_NAME_BYTES` (UTF-8) is cut there and gets the
digest suffix (the photo's temporary folder adds a prefix and a random part, and a file system
allows 255 bytes). A photo whose folder of an earlier run already holds its results keeps that
folder's name when a photo added later shares it (the newcomer gets the suffix): a finished
photo is never redone or orphaned because of another.
"""

from __future__ import annotations

import hashlib
import os
from collections import Counter
from pathlib import Path

from ..image import photo_extensions

__all__ = ["LOCK_FILE", "MANIFEST", "MAX_NAME_BYTES", "NOT_UTF8", "RUN_FILES", "SUFFIX_HEX", "dive_files",
           "output_names", "printable_name"]

#: The run's manifest: the options that change results (:mod:`measure.dive.manifest`)
MANIFEST = "run.json"
#: The run's own files in the output folder (beside the photos' folders)
RUN_FILES = ("summary.csv", "survey.nc", "survey.png", "joint.json", "ifdo.json", MANIFEST)
#: The lock file a run holds while it writes the output folder (:mod:`measure.dive.files`)
LOCK_FILE = ".uw3p.lock"
#: Hex digits of the disambiguating suffix (32 bits: two names of one dive sharing one is a
#: one-in-four-billion event, and then the full path's digest is used)
SUFFIX_HEX = 8
#: Longest output folder name (UTF-8 bytes): 255 (a file name's limit on ext4, XFS, APFS, NTFS)
#: less the temporary folder's prefix ``.uw3p-tmp-old-`` and random part (23 bytes), with room
MAX_NAME_BYTES = 200
#: Why a file whose name is not UTF-8 is not measured (an error row: it may be a photo)
NOT_UTF8 = ("image: the file name is not UTF-8 text (an archive's or another system's "
            "encoding); rename it to measure it")


def printable_name(name: str) -> str:
    """A file name as UTF-8 text: bytes that are not UTF-8 (``os.listdir``'s surrogates) shown
    as ``\\xNN`` escapes.

    Parameters
    ----------
    name : str

    Returns
    -------
    str
    """
    return name.encode("utf-8", "surrogateescape").decode("utf-8", "backslashreplace")


def _is_utf8(name: str) -> bool:
    try:
        name.encode("utf-8")
    except UnicodeEncodeError:
        return False
    return True


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
        The files whose extension :data:`measure.image.IMAGE_READERS` reads (RAW and TIFF),
        sorted by name.
    others : list of (pathlib.Path, str)
        Every other file and why it is not measured.
    """
    skip = {Path(p).resolve() for p in exclude}
    photos, others = [], []
    for p in sorted(Path(folder).iterdir()):
        if p.name.startswith("."):
            continue
        if not _is_utf8(p.name):
            others.append((p.with_name(printable_name(p.name)), NOT_UTF8))
            continue
        if p.is_symlink() and not p.exists():
            others.append((p, f"a link to a missing file ({os.readlink(p)})"))
            continue
        if not p.is_file() or p.resolve() in skip:
            continue
        if p.suffix.lower() in photo_extensions():
            photos.append(p)
        else:
            why = (f"not a RAW or linear TIFF ({p.suffix or 'no extension'}; measured: "
                   f"{', '.join(photo_extensions())})")
            others.append((p, why))
    return photos, others


def _hex(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8", "surrogateescape")).hexdigest()[:SUFFIX_HEX]


def _alike(names: dict) -> set:
    """The keys whose names another key shares (case-insensitively)."""
    count = Counter(n.casefold() for n in names.values())
    return {k for k, n in names.items() if count[n.casefold()] > 1}


def _cut(name: str, limit: int) -> str:
    """``name`` cut to at most ``limit`` UTF-8 bytes (on a character's boundary)."""
    return name.encode("utf-8", "surrogateescape")[:limit].decode("utf-8", "ignore")


def output_names(photos, owner=None) -> dict:
    """Each photo's output folder name (the module's scheme): the file name with its dots
    replaced by ``_``, and a digest suffix where two would be alike or the name is long.

    Parameters
    ----------
    photos : list of path
    owner : callable, optional
        ``owner(name)``: the photo (absolute path) whose results the folder ``name`` holds
        already, or None; such a photo keeps its folder's name.

    Returns
    -------
    dict
        path -> folder name; no two alike case-insensitively, none with a ``.``, none longer
        than :data:`MAX_NAME_BYTES`.
    """
    room = MAX_NAME_BYTES - 1 - SUFFIX_HEX
    base = {p: Path(p).name.replace(".", "_") for p in photos}
    long = {p for p, n in base.items() if len(n.encode("utf-8", "surrogateescape"))
            > MAX_NAME_BYTES}
    names = {p: f"{_cut(n, room)}-{_hex(Path(p).name)}" if p in long else n
             for p, n in base.items()}
    for p in _alike(names):
        names[p] = f"{_cut(base[p], room)}-{_hex(Path(p).name)}"
    for p in _alike(names):  # the same file name twice (two folders): the path decides
        names[p] = f"{_cut(base[p], room)}-{_hex(os.path.abspath(p))}"
    if owner is not None:  # a photo whose folder holds its results keeps it
        taken = {n.casefold() for n in names.values()}
        for p in photos:
            if names[p] != base[p] and base[p].casefold() not in taken and p not in long \
                    and owner(base[p]) == os.path.abspath(p):
                names[p] = base[p]
                taken.add(base[p].casefold())
    return names
