"""The plan of a dive: each photo's inputs and their sources (:func:`resolve_inputs`), the key
that says "same inputs" (:func:`photo_key`), and what to do with each photo (:func:`plan_photo`):
measure it, skip it (complete with the same key), a summary row saying why not, or a conflict
that refuses the run before it writes anything. A folder is complete when its marker's key is
the photo's and every file the marker lists is there at its size (:func:`complete_files`);
``overwrite`` redoes every photo.

The key is the content: the SHA-256 of the photo's bytes, its metadata row, its resolved inputs
(depth, distance, their sds, corners, EXIF time) and the run's manifest (the options that
change results, files by content: :mod:`measure.dive.manifest`). A photo replaced by another of
the same name, size and time is redone; a photo whose folder holds results of the same photo
made with the same options but other inputs or content is redone (its folder replaced); a
folder that holds another photo's results or results of other options, or files that are not
uw3p results, is a conflict.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

import numpy as np

from ..output import read_marker, result_owner
from ..camera import file_digest
from .summary import CORRECTED, summary_row
from forward.errors import InputError

__all__ = ["complete_files", "correction_range", "holds_results", "photo_key", "plan_photo",
           "resolve_inputs", "run_setup"]


def correction_range(inputs: dict):
    """What a photo is corrected along: its ``range_map``, else its ``range_m``, else its
    ``distance_m`` (m).

    Parameters
    ----------
    inputs : dict
        :func:`resolve_inputs`'s.

    Returns
    -------
    str or float
        A range-map path or a range in m (:func:`measure.rangemap.read_range`).
    """
    for k in ("range_map", "range_m", "distance_m"):
        if inputs.get(k) is not None:
            return inputs[k]
    raise InputError("range", "not given (range_map, range_m or distance_m)")


def resolve_inputs(photo: Path, row, exif, depth, distance, corners) -> dict:
    """The photo's inputs and their sources.

    Parameters
    ----------
    photo : pathlib.Path
        The photo.
    row : dict or None
        Its metadata row (:func:`measure.dive.read_metadata`).
    exif : dict
        :func:`measure.dive.exif_info`'s.
    depth, distance : float or None
        The defaults (m).
    corners : str or array_like or None
        The default corners.

    Returns
    -------
    dict
        ``depth_m``, ``distance_m``, their sds, ``corners``, ``time``, the row's measurements
        of the water (``auxiliary``, :mod:`sca.auxiliary`'s form) and their sources, and
        ``range_m`` and ``range_map`` (what the photo is corrected along; None: not given).

    Raises
    ------
    ValueError
        Naming ``depth`` or ``distance`` when neither the row, the EXIF nor a default gives it.
    """
    def pick(name, cands):
        for value, source in cands:
            if value is not None:
                return value, source
        raise InputError(name, f"not given for {photo.name} (a metadata row, the EXIF, or "
                         f"--{name})")
    row = row or {}
    d, d_src = pick("depth", [(row.get("depth_m"), "metadata"),
                              (exif.get("depth_m"), f"exif:{exif.get('depth_tag')}"),
                              (depth, "--depth")])
    r, r_src = pick("distance", [(row.get("distance_m"), "metadata"), (distance, "--distance")])
    if row.get("corners"):
        c, c_src = row["corners"], "metadata"
    elif corners is not None:
        c, c_src = corners, "--corners"
    else:
        c, c_src = None, "detected"
    return {"depth_m": d, "depth_source": d_src, "distance_m": r, "distance_source": r_src,
            "depth_sd_m": row.get("depth_sd_m"), "distance_sd_m": row.get("distance_sd_m"),
            "corners": c if c is None or isinstance(c, str) else np.asarray(c, float).tolist(),
            "corners_source": c_src, "time": exif.get("time"),
            "range_m": row.get("range_m"), "range_map": row.get("range_map"),
            "auxiliary": row.get("auxiliary") or {}, "reference": row.get("reference") or [],
            "auxiliary_source": f"metadata line {row['line']}" if row.get("line") else ""}


def photo_key(photo: Path, row, inputs, run_digest: str) -> str:
    """The hash that says "same inputs" (the module's key).

    Parameters
    ----------
    photo : pathlib.Path
        The photo (its bytes are hashed).
    row : dict or None
        Its metadata row.
    inputs : dict
        :func:`resolve_inputs`'s.
    run_digest : str
        :func:`measure.dive.manifest.manifest_digest` of the run.

    Returns
    -------
    str
        Hex SHA-256.

    Raises
    ------
    OSError
        The photo cannot be read.
    """
    data = {"image": photo.name, "sha256": file_digest(photo),
            "range_map_sha256": file_digest(Path(inputs["range_map"]))
            if inputs.get("range_map") else None,
            "row": {k: v for k, v in (row or {}).items() if k != "line"},
            "inputs": {k: v for k, v in inputs.items() if not k.endswith("_source")},
            "run": run_digest}
    return hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()


def complete_files(out: Path, marker: dict) -> bool:
    """Whether every file a result folder's marker lists is there, with the size it was written
    with (where the marker records it): a folder that lost or truncated a file is redone.

    Parameters
    ----------
    out : pathlib.Path
        The photo's result folder.
    marker : dict
        Its complete.json (:func:`measure.output.read_marker`).

    Returns
    -------
    bool
    """
    sizes = marker.get("sizes") or {}
    for name in marker.get("files") or ():
        try:
            size = (out / name).stat().st_size
        except OSError:
            return False
        if name in sizes and size != sizes[name]:
            return False
    return True


def holds_results(root: Path) -> bool:
    """Whether the output folder holds a photo's results (a folder with its marker).

    Parameters
    ----------
    root : pathlib.Path

    Returns
    -------
    bool
    """
    try:
        return any(p.is_dir() and not p.name.startswith(".") and read_marker(p) is not None
                   for p in root.iterdir())
    except OSError:
        return False


def _record(out: Path):
    try:
        return json.loads((out / "measurement.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None  # a marker without its measurement: redo


def plan_photo(photo: Path, name: str, root: Path, meta, exif: dict, defaults, options: dict,
               outputs, run_digest: str, overwrite: bool) -> tuple:
    """What to do with one photo.

    Parameters
    ----------
    photo : pathlib.Path
        The photo (absolute).
    name : str
        Its output folder's name (:func:`measure.dive.output_names`).
    root : pathlib.Path
        The output folder.
    meta : dict or None
        The metadata CSV's rows (None: no metadata CSV).
    exif : dict
        :func:`measure.dive.exif_info`'s.
    defaults : tuple
        (depth, distance, corners) given for every photo.
    options : dict
        The ``measure.measure`` options.
    outputs : tuple
        (images, report): :func:`measure.output.image_options`'s dict and report.png.
    run_digest : str
        The run's manifest digest (recorded in complete.json).
    overwrite : bool
        Folders of another photo or of other options may be replaced.

    Returns
    -------
    job : dict or None
        The photo to measure.
    row : dict or None
        Its summary row when it is not measured now (done earlier, or why not).
    conflict : str or None
        Why its folder may not be written (the run is refused).
    """
    out = root / name
    images, report = outputs
    plan = {"out": str(out), "options": options, "tiff": images["tiff"]}
    if meta is not None and photo.name not in meta:
        return None, summary_row(photo, plan, "not in metadata", error=(
            f"metadata: no row for {photo.name}: not measured")), None
    row = (meta or {}).get(photo.name)
    try:
        inputs = resolve_inputs(photo, row, exif, *defaults)
    except ValueError as exc:
        return None, summary_row(photo, plan, "error", error=str(exc)), None
    plan["inputs"] = inputs
    try:
        key = photo_key(photo, row, inputs, run_digest)
    except OSError as exc:
        return None, summary_row(photo, plan, "error", error=(
            f"image: cannot read {photo}: {exc.strerror or exc}")), None
    marker = read_marker(out) if out.is_dir() else None
    done = marker is not None and marker.get("key") == key and not overwrite \
        and complete_files(out, marker)
    if done and marker.get("corrected"):
        # a frame without a chart corrected with the dive's water: the run checks the water
        return None, summary_row(photo, plan, CORRECTED), None
    if done:
        record = _record(out)
        if record is not None:
            return None, summary_row(photo, plan, "done earlier", record), None
    owner = result_owner(out) if out.is_dir() else None
    if out.exists() and not out.is_dir():
        return None, None, f"{out} is a file"
    if owner is None and out.exists() and any(out.iterdir()):
        return None, None, (f"{out} holds files that are not uw3p results (never replaced, not "
                            "even with --overwrite)")
    if owner is not None and not overwrite:
        same_photo = os.path.abspath(owner) == str(photo) if owner else False
        if not same_photo:
            return None, None, f"{out} holds the results of another photo ({owner or 'unknown'})"
        if marker is None or marker.get("run") != run_digest:
            return None, None, f"{out} holds results of {photo.name} made with other options"
        # the same photo and options, its content or inputs changed: redone
    job = {"image": str(photo), "out": str(out), "inputs": inputs, "options": options,
           "images": images, "report": report, "key": key, "run": run_digest, "plan": plan}
    return job, None, None


def run_setup(options):
    """The run's camera set-up (camera, profile balance, illuminant, the chart's measured
    reflectance if given)."""
    import forward

    from ..camera import camera_setup, load_profile, read_chart_reflectance

    prof = options.get("profile")
    prof = load_profile(prof) if isinstance(prof, (str, os.PathLike)) else prof
    chart = options.get("chart_reflectance")
    return camera_setup(options.get("camera", forward.DEFAULT_CAMERA),
                        quantal=options.get("quantal", False),
                        illuminant=options.get("illuminant"),
                        gains=None if prof is None else (prof.gains or None),
                        reflectances=None if chart is None else read_chart_reflectance(chart))
