"""Wavelength grid, data tables and the spectra of camera, illuminant and chart.

Everything spectral is put on one wavelength grid here, so that the rest of the package works
with plain arrays:

* the model range is 400-700 nm (the phytoplankton basis of ``data/`` stops there);
* tables are resampled with colour-science (:class:`colour.SpectralDistribution` evaluated with
  a linear interpolator: exact at the table's nodes, never overshooting);
* ColorChecker reflectances, camera sensitivities and illuminants come from colour-science
  (``colour.SDS_COLOURCHECKERS``, ``colour.MSDS_CAMERA_SENSITIVITIES``,
  ``colour.SDS_ILLUMINANTS``), or from the caller as arrays on the grid or as CSV files.

References: Blasinski & Farrell, "A Three Parameter Underwater Image Formation Model", eqs 1, 9,
15 (the matrices P, i, R, T); data sources in ``data/README.md``.
"""

from __future__ import annotations

import functools
import os
import sys
from importlib import resources
from pathlib import Path

import numpy as np

from . import validate
from forward.errors import InputError

__all__ = [
    "COLOUR_CACHE",
    "COLOUR_CACHE_COLUMNS",
    "SRGB_CACHE",
    "SRGB_REFERENCE_CHART",
    "DEFAULT_CAMERA",
    "DEFAULT_CHART",
    "DEFAULT_ILLUMINANT",
    "DEFAULT_STEP_NM",
    "LAMBDA_0_NM",
    "MODEL_RANGE_NM",
    "TAIL_FRACTION",
    "WHITE_PATCH",
    "camera_sensitivities",
    "chart_reflectances",
    "cie_1931_cmfs",
    "colour_samples",
    "colour_spectrum",
    "colour_wavelength_range",
    "illuminant_spd",
    "is_path",
    "on_grid",
    "quadrature_weights",
    "read_spectral_csv",
    "read_spectral_table",
    "read_table",
    "reference_chart_linear_srgb",
    "srgb_8bit",
    "resample",
    "wavelength_grid",
]

#: Model wavelength range in nm (inclusive); the basis and pure-water tables cover it.
MODEL_RANGE_NM = (400.0, 700.0)
#: Default grid: 400-700 nm in 1 nm steps (q = 301): the finest the data support, so that the
#: simulator is a continuous world and the estimator's quadrature fits it (decision
#: 0018-spectral-grid). ``wavelengths=np.arange(400, 701, 10)`` gives the paper's coarse bands.
DEFAULT_STEP_NM = 1.0
#: A camera's measured curves that stop inside the grid (the NPL 'Sigma SDMerill' ends at
#: 680 nm) are taken as 0 beyond their last (or before their first) wavelength when every
#: channel there has fallen to at most this fraction of its peak: the camera's IR-cut (or UV)
#: filter has closed, and the integral of eq 1 over the rest of the grid adds nothing. Curves
#: that stop higher are refused (the grid must then stay inside their data).
TAIL_FRACTION = 0.02
#: Reference wavelength of eqs 6, 7, 8, 10, 17 (nm).
LAMBDA_0_NM = 440.0

