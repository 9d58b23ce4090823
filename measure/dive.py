"""A dive: every photo of a folder measured with its own inputs, on Dask, resumable, with
survey outputs.

:func:`measure_dive` lists the folder (every file is accounted for: measured, or the reason
why not), resolves each photo's inputs (a row of the metadata CSV, :func:`read_metadata`; the
camera's EXIF depth, :func:`exif_info`; the defaults given), measures the photos on a Dask
cluster (a ``distributed.LocalCluster`` by default, or an existing scheduler), writes each
photo's folder whole or not at all (:func:`measure.write_outputs`), skips the photos whose
complete results match the same inputs and options, and writes ``summary.csv``, ``survey.nc``
(CF-1.8) and ``survey.png`` -- also when interrupted, for what is done.

Output folders: a photo's folder is named after its file's stem (``IMG_1.dng`` ->
``IMG_1/``); when several files of the folder share a stem (``IMG_1.dng``, ``IMG_1.tif``),
each of them gets its stem and extension (``IMG_1_dng/``, ``IMG_1_tif/``).
"""

from __future__ import annotations

import contextlib
import csv
import dataclasses
import datetime
import hashlib
import json
import logging
import math
import os
import shutil
import signal
import tempfile
import threading
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import forward

from .image import RAW_EXTENSIONS, TIFF_EXTENSIONS
from .output import TEMP_PREFIX, TIFF_MODES, read_marker, result_owner, strict_json

__all__ = ["CF_CDOM", "CF_CHL", "EXIF_DEPTH_TAGS", "METADATA_COLUMNS", "METADATA_OPTIONAL",
           "STATUSES", "SUMMARY_COLUMNS", "DiveResult", "dive_files", "exif_info",
           "measure_dive", "netcdf_engine", "output_names", "plot_survey", "read_metadata",
           "survey_dataset"]

#: Required columns of the metadata CSV (``--metadata``): the image's file name relative to the
#: folder, the chart's depth (m) and the camera-to-chart distance (m)
METADATA_COLUMNS = ("image", "depth_m", "distance_m")
#: Optional columns: the standard deviations (m) of depth and distance, the chart's corners
#: ("x1,y1 x2,y2 x3,y3 x4,y4", pixels; empty: detected)
METADATA_OPTIONAL = ("depth_sd_m", "distance_sd_m", "corners")
#: EXIF tags that record the depth under water, in the order tried. EXIF 2.31 (CIPA DC-008-2016)
#: added ``WaterDepth`` (tag 0x9403 = 37891, signed rational, m) to the Exif IFD; tough
#: compacts (e.g. Olympus/OM System TG series) write it. Dive-log geotagging tools write the
#: depth as ``GPSAltitude`` with ``GPSAltitudeRef`` = 1 (below sea level).
EXIF_DEPTH_TAGS = ("WaterDepth", "GPSAltitude")
#: EXIF 2.31 WaterDepth (Exif IFD)
WATER_DEPTH_TAG = 37891
#: EXIF DateTimeOriginal (Exif IFD), "YYYY:MM:DD HH:MM:SS"
DATETIME_ORIGINAL_TAG = 36867
#: CF standard name and canonical units of C (Chl-a concentration; mg m-3 = 1e-6 kg m-3)
CF_CHL = ("mass_concentration_of_chlorophyll_a_in_sea_water", "mg m-3")
#: CF standard name and units of a_CDOM(440)
CF_CDOM = (("volume_absorption_coefficient_of_radiative_flux_in_sea_water_due_to_"
            "dissolved_organic_matter"), "m-1")
#: The wavelength a_CDOM refers to, nm (Blasinski & Farrell eq 6)
CDOM_WAVELENGTH_NM = 440.0
#: A row's status: measured now; complete results of the same inputs found (not redone);
#: not measurable (``error`` says why); not measured because the run was interrupted; a file
#: that is not a photo (``error`` says why)
STATUSES = ("measured", "done earlier", "error", "interrupted", "not an image")
#: Columns of summary.csv, one row per file (the first 20 as in earlier versions)
SUMMARY_COLUMNS = ("image", "chl", "chl_lo", "chl_hi", "cdom", "cdom_lo", "cdom_hi", "gain",
                   "fit_rms", "chi2_dof", "orientation", "reliable", "flags", "depth_m",
                   "depth_sd", "distance_m", "distance_sd", "chl_budget", "out", "error",
                   "status", "depth_source", "distance_source", "corners", "corners_source",
                   "time", "camera", "profile", "illuminant", "layout", "path_model",
                   "uncertain", "tiff")
#: Seconds given to the Dask cluster to shut down
CLOSE_TIMEOUT_S = 20


