"""Patch-value CSV files: read by column name, written as ``uw3p simulate`` writes them.

A single chart: one row per patch, a header ``patch,red,green,blue`` (columns in any order;
other channel names are taken in file order), optionally ``red_sd,green_sd,blue_sd``: the
standard deviation of each value (the estimator's ``sigma``). Without a header the first column
numbers the patches and the others are the channels in order. A batch: a header
``chart,patch,<channels>[,<channel>_sd...][,depth_m,distance_m]``; chart ids are any text.

Every problem raises ``ValueError`` naming the file (the CLI prints it and exits 2).
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

__all__ = ["RGB", "BATCH_EXTRA", "read_patch_csv", "read_batch_csv", "patch_csv"]

#: Channel names recognised by name, in the order the estimator expects them.
RGB = ("red", "green", "blue")
#: Columns of a batch file that are not channels.
BATCH_EXTRA = ("depth_m", "distance_m")


def _rows(path, name):
    p = Path(path)
    if not p.is_file():
        raise ValueError(f"{name}: file not found: {p}")
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"{name}: cannot read {p} as text: {exc}") from None
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    rows = [[c.strip() for c in r] for r in csv.reader(lines)]
    if not rows:
        raise ValueError(f"{name}: {p} has no rows")
    return p, rows


def _numbers(rows, p, name):
    try:
        arr = np.array([[float(x) for x in r] for r in rows], dtype=float)
    except ValueError as exc:
        raise ValueError(f"{name}: non-numeric value in {p}: {exc}") from None
    if arr.ndim != 2:
        raise ValueError(f"{name}: every row of {p} needs the same number of values")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: {p} contains NaN or infinite values")
    return arr


def _channels(header, skip):
    """Indices and names of the channel columns -- red, green, blue by name when all three are
    there, else every column not in ``skip`` and not ending in ``_sd``, in file order -- and the
    indices of their ``<name>_sd`` columns (None when the file has none)."""
    low = [h.lower() for h in header]
    if all(c in low for c in RGB):
        names = list(RGB)
    else:
        names = [h for h in low if h not in skip and not h.endswith("_sd")]
    idx = [low.index(c) for c in names]
    sd = [f"{c}_sd" for c in names]
    if not any(c in low for c in sd):
        return idx, names, None
    missing = [c for c in sd if c not in low]
    if missing:
        raise ValueError(f"columns {missing} are missing: give a standard deviation for every "
                         "channel or for none")
    return idx, names, [low.index(c) for c in sd]


def _patch_order(patch, p, name, where=""):
    n = patch.size
    if not np.array_equal(np.sort(patch), np.arange(1, n + 1)):
        raise ValueError(f"{name}: {p}{where}: the patch column must number the patches 1..{n} "
                         "once each")
    return np.argsort(patch)


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
        The file is missing, unreadable, not numeric, ragged, or does not number its patches
        1..n once each; the message starts with ``name``.
    """
    p, rows = _rows(path, name)
    header = None
    try:
        [float(x) for x in rows[0]]
    except ValueError:
        header, rows = rows[0], rows[1:]
    if not rows:
        raise ValueError(f"{name}: {p} has a header but no values")
    if len({len(r) for r in rows} | ({len(header)} if header else set())) != 1:
        raise ValueError(f"{name}: every row of {p} needs "
                         f"{len(header) if header else len(rows[0])} values")
    arr = _numbers(rows, p, name)
    sd_idx = None
    if header is None:
        patch_col, ch_idx = 0, list(range(1, arr.shape[1]))
    else:
        low = [h.lower() for h in header]
        if "patch" not in low:
            raise ValueError(f"{name}: {p} has a header without a 'patch' column")
        patch_col = low.index("patch")
        try:
            ch_idx, _, sd_idx = _channels(header, {"patch"})
        except ValueError as exc:
            raise ValueError(f"{name}: {p}: {exc}") from None
    if not ch_idx:
        raise ValueError(f"{name}: {p} needs a patch column and one column per channel")
    order = _patch_order(arr[:, patch_col], p, name)
    sigma = None if sd_idx is None else arr[order][:, sd_idx].T
    return arr[order][:, ch_idx].T, sigma


def read_batch_csv(path, *, name: str = "--batch"):
    """Read a batch of charts from one CSV file (see the module docstring).

    Parameters
    ----------
    path : str or pathlib.Path
        The CSV file, header ``chart,patch,<channels>[,<channel>_sd...][,depth_m,distance_m]``.
    name : str, optional
        What error messages call the file (the CLI argument), default ``"--batch"``.

    Returns
    -------
    charts : list of str
        Chart ids, in order of first appearance.
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
        ``name``.
    """
    p, rows = _rows(path, name)
    header = rows[0]
    low = [h.lower() for h in header]
    if low[:2] != ["chart", "patch"]:
        raise ValueError(f"{name}: {p} must start with the columns "
                         "chart,patch,<channels>[,depth_m,distance_m]")
    body = rows[1:]
    if not body:
        raise ValueError(f"{name}: {p} has a header but no values")
    if any(len(r) != len(header) for r in body):
        raise ValueError(f"{name}: every row of {p} needs {len(header)} values")
    ids = [r[0] for r in body]
    arr = _numbers([r[1:] for r in body], p, name)  # patch, channels, extras
    cols = header[1:]
    try:
        ch_idx, _, sd_idx = _channels(cols, {"patch", *BATCH_EXTRA})
    except ValueError as exc:
        raise ValueError(f"{name}: {p}: {exc}") from None
    charts = list(dict.fromkeys(ids))
    ids = np.array(ids, dtype=object)
    n = int(np.sum(ids == charts[0]))
    M = np.empty((len(charts), len(ch_idx), n))
    sigma = None if sd_idx is None else np.empty_like(M)
    extra = {k: np.full(len(charts), np.nan) for k in BATCH_EXTRA}
    for j, c in enumerate(charts):
        sel = arr[ids == c]
        if sel.shape[0] != n:
            raise ValueError(f"{name}: chart {c!r} has {sel.shape[0]} patches, chart "
                             f"{charts[0]!r} has {n}")
        sel = sel[_patch_order(sel[:, 0], p, name, f" (chart {c!r})")]
        M[j] = sel[:, ch_idx].T
        if sigma is not None:
            sigma[j] = sel[:, sd_idx].T
        for k in BATCH_EXTRA:
            if k in cols:
                vals = sel[:, cols.index(k)]
                if np.ptp(vals) > 0:
                    raise ValueError(f"{name}: chart {c!r} has more than one {k} in {p}")
                extra[k][j] = vals[0]
    return charts, M, sigma, extra["depth_m"], extra["distance_m"]


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
    w = csv.writer(buf, lineterminator="\n")
    names = list(RGB) if rgb.shape[0] == 3 else [f"ch{j}" for j in range(rgb.shape[0])]
    sd = [] if sigma is None else [f"{c}_sd" for c in names]
    w.writerow(["patch"] + names + sd)
    for p in range(rgb.shape[1]):
        row = [repr(float(v)) for v in rgb[:, p]]
        if sigma is not None:
            row += [repr(float(v)) for v in np.asarray(sigma)[:, p]]
        w.writerow([p + 1] + row)
    return buf.getvalue()