#: Default camera: a name of ``colour.MSDS_CAMERA_SENSITIVITIES``.
DEFAULT_CAMERA = "Nikon 5100 (NPL)"
#: Default surface illuminant: a name of ``colour.SDS_ILLUMINANTS`` (CIE D65 daylight).
DEFAULT_ILLUMINANT = "D65"
#: Default chart: a name of ``colour.SDS_COLOURCHECKERS`` (24 ColorChecker patches).
DEFAULT_CHART = "BabelColor Average"
#: 0-based index of the white patch in ColorChecker reading order (the default chart's 24
#: patches): the ColorChecker Classic is 4 rows x 6 columns read row by row, and patch 19 --
#: row 4, column 1, "white 9.5 (.05 D)", the first of the grey row 19-24 -- is its white
#: (McCamy, Marcus & Davidson, "A Color-Rendition Chart", J. Appl. Photogr. Eng. 2(3), 1976;
#: ``colour.SDS_COLOURCHECKERS["BabelColor Average"]``, in the same order).
WHITE_PATCH = 18
#: colour-science's spectra used by default, cached in the package data on the 1 nm grid of
#: 400-700 nm (``data/README.md``): importing colour-science costs seconds (it loads its
#: plotting), the table milliseconds. Written by ``python -m experiments.colour_tables`` from
#: colour-science itself; ``tests/test_wait.py`` checks every value against the installed
#: colour-science, so the table cannot outlive its numbers unnoticed.
COLOUR_CACHE = "colour_science_spectra_1nm.csv"
#: (colour-science database, name) -> the cache's columns (ColorChecker: patches 1-24 in order)
COLOUR_CACHE_COLUMNS = {
    ("MSDS_CAMERA_SENSITIVITIES", "Nikon 5100 (NPL)"): ("nikon_5100_npl_r", "nikon_5100_npl_g",
                                                         "nikon_5100_npl_b"),
    ("SDS_ILLUMINANTS", "D65"): ("cie_d65",),
    ("SDS_COLOURCHECKERS", "BabelColor Average"): tuple(f"babelcolor_average_{j:02d}"
                                                        for j in range(1, 25)),
    ("MSDS_CMFS", "CIE 1931 2 Degree Standard Observer"): ("cie_1931_x", "cie_1931_y",
                                                           "cie_1931_z"),
    # the training reflectances of measure.correct_matrix (colour.quality.datasets): CIE 13.3
    # / CIE 1995 test colour samples TCS01-14 and NIST CQS 9.0 samples VS1-15, in order
    ("SDS_TCS", "CIE 1995"): tuple(f"tcs{j:02d}" for j in range(1, 15)),
    ("SDS_VS", "NIST CQS 9.0"): tuple(f"vs{j}" for j in range(1, 16)),
}
#: The databases of ``colour.quality.datasets`` (the others are top-level names of ``colour``)
QUALITY_DATABASES = ("SDS_TCS", "SDS_VS")
#: The cached cameras' data ranges in colour-science, nm (first and last wavelength measured)
COLOUR_CACHE_RANGES_NM = {("MSDS_CAMERA_SENSITIVITIES", "Nikon 5100 (NPL)"): (380.0, 780.0)}
#: colour-science's sRGB for 8-bit images, cached in the package data (``data/README.md``): the
#: CIE XYZ -> linear sRGB matrix and the 255 levels of linear light where the 8-bit code of
#: the sRGB encoding steps up. The previews of ``uw3p measure`` read it instead of importing
#: colour-science (about 1 s, most of it plotting). Written by ``python -m
#: experiments.colour_tables``; ``tests/test_wait.py`` checks it against colour-science.
SRGB_CACHE = "colour_science_srgb.csv"
#: The ColorChecker chromaticities whose linear sRGB :data:`SRGB_CACHE` holds (the chart
#: detection's reference colours)
SRGB_REFERENCE_CHART = "ColorChecker24 - After November 2014"


# --------------------------------------------------------------------------- grid
def wavelength_grid(wavelengths=None) -> np.ndarray:
    """Return the model wavelength grid in nm as a read-only float array.

    Any strictly increasing grid of at least 3 points inside 400-700 nm
    (:data:`MODEL_RANGE_NM`) is accepted, uniform or not.

    Parameters
    ----------
    wavelengths : array_like, shape (q,), optional
        Wavelengths in nm. ``None`` (default) gives 400-700 nm at 1 nm
        (:data:`DEFAULT_STEP_NM`, q = 301); ``np.arange(400, 701, 10)`` gives the paper's 31
        bands.

    Returns
    -------
    numpy.ndarray, shape (q,)
        The grid in nm, read-only (a copy of ``wavelengths``).

    Raises
    ------
    ValueError
        If the grid has fewer than 3 points, is not strictly increasing or leaves 400-700 nm.
    """
    if wavelengths is None:
        wl = np.arange(MODEL_RANGE_NM[0], MODEL_RANGE_NM[1] + 0.5 * DEFAULT_STEP_NM, DEFAULT_STEP_NM)
    else:
        wl = validate.array("wavelengths", wavelengths, ndim=1).copy()
        if wl.size < 3:
            raise InputError("wavelengths", f"need at least 3 wavelengths, got {wl.size}")
        if np.any(np.diff(wl) <= 0):
            raise InputError("wavelengths", "must be strictly increasing")
        lo, hi = MODEL_RANGE_NM
        if wl[0] < lo - 1e-9 or wl[-1] > hi + 1e-9:
            raise InputError(
                "wavelengths", f"grid {wl[0]:g}-{wl[-1]:g} nm leaves the model range "
                f"{lo:g}-{hi:g} nm (the pure-water and phytoplankton tables end there)"
            )
    wl.setflags(write=False)
    return wl


