"""An independent renderer of underwater ColorChecker photographs (a second world).

This module re-implements the image formation of Blasinski & Farrell, "A Three Parameter
Underwater Image Formation Model" (eqs 1-12, 15 and Table 1) from the paper's equations,
sharing no code with the project's own simulator (``forward``): it imports only numpy, scipy,
colour-science and the standard library, parses the project's data tables itself, resamples
every table with its own interpolation (PCHIP by default) onto its own grid (400-700 nm at
0.5 nm by default) and integrates eq 1 by its own trapezoid rule. Its purpose is to test the
project's estimator on worlds that the estimator's own forward model did not make.

With every option off (:func:`render_chart`'s defaults, ``noise=False``) it renders the
paper's nominal world::

    m_{ch,j} = sum_lambda P_ch(lambda) i(lambda) k(lambda) R_j(lambda) w(lambda),
    k = exp(-c (depth + distance)),  c = a + b  (eqs 1, 3, 4, 15),

in model units (a perfect white reflector in air under the illuminant gives 1 in the camera's
most sensitive channel). Options add what a real photograph has and the paper's model does
not: chart tolerances and ageing, camera curve and balance errors, a different illuminant or
camera, other CDOM/NAP slopes, a diffuse downwelling leg, uneven light, a single-scattering
veiling light (a model of its own, unlike ``forward.veiling_light``), an unknown exposure,
photon and read noise, pixel clipping, specular glints, a misplaced sampling grid and occluded
patches. :func:`render_calibration` renders the same chart in air with the same camera.

Units: wavelengths nm; coefficients m^-1; ``chl`` (C) mg m^-3; ``cdom`` = a_CDOM(440 nm)
m^-1; ``depth`` and ``distance`` m.
"""

from __future__ import annotations

import csv
import dataclasses
import functools
from pathlib import Path

import colour
import numpy as np
from scipy.interpolate import PchipInterpolator

__all__ = [
    "BORDER_REFLECTANCE",
    "CDOM_SLOPE_PER_NM",
    "CHART_COLUMNS",
    "CHART_ROWS",
    "DATA_DIR",
    "DEFAULT_CAMERA",
    "DEFAULT_CHART",
    "DEFAULT_ILLUMINANT",
    "DEFAULT_STEP_NM",
    "HAND_REFLECTANCE",
    "MEAN_COSINE_DOWNWELLING",
    "NAP_440_EXPONENT",
    "NAP_440_SCALE",
    "NAP_SLOPE_PER_NM",
    "PARTICLE_BACKSCATTER_RATIO",
    "PHYTO_440_EXPONENT",
    "PHYTO_440_SCALE",
    "REFERENCE_NM",
    "SAND_REFLECTANCE",
    "WATER_BACKSCATTER_RATIO",
    "WATER_SCATTERING_500",
    "WATER_SCATTERING_EXPONENT",
    "WAVELENGTH_RANGE_NM",
    "WorldOptions",
    "D65_CCT",
    "camera_curves",
    "chart_reflectances",
    "daylight_spd",
    "illuminant_spd",
    "patch_columns",
    "path_coefficient",
    "read_constants",
    "read_spectral_table",
    "render_calibration",
    "render_chart",
    "render_range_scene",
    "resample",
    "trapezoid_weights",
    "water_optics",
    "wavelength_grid",
]

# --------------------------------------------------------------------------- constants
#: The project's data tables (read here with this module's own parser).
DATA_DIR = Path(__file__).resolve().parents[1] / "data"
_PURE_WATER_FILE = "pure_water_absorption_smith_baker_1981.csv"
_BASIS_FILE = "phytoplankton_absorption_basis.csv"
_TABLE1_FILE = "particle_scattering_table1.csv"

#: Spectral range of the world, nm (the phytoplankton basis table spans exactly this).
WAVELENGTH_RANGE_NM = (400.0, 700.0)
#: Default grid step, nm (finer than the project's 1 nm on purpose: a different quadrature).
DEFAULT_STEP_NM = 0.5
#: Reference wavelength lambda_0 of eqs 6, 7, 8 and 10, nm (Blasinski & Farrell).
REFERENCE_NM = 440.0
#: Eq 6 slope S_CDOM, nm^-1 (Blasinski & Farrell eq 6; Bricaud, Morel & Prieur 1981).
CDOM_SLOPE_PER_NM = 0.014
#: Eq 7 slope S_NAP, nm^-1 (Blasinski & Farrell eq 7; Roesler, Perry & Carder 1989).
NAP_SLOPE_PER_NM = 0.011
#: Eq 8: a_NAP(440) = 0.0124 C^0.724 m^-1 (Bricaud et al. 1998, the paper's ref. [18]).
NAP_440_SCALE = 0.0124
#: Exponent of eq 8 (Bricaud et al. 1998).
NAP_440_EXPONENT = 0.724
#: Eq 10: a_phi(440) = 0.0378 C^0.627 m^-1 (Bricaud et al. 1998, the paper's ref. [18]).
PHYTO_440_SCALE = 0.0378
#: Exponent of eq 10 (Bricaud et al. 1998).
PHYTO_440_EXPONENT = 0.627
#: Pure sea-water scattering at 500 nm, m^-1: b_w = 0.00288 (lambda/500)^-4.32 (Morel 1974).
WATER_SCATTERING_500 = 0.00288
#: Spectral exponent of pure sea-water scattering (Morel 1974).
WATER_SCATTERING_EXPONENT = 4.32
#: b_bw / b_w: pure water scatters symmetrically forward/backward (Morel 1974; Mobley 1994,
#: "Light and Water", sec. 3.8).
WATER_BACKSCATTER_RATIO = 0.5
#: b_bp / b_p of Petzold's (1972) average particle phase function, the "typical" particulate
#: backscattering ratio (Mobley 1994, "Light and Water", table 3.10).
PARTICLE_BACKSCATTER_RATIO = 0.0183
#: Mean cosine of the downwelling light, mu_d, for K_d ~ (a + b_b) / mu_d (Kirk 2011,
#: "Light and Photosynthesis in Aquatic Ecosystems", 3rd ed., ch. 6; Gordon 1989, Limnol.
#: Oceanogr. 34:1389-1409).
MEAN_COSINE_DOWNWELLING = 0.75
#: Default camera, illuminant and chart: names in colour-science's databases.
DEFAULT_CAMERA = "Nikon 5100 (NPL)"
#: CIE standard illuminant D65 (``colour.SDS_ILLUMINANTS``).
DEFAULT_ILLUMINANT = "D65"
#: Correlated colour temperature of D65, K: 6500 K times 1.4388 / 1.4380 (the change of the
#: second radiation constant c2 since the illuminant was defined; CIE 015:2018, 4.1.2).
D65_CCT = 6500.0 * 1.4388 / 1.4380
#: Default chart reflectances (``colour.SDS_COLOURCHECKERS``).
DEFAULT_CHART = "BabelColor Average"
#: ColorChecker Classic layout: 4 rows x 6 columns, read row by row (McCamy, Marcus &
#: Davidson 1976, J. Appl. Photogr. Eng. 2(3)).
CHART_ROWS = 4
#: See :data:`CHART_ROWS`.
CHART_COLUMNS = 6
#: Spectrally flat reflectance of the chart's black border (approximate, a matte black card).
BORDER_REFLECTANCE = 0.02
#: Spectrally flat reflectance of a diver's gloved hand occluding a patch (approximate).
HAND_REFLECTANCE = 0.05

