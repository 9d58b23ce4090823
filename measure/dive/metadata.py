"""A dive's per-photo inputs from outside the photo's pixels: the metadata CSV
(:func:`read_metadata`) and the camera's EXIF depth and time (:func:`exif_info`)."""

from __future__ import annotations

import datetime
import math
import re
from pathlib import Path
from forward.errors import InputError

from .. import exif
from ..exif import tag_value

__all__ = ["REFERENCE_COLUMNS", "AUXILIARY_COLUMNS", "DATETIME_ORIGINAL_TAG", "EXIF_DEPTH_TAGS", "KD_COLUMN",
           "METADATA_COLUMNS", "METADATA_OPTIONAL", "WATER_DEPTH_TAG", "exif_info",
           "read_metadata"]

#: Required columns of the metadata CSV (``--metadata``): the image's file name relative to the
#: folder, the chart's depth (m) and the camera-to-chart distance (m)
METADATA_COLUMNS = ("image", "depth_m", "distance_m")
#: Optional columns: the standard deviations (m) of depth and distance, the chart's corners
#: ("x1,y1 x2,y2 x3,y3 x4,y4", pixels; empty: detected), and what a photo is corrected along:
#: ``range_m``, the camera-to-scene range (m), or ``range_map``, a range-map file (a float TIFF
#: in m, a 16-bit PNG in mm or a .npy in m; relative to the metadata file's folder;
#: :mod:`measure.rangemap`). Without either a photo is corrected at its ``distance_m``.
METADATA_OPTIONAL = ("depth_sd_m", "distance_sd_m", "corners", "range_m", "range_map",
                     "reference", "reference_after")
#: Optional columns of the reference shots (the chart in air at the site, decisions
#: 0069-reference-shot and 0074-reference-bracket): ``PHOTO[:MINUTES]`` relative to the
#: metadata file's folder, MINUTES from the dive (default 10); ``reference_after`` a second
#: shot on the other side of the dive. The photo's fit takes the daylight they measure, as
#: ``uw3p measure --reference``.
REFERENCE_COLUMNS = ("reference", "reference_after")
#: Optional columns of what was measured of the water besides the photo
#: (:mod:`sca.auxiliary`), each with its standard deviation: a water sample's a_CDOM(440)
#: (m^-1) and a Secchi-disk depth (m); a radiometer's K_d at a band (m^-1) is
#: :data:`KD_COLUMN`. kind -> (value column, sd column).
AUXILIARY_COLUMNS = {"cdom": ("cdom_sample", "cdom_sample_sd"),
                     "secchi": ("secchi_m", "secchi_sd_m")}
#: A radiometer's K_d at a band: ``kd_<nm>`` (m^-1) with ``kd_<nm>_sd``, e.g. ``kd_490``,
#: ``kd_490_sd`` (the band 400-700 nm)
KD_COLUMN = re.compile(r"^kd_(\d+(?:\.\d+)?)(_sd)?$")
#: EXIF tags that record the depth under water, in the order tried. EXIF 2.31 (CIPA DC-008-2016)
#: added ``WaterDepth`` (tag 0x9403 = 37891, signed rational, m) to the Exif IFD; tough
#: compacts (e.g. Olympus/OM System TG series) write it. Dive-log geotagging tools write the
#: depth as ``GPSAltitude`` with ``GPSAltitudeRef`` = 1 (below sea level).
EXIF_DEPTH_TAGS = ("WaterDepth", "GPSAltitude")
#: EXIF 2.31 WaterDepth (Exif IFD)
WATER_DEPTH_TAG = 37891
#: EXIF DateTimeOriginal (Exif IFD), "YYYY:MM:DD HH:MM:SS"
DATETIME_ORIGINAL_TAG = 36867


def _number(value, name, where, *, positive=True):
    value = value.strip()
    if not value:
        return None
    try:
        x = float(value)
    except ValueError:
        raise InputError("metadata", f"{where}: {name} is not a number: {value!r}") from None
    if not math.isfinite(x) or x < 0 or (positive and x == 0):
        raise InputError("metadata", f"{where}: {name} must be finite and {'> 0' if positive else '>= 0'}, "
                         f"got {value!r}")
    return x


