"""run.json: the options of a dive's run that change its results, recorded in the output folder,
so that a rerun with other options is refused before it writes anything (:func:`check_manifest`).

The manifest holds uw3p's version, the ``measure.measure`` options (camera, quantal, profile,
illuminant, layout, water model, black and white levels, light field, uncertainty budget, the
run's measurements of the water, a measured chart) and the outputs asked for (``tiff``,
``report``). An option that names a file (the profile, a camera's or an illuminant's curves as
CSV, a measured chart's spectra) is recorded by the SHA-256 of the file's content, so
an edited file is noticed and a moved one is not. ``--joint`` and the survey figure are not in
it: they change no photo's results, and the run's own files follow the run that wrote them.
The defaults given for every photo (``--depth``, ``--distance``, ``--corners``) are: a rerun with
another default is refused like one with another option (a metadata row edited redoes its photo
only). A folder that holds no photo's results (a run that measured nothing, or was interrupted
before its first photo) refuses nothing: its run.json is replaced (the caller, measure.dive.run,
asks :func:`measure.dive.plan.holds_results`).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
from pathlib import Path

import numpy as np

from ..camera import file_digest
from .files import atomic
from .names import MANIFEST
from forward.errors import InputError

__all__ = ["FILE_OPTIONS", "check_manifest", "manifest", "manifest_digest", "write_manifest"]

#: Options of ``measure.measure`` that may name a file (recorded by its content's hash)
FILE_OPTIONS = ("profile", "camera", "illuminant", "chart_reflectance")


def _plain(x):
    """JSON's form of an option value (numpy arrays and scalars, dataclasses, paths)."""
    if isinstance(x, Path):
        return str(x)
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    if dataclasses.is_dataclass(x):
        return {f.name: getattr(x, f.name) for f in dataclasses.fields(x)
                if not f.name.endswith("_table")}
    return repr(x)


def _is_file(value) -> bool:
    return isinstance(value, (str, os.PathLike)) and os.path.isfile(value)


def manifest(options: dict, images: dict, report: bool, version: str, defaults=None) -> dict:
    """The run's options that change its results, as run.json records them.

    Parameters
    ----------
    options : dict
        The ``measure.measure`` options of the run (paths absolute).
    images : dict
        The images asked for (:func:`measure.output.image_options`: ``tiff``,
        ``output_format``, ``linear``, ``method``).
    report : bool
        report.png drawn.
    version : str
        uw3p's version.
    defaults : dict, optional
        The values given for every photo: ``depth``, ``distance`` (m), ``corners`` (a list of
        four [x, y] or None).

    Returns
    -------
    dict
        JSON-ready: ``version``, ``options`` (a file by ``{"sha256": ...}``), ``outputs`` and
        ``defaults``.

    Raises
    ------
    ValueError
        Naming the option whose file cannot be read.
    """
    opts = {}
    for k, v in sorted(options.items()):
        if k in FILE_OPTIONS and _is_file(v):
            try:
                v = {"sha256": file_digest(v)}
            except OSError as exc:
                raise InputError(k, f"cannot read {v}: {exc.strerror}") from None
        opts[k] = v
    return json.loads(json.dumps({"version": version, "options": opts,
                                  "outputs": dict(images) | {"report": bool(report)},
                                  "defaults": dict(defaults or {})},
                                 sort_keys=True, default=_plain))


def manifest_digest(content: dict) -> str:
    """The SHA-256 of a manifest (what each photo's key and complete.json refer to).

    Parameters
    ----------
    content : dict
        :func:`manifest`'s.

    Returns
    -------
    str
        Hex digest.
    """
    return hashlib.sha256(json.dumps(content, sort_keys=True).encode()).hexdigest()


#: What the refusal calls the defaults given for every photo
_DEFAULT_NAMES = {"depth": "--depth", "distance": "--distance", "corners": "--corners"}


def _changed(name: str, a, b, out: list) -> None:
    """The differences of one entry in words; of a dict (the water model), its fields only."""
    if a == b:
        return
    if isinstance(a, dict) and isinstance(b, dict):
        if "sha256" in a and "sha256" in b:
            out.append(f"{name}: the file's content changed")
            return
        for k in sorted(set(a) | set(b)):
            _changed(f"{name}.{k}", a.get(k), b.get(k), out)
        return
    out.append(f"{name}: {a!r} -> {b!r}")


def _differences(old: dict, new: dict) -> list:
    """What differs between two manifests, in words."""
    out = []
    if old.get("version") != new.get("version"):
        out.append(f"uw3p version {old.get('version')!r} -> {new.get('version')!r}")
    for group in ("options", "outputs", "defaults"):
        a, b = old.get(group) or {}, new.get(group) or {}
        for k in sorted(set(a) | set(b)):
            _changed(_DEFAULT_NAMES.get(k, k) if group == "defaults" else k, a.get(k), b.get(k),
                     out)
    return out


def check_manifest(root: Path, content: dict, overwrite: bool) -> None:
    """Refuse a run whose options differ from those of the run that wrote ``root``.

    Parameters
    ----------
    root : pathlib.Path
        The output folder.
    content : dict
        This run's :func:`manifest`.
    overwrite : bool
        Allowed: the run redoes every photo with its own options.

    Raises
    ------
    ValueError
        Naming ``out``: the options differ (which, and the choice: ``--overwrite`` or a new
        ``--out``), or run.json cannot be read.
    """
    path = root / MANIFEST
    if overwrite or not path.exists():
        return
    try:
        old = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise InputError("out", f"cannot read {path} ({exc}); give --overwrite to replace the "
                         "results there, or a new --out") from None
    diff = _differences(old, content)
    if diff:
        raise InputError("out", f"{root} holds the results of a run with other options ("
                         + "; ".join(diff) + "); a rerun with other options would replace "
                         "them: give --overwrite to redo every photo with these options, or a "
                         "new --out")


def write_manifest(root: Path, content: dict) -> Path:
    """Write run.json (whole or not at all) unless it holds ``content`` already.

    Parameters
    ----------
    root : pathlib.Path
        The output folder.
    content : dict
        :func:`manifest`'s.

    Returns
    -------
    pathlib.Path
    """
    path = root / MANIFEST
    try:
        if json.loads(path.read_text(encoding="utf-8")) == content:
            return path  # the same run's: not rewritten (a rerun rewrites nothing complete)
    except (OSError, ValueError):
        pass
    with atomic(path) as tmp:
        tmp.write_text(json.dumps(content, indent=1, sort_keys=True) + "\n", encoding="utf-8")
    return path