def quadrature_weights(wavelengths) -> np.ndarray:
    """Trapezoid weights (nm) that turn the integral of eq 1 into a sum over the grid.

    Parameters
    ----------
    wavelengths : array_like, shape (q,)
        Strictly increasing wavelengths in nm (at least 2).

    Returns
    -------
    numpy.ndarray, shape (q,)
        Weights in nm: half the step at the ends, the mean of the two neighbouring steps
        inside, so that ``sum(w * f)`` approximates the integral of f d lambda.

    References
    ----------
    Blasinski & Farrell, eq 1 (m = integral of p(lambda) rho(lambda) d lambda).
    """
    wl = np.asarray(wavelengths, dtype=float)
    w = np.empty_like(wl)
    d = np.diff(wl)
    w[0] = d[0] / 2
    w[-1] = d[-1] / 2
    w[1:-1] = (d[:-1] + d[1:]) / 2
    return w


# --------------------------------------------------------------------------- tables
def _data_dir():
    return resources.files("uw3p_data")


@functools.cache
def read_table(filename: str) -> tuple[tuple[str, ...], tuple[tuple[str, ...], ...]]:
    """Read a CSV table of ``data/`` as column names and rows of strings.

    Lines starting with '#' (the header comments) and blank lines are skipped; the first
    remaining line gives the column names. The result is cached.

    Parameters
    ----------
    filename : str
        File name inside the ``uw3p_data`` package (the repository's ``data/``), e.g.
        ``'particle_scattering_table1.csv'``.

    Returns
    -------
    names : tuple of str
        Column names (stripped).
    rows : tuple of tuple of str
        The data rows, each a tuple of the raw (unstripped) fields; immutable, as the result is
        shared by every caller.
    """
    text = (_data_dir() / filename).read_text(encoding="utf-8")
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    names = tuple(s.strip() for s in lines[0].split(","))
    rows = tuple(tuple(ln.split(",")) for ln in lines[1:])
    return names, rows


@functools.cache
def read_spectral_table(filename: str) -> tuple[np.ndarray, np.ndarray]:
    """Return the wavelengths and values of a spectral table of ``data/``.

    The result is cached and its arrays are read-only.

    Parameters
    ----------
    filename : str
        File name inside the ``uw3p_data`` package; first column wavelength in nm, further
        columns values (read with :func:`read_table`).

    Returns
    -------
    wavelengths : numpy.ndarray, shape (n,)
        Wavelengths in nm.
    values : numpy.ndarray, shape (n, k)
        One column per value column of the table (2-D even for one column), in the table's unit
        (e.g. m^-1 for pure-water absorption).
    """
    _, rows = read_table(filename)
    arr = np.array(rows, dtype=float)
    wl, vals = arr[:, 0], arr[:, 1:]
    wl.setflags(write=False)
    vals.setflags(write=False)
    return wl, vals


def read_spectral_csv(path, *, name: str) -> tuple[np.ndarray, np.ndarray]:
    """Read a user CSV: first column wavelength in nm, further columns values.

    Read by the package's one CSV reader (:class:`forward.csvtable.Table`): comma, semicolon or
    tab separated (detected), a decimal comma in a semicolon- or tab-separated file, ``#``
    comment lines and blank lines before the first row skipped, a first row that is not all
    numbers taken as the header. ``400;0,12;0,45;0,33`` is a wavelength and three values.

    Parameters
    ----------
    path : str or os.PathLike
        The CSV file.
    name : str
        The argument's name, used at the start of every error message.

    Returns
    -------
    wavelengths : numpy.ndarray, shape (n,)
        Strictly increasing wavelengths in nm.
    values : numpy.ndarray, shape (n, k)
        The value columns (k >= 1), in the file's unit.

    Raises
    ------
    ValueError
        If the file is missing, has no numeric rows, a cell that is not a number (its line and
        column named), a row whose number of fields differs from the first's (its line named),
        no value column, non-finite values or non-increasing wavelengths.
    """
    from .csvtable import Table

    table = Table(path, name)
    p, width = table.path, len(table.first)
    if width < 2:
        raise InputError(name, f"{p} must have a wavelength column and >= 1 value column")
    rows = []
    for k, (line, row) in enumerate(table.numbered()):
        if k == 0 and table.header is not None:
            continue
        if len(row) != width:
            raise InputError(name, f"{p} line {line}: {len(row)} fields, the first row has "
                             f"{width} (separator {table.delimiter!r})")
        rows.append([table.number(x, line, j + 1) for j, x in enumerate(row)])
    if not rows:
        raise InputError(name, f"no numeric rows in {p}")
    arr = validate.array(name, rows, ndim=2)
    wl = arr[:, 0]
    if np.any(np.diff(wl) <= 0):
        raise InputError(name, f"wavelengths in {p} must be strictly increasing")
    return wl, arr[:, 1:]