def read_metadata(path) -> dict:
    """Read a dive's metadata CSV: one row per photo.

    Columns (by name, any order; UTF-8 with or without a byte-order mark): ``image`` (file name
    relative to the folder), ``depth_m``, ``distance_m`` (m) and optionally ``depth_sd_m``,
    ``distance_sd_m`` (m), ``corners`` ("x1,y1 x2,y2 x3,y3 x4,y4", pixels), ``range_m`` (m),
    ``range_map`` (a range-map file, relative to the CSV's folder) and what was
    measured of the water when the photo was taken, each with its sd (:data:`AUXILIARY_COLUMNS`,
    :data:`KD_COLUMN`): ``cdom_sample``, ``cdom_sample_sd`` (a water sample's a_CDOM(440),
    m^-1), ``secchi_m``, ``secchi_sd_m`` (a Secchi-disk depth, m), ``kd_<nm>``, ``kd_<nm>_sd``
    (a radiometer's K_d at <nm> nm, m^-1). An empty cell means "not given here": the EXIF depth
    or the default applies (corners: detected; a measurement: the run's, if any). A quoted
    cell may hold line breaks; columns with an empty header (a spreadsheet's trailing comma)
    are ignored when their cells are empty. The file is read by the package's one CSV reader
    (:class:`forward.csvtable.Table`: UTF-8 or UTF-16, comma, semicolon or tab detected, ``#``
    comment lines before the header skipped); with a semicolon or tab, a number may have a
    decimal comma. A row with fewer cells than the columns (a line cut short) is refused.

    Parameters
    ----------
    path : str or os.PathLike
        The CSV file.

    Returns
    -------
    dict
        image name -> {'depth_m', 'distance_m', 'depth_sd_m', 'distance_sd_m', 'range_m'
        (floats or None), 'corners' (str or None), 'range_map' (absolute path or None),
        'auxiliary' (the row's measurements in :mod:`sca.auxiliary`'s form, {} for none), 'line'
        (int: the line the row starts on), 'raw_name' (the cell as written, unstripped: a
        photo whose name begins with a space)}.

    Raises
    ------
    ValueError
        Naming ``metadata`` and the line: a missing file or column, an unknown or repeated
        column, a measurement's column without its sd column (or the reverse), a K_d band
        outside 400-700 nm, a value that is not a positive number, a measurement without its
        sd (or the reverse), a value under no column name, an empty or repeated image name, a
        malformed CSV.
    """
    from forward.csvtable import Table

    table = Table(path, "metadata")
    rows = table.numbered()
    _, header = next(rows)
    return _rows(table.path, [h.strip() for h in header], rows,
                 None if table.decimal_comma else ",")


#: Cells that are text, not numbers (a decimal comma is read in the others when the
#: separator is not a comma)
_TEXT_CELLS = ("image", "corners", "range_map") + REFERENCE_COLUMNS


def _check_header(p: Path, names: list) -> None:
    """Refuse missing, unknown or repeated columns (line 1 of the metadata CSV)."""
    missing = [c for c in METADATA_COLUMNS if c not in names]
    if missing:
        raise InputError("metadata", f"{p} line 1: missing column(s) {', '.join(missing)} "
                         f"(needs {', '.join(METADATA_COLUMNS)}; optional "
                         f"{', '.join(METADATA_OPTIONAL + sum(AUXILIARY_COLUMNS.values(), ()))}"
                         ", kd_<nm>, kd_<nm>_sd)")
    aux_columns = sum(AUXILIARY_COLUMNS.values(), ())
    unknown = [c for c in names if c not in METADATA_COLUMNS + METADATA_OPTIONAL
               + aux_columns and not KD_COLUMN.match(c)]
    if unknown:
        raise InputError("metadata", f"{p} line 1: unknown column(s) {', '.join(unknown)}")
    repeated = sorted({c for c in names if names.count(c) > 1})
    if repeated:
        raise InputError("metadata", f"{p} line 1: column(s) {', '.join(repeated)} repeat")


def _rows(p: Path, header: list, numbered, sep) -> dict:
    """The rows of a metadata CSV (:func:`read_metadata`): ``numbered`` yields (line, cells)
    after the header; ``sep`` ',' when a comma separates the cells (no decimal comma)."""
    named = [(i, h) for i, h in enumerate(header) if h]
    names = [h for _, h in named]
    _check_header(p, names)
    pairs = _auxiliary_pairs(p, names)
    last = max(i for i, _ in named) + 1  # cells a row must have (trailing unnamed: no)
    rows = {}
    for n, raw in numbered:
        where = f"{p} line {n}"  # the argument: metadata
        if len(raw) > len(header):
            raise InputError("metadata", f"{where}: more cells than columns")
        if len(raw) < last and any(v.strip() for v in raw):
            raise InputError("metadata", f"{where}: fewer cells ({len(raw)}) than columns ({last}): a "
                             "line cut short? (give empty cells for values not given)")
        raw = raw + [""] * (len(header) - len(raw))
        stray = [i + 1 for i, h in enumerate(header) if not h and raw[i].strip()]
        if stray:
            raise InputError("metadata", f"{where}: cell {stray[0]} ({raw[stray[0] - 1]!r}) has no "
                             "column name in line 1")
        cell = {h: raw[i] if h in _TEXT_CELLS or sep == "," else raw[i].replace(",", ".")
                for i, h in named}
        if not any(v.strip() for v in cell.values()):
            continue
        name = cell["image"].strip()
        if not name:
            raise InputError("metadata", f"{where}: image is empty")
        if name in rows:
            raise InputError("metadata", f"{where}: image {name!r} repeats line {rows[name]['line']}")
        rows[name] = {"depth_m": _number(cell["depth_m"], "depth_m", where, positive=False),
                      "distance_m": _number(cell["distance_m"], "distance_m", where),
                      "depth_sd_m": _number(cell.get("depth_sd_m", ""), "depth_sd_m", where,
                                            positive=False),
                      "distance_sd_m": _number(cell.get("distance_sd_m", ""),
                                               "distance_sd_m", where, positive=False),
                      "corners": cell.get("corners", "").strip() or None,
                      "range_m": _number(cell.get("range_m", ""), "range_m", where),
                      "range_map": _range_map(p, cell.get("range_map", ""), where),
                      "auxiliary": _auxiliary(cell, pairs, where), "line": n,
                      "reference": _references(p, cell, where),
                      "raw_name": cell["image"]}
    return rows