_INTERPOLATIONS = ("pchip", "linear")
_PATHS = ("paper", "split")
_BACKSCATTERS = (None, "single_scatter")
_OCCLUDERS = ("hand", "water")


# --------------------------------------------------------------------------- tables
def _data_lines(path: Path) -> list[list[str]]:
    """Non-comment, non-blank CSV rows of ``path`` (header row first)."""
    with path.open(encoding="utf-8", newline="") as fh:
        rows = [r for r in csv.reader(fh) if r and not r[0].lstrip().startswith("#")]
    return [[s.strip() for s in r] for r in rows if any(s.strip() for s in r)]


@functools.cache
def read_spectral_table(filename: str) -> tuple[np.ndarray, np.ndarray]:
    """Read a spectral table of the project's ``data/`` folder with this module's parser.

    Parameters
    ----------
    filename : str
        File name in :data:`DATA_DIR`; '#' lines are comments, the first other line names the
        columns, the first column is the wavelength in nm.

    Returns
    -------
    wavelengths : numpy.ndarray, shape (n,)
        nm, read-only.
    values : numpy.ndarray, shape (n,)
        The first value column, in the table's unit, read-only.
    """
    rows = _data_lines(DATA_DIR / filename)[1:]
    arr = np.array([[float(s) for s in r[:2]] for r in rows])
    wl, vals = arr[:, 0].copy(), arr[:, 1].copy()
    wl.setflags(write=False)
    vals.setflags(write=False)
    return wl, vals


@functools.cache
def read_constants(filename: str = _TABLE1_FILE) -> dict:
    """Read a constants table (``parameter,unit,value``) of the project's ``data/`` folder.

    Parameters
    ----------
    filename : str, optional
        File name in :data:`DATA_DIR` (default: Table 1 of the paper,
        ``particle_scattering_table1.csv``).

    Returns
    -------
    dict
        Parameter name -> float value (units in the file's unit column).

    References
    ----------
    Blasinski & Farrell, Table 1 (from Brewin et al. 2012, Opt. Express 20:17632).
    """
    rows = _data_lines(DATA_DIR / filename)
    header = [h.lower() for h in rows[0]]
    i_name, i_value = header.index("parameter"), header.index("value")
    return {r[i_name]: float(r[i_value]) for r in rows[1:]}


# --------------------------------------------------------------------------- grid
def wavelength_grid(step_nm: float = DEFAULT_STEP_NM) -> np.ndarray:
    """The uniform grid 400-700 nm with step ``step_nm``.

    Parameters
    ----------
    step_nm : float, optional
        Step in nm (default 0.5); must divide 300 nm.

    Returns
    -------
    numpy.ndarray, shape (q,)
        Wavelengths in nm.

    Raises
    ------
    ValueError
        If the step is not positive or does not divide 300 nm.
    """
    lo, hi = WAVELENGTH_RANGE_NM
    step_nm = float(step_nm)
    n = (hi - lo) / step_nm if step_nm > 0 else -1.0
    if step_nm <= 0 or abs(n - round(n)) > 1e-9 or round(n) < 2:
        raise ValueError(f"step_nm: must be > 0 and divide {hi - lo:g} nm, got {step_nm!r}")
    return np.linspace(lo, hi, round(n) + 1)


def trapezoid_weights(wavelengths) -> np.ndarray:
    """Trapezoid-rule weights (nm) for the integral of eq 1 on a grid.

    Parameters
    ----------
    wavelengths : array_like, shape (q,)
        Increasing wavelengths, nm.

    Returns
    -------
    numpy.ndarray, shape (q,)
        Weights w with sum(w f) ~ integral of f d lambda.
    """
    wl = np.asarray(wavelengths, dtype=float)
    steps = np.diff(wl)
    return np.concatenate(([0.0], steps)) / 2 + np.concatenate((steps, [0.0])) / 2


def resample(src_wavelengths, values, wavelengths, method: str = "pchip",
             outside: float | None = 0.0) -> np.ndarray:
    """Resample a tabulated spectrum onto ``wavelengths``.

    Parameters
    ----------
    src_wavelengths : array_like, shape (n,)
        Table wavelengths, nm, increasing.
    values : array_like, shape (n,) or (n, k)
        Table values (rows = wavelengths).
    wavelengths : array_like, shape (q,)
        Target wavelengths, nm.
    method : {'pchip', 'linear'}, optional
        PCHIP (scipy, shape-preserving cubic; default) or piecewise linear.
    outside : float or None, optional
        Value outside the table's range (default 0); ``None`` raises instead.

    Returns
    -------
    numpy.ndarray, shape (q,) or (q, k)
        The resampled values.

    Raises
    ------
    ValueError
        For an unknown method, or with ``outside=None`` when the table does not cover the grid.
    """
    x, y = np.asarray(src_wavelengths, float), np.asarray(values, float)
    wl = np.asarray(wavelengths, float)
    inside = (wl >= x[0] - 1e-9) & (wl <= x[-1] + 1e-9)
    if outside is None and not inside.all():
        raise ValueError(f"table covers {x[0]:g}-{x[-1]:g} nm, grid {wl[0]:g}-{wl[-1]:g} nm")
    if method == "pchip":
        out = PchipInterpolator(x, y, axis=0, extrapolate=True)(np.clip(wl, x[0], x[-1]))
    elif method == "linear":
        cols = y.reshape(len(x), -1).T
        out = np.stack([np.interp(wl, x, col) for col in cols], axis=-1).reshape(
            (wl.size,) + y.shape[1:])
    else:
        raise ValueError(f"interpolation: must be one of {_INTERPOLATIONS}, got {method!r}")
    out = np.array(out, dtype=float)
    out[~inside] = 0.0 if outside is None else outside
    return out