def resample(src_wavelengths, values, wavelengths, *, name: str, tail: float | None = None) -> np.ndarray:
    """Resample tabulated spectra (rows = wavelengths) onto ``wavelengths``, linearly.

    Each column is evaluated as colour-science evaluates a :class:`colour.SpectralDistribution`
    with its ``LinearInterpolator`` -- which is ``numpy.interp``, called here directly so that
    resampling the package's own tables does not import colour-science (seconds; the numbers
    are the same bit for bit, ``tests/test_wait.py``): exact at the table's nodes, never
    overshooting.

    Parameters
    ----------
    src_wavelengths : array_like, shape (n,)
        The table's wavelengths in nm, strictly increasing.
    values : array_like, shape (n,) or (n, k)
        The table's values (any unit; kept).
    wavelengths : array_like, shape (q,)
        The target grid in nm; must lie inside the table's range, unless ``tail`` allows an
        end to be extended by zeros.
    name : str
        The argument's name, used at the start of the error message.
    tail : float, optional
        Grid points beyond an end of the table are 0 when every column has fallen there to at
        most ``tail`` times its peak (e.g. :data:`TAIL_FRACTION` for a camera's curves).
        Default (None): the table must cover the grid.

    Returns
    -------
    numpy.ndarray, shape (q,) or (q, k)
        The values on ``wavelengths`` (1-D when ``values`` is).

    Raises
    ------
    ValueError
        Naming ``name``, when the table does not cover the grid (and, with ``tail``, has not
        fallen to zero at the end it misses). The message gives the data's range.
    """
    src = np.asarray(src_wavelengths, dtype=float)
    vals = np.asarray(values, dtype=float)
    wl = np.asarray(wavelengths, dtype=float)
    inside = (wl >= src[0] - 1e-9) & (wl <= src[-1] + 1e-9)
    if not inside.all():
        v2 = np.abs(vals.reshape(vals.shape[0], -1))
        peak = np.where(v2.max(axis=0) > 0, v2.max(axis=0), 1.0)
        ends = []  # the table's ends the grid goes beyond, with the largest relative value there
        if wl[0] < src[0] - 1e-9:
            ends.append((src[0], float(np.max(v2[0] / peak))))
        if wl[-1] > src[-1] + 1e-9:
            ends.append((src[-1], float(np.max(v2[-1] / peak))))
        high = [(w, f) for w, f in ends if tail is None or f > tail]
        if high or not inside.any():
            lo, hi = max(src[0], MODEL_RANGE_NM[0]), min(src[-1], MODEL_RANGE_NM[1])
            why = "" if tail is None or not high else (
                f", and its values at {high[0][0]:g} nm are still {100 * high[0][1]:.0f} % of "
                f"their peak (taken as 0 beyond the data only below {100 * tail:g} %)")
            raise InputError(
                name, f"data cover {src[0]:g}-{src[-1]:g} nm but the wavelength grid is "
                f"{wl[0]:g}-{wl[-1]:g} nm{why}; use a grid inside the data ({lo:g}-{hi:g} nm)"
            )
        out = np.zeros((wl.size,) + vals.shape[1:])
        out[inside] = resample(src, vals, wl[inside], name=name)
        return out
    one_d = vals.ndim == 1
    vals2 = vals[:, None] if one_d else vals
    out = np.empty((wl.size, vals2.shape[1]))
    for j in range(vals2.shape[1]):  # colour.LinearInterpolator's evaluation
        out[:, j] = np.interp(wl, src, vals2[:, j])
    return out[:, 0] if one_d else out


@functools.lru_cache(maxsize=32)
def _cmfs(wl_key: tuple) -> np.ndarray:
    return _named("MSDS_CMFS", "wavelengths", "CIE 1931 2 Degree Standard Observer", wl_key)


def cie_1931_cmfs(wavelengths=None) -> np.ndarray:
    """CIE 1931 2-degree colour-matching functions (x_bar, y_bar, z_bar) on the grid.

    Taken from colour-science (``colour.MSDS_CMFS['CIE 1931 2 Degree Standard Observer']``),
    cached per grid.

    Parameters
    ----------
    wavelengths : array_like, shape (q,), optional
        Wavelengths in nm (default: :func:`wavelength_grid`'s 400-700 nm at 1 nm).

    Returns
    -------
    numpy.ndarray, shape (q, 3)
        The columns x_bar, y_bar, z_bar (y_bar is the photopic luminous efficiency V(lambda)); read-only,
        shared by every caller with the same grid.

    References
    ----------
    CIE 1931 2-degree standard colorimetric observer (CIE 015:2018, Colorimetry).
    """
    return _cmfs(tuple(wavelength_grid(wavelengths)))