def _references(csv_path: Path, cell: dict, where: str) -> list:
    """The row's reference shots [(absolute path, minutes)] (:data:`REFERENCE_COLUMNS`)."""
    from ..reference import parse_reference

    out = []
    for col in REFERENCE_COLUMNS:
        if cell.get(col, "").strip():
            try:
                out.append(list(parse_reference(cell[col], csv_path.parent, col)))
            except InputError as exc:
                raise InputError("metadata", f"{where}: {exc.argument}: {exc.reason}") from None
    return out


def _range_map(csv_path: Path, value: str, where: str):
    """A range map's absolute path (relative to the CSV's folder), or None for an empty cell."""
    value = value.strip()
    if not value:
        return None
    p = Path(value)
    p = p if p.is_absolute() else csv_path.resolve().parent / p
    if not p.is_file():
        raise InputError("metadata", f"{where}: range_map: no such file: {value}")
    return str(p)


def _auxiliary_pairs(p: Path, names) -> dict:
    """kind (or ('kd', nm)) -> (value column, sd column) of the measurement columns of a
    header; each value column must come with its sd column and the reverse, and two columns
    of one band (``kd_490``, ``kd_490.0``) are refused."""
    pairs = {k: v for k, v in AUXILIARY_COLUMNS.items() if v[0] in names or v[1] in names}
    for c in names:
        m = KD_COLUMN.match(c)
        if m:
            nm = float(m.group(1))
            if not 400.0 <= nm <= 700.0:
                raise InputError("metadata", f"{p} line 1: column {c}: the band {nm:g} nm lies "
                                 "outside 400-700 nm")
            col = f"kd_{m.group(1)}"
            other = pairs.get(("kd", nm), (col,))[0]
            if other != col:
                raise InputError("metadata", f"{p} line 1: columns {other} and {col} name the "
                                 f"same quantity (K_d at {nm:g} nm); keep one")
            pairs[("kd", nm)] = (col, f"{col}_sd")
    for value, sd in pairs.values():
        if (value in names) != (sd in names):
            have, lack = (value, sd) if value in names else (sd, value)
            raise InputError("metadata", f"{p} line 1: column {have} needs column {lack} (every "
                             "measurement with its standard deviation)")
    return pairs


def _auxiliary(cell, pairs, where) -> dict:
    """A row's measurements in :mod:`sca.auxiliary`'s form: only those given."""
    out = {}
    for key, (vcol, scol) in pairs.items():
        value = _number(cell.get(vcol, ""), vcol, where)
        sd = _number(cell.get(scol, ""), scol, where)
        if (value is None) != (sd is None):
            empty = scol if sd is None else vcol
            raise InputError("metadata", f"{where}: {empty} is empty: give the measurement with its "
                             "standard deviation, or neither")
        if value is None:
            continue
        if isinstance(key, tuple):
            out.setdefault("kd", {})[key[1]] = (value, sd)
        else:
            out[key] = (value, sd)
    return out


def _tag_number(value):
    """A tag's value as a number (:func:`measure.exif.tag_value`), or None."""
    value = tag_value(value)
    return value if isinstance(value, float) else None


def exif_info(path) -> dict:
    """The depth and the time a photo's EXIF records, where it does.

    Read by the package's one EXIF reader (:func:`measure.exif.read_exif`: tifffile, from TIFF
    containers -- TIFF, DNG, NEF, ARW, CR2, PEF, ...); formats that are not TIFF containers give
    nothing. The depth: EXIF 2.31 ``WaterDepth`` (tag
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
    out = {}
    pool = {k: v for ifd in exif.read_exif(path) for k, v in ifd.items()}  # Exif, GPS over IFD0
    depth = _tag_number(pool.get("WaterDepth", pool.get(WATER_DEPTH_TAG)))
    if depth is not None and depth >= 0:
        out.update(depth_m=float(depth), depth_tag="WaterDepth")
    elif _tag_number(pool.get("GPSAltitudeRef")) == 1:
        alt = _tag_number(pool.get("GPSAltitude"))
        if alt is not None and alt >= 0:
            out.update(depth_m=float(alt), depth_tag="GPSAltitude")
    stamp = tag_value(pool.get("DateTimeOriginal", pool.get(DATETIME_ORIGINAL_TAG)))
    if isinstance(stamp, str):
        try:
            t = datetime.datetime.strptime(stamp, "%Y:%m:%d %H:%M:%S")
            out["time"] = t.isoformat()
        except ValueError:
            pass
    return out