def _readonly(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a


# --------------------------------------------------------------------------- water (eqs 4-12)
def _absorption(wl, chl, cdom, cdom_slope, nap_slope, method):
    """(a, a_w): a = a_w + a_CDOM + a_phi + a_NAP (eqs 5-10) and pure water's a_w, m^-1."""
    a_w = resample(*read_spectral_table(_PURE_WATER_FILE), wl, method, outside=None)
    basis_wl, basis = read_spectral_table(_BASIS_FILE)
    shape = resample(basis_wl, basis, wl, method, outside=None) / np.interp(
        REFERENCE_NM, basis_wl, basis)
    a_phi = PHYTO_440_SCALE * chl ** PHYTO_440_EXPONENT * shape
    a_cdom = cdom * np.exp(-cdom_slope * (wl - REFERENCE_NM))
    a_nap = NAP_440_SCALE * chl ** NAP_440_EXPONENT * np.exp(-nap_slope * (wl - REFERENCE_NM))
    return a_w + a_cdom + a_phi + a_nap, a_w


def _particle_scattering(wl, chl):
    """b_p of eq 12 with Table 1's constants, m^-1."""
    t = read_constants()
    r = wl / t["lambda_0"]
    small = t["C_12"] * (1.0 - np.exp(-t["S_12"] * chl))
    return (t["b_p12_star"] * r ** -t["gamma_12"] * small
            + t["b_p3_star"] * r ** -t["gamma_3"] * (chl - small)
            + t["b_k"] * r ** -t["gamma_k"])


def water_optics(wavelengths, chl: float, cdom: float, *, cdom_slope: float = CDOM_SLOPE_PER_NM,
                 nap_slope: float = NAP_SLOPE_PER_NM, interpolation: str = "pchip") -> dict:
    """Inherent and apparent optical properties of the paper's water on a grid.

    Parameters
    ----------
    wavelengths : array_like, shape (q,)
        Grid, nm, inside 400-700 nm.
    chl : float
        Chlorophyll concentration C, mg m^-3.
    cdom : float
        a_CDOM(440 nm), m^-1.
    cdom_slope, nap_slope : float, optional
        Slopes of eqs 6 and 7, nm^-1 (defaults 0.014 and 0.011).
    interpolation : {'pchip', 'linear'}, optional
        Resampling of the a_w and phytoplankton tables.

    Returns
    -------
    dict
        Arrays (q,) in m^-1: ``a`` (eq 5), ``a_w`` (pure water's part of it), ``b_w`` (Morel 1974), ``b_p`` (eq 12), ``b`` (eq 11),
        ``c`` (eq 4), ``b_b`` = 0.5 b_w + 0.0183 b_p (Petzold/Mobley ratio) and ``K_d`` =
        (a + b_b) / mu_d with mu_d = 0.75 (Gordon 1989; Kirk 2011).

    References
    ----------
    Blasinski & Farrell eqs 4-12, Table 1; Morel 1974; Petzold 1972; Mobley 1994; Kirk 2011.
    """
    wl = np.asarray(wavelengths, float)
    a, a_w = _absorption(wl, chl, cdom, cdom_slope, nap_slope, interpolation)
    b_w = WATER_SCATTERING_500 * (wl / 500.0) ** -WATER_SCATTERING_EXPONENT
    b_p = _particle_scattering(wl, chl)
    b_b = WATER_BACKSCATTER_RATIO * b_w + PARTICLE_BACKSCATTER_RATIO * b_p
    return {"a": a, "a_w": a_w, "b_w": b_w, "b_p": b_p, "b": b_w + b_p, "c": a + b_w + b_p,
            "b_b": b_b,
            "K_d": (a + b_b) / MEAN_COSINE_DOWNWELLING}


# --------------------------------------------------------------------------- camera, light, chart
def _colour_table(database: str, name: str):
    db = getattr(colour, database)
    if name not in db:
        raise ValueError(f"unknown name {name!r} in colour.{database}; known: {sorted(db)}")
    return db[name]


@functools.lru_cache(maxsize=64)
def _camera_table(name: str):
    msds = _colour_table("MSDS_CAMERA_SENSITIVITIES", name)
    vals = np.clip(np.asarray(msds.values, float), 0.0, None)
    return np.asarray(msds.wavelengths, float), vals / vals.max(axis=0)


def camera_curves(camera: str = DEFAULT_CAMERA, wavelengths=None, *, shifts_nm=(0.0, 0.0, 0.0),
                  interpolation: str = "pchip") -> np.ndarray:
    """Camera spectral sensitivities (3, q), each channel's table peak 1, optionally shifted.

    Parameters
    ----------
    camera : str, optional
        Name in ``colour.MSDS_CAMERA_SENSITIVITIES`` (default 'Nikon 5100 (NPL)').
    wavelengths : array_like, shape (q,), optional
        Grid, nm (default :func:`wavelength_grid`).
    shifts_nm : sequence of 3 float, optional
        Wavelength shift of each channel's curve, nm: p_ch(lambda - shift).
    interpolation : {'pchip', 'linear'}, optional
        Resampling method.

    Returns
    -------
    numpy.ndarray, shape (3, q)
        Relative sensitivities (negative table values clipped to 0; zero outside the table,
        e.g. above 680 nm for 'Sigma SDMerill (NPL)').
    """
    wl = wavelength_grid() if wavelengths is None else np.asarray(wavelengths, float)
    src, vals = _camera_table(camera)
    return np.stack([resample(src, vals[:, ch], wl - shift, interpolation)
                     for ch, shift in enumerate(shifts_nm)])


def illuminant_spd(illuminant: str = DEFAULT_ILLUMINANT, wavelengths=None, *,
                   interpolation: str = "pchip") -> np.ndarray:
    """Relative spectral power distribution of a colour-science illuminant, table peak in range 1.

    Parameters
    ----------
    illuminant : str, optional
        Name in ``colour.SDS_ILLUMINANTS`` (default 'D65').
    wavelengths : array_like, shape (q,), optional
        Grid, nm (default :func:`wavelength_grid`).
    interpolation : {'pchip', 'linear'}, optional
        Resampling method.

    Returns
    -------
    numpy.ndarray, shape (q,)
        Relative SPD (the scale cancels in model units).
    """
    wl = wavelength_grid() if wavelengths is None else np.asarray(wavelengths, float)
    sd = _colour_table("SDS_ILLUMINANTS", illuminant)
    spd = resample(sd.wavelengths, sd.values, wl, interpolation)
    return spd / spd.max()


def daylight_spd(mired_shift: float = 0.0, wavelengths=None, *,
                 interpolation: str = "pchip") -> np.ndarray:
    """Relative SPD of CIE daylight whose colour temperature is D65's moved by ``mired_shift``.

    The temperature is T = 10^6 / (10^6 / :data:`D65_CCT` + ``mired_shift``); the spectrum is
    colour-science's CIE daylight series at the daylight locus's chromaticity of T
    (``colour.temperature.CCT_to_xy_CIE_D``, ``colour.sd_CIE_illuminant_D_series``), resampled
    to the grid. At 0 mired it is D65's table to 0.1 %.

    Parameters
    ----------
    mired_shift : float, optional
        Change of 10^6 / T from D65's, mired (positive: warmer, redder light).
    wavelengths : array_like, shape (q,), optional
        Grid, nm (default :func:`wavelength_grid`).
    interpolation : {'pchip', 'linear'}, optional
        Resampling method.

    Returns
    -------
    numpy.ndarray, shape (q,)
        Relative SPD, peak in range 1 (the scale cancels in model units).

    Raises
    ------
    ValueError
        When T leaves the daylight series' range, 4000-25 000 K (CIE 015:2018, 4.1.2).

    References
    ----------
    CIE 015:2018, Colorimetry, 4th ed., section 4.1.2 (the daylight series).
    """
    wl = wavelength_grid() if wavelengths is None else np.asarray(wavelengths, float)
    mired = 1e6 / D65_CCT + float(mired_shift)
    cct = 1e6 / mired if mired > 0 else np.inf
    if not 4000.0 <= cct <= 25000.0:
        raise ValueError(f"mired_shift: the temperature {cct:.0f} K leaves the daylight series' "
                         "range 4000-25000 K")
    sd = colour.sd_CIE_illuminant_D_series(colour.temperature.CCT_to_xy_CIE_D(cct))
    spd = resample(sd.wavelengths, sd.values, wl, interpolation)
    return spd / spd.max()


def _light(opts, wl) -> np.ndarray:
    """The surface light of ``opts``: the named illuminant, or CIE daylight moved by
    ``daylight_mired`` from D65."""
    if opts.daylight_mired != 0.0:
        return daylight_spd(opts.daylight_mired, wl, interpolation=opts.interpolation)
    return illuminant_spd(opts.illuminant, wl, interpolation=opts.interpolation)


def chart_reflectances(chart: str = DEFAULT_CHART, wavelengths=None, *,
                       interpolation: str = "pchip") -> np.ndarray:
    """The 24 ColorChecker reflectances (q, 24) in reading order.

    Parameters
    ----------
    chart : str, optional
        Name in ``colour.SDS_COLOURCHECKERS``: 'BabelColor Average' (default) or
        'ColorChecker N Ohta' (an independent measurement of the same chart).
    wavelengths : array_like, shape (q,), optional
        Grid, nm (default :func:`wavelength_grid`).
    interpolation : {'pchip', 'linear'}, optional
        Resampling method.

    Returns
    -------
    numpy.ndarray, shape (q, 24)
        Reflectance factors, one column per patch (row by row, white = column 18).
    """
    wl = wavelength_grid() if wavelengths is None else np.asarray(wavelengths, float)
    sds = list(_colour_table("SDS_COLOURCHECKERS", chart).values())
    return np.stack([resample(sd.wavelengths, sd.values, wl, interpolation, outside=None)
                     for sd in sds], axis=1)


def patch_columns(n: int = CHART_ROWS * CHART_COLUMNS) -> np.ndarray:
    """Normalised column position x in [-1, 1] of each patch (patch j is in column j % 6).

    Parameters
    ----------
    n : int, optional
        Number of patches (default 24).

    Returns
    -------
    numpy.ndarray, shape (n,)
        -1 for the first column, +1 for the last.
    """
    col = np.arange(n) % CHART_COLUMNS
    return 2.0 * col / (CHART_COLUMNS - 1) - 1.0


# --------------------------------------------------------------------------- options
@dataclasses.dataclass(frozen=True)
class WorldOptions:
    """Every option of :func:`render_chart` (all off by default: the paper's nominal world).

    Parameters
    ----------
    step_nm : float
        Grid step, nm (default 0.5).
    interpolation : {'pchip', 'linear'}
        Resampling of every table (default 'pchip').
    chart : str
        'BabelColor Average' (default) or 'ColorChecker N Ohta' (``colour.SDS_COLOURCHECKERS``).
    reflectance_sd : float
        Relative sd of a per-patch multiplicative reflectance error (e.g. 0.005), drawn.
    reflectance_factors : sequence of 24 float or None
        Explicit per-patch factors (replace the drawn ones; e.g. to reuse a draw).
    yellowing : float
        Reflectance times 1 - yellowing (700 - lambda) / 300 (an aged chart; e.g. 0.03).
    camera : str
        Camera name (``colour.MSDS_CAMERA_SENSITIVITIES``; default 'Nikon 5100 (NPL)').
    camera_shift_nm_sd : float
        sd of a random wavelength shift of each channel's curve, nm (drawn).
    camera_shift_nm : sequence of 3 float or None
        Explicit per-channel shifts, nm (replace the drawn ones).
    camera_gain_sd : float
        Relative sd of a per-channel gain error (channel balance), drawn.
    camera_gains : sequence of 3 float or None
        Explicit per-channel gains (replace the drawn ones).
    illuminant : str
        Illuminant name (``colour.SDS_ILLUMINANTS``; default 'D65').
    daylight_mired : float
        When not 0: the surface light is CIE daylight whose colour temperature is D65's moved
        by this many mired (:func:`daylight_spd`; ``illuminant`` must then be 'D65').
    cdom_slope, nap_slope : float
        Slopes of eqs 6 and 7, nm^-1 (defaults 0.014, 0.011).
    path : {'paper', 'split'}
        'paper': k = exp(-c (depth + distance)); 'split': k = exp(-K_d depth - c distance).
    light_gradient : float
        g: the light on patch j is times 1 + g x_j (x_j of :func:`patch_columns`); |g| < 1.
    backscatter : {None, 'single_scatter'}
        Veiling light: none (default) or single scattering along the camera ray.
    backscatter_scale : float
        Multiplies the veiling light (default 1).
    backscatter_gradient : float
        The veiling light on patch j is times 1 + g_b x_j; |g_b| < 1.
    exposure : float
        Unknown overall gain multiplying every recorded value (default 1).
    noise : bool
        Simulate photon and read noise (default True).
    pixels_per_patch : int
        Pixels averaged per patch (default 1000, >= 2).
    electrons_full_scale : float
        Electrons for a recorded value of 1.0 (default 20000).
    read_noise_e : float
        Read noise sd, electrons (default 3).
    clip : float or None
        Pixel values above this are clipped (default 1.0; ``None``: no clipping).
    glints : float
        Fraction of the pixels of ``glint_patches`` random patches set to the clip level.
    glint_patches : int
        Number of patches with glints (default 3).
    corner_shift : float
        Sampling offset, fraction of a patch pitch to the right, in [0, 1].
    occluded : sequence of int
        Patch indices hidden by ``occluder``.
    occluder : {'hand', 'water'}
        A diver's hand (flat reflectance 0.05) or open water behind the chart.

    Raises
    ------
    ValueError
        Naming the option, for a value out of range or an unknown name.
    """

    step_nm: float = DEFAULT_STEP_NM
    interpolation: str = "pchip"
    chart: str = DEFAULT_CHART
    reflectance_sd: float = 0.0
    reflectance_factors: tuple | None = None
    yellowing: float = 0.0
    camera: str = DEFAULT_CAMERA
    camera_shift_nm_sd: float = 0.0
    camera_shift_nm: tuple | None = None
    camera_gain_sd: float = 0.0
    camera_gains: tuple | None = None
    illuminant: str = DEFAULT_ILLUMINANT
    daylight_mired: float = 0.0
    cdom_slope: float = CDOM_SLOPE_PER_NM
    nap_slope: float = NAP_SLOPE_PER_NM
    path: str = "paper"
    light_gradient: float = 0.0
    backscatter: str | None = None
    backscatter_scale: float = 1.0
    backscatter_gradient: float = 0.0
    exposure: float = 1.0
    noise: bool = True
    pixels_per_patch: int = 1000
    electrons_full_scale: float = 20000.0
    read_noise_e: float = 3.0
    clip: float | None = 1.0
    glints: float = 0.0
    glint_patches: int = 3
    corner_shift: float = 0.0
    occluded: tuple = ()
    occluder: str = "hand"

    def __post_init__(self):
        self._check_choices()
        self._check_numbers()
        for name, size in (("reflectance_factors", 24), ("camera_shift_nm", 3),
                           ("camera_gains", 3)):
            self._check_vector(name, size)
        occ = tuple(int(j) for j in self.occluded)
        if any(not 0 <= j < CHART_ROWS * CHART_COLUMNS for j in occ):
            raise ValueError(f"occluded: patch indices must be in 0..23, got {self.occluded!r}")
        object.__setattr__(self, "occluded", occ)

    def _check_choices(self):
        wavelength_grid(self.step_nm)
        for name, allowed in (("interpolation", _INTERPOLATIONS), ("path", _PATHS),
                              ("backscatter", _BACKSCATTERS), ("occluder", _OCCLUDERS)):
            if getattr(self, name) not in allowed:
                raise ValueError(f"{name}: must be one of {allowed}, got {getattr(self, name)!r}")
        for name, db in (("chart", "SDS_COLOURCHECKERS"), ("camera", "MSDS_CAMERA_SENSITIVITIES"),
                         ("illuminant", "SDS_ILLUMINANTS")):
            if getattr(self, name) not in getattr(colour, db):
                raise ValueError(f"{name}: unknown name {getattr(self, name)!r} in colour.{db}")

    def _check_numbers(self):
        nonneg = ("reflectance_sd", "yellowing", "camera_shift_nm_sd", "camera_gain_sd",
                  "backscatter_scale", "read_noise_e", "glints", "corner_shift")
        for name in nonneg + ("exposure", "electrons_full_scale"):
            v, strict = getattr(self, name), name not in nonneg
            if not np.isfinite(v) or v < 0 or (strict and v == 0):
                raise ValueError(f"{name}: must be a finite number {'>' if strict else '>='} 0, "
                                 f"got {v!r}")
        for name in ("light_gradient", "backscatter_gradient"):
            if not abs(getattr(self, name)) < 1:
                raise ValueError(f"{name}: must be in (-1, 1), got {getattr(self, name)!r}")
        if self.glints > 1 or self.corner_shift > 1 or self.yellowing >= 1:
            raise ValueError("glints, corner_shift: must be <= 1; yellowing < 1")
        if int(self.pixels_per_patch) != self.pixels_per_patch or self.pixels_per_patch < 2:
            raise ValueError(f"pixels_per_patch: an integer >= 2, got {self.pixels_per_patch!r}")
        if not 0 <= int(self.glint_patches) <= CHART_ROWS * CHART_COLUMNS:
            raise ValueError(f"glint_patches: must be in 0..24, got {self.glint_patches!r}")
        if self.daylight_mired != 0.0:
            if self.illuminant != DEFAULT_ILLUMINANT:
                raise ValueError("daylight_mired: moves D65; the illuminant must be 'D65'")
            daylight_spd(self.daylight_mired, np.array([500.0, 600.0]))  # in range
        if self.clip is not None and not self.clip > 0:
            raise ValueError(f"clip: must be > 0 or None, got {self.clip!r}")

    def _check_vector(self, name, size):
        v = getattr(self, name)
        if v is None:
            return
        arr = np.asarray(v, dtype=float)
        if arr.shape != (size,) or not np.all(np.isfinite(arr)):
            raise ValueError(f"{name}: expected {size} finite numbers, got {v!r}")
        object.__setattr__(self, name, tuple(float(x) for x in arr))


# --------------------------------------------------------------------------- rendering steps
def _draw(explicit, sd, size, centre, rng):
    """An explicit perturbation, or centre + sd N(0, 1) draws (centre without a spread)."""
    if explicit is not None:
        return np.array(explicit, dtype=float)
    if sd > 0:
        return centre + sd * rng.standard_normal(size)
    return np.full(size, float(centre))


def _camera_matrix(opts: WorldOptions, wl, i, rngs, truth) -> np.ndarray:
    """P (3, q): curves x trapezoid weights / white-in-air, then shifts and gains applied."""
    w = trapezoid_weights(wl)
    nominal = camera_curves(opts.camera, wl, interpolation=opts.interpolation) * w
    scale = float((nominal @ i).max())  # model units: white in air = 1, most sensitive channel
    shifts = _draw(opts.camera_shift_nm, opts.camera_shift_nm_sd, 3, 0.0, rngs["camera_shift"])
    gains = _draw(opts.camera_gains, opts.camera_gain_sd, 3, 1.0, rngs["camera_gain"])
    truth.update(camera_shift_nm=shifts, camera_gains=gains)
    curves = camera_curves(opts.camera, wl, shifts_nm=shifts, interpolation=opts.interpolation)
    return gains[:, None] * curves * w / scale


def _chart_matrix(opts: WorldOptions, wl, rngs, truth) -> np.ndarray:
    """R (q, 24): the chart with its tolerance, ageing and occluding hand."""
    R = chart_reflectances(opts.chart, wl, interpolation=opts.interpolation)
    factors = _draw(opts.reflectance_factors, opts.reflectance_sd, R.shape[1], 1.0,
                    rngs["reflectance"])
    truth["reflectance_factors"] = factors
    R = R * factors * (1.0 - opts.yellowing * (WAVELENGTH_RANGE_NM[1] - wl) / 300.0)[:, None]
    if opts.occluder == "hand":
        R[:, list(opts.occluded)] = HAND_REFLECTANCE
    return R


def _scene(P, light, R, veil, background, opts: WorldOptions):
    """Noise-free values (3, 24) at the sampled positions, in model units (before exposure).

    ``light`` (q,) is i k, ``veil`` (3,) the veiling light per channel and ``background`` (3,)
    open water (for the 'water' occluder).
    """
    x = patch_columns(R.shape[1])
    lit = 1.0 + opts.light_gradient * x
    veiled = veil[:, None] * (1.0 + opts.backscatter_gradient * x)
    values = (P * light) @ R * lit + veiled
    border = (P * light).sum(axis=1) * BORDER_REFLECTANCE * lit[-1] + veiled[:, -1]
    if opts.occluder == "water" and opts.occluded:
        values[:, list(opts.occluded)] = background[:, None]
    return _corner_mix(values, border, opts.corner_shift)


def _corner_mix(values, border, shift):
    """Each sample takes (1 - shift) of its patch and ``shift`` of its right neighbour (the
    last column: the black border)."""
    if shift == 0:
        return values
    right = np.roll(values, -1, axis=1)
    last = np.arange(values.shape[1]) % CHART_COLUMNS == CHART_COLUMNS - 1
    right[:, last] = border[:, None]
    return (1.0 - shift) * values + shift * right


def _pixels(expected, opts: WorldOptions, rng) -> np.ndarray:
    """Pixel values (3, 24, n): Poisson photo-electrons plus Gaussian read noise, or exact."""
    n = int(opts.pixels_per_patch)
    if not opts.noise:
        return np.repeat(expected[..., None], n, axis=-1)
    e_fs = opts.electrons_full_scale
    electrons = rng.poisson(np.broadcast_to(np.clip(expected, 0, None)[..., None] * e_fs,
                                            expected.shape + (n,))).astype(float)
    electrons += rng.normal(0.0, opts.read_noise_e, size=electrons.shape)
    return electrons / e_fs


def _add_glints(px, opts: WorldOptions, rng, truth):
    """Replace a fraction ``glints`` of the pixels of random patches by the clip level."""
    n_px = round(float(opts.glints) * px.shape[-1])
    patches = []
    if n_px > 0 and opts.glint_patches > 0:
        patches = sorted(rng.choice(px.shape[1], size=int(opts.glint_patches), replace=False))
        level = 1.0 if opts.clip is None else opts.clip
        for j in patches:
            px[:, j, rng.choice(px.shape[-1], size=n_px, replace=False)] = level
    truth["glint_patches"] = [int(j) for j in patches]
    truth["glint_pixels_per_patch"] = n_px if patches else 0


def _record(expected, opts: WorldOptions, rngs, truth) -> dict:
    """Expose, add noise and glints, clip, and average: the camera user's patch statistics."""
    px = _pixels(expected, opts, rngs["noise"])
    _add_glints(px, opts, rngs["glints"], truth)
    saturated = 0.0
    if opts.clip is not None:
        saturated = float(np.mean(px >= opts.clip))
        np.minimum(px, opts.clip, out=px)
    n = px.shape[-1]
    model_sd = np.sqrt(np.clip(expected, 0, None) * opts.electrons_full_scale
                       + opts.read_noise_e ** 2) / opts.electrons_full_scale
    return {"rgb": px.mean(axis=-1), "sigma": px.std(axis=-1, ddof=1) / np.sqrt(n),
            "sigma_model": model_sd / np.sqrt(n), "saturated": saturated}


def _generators(rng) -> dict:
    """Independent streams per effect, so switching one effect on leaves the others' draws."""
    rng = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    names = ("camera_shift", "camera_gain", "reflectance", "glints", "noise")
    return dict(zip(names, rng.spawn(len(names))))


def _render(k, veil_light, background_light, opts: WorldOptions, rng, truth) -> dict:
    """The shared pipeline: spectra -> scene values -> exposure -> pixels -> statistics."""
    wl = wavelength_grid(opts.step_nm)
    rngs = _generators(rng)
    i = _light(opts, wl)
    P = _camera_matrix(opts, wl, i, rngs, truth)
    R = _chart_matrix(opts, wl, rngs, truth)
    veil, background = P @ veil_light, P @ background_light
    expected = opts.exposure * _scene(P, i * k, R, veil, background, opts)
    out = _record(expected, opts, rngs, truth)
    truth.update(exposure=opts.exposure, options=dataclasses.asdict(opts))
    out.update(expected=expected, truth=truth, wavelengths=wl, attenuation=k,
               backscatter=opts.exposure * veil)
    return out


def _transmittance(optics, depth, distance, path):
    """k(lambda): 'paper' exp(-c (depth + distance)); 'split' exp(-K_d depth - c distance)."""
    if path == "paper":
        return np.exp(-optics["c"] * (depth + distance))
    return np.exp(-optics["K_d"] * depth - optics["c"] * distance)


def path_coefficient(optics: dict, depth: float, distance: float, path: str = "paper"):
    """The attenuation coefficient of the light's path: tau / (depth + distance), m^-1.

    tau = -ln k is the optical depth of the path from the surface to the chart and on to the
    camera (:func:`render_chart`'s ``attenuation`` k): for the paper's path c (depth +
    distance), so the coefficient is the beam attenuation c; for 'split' K_d depth + c distance,
    its path-weighted mean.

    Parameters
    ----------
    optics : dict
        :func:`water_optics`' result (``render_chart``'s ``optics``).
    depth, distance : float
        The true depth and distance, m (depth + distance > 0).
    path : {'paper', 'split'}, optional
        The renderer's path (:class:`WorldOptions`' ``path``).

    Returns
    -------
    numpy.ndarray, shape (q,)
        m^-1 on the optics' grid.

    Raises
    ------
    ValueError
        For an unknown path or a path of length 0.
    """
    if path not in _PATHS:
        raise ValueError(f"path: must be one of {_PATHS}, got {path!r}")
    length = float(depth) + float(distance)
    if not length > 0:
        raise ValueError("depth + distance: must be > 0")
    if path == "paper":
        return np.array(optics["c"], dtype=float)
    return (optics["K_d"] * float(depth) + optics["c"] * float(distance)) / length


def _veiling_light(optics, i, depth, distance, opts: WorldOptions):
    """Single-scattering veil i exp(-K_d depth) (b_b/c)(1 - exp(-c distance)) x scale, and the
    open-water radiance (its limit for an infinite distance), in i x reflectance units."""
    lit = i * np.exp(-optics["K_d"] * depth) * optics["b_b"] / optics["c"] * opts.backscatter_scale
    veil = lit * -np.expm1(-optics["c"] * distance)
    return (veil if opts.backscatter == "single_scatter" else np.zeros_like(veil)), lit


def _check_condition(chl, cdom, depth, distance) -> dict:
    out = {}
    for name, v in (("chl", chl), ("cdom", cdom), ("depth", depth), ("distance", distance)):
        v = float(v)
        if not np.isfinite(v) or v < 0:
            raise ValueError(f"{name}: must be a finite number >= 0, got {v!r}")
        out[name] = v
    return out


# --------------------------------------------------------------------------- public renderers
def render_chart(chl: float, cdom: float, depth: float, distance: float, *, rng=None,
                 **options) -> dict:
    """Render a photograph of a ColorChecker at ``depth`` m seen from ``distance`` m.

    Parameters
    ----------
    chl : float
        Chlorophyll concentration C, mg m^-3.
    cdom : float
        a_CDOM(440 nm), m^-1.
    depth : float
        Depth of the chart (and camera) below the surface, m: the daylight's path down.
    distance : float
        Horizontal camera-to-chart distance, m.
    rng : numpy.random.Generator or int or None, optional
        Randomness (a generator, a seed, or ``None`` for fresh entropy). Each effect draws
        from its own child stream.
    **options
        The fields of :class:`WorldOptions`, all off by default (the paper's nominal world,
        with photon and read noise; ``noise=False`` for exact values).

    Returns
    -------
    dict
        ``rgb`` (3, 24) patch means (model units times ``exposure``); ``sigma`` (3, 24) their
        standard errors from the pixels (sample sd / sqrt(n)); ``sigma_model`` (3, 24) the
        noise model's standard error (ignoring clipping and glints); ``expected`` (3, 24) the
        noise-free, unclipped values; ``saturated`` the fraction of clipped pixels; ``truth``
        (chl, cdom, depth, distance, every drawn perturbation, the exposure and ``options``);
        ``wavelengths`` (q,) nm; ``attenuation`` k (q,); ``backscatter`` (3,) the veiling light
        per channel (times exposure, before ``backscatter_gradient``); ``optics`` (dict of
        :func:`water_optics`).

    Raises
    ------
    ValueError
        For a negative or non-finite condition, or an invalid option.
    TypeError
        For an unknown option name.

    References
    ----------
    Blasinski & Farrell eqs 1-12, 15, Table 1; veiling light after Jaffe (1990) and Mobley
    (1994) single scattering; K_d after Gordon (1989) and Kirk (2011).
    """
    truth = _check_condition(chl, cdom, depth, distance)
    opts = WorldOptions(**options)
    wl = wavelength_grid(opts.step_nm)
    optics = water_optics(wl, truth["chl"], truth["cdom"], cdom_slope=opts.cdom_slope,
                          nap_slope=opts.nap_slope, interpolation=opts.interpolation)
    k = _transmittance(optics, truth["depth"], truth["distance"], opts.path)
    i = _light(opts, wl)
    veil, water = _veiling_light(optics, i, truth["depth"], truth["distance"], opts)
    out = _render(k, veil, water, opts, rng, truth)
    out["optics"] = optics
    return out


def render_calibration(*, rng=None, **options) -> dict:
    """Render the chart in air (k = 1, no veiling light) with the same camera options.

    Parameters
    ----------
    rng : numpy.random.Generator or int or None, optional
        Randomness, as for :func:`render_chart`. Pass the underwater photo's drawn
        ``camera_shift_nm``, ``camera_gains`` and ``reflectance_factors`` (from its ``truth``)
        to photograph the same chart with the same camera.
    **options
        The fields of :class:`WorldOptions`; the water's (slopes, ``path``, ``backscatter*``)
        have no effect; an occluding 'water' reads 0 (nothing behind the chart in air).

    Returns
    -------
    dict
        As :func:`render_chart` (``truth`` without the water's conditions; no ``optics``).

    Raises
    ------
    ValueError
        For an invalid option.
    TypeError
        For an unknown option name.
    """
    opts = WorldOptions(**options)
    q = wavelength_grid(opts.step_nm).size
    return _render(np.ones(q), np.zeros(q), np.zeros(q), opts, rng, {"in_air": True})


# --------------------------------------------------------------------------- whole frames
#: Spectrally flat-ish sand for the seafloor of :func:`render_range_scene`: reflectance 0.25
#: rising 20 % from 400 to 700 nm (carbonate sand is bright and slightly redder, Hochberg et al.
#: 2003, Remote Sens. Environ. 85:174)
SAND_REFLECTANCE = (0.25, 0.20)


def _smooth_field(rng, shape, scale_px):
    """Zero-mean, unit-sd noise smooth on ``scale_px`` pixels (scipy's zoom of a coarse draw)."""
    from scipy import ndimage

    H, W = shape
    small = rng.standard_normal((max(2, int(H / scale_px) + 2), max(2, int(W / scale_px) + 2)))
    big = ndimage.zoom(small, (H / small.shape[0], W / small.shape[1]), order=3)[:H, :W]
    return (big - big.mean()) / (big.std() + 1e-12)


def render_range_scene(chl: float, cdom: float, depth: float, *, size=(300, 480),
                       near: float = 0.8, far: float = 9.0, charts=(), chart_px: int = 72,
                       open_water: float = 0.12, exposure: float = 0.7, rng=None,
                       **options) -> dict:
    """A whole frame of a seafloor receding from ``near`` to ``far`` m, with charts on it.

    Every pixel is rendered at its own range r with this module's water: the direct light
    i k(r) R (``k`` of the ``path`` option: exp(-c (depth + r)) or exp(-K_d depth - c r)) and
    the single-scattering veiling light along its ray (``backscatter='single_scatter'`` is
    the default here), through the camera's curves (eq 1, trapezoid rule). The floor's range
    grows geometrically from the bottom row to the top of the floor (a plane seen obliquely);
    the rows above it are open water (range unknown: NaN in the map; the veil of an infinite
    ray). The floor is sand with smooth brightness texture and patches of the chart's colours
    (a reef's variety); each chart of ``charts`` stands upright facing the camera at its range
    (its pixels share that range), ``chart_px`` pixels wide whatever the range (a bigger board
    farther away: its colours, not its size, are what is tested). Photon and read noise and
    clipping as :func:`render_chart`'s options say.

    Parameters
    ----------
    chl, cdom, depth : float
        The water (mg m^-3, m^-1 at 440 nm) and the camera's and scene's depth (m).
    size : tuple of int
        (height, width), pixels.
    near, far : float
        The floor's range at the bottom row and at the top of the floor, m.
    charts : sequence of (range_m, x_fraction, width_px or None)
        Each chart's range, the horizontal position of its centre (fraction of the width) and
        its width in pixels (None: ``chart_px``).
    chart_px : int
        Default chart width, pixels (6 patch columns).
    open_water : float
        Fraction of the rows at the top that are open water.
    exposure : float
        The brightest noise-free value is this fraction of full scale.
    rng : numpy.random.Generator or int, optional
    **options
        :class:`WorldOptions` fields (``path``, ``backscatter_scale``, ``camera``, ``noise``,
        ``electrons_full_scale``, ...).

    Returns
    -------
    dict
        ``image`` (H, W, 3) float32 linear 0-1 (clipped); ``expected`` the noise-free values;
        ``range`` (H, W) float32 m (NaN: open water); ``charts`` a list of dicts (``range``,
        ``grid`` corners (4, 2) next to patch 1, 6, 24, 19, ``boxes`` (24, 4) x0, y0, x1, y1 of
        each patch's central half, ``air`` (3, 24) the patches' values in air in model units);
        ``white_air`` (3,) a white reflector in air; ``scale`` the model units per image unit;
        ``optics``; ``truth``.
    """
    opts = WorldOptions(**{"backscatter": "single_scatter"} | options)
    gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    H, W = (int(v) for v in size)
    wl = wavelength_grid(opts.step_nm)
    w = trapezoid_weights(wl)
    i = illuminant_spd(opts.illuminant, wl, interpolation=opts.interpolation)
    nominal = camera_curves(opts.camera, wl, interpolation=opts.interpolation) * w
    P = nominal / float((nominal @ i).max())  # model units: white in air = 1
    R = chart_reflectances(opts.chart, wl, interpolation=opts.interpolation)
    optics = water_optics(wl, chl, cdom, cdom_slope=opts.cdom_slope, nap_slope=opts.nap_slope,
                          interpolation=opts.interpolation)
    sand = SAND_REFLECTANCE[0] * (1 + SAND_REFLECTANCE[1] * (wl - wl[0]) / (wl[-1] - wl[0]))
    palette = np.column_stack([sand, R])  # 0: sand, 1..24: the chart's colours
    top = int(round(open_water * H))
    t = (H - 1 - np.arange(H)) / max(H - 1 - top, 1)
    row_range = near * (far / near) ** np.clip(t, 0, 1)
    rng_map = np.broadcast_to(row_range[:, None], (H, W)).astype(np.float32).copy()
    rng_map[:top] = np.nan
    index = np.zeros((H, W), int)
    blobs = _smooth_field(gen, (H, W), W / 10)
    pick = gen.integers(1, 25, size=8)
    for k, level in enumerate(np.linspace(1.2, 2.2, 8)):
        index[(blobs > level - 0.12) & (blobs <= level)] = pick[k]
    bright = np.exp(0.25 * _smooth_field(gen, (H, W), W / 30)).astype(float)
    out_charts = []
    for spec in charts:
        r_c, xf = float(spec[0]), float(spec[1])
        wpx = int(spec[2] if len(spec) > 2 and spec[2] else chart_px)
        pitch = wpx / CHART_COLUMNS
        y_row = int(np.argmin(np.abs(np.where(np.isnan(row_range), np.inf, row_range) - r_c)))
        x0 = int(round(xf * W - wpx / 2))
        y0 = int(round(min(max(y_row - CHART_ROWS * pitch / 2, top), H - CHART_ROWS * pitch - 1)))
        y1, x1 = int(round(y0 + CHART_ROWS * pitch)), x0 + wpx
        rng_map[y0:y1, x0:x1] = r_c
        bright[y0:y1, x0:x1] = 1.0
        boxes = []
        for j in range(CHART_ROWS * CHART_COLUMNS):
            rr, cc = divmod(j, CHART_COLUMNS)
            a0, b0 = x0 + cc * pitch, y0 + rr * pitch
            index[int(round(b0)):int(round(b0 + pitch)), int(round(a0)):int(round(a0 + pitch))] = j + 1
            boxes.append([a0 + pitch / 4, b0 + pitch / 4, a0 + 3 * pitch / 4, b0 + 3 * pitch / 4])
        out_charts.append({"range": r_c, "grid": np.array([[x0 - 0.5, y0 - 0.5], [x1 - 0.5, y0 - 0.5],
                                                          [x1 - 0.5, y1 - 0.5], [x0 - 0.5, y1 - 0.5]]),
                           "boxes": np.array(boxes), "air": P @ (i[:, None] * R)})
    # the direct light of every palette colour at every row's range, then per pixel
    known = np.where(np.isfinite(rng_map), rng_map, 0.0)
    flat = known.ravel()
    uniq, inv = np.unique(flat, return_inverse=True)
    k = np.exp(-optics["c"] * (depth + uniq[:, None])) if opts.path == "paper" else \
        np.exp(-optics["K_d"] * depth - optics["c"] * uniq[:, None])
    direct = np.einsum("cq,uq,qk->uck", P, i * k, palette)  # (ranges, 3, colours)
    lit = i * np.exp(-optics["K_d"] * depth) * optics["b_b"] / optics["c"] * opts.backscatter_scale
    veil = (lit * -np.expm1(-optics["c"] * uniq[:, None])) @ P.T  # (ranges, 3)
    veil_inf = P @ lit
    pix = direct[inv, :, index.ravel()] * bright.ravel()[:, None] + veil[inv]
    pix = pix.reshape(H, W, 3)
    pix[:top] = veil_inf
    scale = exposure / float(pix.max())
    expected = (pix * scale).astype(np.float32)
    if opts.noise:
        e = opts.electrons_full_scale
        img = (gen.poisson(np.clip(expected, 0, None) * e) + gen.normal(0, opts.read_noise_e,
                                                                         expected.shape)) / e
    else:
        img = expected.copy()
    img = np.clip(img, 0, 1 if opts.clip is None else opts.clip).astype(np.float32)
    return {"image": img, "expected": expected, "range": rng_map, "charts": out_charts,
            "white_air": P @ i, "scale": scale, "optics": optics,
            "truth": {"chl": chl, "cdom": cdom, "depth": depth, "options": dataclasses.asdict(opts)}}
