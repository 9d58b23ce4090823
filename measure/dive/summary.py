"""summary.csv: one row per file of the dive and per metadata row (:data:`SUMMARY_COLUMNS`),
its status (:data:`STATUSES`) and the exit status the rows give (:func:`exit_code`,
:func:`dive_code`).

Exit status: 0 when every photo measured is reliable, 1 when one is not, 2 when a photo could
not be measured (status ``error``: bad input or a failure) or when no photo at all was
measured, 130 when the run was interrupted. A frame without a chart, a metadata row naming no
photo, a photo without a metadata row and a file that is not a photo are rows with their reason
(and, for the last three but one, a warning) that do not raise the exit status.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

from sca.derived import QUANTITIES

from ..csvsafe import safe_writer
from .files import atomic

__all__ = ["CORRECTED", "MEASURED", "QUANTITY_COLUMNS", "STATUSES", "SUMMARY_COLUMNS",
           "dive_code", "exit_code", "summary_row", "to_float", "write_summary"]

#: A frame without a chart corrected with the dive's joint water (measure.dive.chartless)
CORRECTED = "corrected with the dive's water"
#: A row's status: measured now; complete results of the same inputs found (not redone);
#: not measurable (``error`` says why); not measured because the run was interrupted; a file
#: that is not a photo; a photo in which no chart was found (its inputs kept; not corrected:
#: ``error`` says why); a metadata row that names no photo of the folder; a photo that has no
#: metadata row (``error`` says why); a photo without a chart corrected with the dive's water
STATUSES = ("measured", "done earlier", "error", "interrupted", "not an image", "no chart",
            "no such photo", "not in metadata", CORRECTED)
#: The statuses of a photo with results
MEASURED = ("measured", "done earlier")
#: Columns of what the photo measures (:mod:`sca.derived`, m^-1): each quantity, its 95 %
#: interval and its verdict (:func:`sca.derived.verdict`)
QUANTITY_COLUMNS = tuple(f"{q}{end}" for q in QUANTITIES for end in ("", "_lo", "_hi",
                                                                      "_verdict"))
#: Columns of summary.csv, one row per file (the first 33 as in earlier versions): then the
#: verdicts of C and a_CDOM, what the photo measures (:data:`QUANTITY_COLUMNS`), the path models
#: the fit found (best, and every one the data support), the measurements of the water fused in
#: the fit (JSON) and the measured chart's file
SUMMARY_COLUMNS = ("image", "chl", "chl_lo", "chl_hi", "cdom", "cdom_lo", "cdom_hi", "gain",
                   "fit_rms", "chi2_dof", "orientation", "reliable", "flags", "depth_m",
                   "depth_sd", "distance_m", "distance_sd", "chl_budget", "out", "error",
                   "status", "depth_source", "distance_source", "corners", "corners_source",
                   "time", "camera", "profile", "illuminant", "layout", "path_model",
                   "uncertain", "tiff", "range_m", "range_map", "chl_verdict",
                   "cdom_verdict") + QUANTITY_COLUMNS + (
                   "path_model_fitted", "path_models_supported", "auxiliary",
                   "chart_reflectance")


def to_float(v) -> float:
    """A summary cell as a float (NaN where empty).

    Parameters
    ----------
    v : number, str or None

    Returns
    -------
    float
    """
    if v is None or v == "":
        return math.nan
    return float(v)


def _budget_text(budget) -> str:
    shares = (budget or {}).get("chl", {}).get("shares", {})
    parts = sorted(shares.items(), key=lambda kv: -to_float(kv[1]))
    return ", ".join(f"{k} {100 * to_float(v):.0f} %" for k, v in parts if to_float(v) >= 0.005)


def summary_row(photo, plan, status, record=None, error="") -> dict:
    """A summary row: the inputs planned and, from measurement.json's content, the results.

    Parameters
    ----------
    photo : path
        The file (its path is the row's ``image``).
    plan : dict
        ``out``, ``options``, ``tiff`` and ``inputs`` (resolved) where known.
    status : str
        One of :data:`STATUSES`.
    record : dict, optional
        measurement.json's content.
    error : str, optional
        Why the photo was not measured.

    Returns
    -------
    dict
        Of :data:`SUMMARY_COLUMNS`.
    """
    inputs, options = plan.get("inputs") or {}, plan.get("options") or {}
    corners = inputs.get("corners")
    row = {"image": str(photo), "status": status, "error": error, "out": plan.get("out", ""),
           "tiff": plan.get("tiff", "")}
    for k in ("depth_m", "distance_m", "depth_source", "distance_source", "corners_source",
              "time", "range_m", "range_map"):
        row[k] = inputs.get(k, "")
    row["corners"] = corners if corners is None or isinstance(corners, str) else " ".join(
        f"{x:g},{y:g}" for x, y in corners)
    prof = options.get("profile")
    row.update(camera=options.get("camera", ""), profile=prof if isinstance(
        prof, (str, os.PathLike)) or prof is None else "given", illuminant=options.get(
        "illuminant") or "", layout=options.get("layout", ""))
    if record is None:
        return row
    e, inp = record["estimate"], record.get("inputs", {})
    row.update(chl=e["chl"], chl_lo=e["chl_ci"][0], chl_hi=e["chl_ci"][1], cdom=e["cdom"],
               cdom_lo=e["cdom_ci"][0], cdom_hi=e["cdom_ci"][1], gain=e["gain"],
               fit_rms=e["fit_rms"], chi2_dof=e["chi2_dof"], orientation=record["orientation"],
               reliable=e["reliable"], flags=" ".join(e["flags"]),
               depth_m=inp.get("depth_m"), distance_m=inp.get("distance_m"),
               depth_sd=inp.get("depth_sd"), distance_sd=inp.get("distance_sd"),
               chl_budget=_budget_text(e.get("budget")), path_model=inp.get("path_model", ""),
               uncertain=json.dumps(inp.get("uncertain", {}), sort_keys=True),
               chl_verdict=(e.get("verdicts") or {}).get("chl", ""),
               cdom_verdict=(e.get("verdicts") or {}).get("cdom", ""),
               path_model_fitted=e.get("path_model", ""),
               path_models_supported=" ".join(e.get("path_models") or []),
               auxiliary=json.dumps(inp.get("auxiliary") or [], sort_keys=True),
               chart_reflectance=(inp.get("chart_reflectance") or {}).get("path", ""))
    quantities, intervals = e.get("quantities") or {}, e.get("quantity_intervals") or {}
    for q in QUANTITIES:
        if q in quantities:
            row.update({q: quantities[q], f"{q}_lo": intervals[q][0],
                        f"{q}_hi": intervals[q][1],
                        f"{q}_verdict": (e.get("verdicts") or {}).get(q, "")})
    if row["corners_source"] == "detected":
        row["corners"] = " ".join(f"{x:.1f},{y:.1f}" for x, y in record["corners"])
    return row


def exit_code(row) -> int | None:
    """The row's exit status.

    Parameters
    ----------
    row : dict
        A summary row.

    Returns
    -------
    int or None
        0 reliable, 1 not reliable, 2 not measurable (``error``); None for the other statuses
        (they do not change the exit status).
    """
    if row["status"] in MEASURED:
        return 0 if row.get("reliable") in (True, "True") else 1
    return 2 if row["status"] == "error" else None


def dive_code(rows, interrupted: bool) -> int:
    """The dive's exit status (the module's rule).

    Parameters
    ----------
    rows : list of dict
        Every summary row.
    interrupted : bool
        The run was interrupted.

    Returns
    -------
    int
        130 interrupted; else the worst row's :func:`exit_code`, and 2 when no photo was
        measured at all.
    """
    if interrupted:
        return 130
    if not any(r["status"] in MEASURED for r in rows):
        return 2
    return max((c for c in map(exit_code, rows) if c is not None), default=0)



def write_summary(rows, path: Path) -> Path:
    """Write summary.csv (whole or not at all; text cells neutralised,
    :func:`measure.csvsafe.neutralise`).

    Parameters
    ----------
    rows : list of dict
        Summary rows.
    path : pathlib.Path

    Returns
    -------
    pathlib.Path
    """
    with atomic(path) as tmp, open(tmp, "w", encoding="utf-8", newline="") as fh:
        w = safe_writer(fh, fieldnames=SUMMARY_COLUMNS)
        w.writeheader()
        for row in rows:
            w.writerow({k: ("" if row.get(k) is None else row.get(k, ""))
                        for k in SUMMARY_COLUMNS})
    return path
