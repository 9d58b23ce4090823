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
from importlib import resources
from pathlib import Path

import numpy as np

from . import validate

#: Model wavelength range in nm (inclusive); the basis and pure-water tables cover it.
MODEL_RANGE_NM = (400.0, 700.0)
#: Default grid: 400-700 nm in 1 nm steps (q = 301): the finest the data support, so that the
#: simulator is a continuous world and the estimator's quadrature fits it (DECISIONS.md,
#: "Spectral grid"). ``wavelengths=np.arange(400, 701, 10)`` gives the paper's coarse bands.
DEFAULT_STEP_NM = 1.0
#: Reference wavelength of eqs 6, 7, 8, 10, 17 (nm).
LAMBDA_0_NM = 440.0

DEFAULT_CAMERA = "Nikon 5100 (NPL)"
DEFAULT_ILLUMINANT = "D65"
DEFAULT_CHART = "BabelColor Average"
#: 0-based index of the white patch in ColorChecker reading order (the default chart's 24
#: patches): the ColorChecker Classic is 4 rows x 6 columns read row by row, and patch 19 --
#: row 4, column 1, "white 9.5 (.05 D)", the first of the grey row 19-24 -- is its white
#: (McCamy, Marcus & Davidson, "A Color-Rendition Chart", J. Appl. Photogr. Eng. 2(3), 1976;
#: ``colour.SDS_COLOURCHECKERS["BabelColor Average"]``, in the same order).
WHITE_PATCH = 18


# --------------------------------------------------------------------------- grid
def wavelength_grid(wavelengths=None) -> np.ndarray:
    """Return the model wavelength grid in nm as a read-only float array.

    ``None`` gives 400-700 nm at 1 nm (:data:`DEFAULT_STEP_NM`). Any strictly increasing grid of at least 3 points inside
    400-700 nm is accepted (uniform or not).
    """
    if wavelengths is None:
        wl = np.arange(MODEL_RANGE_NM[0], MODEL_RANGE_NM[1] + 0.5 * DEFAULT_STEP_NM, DEFAULT_STEP_NM)
    else:
        wl = validate.array("wavelengths", wavelengths, ndim=1).copy()
        if wl.size < 3:
            raise ValueError(f"wavelengths: need at least 3 wavelengths, got {wl.size}")
        if np.any(np.diff(wl) <= 0):
            raise ValueError("wavelengths: must be strictly increasing")
        lo, hi = MODEL_RANGE_NM
        if wl[0] < lo - 1e-9 or wl[-1] > hi + 1e-9:
            raise ValueError(
                f"wavelengths: grid {wl[0]:g}-{wl[-1]:g} nm leaves the model range "
                f"{lo:g}-{hi:g} nm (the pure-water and phytoplankton tables end there)"
            )
    wl.setflags(write=False)
    return wl


def quadrature_weights(wavelengths) -> np.ndarray:
    """Trapezoid weights (nm) that turn the integral of eq 1 into a sum over the grid."""
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


@functools.lru_cache(maxsize=None)
def read_table(filename: str) -> tuple[tuple[str, ...], tuple[tuple[str, ...], ...]]:
    """Read a CSV table of ``data/``: returns (column names, rows of strings), both immutable
    tuples (the result is cached); '#' lines are the header."""
    text = (_data_dir() / filename).read_text(encoding="utf-8")
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    names = tuple(s.strip() for s in lines[0].split(","))
    rows = tuple(tuple(ln.split(",")) for ln in lines[1:])
    return names, rows


@functools.lru_cache(maxsize=None)
def read_spectral_table(filename: str) -> tuple[np.ndarray, np.ndarray]:
    """Return (wavelength_nm, values) of a spectral table of ``data/`` (values 2-D, one column each)."""
    _, rows = read_table(filename)
    arr = np.array(rows, dtype=float)
    wl, vals = arr[:, 0], arr[:, 1:]
    wl.setflags(write=False)
    vals.setflags(write=False)
    return wl, vals


