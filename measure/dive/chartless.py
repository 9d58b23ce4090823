"""The dive's frames without a chart, corrected with the dive's joint water
(:func:`correct_frames`).

After the joint fit (joint.json), every frame in which no chart was found is corrected pixel by
pixel (:func:`measure.correct_image`) with the joint water at its own depth (its metadata row,
EXIF or the default), along its range (its ``range_map``, else ``range_m``, else
``distance_m``), with the veiling light and gain of the dive photo nearest in depth, scaled by
the two photos' EXIF exposure ratio where both are known. Its folder (the run's sRGB image,
corrected.jpg or corrected_srgb.tif, corrected.tiff with ``linear``, correction.json,
complete.json: the run's images and method) is written whole or not at all,
its row's status becomes "corrected with the dive's water", its ``reliable`` and ``flags`` those
of the joint water (``extrapolated`` added when the frame's depth lies outside the dive's
photos' depths, by at most :data:`measure.correctwater.DEPTH_EXTRAPOLATION_MAX_M`; a frame
farther is not corrected and its row says why). complete.json records the frame's
key and the joint water's digest: a rerun with the same inputs and the same joint water leaves
it as it is; a changed joint water corrects it again.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

from ..output import image_options, read_marker, strict_json
from .plan import correction_range
from .summary import CORRECTED

__all__ = ["correct_frames", "water_digest"]


def water_digest(joint_data: dict) -> str:
    """The SHA-256 of joint.json's content (the water the frames were corrected with)."""
    return hashlib.sha256(json.dumps(strict_json(joint_data), sort_keys=True).encode()).hexdigest()


def _reference(joint_data, records, depth):
    """(name, record) of the joint fit's photo nearest in depth (its record, if measured)."""
    photos = joint_data.get("photos") or {}
    name = min(photos, key=lambda k: abs(float(photos[k]["depth"]) - float(depth)))
    rec = next((r for r in records.values()
                if Path((r.get("image") or {}).get("path", "")).name == name), None)
    return name, rec


def _water_verdict(joint_data: dict, extrapolated) -> dict:
    """A corrected frame's ``reliable`` and ``flags``: the joint water's, and ``extrapolated``
    when the frame's depth lies outside the dive's measured depths."""
    flags = list(joint_data.get("flags") or []) + (["extrapolated"] if extrapolated else [])
    return {"reliable": bool(joint_data.get("reliable", False)), "flags": " ".join(flags)}


def correct_frames(rows, records, jobs, joint_data, setup, *, water=None, version="",
                   command="", images=None) -> int:
    """Correct the chartless frames of a dive with its joint water (rows updated in place).

    Parameters
    ----------
    rows : list of dict
        The summary rows; those of status ``no chart`` (and ``corrected with the dive's
        water`` from an earlier run) are corrected.
    records : dict
        image -> measurement.json content of the photos measured.
    jobs : dict
        image -> this run's job of the photo (its key, inputs and folder).
    joint_data : dict or None
        joint.json's content; None: nothing is corrected (the rows say why).
    setup : forward.ChartSetup
        The run's camera.
    water : forward.Water, optional
        The run's water model.
    version, command : str
        Recorded in correction.json and complete.json.
    images : dict, optional
        The run's images (:func:`measure.output.image_options`; default its defaults): the
        frames get the same format, linear TIFF and method as the measured photos.

    Returns
    -------
    int
        The number of frames corrected now.
    """
    from ..correct import applied, correct_image, seathru_coefficients
    from ..correct_output import NOT_MODELLED, write_corrected
    from ..correctwater import exposure_ratio
    from ..image import read_image
    from ..imagefiles import SRGB_BITS

    images = image_options() if images is None else images
    digest = water_digest(joint_data) if joint_data else None
    done = 0
    for row in rows:
        if row["status"] not in ("no chart", CORRECTED):
            continue
        if joint_data is None or not (joint_data.get("photos")):
            if row["status"] == "no chart":
                row["error"] = (f"{row.get('error', '')}; not corrected: no joint water (give "
                                "--joint, with at least one photo measured)").lstrip("; ")
            continue
        job = jobs.get(row["image"])
        marker = read_marker(row["out"]) if row.get("out") else None
        if row["status"] == CORRECTED and marker is not None and marker.get("water") == digest:
            row.update(_water_verdict(joint_data, marker.get("extrapolated")))
            continue  # corrected earlier with this very water
        inputs = job["inputs"] if job else {k: row.get(k) for k in
                                            ("depth_m", "distance_m", "range_m", "range_map")}
        key = job["key"] if job else (marker or {}).get("key")
        try:
            photo = read_image(row["image"])
            name, ref = _reference(joint_data, records, inputs["depth_m"])
            ratio = exposure_ratio(photo.exposure, (ref or {}).get("image", {}).get("exposure"))
            corr = correct_image(photo, joint_data, correction_range(inputs), setup=setup,
                                 depth=float(inputs["depth_m"]), photo=name,
                                 exposure_ratio=ratio, model=water, linear=images["linear"],
                                 method=images["method"],
                                 srgb_bits=SRGB_BITS[images["output_format"]])
            if ratio is None:
                corr.notes.append(f"exposure ratio to {name} unknown (EXIF): taken as 1")
            record = {"image": row["image"], "range": {"given": str(correction_range(inputs))}
                      | corr.ranges, "seathru": seathru_coefficients(corr.table),
                      "notes": corr.notes, "not_modelled": list(NOT_MODELLED),
                      "water_digest": digest, "command": command, "version": version
                      } | applied(corr.table)
            write_corrected(corr, row["out"], record=record, version=version,
                            tiff=images["tiff"], output_format=images["output_format"],
                            overwrite=True, marker={
                                "key": key, "water": digest, "corrected": True,
                                "extrapolated": corr.table.water.extrapolated is not None})
        except ValueError as exc:
            row["status"], row["error"] = "no chart", f"no chart; not corrected: {exc}"
            continue
        row["status"], row["error"] = CORRECTED, "; ".join(corr.notes)
        row.update(_water_verdict(joint_data, corr.table.water.extrapolated))
        done += 1
    return done
