"""Patch-value CSV files: read by column name, written as ``uw3p simulate`` writes them.

The file is read by the package's one CSV reader (:class:`forward.csvtable.Table`: encoding,
separator, decimal comma, comments and header as for curves and a dive's metadata); the
conventions (the README's command-line section says the same):

* **Encoding**: UTF-8 with or without a byte-order mark (a spreadsheet's "CSV UTF-8"), or
  UTF-16 with a byte-order mark (a spreadsheet's "Unicode text").
* **Separator**: comma, semicolon or tab, detected (the one that splits every line of the
  file's start into the same number of fields, quotes respected); a spreadsheet's ``sep=;``
  first line is honoured. Fields may be quoted (``"dive 3, north"``).
* **Decimal comma**: in a semicolon- or tab-separated file, numbers may be written ``0,25``.
* Lines starting with ``#`` before the header (comments), blank lines and rows of empty
  fields are skipped; a column with an empty name (a spreadsheet's trailing separator; in a
  file without a header, empty fields that end the first row) is ignored, and a value in it
  refused. A quoted field may hold line breaks (the csv module reads the file whole).
* **Columns by name**, in any order and any case (spaces and ``-`` read as ``_``): ``patch``
  (1..n, rows in any order); the channels ``red``, ``green``, ``blue`` (or ``R``, ``G``,
  ``B``; ``ch0``, ``ch1``, ... for a camera with other channels); optionally the standard
  deviation of every value, ``<channel>_sd`` (``red_sd`` or ``R_sd``, ...), for every channel
  or for none. A batch adds ``chart`` (any text) and optionally ``depth_m``, ``distance_m``
  (one value per chart). Any other name is refused with the list of the known ones.
* A single chart's file may have no header: then its columns are patch, red, green, blue.

Every problem raises ``ValueError`` naming the file (the CLI prints it and exits 2). Reading
is linear in the number of rows: a batch is parsed in blocks by the ``csv`` module and
converted column by column.
"""

from __future__ import annotations

import io
import itertools
import re

import numpy as np

from measure.csvsafe import safe_writer

from forward.csvtable import Table as _Table
from forward.csvtable import to_float as _float
from forward.errors import InputError

__all__ = ["RGB", "BATCH_EXTRA", "CHANNEL_ALIASES", "read_patch_csv", "read_batch_csv",
           "patch_csv", "known_columns"]

#: Channel names recognised by name, in the order the estimator expects them.
RGB = ("red", "green", "blue")
#: Other accepted spellings of the channel names (after lower-casing).
CHANNEL_ALIASES = {"r": "red", "g": "green", "b": "blue"}
#: Columns of a batch file that are not channels (one value per chart, m).
BATCH_EXTRA = ("depth_m", "distance_m")
#: Rows converted at a time when reading (bounds the memory of the text being converted).
BLOCK_ROWS = 65536
_CH = re.compile(r"^ch(\d+)$")


# --------------------------------------------------------------------------- column names
def _norm(name: str) -> str:
    return "_".join(name.strip().lower().replace("-", " ").split())


def _canonical(name: str) -> str:
    """A column name in its canonical spelling ('R_sd' -> 'red_sd', 'G' -> 'green')."""
    n = _norm(name)
    base, sd = (n[:-3], "_sd") if n.endswith("_sd") else (n, "")
    return CHANNEL_ALIASES.get(base, base) + sd


def known_columns(batch: bool) -> str:
    """The known column names, for error messages and the documentation."""
    extra = ", chart, depth_m, distance_m" if batch else ""
    return ("patch, red, green, blue (or R, G, B), red_sd, green_sd, blue_sd (or R_sd, G_sd, "
            f"B_sd); ch0, ch1, ... and ch0_sd, ... for a camera with other channels{extra}")