def read_spectral_csv(path, *, name: str) -> tuple[np.ndarray, np.ndarray]:
    """Read a user CSV: first column wavelength in nm, further columns values; '#' lines ignored.

    A first non-comment line that is not numeric is taken as a header.
    """
    p = Path(path)
    if not p.is_file():
        raise ValueError(f"{name}: file not found: {p}")
    rows = []
    for ln in p.read_text(encoding="utf-8").splitlines():
        if not ln.strip() or ln.lstrip().startswith("#"):
            continue
        parts = [s.strip() for s in ln.replace(";", ",").split(",")]
        try:
            rows.append([float(s) for s in parts])
        except ValueError:
            if rows:
                raise ValueError(f"{name}: non-numeric row in {p}: {ln!r}") from None
            continue  # header
    if not rows:
        raise ValueError(f"{name}: no numeric rows in {p}")
    if len({len(r) for r in rows}) != 1 or len(rows[0]) < 2:
        raise ValueError(f"{name}: {p} must have a wavelength column and >= 1 value column in every row")
    arr = validate.array(name, rows, ndim=2)
    wl = arr[:, 0]
    if np.any(np.diff(wl) <= 0):
        raise ValueError(f"{name}: wavelengths in {p} must be strictly increasing")
    return wl, arr[:, 1:]


def resample(src_wavelengths, values, wavelengths, *, name: str) -> np.ndarray:
    """Resample tabulated spectra (rows = wavelengths) onto ``wavelengths`` with colour-science.

    Raises ``ValueError`` naming ``name`` when the table does not cover the grid.
    """
    import colour

    src = np.asarray(src_wavelengths, dtype=float)
    vals = np.asarray(values, dtype=float)
    wl = np.asarray(wavelengths, dtype=float)
    if wl[0] < src[0] - 1e-9 or wl[-1] > src[-1] + 1e-9:
        raise ValueError(
            f"{name}: data cover {src[0]:g}-{src[-1]:g} nm but the wavelength grid is "
            f"{wl[0]:g}-{wl[-1]:g} nm; choose a grid inside the data (e.g. wavelengths="
            f"np.arange({max(src[0], 400):g}, {min(src[-1], 700) + 1:g}, 10))"
        )
    one_d = vals.ndim == 1
    vals2 = vals[:, None] if one_d else vals
    out = np.empty((wl.size, vals2.shape[1]))
    for j in range(vals2.shape[1]):
        sd = colour.SpectralDistribution(vals2[:, j], src, interpolator=colour.LinearInterpolator)
        out[:, j] = sd[wl]
    return out[:, 0] if one_d else out


@functools.lru_cache(maxsize=32)
def _cmfs(wl_key: tuple) -> np.ndarray:
    import colour

    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    out = np.asarray(cmfs[np.array(wl_key)], dtype=float)
    out.setflags(write=False)
    return out


def cie_1931_cmfs(wavelengths=None) -> np.ndarray:
    """CIE 1931 2-degree colour-matching functions (x_bar, y_bar, z_bar) on the grid, (q, 3),
    from colour-science (cached per grid)."""
    return _cmfs(tuple(wavelength_grid(wavelengths)))


# --------------------------------------------------------------------------- user spectra
def is_path(x) -> bool:
    return isinstance(x, (str, os.PathLike)) and (
        str(x).lower().endswith((".csv", ".txt")) or Path(x).is_file()
    )


def _from_colour(obj, wl, name):
    """Resample a colour-science (Multi)SpectralDistribution onto the grid."""
    vals = np.asarray(obj.values, dtype=float)
    return resample(obj.wavelengths, vals, wl, name=name)


def on_grid(value, wl, name, ncols):
    arr = validate.array(name, value, nonnegative=True)
    if arr.ndim == 1 and ncols == 1:
        arr = arr[:, None]
    if arr.ndim != 2 or arr.shape[0] != wl.size or (ncols is not None and arr.shape[1] != ncols):
        want = f"({wl.size}, {ncols if ncols else 'n'})"
        raise ValueError(
            f"{name}: an array must be given on the wavelength grid with shape {want}, got {arr.shape}"
        )
    return arr


@functools.lru_cache(maxsize=64)
def _named(database: str, arg: str, name: str, wl_key: tuple) -> np.ndarray:
    """A colour-science spectrum (``colour.<database>[name]``) resampled onto the grid, cached;
    for a chart database the (q, n) stack of its patches. ``arg`` names the argument."""
    import colour

    db = getattr(colour, database)
    if name not in db:
        raise ValueError(f"{arg}: unknown name {name!r}; known: {sorted(db.keys())}")
    wl = np.array(wl_key)
    entry = db[name]
    if not hasattr(entry, "wavelengths"):  # a ColorChecker (a mapping): its patches in order
        out = np.stack([_from_colour(sd, wl, arg) for sd in entry.values()], axis=1)
    else:
        out = _from_colour(entry, wl, arg)
    out.setflags(write=False)  # cached: read-only
    return out