# --------------------------------------------------------------------------- user spectra
def is_path(x) -> bool:
    """Whether ``x`` names a file: a string or path ending in .csv / .txt, or an existing file.

    Parameters
    ----------
    x : object
        Any argument that may be a name, an array or a file.

    Returns
    -------
    bool
        True for a ``str`` or :class:`os.PathLike` that ends in '.csv' or '.txt' (any case) or
        names an existing file; False otherwise.
    """
    return isinstance(x, (str, os.PathLike)) and (
        str(x).lower().endswith((".csv", ".txt")) or Path(x).is_file()
    )


def _is_colour(obj, cls: str) -> bool:
    """``isinstance(obj, colour.<cls>)`` without importing colour-science: an object of its
    classes exists only once it is imported."""
    mod = sys.modules.get("colour")
    return mod is not None and isinstance(obj, getattr(mod, cls))


def _from_colour(obj, wl, name, tail=None):
    """Resample a colour-science (Multi)SpectralDistribution onto the grid (``tail``: as
    :func:`resample`)."""
    vals = np.asarray(obj.values, dtype=float)
    return resample(obj.wavelengths, vals, wl, name=name, tail=tail)


def on_grid(value, wl, name, ncols):
    """Check a user array given on the wavelength grid (rows = wavelengths).

    Parameters
    ----------
    value : array_like, shape (q,) or (q, ncols)
        Nonnegative, finite values (a 1-D array is accepted when ``ncols`` is 1).
    wl : numpy.ndarray, shape (q,)
        The wavelength grid in nm.
    name : str
        The argument's name, used at the start of every error message.
    ncols : int or None
        Required number of columns; ``None`` allows any.

    Returns
    -------
    numpy.ndarray, shape (q, ncols)
        ``value`` as a 2-D float array.

    Raises
    ------
    ValueError
        If ``value`` is not finite and nonnegative or does not have one row per wavelength (and
        ``ncols`` columns).
    """
    arr = validate.array(name, value, nonnegative=True)
    if arr.ndim == 1 and ncols == 1:
        arr = arr[:, None]
    if arr.ndim != 2 or arr.shape[0] != wl.size or (ncols is not None and arr.shape[1] != ncols):
        want = f"({wl.size}, {ncols if ncols else 'n'})"
        raise InputError(
            name, f"an array must be given on the wavelength grid with shape {want}, got {arr.shape}"
        )
    return arr


@functools.cache
def _colour_cache() -> tuple[np.ndarray, dict]:
    """The cached colour-science table: its grid (nm) and column name -> values (read-only)."""
    names, _ = read_table(COLOUR_CACHE)
    wl, vals = read_spectral_table(COLOUR_CACHE)
    return wl, {name: vals[:, j] for j, name in enumerate(names[1:])}


@functools.cache
def _srgb_table() -> dict:
    """:data:`SRGB_CACHE` as quantity -> its values in index order (read-only arrays)."""
    _, rows = read_table(SRGB_CACHE)
    items = {}
    for quantity, index, value in rows:
        items.setdefault(quantity.strip(), []).append((int(index), float(value)))
    out = {}
    for quantity, pairs in items.items():
        arr = np.array([v for _, v in sorted(pairs)])
        arr.setflags(write=False)
        out[quantity] = arr
    return out


def srgb_8bit() -> tuple[np.ndarray, np.ndarray]:
    """colour-science's sRGB (IEC 61966-2-1, D65) for 8-bit images, from :data:`SRGB_CACHE`.

    Returns
    -------
    xyz_to_rgb : numpy.ndarray, (3, 3)
        CIE XYZ -> linear sRGB, ``colour.RGB_COLOURSPACES['sRGB'].matrix_XYZ_to_RGB``.
    levels : numpy.ndarray, (255,)
        Linear light where the 8-bit code of the sRGB encoding reaches k = 1..255
        (``levels[k - 1]`` is colour-science's ``cctf_decoding((k - 0.5) / 255)``, to the
        ulp by which numpy's power differs between CPUs). For float32
        x (the previews' type) ``numpy.searchsorted(levels, x, side='right')`` is, to the last
        bit, the rounded code round(255 cctf_encoding(clip(x, 0, 1))); for float64 x within
        an ulp or so of a level it may differ by one. NaN sorts above every level (code 255).

    Both arrays are read-only (the table is read once).

    References
    ----------
    IEC 61966-2-1:1999, Multimedia systems and equipment - Colour measurement and management -
    Default RGB colour space - sRGB.
    """
    table = _srgb_table()
    matrix = table["xyz_to_srgb"].reshape(3, 3)
    levels = table["encoding_8bit_level"]
    if levels.shape != (255,) or np.any(np.diff(levels) <= 0):
        raise RuntimeError(f"{SRGB_CACHE}: expected 255 increasing levels (the package's data "
                           "table is damaged: reinstall uw3p)")
    return matrix, levels