def _columns(table: _Table, batch: bool):
    """Map the header to column indices: {'patch': i, 'chart': i, 'depth_m': i, ...},
    the channel indices and names in the estimator's order, and the sd indices (or None)."""
    name, p = table.name, table.path
    known = {"patch", *RGB, *(f"{c}_sd" for c in RGB)} | (
        {"chart", *BATCH_EXTRA} if batch else set())
    where, unknown = {}, []
    for i, h in enumerate(table.header):
        if not h.strip():
            continue  # an unnamed column (a trailing separator): ignored
        c = _canonical(h)
        base = c[:-3] if c.endswith("_sd") else c
        if c not in known and not _CH.match(base):
            unknown.append(h)
            continue
        if c in where:
            raise InputError(name, f"{p}: column {c!r} is given twice (columns "
                             f"{table.header[where[c]]!r} and {h!r})")
        where[c] = i
    if unknown:
        hint = (" (a batch file: use --batch)" if not batch and any(
            _norm(u) == "chart" for u in unknown) else "")
        raise InputError(name, f"{p}: unknown column{'s' if len(unknown) > 1 else ''} "
                         f"{', '.join(repr(u) for u in unknown)}{hint}; known columns: "
                         f"{known_columns(batch)}")
    for need in ("patch",) + (("chart",) if batch else ()):
        if need not in where:
            raise InputError(name, f"{p}: no {need!r} column (header: "
                             f"{', '.join(table.header)}); known columns: {known_columns(batch)}")
    named = [c for c in RGB if c in where]
    numbered = sorted((int(_CH.match(c).group(1)), c) for c in where if _CH.match(c))
    if named and numbered:
        raise InputError(name, f"{p}: give the channels as red, green, blue or as ch0, ch1, "
                         "..., not both")
    if numbered:
        channels = [c for _, c in numbered]
        if [k for k, _ in numbered] != list(range(len(numbered))):
            raise InputError(name, f"{p}: channel columns must be ch0, ch1, ... without gaps, "
                             f"got {', '.join(channels)}")
    else:
        channels = list(RGB)
        missing = [c for c in RGB if c not in where]
        if missing:
            raise InputError(name, f"{p}: no {' or '.join(missing)} column (header: "
                             f"{', '.join(table.header)}); known columns: {known_columns(batch)}")
    sds = [f"{c}_sd" for c in channels]
    stray = [c for c in where if c.endswith("_sd") and c not in sds]
    if stray:
        raise InputError(name, f"{p}: {', '.join(stray)} without its channel")
    have = [c for c in sds if c in where]
    if have and len(have) != len(sds):
        missing = [c for c in sds if c not in where]
        raise InputError(name, f"{p}: columns {missing} are missing: give a standard deviation "
                         "for every channel or for none")
    return where, [where[c] for c in channels], channels, (
        [where[c] for c in sds] if have else None)


# --------------------------------------------------------------------------- reading
def _unnamed(table: _Table) -> list:
    """The columns without a name (a spreadsheet's trailing separator): the header's empty
    names, or in a file without a header the first row's trailing empty fields."""
    if table.header is not None:
        return [i for i, h in enumerate(table.header) if not h.strip()]
    width = len(table.first)
    while width and not table.first[width - 1].strip():
        width -= 1
    return list(range(width, len(table.first)))


def _read(table: _Table, columns: dict, id_col, progress=None):
    """Read every data row: (ids, codes, values) -- the chart ids in order of first appearance
    (or None), the chart index of every row (or None), and the requested numeric columns
    ({key: (R,) float array}); each block of rows converted column by column. A value in a
    column without a name (:func:`_unnamed`) is refused, never dropped."""
    rows = table.rows(progress)
    try:
        return _read_rows(table, rows, columns, id_col, _unnamed(table))
    finally:
        rows.close()


def _read_rows(table, rows, columns, id_col, unnamed=()):
    name = table.name
    if table.header is not None:
        next(rows)
    width = len(table.header) if table.header is not None else None
    ids, codes = {}, []
    chunks = {k: [] for k in columns}
    done = 0
    while True:
        block = list(itertools.islice(rows, BLOCK_ROWS))
        if not block:
            break
        if width is None:
            width = len(block[0])
        lens = set(map(len, block))
        if lens != {width}:
            k = next(i for i, r in enumerate(block) if len(r) != width)
            raise InputError(name, f"{table.where(done + k)} has {len(block[k])} fields, "
                             f"{'the header' if table.header else 'the first row'} {width}")
        cols = list(zip(*block))
        for j in unnamed:
            k = next((i for i, x in enumerate(cols[j]) if x.strip()), None)
            if k is not None:
                raise InputError(name, f"{table.where(done + k)}: {cols[j][k]!r} in column "
                                 f"{j + 1}, which has no name (a value the file does not name "
                                 "is not read): name the column or remove the value")
        if id_col is not None:
            get = ids.setdefault
            codes.append(np.fromiter((get(c, len(ids)) for c in map(str.strip, cols[id_col])),
                                     np.int64, len(block)))
        for key, j in columns.items():
            try:
                if table.decimal_comma:
                    arr = np.fromiter((float(x.replace(",", ".")) for x in cols[j]), float,
                                      len(block))
                else:
                    arr = np.fromiter(map(float, cols[j]), float, len(block))
            except ValueError:
                k = next(i for i, x in enumerate(cols[j]) if not _is_float(x, table.decimal_comma))
                col = table.header[j] if table.header else f"column {j + 1}"
                value = cols[j][k]
                raise InputError(name, f"{table.where(done + k)}: {value!r} in {col} is not a "
                                 f"number" + ("" if value.strip() else " (an empty cell)")
                                 ) from None
            chunks[key].append(arr)
        done += len(block)
    if done == 0:
        raise InputError(name, f"{table.path} has a header but no values")
    values = {k: np.concatenate(v) for k, v in chunks.items()}
    return (list(ids) if id_col is not None else None,
            np.concatenate(codes) if id_col is not None else None, values)