# --------------------------------------------------------------------------- inputs
def _number(value, name, where, *, positive=True):
    value = value.strip()
    if not value:
        return None
    try:
        x = float(value)
    except ValueError:
        raise ValueError(f"{where}: {name} is not a number: {value!r}") from None
    if not math.isfinite(x) or x < 0 or (positive and x == 0):
        raise ValueError(f"{where}: {name} must be finite and {'> 0' if positive else '>= 0'}, "
                         f"got {value!r}")
    return x


def read_metadata(path) -> dict:
    """Read a dive's metadata CSV: one row per photo.

    Columns (by name, any order; UTF-8 with or without a byte-order mark): ``image`` (file name
    relative to the folder), ``depth_m``, ``distance_m`` (m) and optionally ``depth_sd_m``,
    ``distance_sd_m`` (m) and ``corners`` ("x1,y1 x2,y2 x3,y3 x4,y4", pixels). An empty cell
    means "not given here": the EXIF depth or the default applies (corners: detected).

    Parameters
    ----------
    path : str or os.PathLike
        The CSV file.

    Returns
    -------
    dict
        image name -> {'depth_m', 'distance_m', 'depth_sd_m', 'distance_sd_m' (floats or None),
        'corners' (str or None), 'line' (int)}.

    Raises
    ------
    ValueError
        Naming ``metadata`` and the line: a missing file or column, an unknown column, a value
        that is not a positive number, an empty or repeated image name.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"metadata: cannot read {p}: {getattr(exc, 'strerror', None) or exc}") \
            from None
    reader = csv.DictReader(text.splitlines())
    header = [h.strip() for h in (reader.fieldnames or [])]
    missing = [c for c in METADATA_COLUMNS if c not in header]
    if missing:
        raise ValueError(f"metadata: {p} line 1: missing column(s) {', '.join(missing)} (needs "
                         f"{', '.join(METADATA_COLUMNS)}; optional {', '.join(METADATA_OPTIONAL)})")
    unknown = [c for c in header if c not in METADATA_COLUMNS + METADATA_OPTIONAL]
    if unknown:
        raise ValueError(f"metadata: {p} line 1: unknown column(s) {', '.join(unknown)}")
    rows = {}
    for n, raw in enumerate(reader, start=2):
        if None in raw:
            raise ValueError(f"metadata: {p} line {n}: more cells than columns")
        cell = {k.strip(): (v or "") for k, v in raw.items()}
        if not any(v.strip() for v in cell.values()):
            continue
        where = f"metadata: {p} line {n}"
        name = cell["image"].strip()
        if not name:
            raise ValueError(f"{where}: image is empty")
        if name in rows:
            raise ValueError(f"{where}: image {name!r} repeats line {rows[name]['line']}")
        corners = cell.get("corners", "").strip() or None
        rows[name] = {"depth_m": _number(cell["depth_m"], "depth_m", where, positive=False),
                      "distance_m": _number(cell["distance_m"], "distance_m", where),
                      "depth_sd_m": _number(cell.get("depth_sd_m", ""), "depth_sd_m", where,
                                            positive=False),
                      "distance_sd_m": _number(cell.get("distance_sd_m", ""), "distance_sd_m",
                                               where, positive=False),
                      "corners": corners, "line": n}
    return rows


def _rational(value):
    if isinstance(value, tuple) and len(value) == 2:
        return value[0] / value[1] if value[1] else None
    if isinstance(value, tuple) and value:
        return _rational(value[0])
    try:
        return float(value)
    except (TypeError, ValueError):
        return None


def exif_info(path) -> dict:
    """The depth and the time a photo's EXIF records, where it does.

    Read with tifffile from TIFF containers (TIFF, DNG, NEF, ARW, CR2, PEF, ...); formats
    that are not TIFF containers give nothing. The depth: EXIF 2.31 ``WaterDepth`` (tag
    0x9403, in the Exif IFD or IFD0; a negative value -- above the surface -- is not used), else
    ``GPSAltitude`` when ``GPSAltitudeRef`` is 1 (below sea level). The time:
    ``DateTimeOriginal`` (tag 0x9003), the camera's local time.

    Parameters
    ----------
    path : str or os.PathLike
        The photo.

    Returns
    -------
    dict
        ``depth_m`` (m) and ``depth_tag`` (the tag's name) where a depth is recorded, ``time``
        (ISO 8601 text, no time zone) where a time is.

    References
    ----------
    CIPA DC-008-2016, Exchangeable image file format for digital still cameras: Exif Version
    2.31, tags WaterDepth (0x9403) and DateTimeOriginal (0x9003); GPS tags GPSAltitudeRef,
    GPSAltitude.
    """
    import tifffile

    out = {}
    try:
        with tifffile.TiffFile(path) as tf:
            page = tf.pages[0]
            pool = {}
            for tag in page.tags.values():
                pool[tag.code] = tag.value
                pool[tag.name] = tag.value
            for sub in ("ExifTag", "GPSTag"):
                if isinstance(pool.get(sub), dict):
                    pool.update(pool[sub])
    except Exception:  # noqa: BLE001 - not a TIFF container (tifffile raises many kinds): no EXIF, allowed
        return out
    depth = _rational(pool.get("WaterDepth", pool.get(WATER_DEPTH_TAG)))
    if depth is not None and depth >= 0:
        out.update(depth_m=float(depth), depth_tag="WaterDepth")
    elif _rational(pool.get("GPSAltitudeRef")) == 1:
        alt = _rational(pool.get("GPSAltitude"))
        if alt is not None and alt >= 0:
            out.update(depth_m=float(alt), depth_tag="GPSAltitude")
    stamp = pool.get("DateTimeOriginal", pool.get(DATETIME_ORIGINAL_TAG))
    if isinstance(stamp, bytes):
        stamp = stamp.decode("ascii", "replace")
    if isinstance(stamp, str):
        try:
            t = datetime.datetime.strptime(stamp.strip("\x00 "), "%Y:%m:%d %H:%M:%S")
            out["time"] = t.isoformat()
        except ValueError:
            pass
    return out


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


# --------------------------------------------------------------------------- plan
def _resolve(photo: Path, row, exif, depth, distance, corners):
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


def _key(photo: Path, inputs, options, outputs, version) -> str:
    """The hash that says "same inputs": the image (name, size, modification time), its
    resolved inputs, the options (a profile by content), the outputs asked for (TIFF mode,
    report) and uw3p's version."""
    st = photo.stat()
    data = {"image": photo.name, "size": st.st_size, "mtime_ns": st.st_mtime_ns,
            "inputs": {k: v for k, v in inputs.items() if not k.endswith("_source")},
            "options": _options_text(options), "outputs": outputs, "version": version}
    text = json.dumps(data, sort_keys=True, default=_key_default)
    return hashlib.sha256(text.encode()).hexdigest()


# --------------------------------------------------------------------------- worker
def _budget(options, inputs) -> dict | None:
    """``uncertain=`` for one photo: the options' budget with the row's sds over it."""
    sds = {k: inputs[f"{k}_sd_m"] for k in ("depth", "distance")
           if inputs.get(f"{k}_sd_m") is not None}
    if not sds:
        return options.get("uncertain")
    from .camera import load_profile
    from .measurement import budget_for

    prof = options.get("profile")
    prof = load_profile(prof) if isinstance(prof, (str, os.PathLike)) else prof
    return budget_for(options.get("uncertain"), prof) | sds


def _run_job(job: dict) -> dict:
    """One photo, in a worker: measure, write its folder; returns (status, record or error)."""
    from .measurement import measure
    from .output import write_outputs

    inputs, options = job["inputs"], job["options"]
    try:
        meas = measure(job["image"], corners=inputs["corners"], depth=inputs["depth_m"],
                       distance=inputs["distance_m"], uncertain=_budget(options, inputs),
                       **{k: v for k, v in options.items() if k != "uncertain"})
        meas.inputs.update({k: inputs[k] for k in ("depth_source", "distance_source",
                                                   "corners_source", "time")})
        meas.inputs["command"] = job["command"]
        write_outputs(meas, job["out"], version=job["version"], report=job["report"],
                      tiff=job["tiff"],
                      overwrite=True, marker={"key": job["key"]})
        record = strict_json(meas.to_dict(job["version"]))
        return {"status": "measured", "record": record}
    except ValueError as exc:
        return {"status": "error", "error": str(exc)}
    except Exception as exc:  # noqa: BLE001 - a failure is reported in the row, never hidden
        return {"status": "error", "error": f"failed: {type(exc).__name__}: {exc}"}


# --------------------------------------------------------------------------- rows
def _num(v):
    if v is None or v == "":
        return math.nan
    return float(v)


def _budget_text(budget) -> str:
    shares = (budget or {}).get("chl", {}).get("shares", {})
    parts = sorted(shares.items(), key=lambda kv: -_num(kv[1]))
    return ", ".join(f"{k} {100 * _num(v):.0f} %" for k, v in parts if _num(v) >= 0.005)


def _row(photo, plan, status, record=None, error="") -> dict:
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


def _code(row) -> int | None:
    """The row's exit status: 0 reliable, 1 not reliable, 2 not measurable; None for rows that
    are not photos or were interrupted."""
    if row["status"] in ("measured", "done earlier"):
        return 0 if row.get("reliable") in (True, "True") else 1
    return 2 if row["status"] == "error" else None


# --------------------------------------------------------------------------- survey outputs
@contextlib.contextmanager
def _atomic(path: Path):
    """A temporary path beside ``path`` that replaces it when the block ends without error."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    os.close(fd)
    try:
        yield Path(tmp)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def _write_summary(rows, path: Path) -> Path:
    with _atomic(path) as tmp, open(tmp, "w", encoding="utf-8", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=SUMMARY_COLUMNS)
        w.writeheader()
        for row in rows:
            w.writerow({k: ("" if row.get(k) is None else row.get(k, ""))
                        for k in SUMMARY_COLUMNS})
    return path


def survey_dataset(rows, records, attrs=None):
    """The survey as an xarray Dataset (CF-1.8): one record per photo.

    Parameters
    ----------
    rows : list of dict
        The summary rows (:data:`SUMMARY_COLUMNS`), photos only.
    records : dict
        image -> measurement.json content, for the photos measured.
    attrs : dict, optional
        More global attributes (``history``, ``command``, ``uw3p_version``).

    Returns
    -------
    xarray.Dataset
        Dimension ``photo`` (coordinate ``image``), ``wavelength`` (nm) and ``nv`` (2, the
        interval ends): ``chl`` (mg m-3) and ``cdom`` (m-1 at 440 nm) with CF standard names
        and ``chl_bounds``/``cdom_bounds`` (95 % intervals), ``attenuation`` (photo,
        wavelength), ``depth``, ``distance`` and their sds (m), ``time`` (EXIF, NaT where
        absent), ``reliable``, ``flags``, ``status``, ``error`` and the input sources.
    """
    import xarray as xr

    from sca.budget import parse_sd

    n = len(rows)
    wl = next((np.asarray(r["estimate"]["wavelengths"], float) for r in records.values()),
              np.array([], float))
    k = np.full((n, wl.size), np.nan)
    for i, row in enumerate(rows):
        rec = records.get(row["image"])
        if rec is not None and np.array_equal(rec["estimate"]["wavelengths"], wl):
            k[i] = np.asarray(rec["estimate"]["attenuation"], float)

    def col(name):
        return np.array([_num(r.get(name)) for r in rows], float)

    def sd(name):  # m; a percentage ("5%") of the length it refers to
        return np.array([math.nan if r.get(f"{name}_sd") in (None, "") else float(
            parse_sd(name, r[f"{name}_sd"], _num(r.get(f"{name}_m")))) for r in rows], float)

    def text(name):
        return np.array([str(r.get(name) or "") for r in rows], dtype=object)

    times = np.array([np.datetime64(r["time"]) if r.get("time") else np.datetime64("NaT")
                      for r in rows], dtype="datetime64[ns]")
    photo = ("photo",)
    ds = xr.Dataset(
        {"chl": (photo, col("chl"), {"standard_name": CF_CHL[0], "units": CF_CHL[1],
                                     "long_name": "chlorophyll concentration C",
                                     "bounds": "chl_bounds"}),
         "chl_bounds": (("photo", "nv"), np.column_stack([col("chl_lo"), col("chl_hi")]),
                        {"long_name": "95 % interval of chl", "units": CF_CHL[1]}),
         "cdom": (photo, col("cdom"), {"standard_name": CF_CDOM[0], "units": CF_CDOM[1],
                                       "long_name": "CDOM absorption a_CDOM at 440 nm",
                                       "bounds": "cdom_bounds",
                                       "coordinates": "cdom_wavelength"}),
         "cdom_bounds": (("photo", "nv"), np.column_stack([col("cdom_lo"), col("cdom_hi")]),
                         {"long_name": "95 % interval of cdom", "units": CF_CDOM[1]}),
         "attenuation": (("photo", "wavelength"), k,
                         {"long_name": "path attenuation k = exp(-(depth + distance) c)",
                          "units": "1"}),
         "depth": (photo, col("depth_m"), {"standard_name": "depth", "units": "m",
                                           "positive": "down", "long_name": "chart depth"}),
         "depth_sd": (photo, sd("depth"), {"long_name": "standard deviation of depth",
                                               "units": "m"}),
         "distance": (photo, col("distance_m"), {"long_name": "camera-to-chart distance",
                                                 "units": "m"}),
         "distance_sd": (photo, sd("distance"),
                         {"long_name": "standard deviation of distance", "units": "m"}),
         "time": (photo, times, {"standard_name": "time",
                                 "long_name": "EXIF DateTimeOriginal (camera local time)"}),
         "gain": (photo, col("gain"), {"long_name": "exposure gain",
                                       "units": "raw units per model unit"}),
         "chi2_dof": (photo, col("chi2_dof"), {"long_name": "chi-square per degree of freedom",
                                               "units": "1"}),
         "reliable": (photo, np.array([_code(r) == 0 for r in rows], np.int8),
                      {"long_name": "estimate reliable (no blocking flag)",
                       "flag_values": np.array([0, 1], np.int8),
                       "flag_meanings": "not_reliable reliable"}),
         **{name: (photo, text(name), {"long_name": name.replace("_", " ")})
            for name in ("flags", "status", "error", "depth_source", "distance_source",
                         "corners_source", "corners", "out")}},
        coords={"image": (photo, text("image"), {"long_name": "photo file"}),
                "wavelength": ("wavelength", wl, {"standard_name": "radiation_wavelength",
                                                  "units": "nm"}),
                "cdom_wavelength": ((), CDOM_WAVELENGTH_NM,
                                    {"standard_name": "radiation_wavelength", "units": "nm"})},
        attrs={"Conventions": "CF-1.8", "title": "uw3p dive survey: one record per photo",
               "source": "uw3p measure (Blasinski & Farrell three-parameter model)",
               "references": "H. Blasinski and J. Farrell, A Three Parameter Underwater Image "
                             "Formation Model, IS&T Electronic Imaging 2016"} | (attrs or {}))
    return ds


def netcdf_engine() -> str:
    """The xarray engine survey.nc is written with: 'h5netcdf' (netCDF-4) when its HDF5
    back end h5py is installed, else 'scipy' (netCDF-3 64-bit offset; the same variables,
    names and attributes, strings as character arrays).

    Returns
    -------
    str
    """
    try:
        import h5py  # noqa: F401
    except ImportError:
        return "scipy"
    return "h5netcdf"


def _write_survey(ds, path: Path) -> Path:
    with _atomic(path) as tmp:
        ds.to_netcdf(tmp, engine=netcdf_engine())
    return path


#: survey.png draws a quantity on a symmetric-log axis when its largest value (interval ends
#: included) exceeds its median by this factor.
SURVEY_LOG_SPAN = 30.0


def plot_survey(ds, path, joint=None):
    """survey.png: C and a_CDOM with their 95 % intervals against depth (and against time where
    the EXIF has it), reliable estimates filled; the joint estimate of the dive as a band.

    Parameters
    ----------
    ds : xarray.Dataset
        :func:`survey_dataset`'s.
    path : str or os.PathLike
        The PNG to write (whole or not at all).
    joint : dict, optional
        joint.json's content (``chl``, ``chl_ci``, ``cdom``, ``cdom_ci``).

    Returns
    -------
    pathlib.Path
        The file written.
    """
    # matplotlib's object interface: no pyplot (its global figures and backend)
    from matplotlib.figure import Figure

    has_time = bool(np.any(~np.isnat(ds["time"].values)))
    xs = [("depth", "depth (m)")] + ([("time", "time (EXIF)")] if has_time else [])
    fig = Figure(figsize=(5.5 * len(xs), 7), dpi=90)
    ax = fig.subplots(2, len(xs), squeeze=False)
    ok = ds["reliable"].values == 1
    for i, (name, label, unit) in enumerate((("chl", "C", "mg m⁻³"),
                                             ("cdom", "a_CDOM(440)", "m⁻¹"))):
        y = ds[name].values
        b = ds[f"{name}_bounds"].values
        hi = np.where(np.isfinite(b[:, 1]), b[:, 1], np.nan)
        err = np.vstack([y - b[:, 0], hi - y])
        for j, (xname, xlabel) in enumerate(xs):
            a = ax[i, j]
            x = ds[xname].values
            for sel, fill in ((ok, "C0"), (~ok, "none")):
                if sel.any():
                    a.errorbar(x[sel], y[sel], yerr=err[:, sel], fmt="o", mfc=fill, mec="C0",
                               ecolor="C0", capsize=3,
                               label="reliable" if fill == "C0" else "not reliable")
            if joint and joint.get(name) is not None:
                lo, up = (_num(v) for v in joint[f"{name}_ci"])
                a.axhspan(lo, up if math.isfinite(up) else np.nanmax(y, initial=lo), color="C1",
                          alpha=0.25, label="joint 95 %")
                a.axhline(_num(joint[name]), color="C1", label="joint estimate")
            a.set_xlabel(xlabel)
            a.set_ylabel(f"{label} ({unit})")
            pos = np.concatenate([y[np.isfinite(y) & (y > 0)], hi[np.isfinite(hi) & (hi > 0)]])
            if pos.size and pos.max() > SURVEY_LOG_SPAN * max(np.median(pos), 1e-12):
                # an open-ish upper end would flatten every other interval: log-like axis
                a.set_yscale("symlog", linthresh=max(float(np.median(pos)) / 10, 1e-6))
                a.set_ylim(bottom=0.0)
            if i == 0 and j == 0:
                a.legend(fontsize=8)
    fig.suptitle("dive survey: per-photo estimates, 95 % intervals", fontsize=10)
    fig.subplots_adjust(left=0.14 / len(xs), right=0.97, bottom=0.08, top=0.92, wspace=0.3,
                        hspace=0.3)
    p = Path(path)
    with _atomic(p) as tmp:
        fig.savefig(tmp, format="png")
    return p


# --------------------------------------------------------------------------- the run
@dataclass
class DiveResult:
    """The result of :func:`measure_dive`.

    Attributes
    ----------
    rows : list of dict
        One per file of the folder (:data:`SUMMARY_COLUMNS`; ``status`` one of
        :data:`STATUSES`).
    code : int
        0 every photo reliable, 1 one not reliable, 2 one not measurable, 130 interrupted.
    summary, survey, figure, joint : pathlib.Path or None
        summary.csv, survey.nc, survey.png and joint.json (None when not written).
    interrupted : bool
        The run was interrupted (Ctrl-C); the outputs list what was done.
    counts : dict
        status -> number of rows.
    joint_error : str
        Why the joint fit was not made, when asked for and not made.
    """

    rows: list
    code: int
    summary: Path | None = None
    survey: Path | None = None
    figure: Path | None = None
    joint: Path | None = None
    interrupted: bool = False
    counts: dict = field(default_factory=dict)
    joint_error: str = ""


def _clean_temp(root: Path) -> None:
    """Remove temporary folders an interrupted or killed run left in ``root``."""
    for p in root.glob(f"{TEMP_PREFIX}*"):
        if p.is_dir():
            shutil.rmtree(p, ignore_errors=True)
        else:
            p.unlink(missing_ok=True)


def _plan(photo, name, root, rows_meta, metadata, exif, defaults, options, outputs, overwrite,
          version):
    """(job or None, row or None) for one photo: a row when it is done or cannot be done."""
    out = root / name
    tiff, report = outputs
    plan = {"out": str(out), "options": options, "tiff": tiff}
    if metadata is not None and photo.name not in rows_meta:
        return None, _row(photo, plan, "error", error=f"metadata: no row for {photo.name} in "
                                                      f"{metadata}")
    try:
        inputs = _resolve(photo, rows_meta.get(photo.name), exif, *defaults)
    except ValueError as exc:
        return None, _row(photo, plan, "error", error=str(exc))
    plan["inputs"] = inputs
    key = _key(photo, inputs, options, outputs, version)
    marker = read_marker(out) if out.is_dir() else None
    if marker is not None and marker.get("key") == key:
        try:
            record = json.loads((out / "measurement.json").read_text(encoding="utf-8"))
            return None, _row(photo, plan, "done earlier", record)
        except (OSError, ValueError):
            pass  # a marker without its measurement: redo
    owner = result_owner(out) if out.is_dir() else None
    if owner is not None and not overwrite:
        same = marker is not None and Path(owner).name == photo.name
        why = "results of the same photo with other inputs or options" if same else \
            f"the results of another photo ({owner or 'unknown'})"
        return None, _row(photo, plan, "error", error=f"out: {out} holds {why}; give another "
                                                      "--out or --overwrite to replace them")
    if out.exists() and owner is None and any(out.iterdir()):
        return None, _row(photo, plan, "error", error=f"out: {out} exists and holds files that "
                                                      "are not uw3p results")
    job = {"image": str(photo), "out": str(out), "inputs": inputs, "options": options,
           "tiff": tiff, "report": report, "key": key, "version": version, "command": ""}
    return (job, plan), None


@contextlib.contextmanager
def _client(scheduler, n):
    """A dask.distributed Client: of an existing scheduler, or of a LocalCluster of ``n``
    single-threaded worker processes started by spawn (no fork: no fork warnings) that ignore
    Ctrl-C (the client handles it)."""
    import dask
    from distributed import Client, LocalCluster

    if scheduler:
        client = Client(scheduler)
        try:
            yield client
        finally:
            client.close(timeout=CLOSE_TIMEOUT_S)
        return
    main = threading.current_thread() is threading.main_thread()
    old = signal.signal(signal.SIGINT, signal.SIG_IGN) if main else None
    try:
        with dask.config.set({"distributed.worker.multiprocessing-method": "spawn"}):
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                   dashboard_address=":0", memory_limit=0,
                                   silence_logs=logging.ERROR)
    finally:
        if main:
            signal.signal(signal.SIGINT, old)
    client = Client(cluster)
    try:
        yield client
    finally:
        client.close(timeout=CLOSE_TIMEOUT_S)
        cluster.close(timeout=CLOSE_TIMEOUT_S)


def _execute(jobs, scheduler, on_result):
    """Run the jobs; ``on_result(job, result)`` as each ends. Returns the keys not run (on
    Ctrl-C; the KeyboardInterrupt is swallowed and reported by the return)."""
    pending = {job["key"]: job for job in jobs}
    if scheduler == "synchronous":
        try:
            for job in jobs:
                result = _run_job(job)
                pending.pop(job["key"])
                on_result(job, result)
        except KeyboardInterrupt:
            return set(pending)
        return set()
    from distributed import as_completed

    n = max(1, min(len(jobs), os.cpu_count() or 1))
    with _client(scheduler, n) as client:
        futures = {client.submit(_run_job, job, key=f"uw3p-{job['key']}", pure=False): job
                   for job in jobs}
        try:
            for fut in as_completed(futures):
                job = futures[fut]
                result = fut.result() if fut.status == "finished" else {
                    "status": "error", "error": f"failed: {fut.exception()!r}"}
                pending.pop(job["key"])
                on_result(job, result)
        except KeyboardInterrupt:
            client.cancel([f for f, j in futures.items() if j["key"] in pending])
            return set(pending)
    return set()


def measure_dive(paths_or_folder, *, out, metadata=None, depth=None, distance=None,
                 corners=None, overwrite: bool = False, tiff: str = "compressed",
                 joint: bool = False, scheduler=None, progress=None, bar=None,
                 report: bool = True, figure: bool = True, version: str = "",
                 command: str = "",
                 **measure_options) -> DiveResult:
    """Measure every photo of a dive, each with its own inputs, and write the survey.

    Parameters
    ----------
    paths_or_folder : path or list of paths
        The dive's folder (every file is listed in the summary: :func:`dive_files`) or the
        photos.
    out : str or os.PathLike
        The output folder (created if missing): one folder per photo (:func:`output_names`),
        summary.csv, survey.nc, survey.png and, with ``joint``, joint.json.
    metadata : str or os.PathLike, optional
        The metadata CSV (:func:`read_metadata`); then a photo without a row is an error row.
    depth, distance : float, optional
        Defaults (m) for the photos whose row (or, for the depth, EXIF: :func:`exif_info`) does
        not give them; a photo without either is an error row.
    corners : str or array_like, optional
        Default corners (pixels); None: detected (where a row gives none).
    overwrite : bool, optional
        Replace folders that hold another photo's results or other inputs' results.
    tiff : {'compressed', 'full', 'none'}, optional
        corrected.tiff (:func:`measure.write_outputs`).
    joint : bool, optional
        Also fit the dive's photos as one water (``measure.joint.fit_joint``): joint.json.
    scheduler : str, optional
        None: a ``distributed.LocalCluster`` of min(photos, cores) single-threaded worker
        processes; an address ('tcp://host:8786'): that cluster; 'synchronous': in this
        process, one photo after another (no Dask).
    progress : callable, optional
        ``progress(row)`` after each photo measured (a KeyboardInterrupt raised in it
        interrupts the run like Ctrl-C).
    bar : text stream, optional
        Where a tqdm progress bar is drawn (None: no bar).
    report : bool, optional
        Draw each photo's report.png (:func:`measure.write_outputs`).
    figure : bool, optional
        Draw survey.png (:func:`plot_survey`).
    version, command : str, optional
        uw3p's version and the command line, recorded in the outputs.
    **measure_options
        Passed to :func:`measure.measure`: ``camera``, ``quantal``, ``profile``,
        ``illuminant``, ``layout``, ``water``, ``black_level``, ``white_level``,
        ``light_field``, ``uncertain``.

    Returns
    -------
    DiveResult
        The rows, the exit status and the files written.

    Raises
    ------
    ValueError
        Naming the argument: no photos, a bad ``metadata`` file, a ``tiff`` not in
        :data:`measure.output.TIFF_MODES`, an ``out`` that cannot be created.
    """
    from tqdm import tqdm

    if tiff not in TIFF_MODES:
        raise ValueError(f"tiff: must be one of {TIFF_MODES}, got {tiff!r}")
    meta = read_metadata(metadata) if metadata is not None else {}
    src = paths_or_folder
    if isinstance(src, (str, os.PathLike)) and Path(src).is_dir():
        photos, others = dive_files(src, exclude=[metadata] if metadata else [])
    else:
        photos, others = [Path(p) for p in ([src] if isinstance(src, (str, os.PathLike))
                                            else src)], []
    if not photos:
        raise ValueError(f"image: no RAW or TIFF files in {src} "
                         f"({', '.join(RAW_EXTENSIONS + TIFF_EXTENSIONS)})")
    root = Path(out)
    try:
        root.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"out: cannot create {root}: {exc.strerror}") from None
    _clean_temp(root)
    names = output_names(photos)
    options = {"camera": forward.DEFAULT_CAMERA} | dict(measure_options)
    rows, records, jobs = {}, {}, []
    for p in photos:
        job, row = _plan(p, names[p], root, meta, metadata, exif_info(p),
                         (depth, distance, corners), options, (tiff, report), overwrite,
                         version)
        if row is not None:
            rows[p] = row
            continue
        job, plan = job
        job["command"] = command
        job["plan"] = plan
        jobs.append(job)
    for p, row in rows.items():
        if row["status"] == "done earlier":
            records[str(p)] = json.loads((Path(row["out"]) / "measurement.json").read_text())
    by_key = {}
    with tqdm(total=len(jobs), file=bar, desc="measuring", unit="photo",
              disable=bar is None or not jobs) as pbar:
        def on_result(job, result):
            p = Path(job["image"])
            row = _row(p, job["plan"], result["status"], result.get("record"),
                       result.get("error", ""))
            rows[p] = row
            if result.get("record") is not None:
                records[str(p)] = result["record"]
            by_key[job["key"]] = row
            pbar.update(1)
            if progress is not None:
                progress(row)
        left = _execute(jobs, scheduler, on_result) if jobs else set()
    if scheduler is None or scheduler == "synchronous":
        _clean_temp(root)  # the local workers are gone: what they left half-written
    for job in jobs:
        if job["key"] in left:
            p = Path(job["image"])
            record = _finished(job)
            rows[p] = _row(p, job["plan"], "interrupted",
                           error="interrupted before this photo was measured") \
                if record is None else _row(p, job["plan"], "measured", record)
            if record is not None:
                records[str(p)] = record
    all_rows = [rows[p] for p in photos] + [_row(p, {}, "not an image", error=why)
                                            for p, why in others]
    all_rows.sort(key=lambda r: Path(r["image"]).name)
    return _finish(all_rows, records, root, bool(left), joint, measure_options, version,
                   command, figure)


def _finished(job):
    """measurement.json's content when the job's folder is complete with the job's key (a
    worker finished it while the run was being interrupted), else None."""
    marker = read_marker(job["out"])
    if marker is None or marker.get("key") != job["key"]:
        return None
    try:
        return json.loads((Path(job["out"]) / "measurement.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


def _finish(rows, records, root, interrupted, joint, options, version, command, figure):
    """Write summary.csv, joint.json, survey.nc and survey.png; the DiveResult."""
    counts = {s: sum(r["status"] == s for r in rows) for s in STATUSES}
    codes = [c for c in (_code(r) for r in rows) if c is not None]
    code = 130 if interrupted else max(codes, default=0)
    res = DiveResult(rows, code, interrupted=interrupted, counts=counts)
    res.summary = _write_summary(rows, root / "summary.csv")
    joint_data = None
    if joint:
        if interrupted:
            res.joint_error = "not fitted: the run was interrupted"
        else:
            joint_data, res.joint, res.joint_error = _joint(rows, records, root, options)
    photo_rows = [r for r in rows if r["status"] != "not an image"]
    now = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
    ds = survey_dataset(photo_rows, records, {
        "history": f"{now} {command or 'uw3p measure_dive'}", "uw3p_version": version,
        "command": command, "interrupted": int(interrupted)})
    res.survey = _write_survey(ds, root / "survey.nc")
    if records and figure:
        res.figure = plot_survey(ds, root / "survey.png", joint_data)
    return res


def _joint(rows, records, root, options):
    """Fit the dive as one water (measure.joint); (content, path, error)."""
    try:
        from . import joint as joint_mod
    except ImportError as exc:
        return None, None, f"not fitted: measure.joint is not available ({exc})"
    from .camera import camera_setup, load_profile

    good = [records[r["image"]] for r in rows
            if r["status"] in ("measured", "done earlier") and r["image"] in records]
    if not good:
        return None, None, "not fitted: no photo was measured"
    prof = options.get("profile")
    prof = load_profile(prof) if isinstance(prof, (str, os.PathLike)) else prof
    setup = camera_setup(options.get("camera", forward.DEFAULT_CAMERA),
                         quantal=options.get("quantal", False),
                         illuminant=options.get("illuminant"),
                         gains=None if prof is None else (prof.gains or None))
    try:
        fit = joint_mod.fit_joint(good, setup=setup, water=options.get("water"),
                                  uncertain=options.get("uncertain"))
    except ValueError as exc:
        return None, None, f"not fitted: {exc}"
    data = strict_json(fit.to_dict())
    path = root / "joint.json"
    with _atomic(path) as tmp:
        tmp.write_text(json.dumps(data, indent=1, allow_nan=False) + "\n", encoding="utf-8")
    return data, path, ""
