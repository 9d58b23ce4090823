"""The plan of a dive: each photo's inputs and their sources (:func:`resolve_inputs`), the key
that says "same inputs" (:func:`photo_key`), and what to do with each photo (:func:`plan_photo`):
measure it, or a summary row saying why not."""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
from pathlib import Path

import numpy as np

from ..output import read_marker, result_owner
from .summary import summary_row

__all__ = ["photo_key", "plan_photo", "resolve_inputs"]


def resolve_inputs(photo: Path, row, exif, depth, distance, corners):
    """The photo's inputs and their sources; raises ValueError when one is missing."""
    def pick(name, cands):
        for value, source in cands:
            if value is not None:
                return value, source
        raise ValueError(f"{name}: not given for {photo.name} (a metadata row, the EXIF, or "
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
            "corners_source": c_src, "time": exif.get("time")}


def _key_default(x):
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


def _options_text(options: dict) -> dict:
    """The options as recorded in the key: a profile file by its content's hash."""
    out = dict(options)
    prof = out.get("profile")
    if isinstance(prof, (str, os.PathLike)):
        try:
            out["profile"] = "sha256:" + hashlib.sha256(Path(prof).read_bytes()).hexdigest()
        except OSError:
            out["profile"] = str(prof)
    return out


def photo_key(photo: Path, inputs, options, outputs, version) -> str:
    """The hash that says "same inputs": the image (name, size, modification time), its
    resolved inputs, the options (a profile by content), the outputs asked for (TIFF mode,
    report) and uw3p's version."""
    st = photo.stat()
    data = {"image": photo.name, "size": st.st_size, "mtime_ns": st.st_mtime_ns,
            "inputs": {k: v for k, v in inputs.items() if not k.endswith("_source")},
            "options": _options_text(options), "outputs": outputs, "version": version}
    text = json.dumps(data, sort_keys=True, default=_key_default)
    return hashlib.sha256(text.encode()).hexdigest()



def plan_photo(photo, name, root, rows_meta, metadata, exif, defaults, options, outputs, overwrite,
          version):
    """(job or None, row or None) for one photo: a row when it is done or cannot be done."""
    out = root / name
    tiff, report = outputs
    plan = {"out": str(out), "options": options, "tiff": tiff}
    if metadata is not None and photo.name not in rows_meta:
        return None, summary_row(photo, plan, "error", error=f"metadata: no row for {photo.name} in "
                                                      f"{metadata}")
    try:
        inputs = resolve_inputs(photo, rows_meta.get(photo.name), exif, *defaults)
    except ValueError as exc:
        return None, summary_row(photo, plan, "error", error=str(exc))
    plan["inputs"] = inputs
    key = photo_key(photo, inputs, options, outputs, version)
    marker = read_marker(out) if out.is_dir() else None
    if marker is not None and marker.get("key") == key:
        try:
            record = json.loads((out / "measurement.json").read_text(encoding="utf-8"))
            return None, summary_row(photo, plan, "done earlier", record)
        except (OSError, ValueError):
            pass  # a marker without its measurement: redo
    owner = result_owner(out) if out.is_dir() else None
    if owner is not None and not overwrite:
        same = marker is not None and Path(owner).name == photo.name
        why = "results of the same photo with other inputs or options" if same else \
            f"the results of another photo ({owner or 'unknown'})"
        return None, summary_row(photo, plan, "error", error=f"out: {out} holds {why}; give another "
                                                      "--out or --overwrite to replace them")
    if out.exists() and owner is None and any(out.iterdir()):
        return None, summary_row(photo, plan, "error", error=f"out: {out} exists and holds files that "
                                                      "are not uw3p results")
    job = {"image": str(photo), "out": str(out), "inputs": inputs, "options": options,
           "tiff": tiff, "report": report, "key": key, "version": version, "command": ""}
    return (job, plan), None