def reference_chart_linear_srgb() -> np.ndarray:
    """Linear sRGB (D65) of colour-science's :data:`SRGB_REFERENCE_CHART` chromaticities, from
    :data:`SRGB_CACHE`: the reference colours of the chart detection (``measure.detect``).

    Returns
    -------
    numpy.ndarray, (24, 3)
        Patches in reading order; read-only. colour-science's ``XYZ_to_RGB(xyY_to_XYZ(xyY),
        'sRGB', illuminant, apply_cctf_encoding=False)`` of
        ``CCS_COLOURCHECKERS[SRGB_REFERENCE_CHART]``.
    """
    return _srgb_table()["reference_chart_linear_srgb"].reshape(24, 3)


def _cached(database: str, name: str, wl: np.ndarray):
    """The spectrum from :data:`COLOUR_CACHE` when it holds it and every grid point is one of
    its nodes (colour-science's resampling is linear between the source's nodes, or the source
    is tabulated at every 1 nm node, so a node's value does not depend on the rest of the
    grid); else None."""
    columns = COLOUR_CACHE_COLUMNS.get((database, name))
    if columns is None:
        return None
    grid, table = _colour_cache()
    idx = np.clip(np.searchsorted(grid, wl), 0, grid.size - 1)
    if not np.array_equal(grid[idx], wl):
        return None
    out = np.stack([table[c][idx] for c in columns], axis=1)
    return out[:, 0] if database == "SDS_ILLUMINANTS" else out


def colour_spectrum(database: str, name: str, wavelengths=None, *, arg: str = "name"):
    """A colour-science spectrum (``colour.<database>[name]``) resampled onto the grid, always
    from colour-science itself (never the cache; what :data:`COLOUR_CACHE` is made of).

    Parameters
    ----------
    database : str
        ``'MSDS_CAMERA_SENSITIVITIES'``, ``'SDS_ILLUMINANTS'``, ``'SDS_COLOURCHECKERS'``,
        ``'MSDS_CMFS'``, or ``'SDS_TCS'`` / ``'SDS_VS'`` (``colour.quality.datasets``: sets of
        samples, stacked like a chart).
    name : str
        A name of that database.
    wavelengths : array_like, shape (q,), optional
        Wavelengths in nm (default: 400-700 nm at 1 nm).
    arg : str, optional
        The argument's name in error messages.

    Returns
    -------
    numpy.ndarray
        (q,) for an illuminant; (q, k) otherwise (a chart: its patches in order), in the
        database's units.

    Raises
    ------
    ValueError
        Naming ``arg``, for an unknown name or a table that does not cover the grid.
    """
    import colour

    db = getattr(colour.quality.datasets if database in QUALITY_DATABASES else colour, database)
    if name not in db:
        raise InputError(arg, f"unknown name {name!r}; known: {sorted(db.keys())}")
    wl = wavelength_grid(wavelengths)
    entry = db[name]
    if database == "MSDS_CMFS":  # colour-science's own interpolation of the observer
        return np.asarray(entry[wl], dtype=float)
    if not hasattr(entry, "wavelengths"):  # a ColorChecker (a mapping): its patches in order
        return np.stack([_from_colour(sd, wl, arg) for sd in entry.values()], axis=1)
    tail = TAIL_FRACTION if database == "MSDS_CAMERA_SENSITIVITIES" else None
    return _from_colour(entry, wl, arg, tail)


def colour_wavelength_range(database: str, name: str) -> tuple[float, float]:
    """First and last wavelength (nm) of a colour-science spectrum's data, without importing
    colour-science for the cached cameras (:data:`COLOUR_CACHE_RANGES_NM`).

    Parameters
    ----------
    database : str
        A colour-science database, e.g. ``'MSDS_CAMERA_SENSITIVITIES'``.
    name : str
        A name of that database.

    Returns
    -------
    tuple of float
        (first, last) wavelength of the data, nm.

    Raises
    ------
    KeyError
        For a name that is not in the database.
    """
    known = COLOUR_CACHE_RANGES_NM.get((database, name))
    if known is not None:
        return known
    import colour

    wl = getattr(colour, database)[name].wavelengths
    return float(wl[0]), float(wl[-1])


