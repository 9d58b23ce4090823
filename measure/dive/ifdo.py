"""ifdo.json: the dive's photometric fields in the iFDO marine imaging metadata standard.

iFDO (image FAIR Digital Object, v2.0.0) describes an image set with an ``image-set-header``
(what holds for every image) and ``image-set-items`` (per image, keyed by file name). This
file holds only the capture section's ``image-photometric-calibration`` -- the one set of
fields uw3p knows -- to be merged into the dive's iFDO, whose core fields (UUIDs, handles,
positions, licence) are the user's:

- ``photometric-sequence-white-balancing``: how the images were white-balanced;
- ``photometric-exposure-factor-RGB``: per image, the RGB factors applied to it (iFDO: the
  factors that turn the recorded pixel values into the corrected ones), one quantity for every
  image: the factor per channel from a raw value (above black and the veiling light) to the
  image's corrected.tiff (16-bit linear camera RGB in air, written with ``linear``) at the
  chart's distance. For a measured photo it is its von Kries gains (measurement.json
  ``correction.gains``), for a chartless frame :func:`measure.correct.linear_factor` (correction.json
  ``seathru.exposure_factor``); the two differ by the white they put at 80 % of full scale (the
  white patch, a perfect white). A correction.json without it (older) gives no field;
- ``photometric-sequence-illumination-type`` and ``-description``: sunlight;
- ``photometric-water-properties-description``: the water measured (C, a_CDOM(440), their
  95 % intervals, the attenuation model).

References
----------
T. Schoening et al., "Making marine image data FAIR", Scientific Data 9, 414 (2022); the iFDO
schema v2.0.0, field ``image-photometric-calibration`` (marine-imaging.com/fair).
"""

from __future__ import annotations

import json
from pathlib import Path

from ..output import strict_json
from .files import atomic
from .summary import CORRECTED, MEASURED

__all__ = ["IFDO_VERSION", "ifdo_fields", "write_ifdo"]

#: The iFDO schema version whose field names are written
IFDO_VERSION = "v2.0.0"
#: How uw3p white-balances (photometric-sequence-white-balancing)
WHITE_BALANCING = (
    "uw3p (Blasinski & Farrell three-parameter water model): each pixel's veiling light "
    "removed and its direct signal divided by the water's transmission along the pixel's "
    "range, per camera channel, from the attenuation spectrum measured on a ColorChecker "
    "underwater, then mapped to the white of air (von Kries); per-image factors at the "
    "image's reference range, per-range coefficients in each image's correction.json / "
    "measurement.json")


def _water_text(chl, cdom, chl_ci, cdom_ci, path_model, source) -> str:
    def end(v):
        return "open" if v in (None, "inf") or float(v) == float("inf") else f"{float(v):.3g}"
    return (f"{source}: chlorophyll-a C = {chl:.3g} mg m-3 (95 % interval {end(chl_ci[0])}-"
            f"{end(chl_ci[1])}), CDOM absorption a_CDOM(440 nm) = {cdom:.3g} m-1 ("
            f"{end(cdom_ci[0])}-{end(cdom_ci[1])}); attenuation from Blasinski & Farrell's "
            f"model, path model '{path_model}'")


def ifdo_fields(rows, records, joint_data=None) -> dict:
    """The iFDO photometric fields of a dive.

    Parameters
    ----------
    rows : list of dict
        The summary rows.
    records : dict
        image -> measurement.json content.
    joint_data : dict, optional
        joint.json's content.

    Returns
    -------
    dict
        {'image-set-header': {...}, 'image-set-items': {file name: {...}}}.
    """
    if joint_data:
        water = _water_text(joint_data["chl"], joint_data["cdom"], joint_data["chl_ci"],
                            joint_data["cdom_ci"], joint_data.get("path_model", ""),
                            "the dive's joint estimate")
    else:
        water = "each image's own estimate (image-set-items)"
    header = {"image-set-ifdo-version": IFDO_VERSION, "image-photometric-calibration": {
        "photometric-sequence-white-balancing": WHITE_BALANCING,
        "photometric-sequence-illumination-type": "sunlight",
        "photometric-sequence-illumination-description":
            "daylight from the surface through the water column (no artificial light modelled)",
        "photometric-water-properties-description": water}}
    items = {}
    for row in rows:
        name = Path(row["image"]).name
        rec = records.get(row["image"])
        if row["status"] in MEASURED and rec is not None:
            e = rec["estimate"]
            gains = (rec.get("correction") or {}).get("gains")
            items[name] = {"image-photometric-calibration": {
                "photometric-exposure-factor-RGB": gains,
                "photometric-water-properties-description": _water_text(
                    e["chl"], e["cdom"], e["chl_ci"], e["cdom_ci"], e.get("path_model", ""),
                    "this image's chart")}}
        elif row["status"] == CORRECTED and row.get("out"):
            try:
                corr = json.loads((Path(row["out"]) / "correction.json").read_text("utf-8"))
            except (OSError, ValueError):
                continue
            factor = corr["seathru"].get("exposure_factor")
            items[name] = {"image-photometric-calibration": {} if factor is None else {
                "photometric-exposure-factor-RGB": factor}}
    return {"image-set-header": header, "image-set-items": items}


def write_ifdo(rows, records, joint_data, path: Path, version: str = "") -> Path:
    """Write ifdo.json (whole or not at all).

    Parameters
    ----------
    rows, records, joint_data :
        As :func:`ifdo_fields`.
    path : pathlib.Path
    version : str
        uw3p's version (recorded as ``uw3p-version``).

    Returns
    -------
    pathlib.Path
    """
    data = ifdo_fields(rows, records, joint_data) | {"uw3p-version": version}
    with atomic(path) as tmp:
        tmp.write_text(json.dumps(strict_json(data), indent=1, allow_nan=False) + "\n",
                       encoding="utf-8")
    return path