def camera_sensitivities(camera=DEFAULT_CAMERA, wavelengths=None) -> np.ndarray:
    """Camera spectral sensitivities on the grid, (q, m), each channel scaled to peak 1.

    ``camera``: a name of ``colour.MSDS_CAMERA_SENSITIVITIES`` (default 'Nikon 5100 (NPL)'), a
    :class:`colour.MultiSpectralDistributions`, a CSV file (wavelength, one column per channel)
    or an array (q, m) on the grid. These are the columns of P in eq 15 (before quadrature).
    """
    import colour

    wl = wavelength_grid(wavelengths)
    if isinstance(camera, str) and not is_path(camera):
        sens = _named("MSDS_CAMERA_SENSITIVITIES", "camera", camera, tuple(wl)).copy()
    elif is_path(camera):
        sens = resample(*read_spectral_csv(camera, name="camera"), wl, name="camera")
    elif isinstance(camera, colour.MultiSpectralDistributions):
        sens = _from_colour(camera, wl, "camera")
    else:
        sens = on_grid(camera, wl, "camera", None)
    sens = np.clip(sens, 0.0, None)
    peak = sens.max(axis=0)
    if np.all(peak <= 0):
        raise ValueError("camera: all channels are zero on the wavelength grid")
    # a channel that is zero on the grid stays zero (a legitimate, if useless, channel)
    return sens / np.where(peak > 0, peak, 1.0)




def illuminant_spd(illuminant=None, wavelengths=None) -> np.ndarray:
    """Relative spectral power distribution of the surface illuminant i on the grid, (q,).

    ``None`` means CIE D65. A name of ``colour.SDS_ILLUMINANTS``, a
    :class:`colour.SpectralDistribution`, a CSV file or an array (q,) on the grid. Scaled so
    that its maximum on the grid is 1 (the absolute level is the sensor's ``illuminance_lux``).
    """
    import colour

    wl = wavelength_grid(wavelengths)
    if illuminant is None:
        illuminant = DEFAULT_ILLUMINANT
    if isinstance(illuminant, str) and not is_path(illuminant):
        spd = _named("SDS_ILLUMINANTS", "illuminant", illuminant, tuple(wl)).copy()
    elif is_path(illuminant):
        spd = resample(*read_spectral_csv(illuminant, name="illuminant"), wl, name="illuminant")[:, 0]
    elif isinstance(illuminant, colour.SpectralDistribution):
        spd = _from_colour(illuminant, wl, "illuminant")
    else:
        spd = on_grid(illuminant, wl, "illuminant", 1)[:, 0]
    if spd.max() <= 0:
        raise ValueError("illuminant: is zero everywhere on the wavelength grid")
    return np.clip(spd, 0, None) / spd.max()


def chart_reflectances(reflectances=None, wavelengths=None) -> np.ndarray:
    """Surface reflectances R on the grid, (q, n); default: the 24 'BabelColor Average' patches.

    A name of ``colour.SDS_COLOURCHECKERS``, a dict or list of
    :class:`colour.SpectralDistribution`, a :class:`colour.MultiSpectralDistributions`, a CSV
    file (wavelength, one column per patch) or an array (q, n) on the grid. Patches are in the
    chart's reading order (row by row, 4 x 6 for a ColorChecker).
    """
    import colour

    wl = wavelength_grid(wavelengths)
    if reflectances is None:
        reflectances = DEFAULT_CHART
    if isinstance(reflectances, str) and not is_path(reflectances):
        refl = _named("SDS_COLOURCHECKERS", "reflectances", reflectances, tuple(wl)).copy()
    elif is_path(reflectances):
        refl = resample(*read_spectral_csv(reflectances, name="reflectances"), wl, name="reflectances")
    elif isinstance(reflectances, colour.MultiSpectralDistributions):
        refl = _from_colour(reflectances, wl, "reflectances")
    elif isinstance(reflectances, dict) or (
        isinstance(reflectances, (list, tuple))
        and reflectances
        and isinstance(reflectances[0], colour.SpectralDistribution)
    ):
        sds = list(reflectances.values()) if isinstance(reflectances, dict) else list(reflectances)
        refl = np.stack([_from_colour(sd, wl, "reflectances") for sd in sds], axis=1)
    else:
        refl = on_grid(reflectances, wl, "reflectances", None)
    if np.any(refl < 0):
        raise ValueError("reflectances: contain negative values")
    return refl