def _is_float(x, decimal_comma) -> bool:
    try:
        _float(x, decimal_comma)
    except ValueError:
        return False
    return True


def _assemble(table, charts, codes, values, channels, sds, extras, batch):
    """Put the rows in place: M (N, m, n), sigma or None, and the per-chart extras; every
    check names the chart (its id, in a batch) and the line."""
    name, p = table.name, table.path
    N = len(charts)

    def label(j):
        return f"chart {charts[j]!r}" if batch else "the chart"

    def at(k):
        return table.where(k) + (f" (chart {charts[codes[k]]!r})" if batch else "")

    vals = np.column_stack([values[c] for c in channels] + ([values[c] for c in sds] if sds else [])
                           + [values[k] for k in extras])
    bad = ~np.all(np.isfinite(vals), axis=1)
    if bad.any():
        raise InputError(name, f"{at(int(np.flatnonzero(bad)[0]))}: NaN or infinite value")
    bad = np.any(vals < 0, axis=1)
    if bad.any():
        raise InputError(name, f"{at(int(np.flatnonzero(bad)[0]))}: negative value; patch "
                         "values, their sds, depths and distances are >= 0 (raw values with the "
                         "black level subtracted, or model units)")
    counts = np.bincount(codes, minlength=N)
    n = int(counts[0])
    if np.any(counts != n):
        j = int(np.flatnonzero(counts != n)[0])
        raise InputError(name, f"{p}: {label(j)} has {counts[j]} patches, {label(0)} has {n}")
    patch = values["patch"]
    bad = (patch != np.round(patch)) | (patch < 1) | (patch > n)
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise InputError(name, f"{at(k)}: patch {patch[k]:g}; "
                         f"the patch column must number the patches 1..{n} once each")
    slot = codes * n + (patch.astype(np.int64) - 1)
    seen = np.bincount(slot, minlength=N * n)
    if np.any(seen != 1):
        s = int(np.flatnonzero(seen != 1)[0])
        raise InputError(name, f"{p}{' (' + label(s // n) + ')' if batch else ''}: patch {s % n + 1} is "
                         f"{'missing' if seen[s] == 0 else 'given more than once'}; the patch "
                         f"column must number the patches 1..{n} once each")
    m = len(channels)
    placed = np.empty((N * n, vals.shape[1]))
    placed[slot] = vals
    placed = placed.reshape(N, n, -1)
    M = np.ascontiguousarray(placed[:, :, :m].transpose(0, 2, 1))
    sigma = None if not sds else np.ascontiguousarray(placed[:, :, m:2 * m].transpose(0, 2, 1))
    out = {}
    for j, k in enumerate(extras):
        per = placed[:, :, vals.shape[1] - len(extras) + j]
        varies = np.ptp(per, axis=1) > 0
        if varies.any():
            c = int(np.flatnonzero(varies)[0])
            raise InputError(name, f"{p}: {label(c)} has more than one {k} (one value per "
                             "chart)")
        out[k] = per[:, 0].copy()
    return M, sigma, out


def read_patch_csv(path, *, name: str = "measurements"):
    """Read the patch values of one chart from a CSV file (see the module docstring).

    Parameters
    ----------
    path : str or pathlib.Path
        The CSV file: one row per patch, with or without a header.
    name : str, optional
        What error messages call the file (the CLI argument), default ``"measurements"``.

    Returns
    -------
    rgb : numpy.ndarray
        Patch values, shape (m channels, n patches), in patch order, in the file's units.
    sigma : numpy.ndarray or None
        Their standard deviations, shape (m, n), same units; None when the file has no
        ``<channel>_sd`` columns.

    Raises
    ------
    ValueError
        The file is missing, a folder, not text, has an unknown column, is not numeric,
        ragged, holds NaN or negative values, or does not number its patches 1..n once each;
        the message starts with ``name``.
    """
    table = _Table(path, name)
    if table.header is None:
        width = len(table.first) - len(_unnamed(table))
        if width < 2:
            raise InputError(name, f"{table.path} needs a patch column and one column per "
                             "channel")
        channels = list(RGB) if width == 4 else [f"ch{j}" for j in range(width - 1)]
        cols = {"patch": 0, **{c: j + 1 for j, c in enumerate(channels)}}
        sds = None
    else:
        where, ch_idx, channels, sd_idx = _columns(table, batch=False)
        cols = {"patch": where["patch"], **dict(zip(channels, ch_idx))}
        sds = None if sd_idx is None else [f"{c}_sd" for c in channels]
        if sds:
            cols.update(dict(zip(sds, sd_idx)))
    _, _, values = _read(table, cols, None)
    codes = np.zeros(values["patch"].size, dtype=np.int64)
    M, sigma, _ = _assemble(table, ["chart"], codes, values, channels, sds, (), batch=False)
    return M[0], None if sigma is None else sigma[0]