@functools.lru_cache(maxsize=64)
def _named(database: str, arg: str, name: str, wl_key: tuple) -> np.ndarray:
    """A colour-science spectrum (``colour.<database>[name]``) resampled onto the grid, cached
    (from :data:`COLOUR_CACHE` when it holds it); for a chart database the (q, n) stack of its
    patches. ``arg`` names the argument."""
    wl = np.array(wl_key)
    out = _cached(database, name, wl)
    if out is None:
        out = colour_spectrum(database, name, wl, arg=arg)
    out.setflags(write=False)  # cached: read-only
    return out


def colour_samples(database: str, name: str, wavelengths=None) -> tuple:
    """A set of colour-science reflectance samples on the grid, from :data:`COLOUR_CACHE` when
    it holds the set (no colour-science import), else from colour-science.

    Parameters
    ----------
    database : str
        ``'SDS_COLOURCHECKERS'``, ``'SDS_TCS'`` or ``'SDS_VS'``.
    name : str
        A name of that database, e.g. ``'CIE 1995'``.
    wavelengths : array_like, shape (q,), optional
        Wavelengths in nm (default: 400-700 nm at 1 nm).

    Returns
    -------
    samples : tuple of str
        The samples' names, ``'<name> <sample>'`` (e.g. 'CIE 1995 TCS01'); for a set the cache
        does not hold, ``'<name> <k>'`` from 1.
    reflectances : numpy.ndarray, (q, k)
        Read-only, the samples in the set's order.
    """
    wl = wavelength_grid(wavelengths)
    refl = _named(database, "name", name, tuple(wl))
    columns = COLOUR_CACHE_COLUMNS.get((database, name)) or range(1, refl.shape[1] + 1)
    return tuple(f"{name} {str(c).upper()}" for c in columns), refl


def camera_sensitivities(camera=DEFAULT_CAMERA, wavelengths=None, *,
                         normalise: bool = True) -> np.ndarray:
    """Camera spectral sensitivities on the grid, (q, m), each channel scaled to peak 1.

    These are the columns of P in eq 15 (before quadrature): the p(lambda) of eq 1. Negative
    values are clipped to 0; a channel that is zero on the grid stays zero. Measured curves
    that stop inside the grid, having fallen there to at most :data:`TAIL_FRACTION` of their
    peak (the NPL 'Sigma SDMerill' at 680 nm), are 0 beyond their data, so every built-in camera
    works on the default grid.

    Parameters
    ----------
    camera : str, os.PathLike, colour.MultiSpectralDistributions or array_like
        A name of ``colour.MSDS_CAMERA_SENSITIVITIES`` (default 'Nikon 5100 (NPL)',
        :data:`DEFAULT_CAMERA`), a :class:`colour.MultiSpectralDistributions`, a CSV file
        (wavelength in nm, one column per channel) or an array (q, m) on the grid.
    wavelengths : array_like, shape (q,), optional
        Wavelengths in nm (default: 400-700 nm at 1 nm).
    normalise : bool, optional
        True (default): each channel scaled to peak 1. False: the curves as given (negative
        values clipped), so their channel balance is kept (measured curves such as the Canon
        G7X's carry it; ``measure.camera_setup`` uses it).

    Returns
    -------
    numpy.ndarray, shape (q, m)
        Relative sensitivities (dimensionless), each channel's maximum on the grid 1 (or the
        curves' own values with ``normalise=False``).

    Raises
    ------
    ValueError
        For an unknown name, a table that does not cover the grid (and has not fallen to zero
        where it stops), an array of the wrong shape or with negative values, or when every
        channel is zero on the grid.

    References
    ----------
    Blasinski & Farrell, eqs 1 and 15 (p(lambda), the matrix P).
    """
    wl = wavelength_grid(wavelengths)
    if isinstance(camera, str) and not is_path(camera):
        sens = _named("MSDS_CAMERA_SENSITIVITIES", "camera", camera, tuple(wl)).copy()
    elif is_path(camera):
        sens = resample(*read_spectral_csv(camera, name="camera"), wl, name="camera",
                        tail=TAIL_FRACTION)
    elif _is_colour(camera, "MultiSpectralDistributions"):
        sens = _from_colour(camera, wl, "camera", TAIL_FRACTION)
    else:
        sens = on_grid(camera, wl, "camera", None)
    sens = np.clip(sens, 0.0, None)
    peak = sens.max(axis=0)
    if np.all(peak <= 0):
        raise InputError("camera", "all channels are zero on the wavelength grid")
    if not normalise:
        return sens
    # a channel that is zero on the grid stays zero (a legitimate, if useless, channel)
    return sens / np.where(peak > 0, peak, 1.0)




