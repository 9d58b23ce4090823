"""summary.csv: one row per file of the dive (:data:`SUMMARY_COLUMNS`), its status
(:data:`STATUSES`) and the exit status it gives (:func:`exit_code`)."""

from __future__ import annotations

import csv
import json
import math
import os
from pathlib import Path

from .files import atomic

__all__ = ["STATUSES", "SUMMARY_COLUMNS", "exit_code", "summary_row", "to_float",
           "write_summary"]

#: A row's status: measured now; complete results of the same inputs found (not redone);
#: not measurable (``error`` says why); not measured because the run was interrupted; a file
#: that is not a photo; a photo in which no chart was found (its inputs kept; ``error`` says
#: why). Only ``error`` makes the exit status 2 (bad input)
STATUSES = ("measured", "done earlier", "error", "interrupted", "not an image", "no chart")
#: Columns of summary.csv, one row per file (the first 20 as in earlier versions)
SUMMARY_COLUMNS = ("image", "chl", "chl_lo", "chl_hi", "cdom", "cdom_lo", "cdom_hi", "gain",
                   "fit_rms", "chi2_dof", "orientation", "reliable", "flags", "depth_m",
                   "depth_sd", "distance_m", "distance_sd", "chl_budget", "out", "error",
                   "status", "depth_source", "distance_source", "corners", "corners_source",
                   "time", "camera", "profile", "illuminant", "layout", "path_model",
                   "uncertain", "tiff")


def to_float(v):
    if v is None or v == "":
        return math.nan
    return float(v)


def _budget_text(budget) -> str:
    shares = (budget or {}).get("chl", {}).get("shares", {})
    parts = sorted(shares.items(), key=lambda kv: -to_float(kv[1]))
    return ", ".join(f"{k} {100 * to_float(v):.0f} %" for k, v in parts if to_float(v) >= 0.005)


def summary_row(photo, plan, status, record=None, error="") -> dict:
    """A summary row: the inputs planned and, from measurement.json's content, the results."""
    inputs, options = plan.get("inputs") or {}, plan.get("options") or {}
    corners = inputs.get("corners")
    row = {"image": str(photo), "status": status, "error": error, "out": plan.get("out", ""),
           "tiff": plan.get("tiff", "")}
    for k in ("depth_m", "distance_m", "depth_source", "distance_source", "corners_source",
              "time"):
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
               uncertain=json.dumps(inp.get("uncertain", {}), sort_keys=True))
    if row["corners_source"] == "detected":
        row["corners"] = " ".join(f"{x:.1f},{y:.1f}" for x, y in record["corners"])
    return row


def exit_code(row) -> int | None:
    """The row's exit status: 0 reliable, 1 not reliable, 2 not measurable; None for rows that
    are not photos or were interrupted."""
    if row["status"] in ("measured", "done earlier"):
        return 0 if row.get("reliable") in (True, "True") else 1
    return 2 if row["status"] == "error" else None



def write_summary(rows, path: Path) -> Path:
    with atomic(path) as tmp, open(tmp, "w", encoding="utf-8", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=SUMMARY_COLUMNS)
        w.writeheader()
        for row in rows:
            w.writerow({k: ("" if row.get(k) is None else row.get(k, ""))
                        for k in SUMMARY_COLUMNS})
    return path