def read_batch_csv(path, *, name: str = "--batch", progress=None):
    """Read a batch of charts from one CSV file (see the module docstring).

    Parameters
    ----------
    path : str or pathlib.Path
        The CSV file, columns ``chart``, ``patch``, the channels, optionally their ``_sd``
        columns, ``depth_m`` and ``distance_m``, by name in any order.
    name : str, optional
        What error messages call the file (the CLI argument), default ``"--batch"``.
    progress : text stream, optional
        Where a progress bar of the bytes read is drawn (tqdm); default none.

    Returns
    -------
    charts : list of str
        Chart ids, in order of first appearance (stripped of surrounding spaces).
    M : numpy.ndarray
        Patch values, shape (N charts, m channels, n patches), in patch order.
    sigma : numpy.ndarray or None
        Their standard deviations, shape (N, m, n); None without ``_sd`` columns.
    depth : numpy.ndarray
        Chart depth per chart in m, shape (N,); NaN where the file has no ``depth_m`` column.
    distance : numpy.ndarray
        Camera-to-chart distance per chart in m, shape (N,); NaN without ``distance_m``.

    Raises
    ------
    ValueError
        A malformed file (see :func:`read_patch_csv`), charts with different numbers of
        patches, or a chart with more than one depth or distance; the message starts with
        ``name`` and names the chart (its id) and the line.
    """
    table = _Table(path, name)
    if table.header is None:
        raise InputError(name, f"{table.path} needs a header naming its columns; known "
                         f"columns: {known_columns(True)}")
    where, ch_idx, channels, sd_idx = _columns(table, batch=True)
    cols = {"patch": where["patch"], **dict(zip(channels, ch_idx))}
    sds = None if sd_idx is None else [f"{c}_sd" for c in channels]
    if sds:
        cols.update(dict(zip(sds, sd_idx)))
    extras = tuple(k for k in BATCH_EXTRA if k in where)
    cols.update({k: where[k] for k in extras})
    bar = None
    if progress is not None:
        from tqdm import tqdm

        bar = tqdm(total=table.size, file=progress, desc="reading", unit="B", unit_scale=True,
                   leave=False)
    try:
        charts, codes, values = _read(table, cols, where["chart"], bar)
    finally:
        if bar is not None:
            bar.close()
    M, sigma, ex = _assemble(table, charts, codes, values, channels, sds, extras, batch=True)
    nan = np.full(len(charts), np.nan)
    return charts, M, sigma, ex.get("depth_m", nan), ex.get("distance_m", nan.copy())


# --------------------------------------------------------------------------- writing
def patch_csv(rgb, sigma=None) -> str:
    """Patch values as CSV text, the format :func:`read_patch_csv` reads.

    Parameters
    ----------
    rgb : array_like
        Patch values, shape (m channels, n patches). Three channels are named red, green,
        blue; otherwise ch0, ch1, ...
    sigma : array_like, optional
        Their standard deviations, shape (m, n); written as ``<channel>_sd`` columns.

    Returns
    -------
    str
        A header, then one row per patch (numbered from 1), values written exactly (``repr``).
    """
    rgb = np.asarray(rgb)
    buf = io.StringIO()
    w = safe_writer(buf, lineterminator="\n")
    names = list(RGB) if rgb.shape[0] == 3 else [f"ch{j}" for j in range(rgb.shape[0])]
    sd = [] if sigma is None else [f"{c}_sd" for c in names]
    w.writerow(["patch"] + names + sd)
    for p in range(rgb.shape[1]):
        row = [repr(float(v)) for v in rgb[:, p]]
        if sigma is not None:
            row += [repr(float(v)) for v in np.asarray(sigma)[:, p]]
        w.writerow([p + 1] + row)
    return buf.getvalue()