def illuminant_spd(illuminant=None, wavelengths=None) -> np.ndarray:
    """Relative spectral power distribution of the surface illuminant i on the grid, (q,).

    Scaled so that its maximum on the grid is 1 (the absolute level is the sensor's
    ``illuminance_lux``, :class:`forward.SensorSettings`).

    Parameters
    ----------
    illuminant : str, os.PathLike, colour.SpectralDistribution or array_like, optional
        ``None`` (default) means CIE D65 (:data:`DEFAULT_ILLUMINANT`). A name of
        ``colour.SDS_ILLUMINANTS``, a :class:`colour.SpectralDistribution`, a CSV file
        (wavelength in nm, values in the first value column) or an array (q,) on the grid.
    wavelengths : array_like, shape (q,), optional
        Wavelengths in nm (default: 400-700 nm at 1 nm).

    Returns
    -------
    numpy.ndarray, shape (q,)
        The relative SPD i (dimensionless), maximum 1, negative values clipped to 0.

    Raises
    ------
    ValueError
        For an unknown name, a table that does not cover the grid, an array of the wrong shape
        or with negative values, or an illuminant that is zero everywhere on the grid.

    References
    ----------
    Blasinski & Farrell, eqs 3 and 15 (i(lambda), the diag(i) of eq 15).
    """
    wl = wavelength_grid(wavelengths)
    if illuminant is None:
        illuminant = DEFAULT_ILLUMINANT
    if isinstance(illuminant, str) and not is_path(illuminant):
        spd = _named("SDS_ILLUMINANTS", "illuminant", illuminant, tuple(wl)).copy()
    elif is_path(illuminant):
        spd = resample(*read_spectral_csv(illuminant, name="illuminant"), wl, name="illuminant")[:, 0]
    elif _is_colour(illuminant, "SpectralDistribution"):
        spd = _from_colour(illuminant, wl, "illuminant")
    else:
        spd = on_grid(illuminant, wl, "illuminant", 1)[:, 0]
    if spd.max() <= 0:
        raise InputError("illuminant", "is zero everywhere on the wavelength grid")
    return np.clip(spd, 0, None) / spd.max()


def chart_reflectances(reflectances=None, wavelengths=None) -> np.ndarray:
    """Surface reflectances R on the grid, (q, n); default: the 24 'BabelColor Average' patches.

    Patches are in the chart's reading order (row by row, 4 x 6 for a ColorChecker; the white
    is :data:`WHITE_PATCH`).

    Parameters
    ----------
    reflectances : str, os.PathLike, dict, list, colour.MultiSpectralDistributions or array_like, optional
        ``None`` (default) means 'BabelColor Average' (:data:`DEFAULT_CHART`). A name of
        ``colour.SDS_COLOURCHECKERS``, a dict or list of :class:`colour.SpectralDistribution`,
        a :class:`colour.MultiSpectralDistributions`, a CSV file (wavelength in nm, one column
        per patch) or an array (q, n) on the grid.
    wavelengths : array_like, shape (q,), optional
        Wavelengths in nm (default: 400-700 nm at 1 nm).

    Returns
    -------
    numpy.ndarray, shape (q, n)
        Reflectance factors (dimensionless, 0-1 for real surfaces), one column per patch.

    Raises
    ------
    ValueError
        For an unknown name, a table that does not cover the grid, an array of the wrong shape
        or negative reflectances.

    References
    ----------
    Blasinski & Farrell, eqs 3 and 15 (r(lambda), the matrix R).
    McCamy, Marcus & Davidson, "A Color-Rendition Chart", J. Appl. Photogr. Eng. 2(3), 1976.
    """
    wl = wavelength_grid(wavelengths)
    if reflectances is None:
        reflectances = DEFAULT_CHART
    if isinstance(reflectances, str) and not is_path(reflectances):
        refl = _named("SDS_COLOURCHECKERS", "reflectances", reflectances, tuple(wl)).copy()
    elif is_path(reflectances):
        refl = resample(*read_spectral_csv(reflectances, name="reflectances"), wl, name="reflectances")
    elif _is_colour(reflectances, "MultiSpectralDistributions"):
        refl = _from_colour(reflectances, wl, "reflectances")
    elif isinstance(reflectances, dict) or (
        isinstance(reflectances, (list, tuple))
        and reflectances
        and _is_colour(reflectances[0], "SpectralDistribution")
    ):
        sds = list(reflectances.values()) if isinstance(reflectances, dict) else list(reflectances)
        refl = np.stack([_from_colour(sd, wl, "reflectances") for sd in sds], axis=1)
    else:
        refl = on_grid(reflectances, wl, "reflectances", None)
    if np.any(refl < 0):
        raise InputError("reflectances", "contain negative values")
    return refl
