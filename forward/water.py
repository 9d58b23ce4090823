"""Inherent optical properties of sea water (eqs 4-12): one immutable :class:`Water` model.

Every constant of eqs 6-12 and Table 1, and the two tables they use (pure-water absorption and
the phytoplankton absorption basis), are fields of :class:`Water`; the paper's values are the
defaults. :class:`Water` alone assembles the attenuation coefficient c(x) and its derivative
on a wavelength grid (:meth:`Water.on_grid` -> :class:`WaterTerms`); the simulator and every
estimator (the cvxpy loop, the scipy path, the batch) take their numbers from it.

The model is a sum of terms, each a weight times a spectrum (``ABSORPTION_TERMS``:
a_w, CDOM, phytoplankton, NAP; ``SCATTERING_TERMS``: b_w, b_k, the two particle terms;
:meth:`WaterTerms.path_coefficient` adds them with their derivatives). The four chlorophyll
terms j (weights phi_j(C), spectra S_j):

    j  term                     phi_j(C)                             S_j(lambda)
    0  phytoplankton (eqs 9-10) 0.0378 C^0.627                       (T w)(l) / (T w)(440)
    1  NAP (eqs 7-8)            0.0124 C^0.724                       exp(-0.011 (l - 440))
    2  pico + nano (eq 12)      C12 (1 - exp(-S12 C))                b*_p12 (l/l0)^-g12  [beam]
    3  micro (eq 12)            C - C12 (1 - exp(-S12 C))            b*_p3 (l/l0)^-g3    [beam]

Every weight has the one form phi(C) = p C^e + g (1 - exp(-h C)); :meth:`Water.chl_terms`
gives the (4, 4) table of (p, e, g, h), so code can evaluate the weights from numbers
(:meth:`Water.chl_weights`, :func:`chl_weight`) instead of restating the formulas.

Wavelengths in nm, coefficients in m^-1, chlorophyll ``chl`` (C) in mg m^-3, ``cdom`` is
a_CDOM(440 nm) in m^-1. ``chl`` and ``cdom`` may be scalars or arrays (shape S); a spectrum then
has shape S + (q,).

Reference: H. Blasinski and J. Farrell, "A Three Parameter Underwater Image Formation Model".
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import hashlib
import math
from dataclasses import dataclass, field

import numpy as np

from . import validate
from .spectra import (
    LAMBDA_0_NM,
    is_path,
    on_grid,
    read_spectral_csv,
    read_spectral_table,
    read_table,
    resample,
    wavelength_grid,
)

__all__ = [
    "BASIS_TABLE",
    "CDOM_SLOPE",
    "CHL_TERMS",
    "COEFFICIENT_PARAMS",
    "NAP_SLOPE",
    "PAPER_WATER",
    "PATH_MODELS",
    "PATH_TERMS",
    "PATH_LEGS",
    "BEAM_TERMS",
    "DIFFUSE_TERMS",
    "ABSORPTION_TERMS",
    "NONWATER_ABSORPTION_TERMS",
    "PARTICLE_TERMS",
    "SCATTERING_TERMS",
    "PURE_WATER_TABLE",
    "TABLE1",
    "Water",
    "WaterTerms",
    "absorption",
    "attenuation_coefficient",
    "backscattering",
    "cdom_absorption",
    "chl_weight",
    "chl_weight_derivative",
    "nap_absorption",
    "nap_absorption_440",
    "particle_scattering",
    "particle_scattering_terms",
    "particle_scattering_weights",
    "phytoplankton_absorption",
    "phytoplankton_absorption_440",
    "phytoplankton_basis",
    "pure_water_absorption",
    "pure_water_scattering",
    "resolve_water",
    "scattering",
    "table1",
]

#: Path models for the attenuation k: 'beam' uses c = a + b (eqs 3, 4), 'absorption' the
#: literal eq 13 / 14 (absorption a only).
PATH_MODELS = ("beam", "absorption", "split")
#: CDOM spectral slope of eq 6 (nm^-1); the paper uses 0.014 (range 0.014-0.019).
CDOM_SLOPE = 0.014
#: NAP spectral slope of eq 7 (nm^-1); the paper uses 0.011 (range 0.006-0.014).
NAP_SLOPE = 0.011
#: Names of the chlorophyll terms (rows of :meth:`Water.chl_terms`).
CHL_TERMS = ("phytoplankton", "nap", "particles_small", "particles_large")

#: File of ``data/`` with the pure-water absorption a_w of eq 5 (Smith & Baker 1981).
PURE_WATER_TABLE = "pure_water_absorption_smith_baker_1981.csv"
#: File of ``data/`` with the phytoplankton absorption basis T of eq 9 (one shape, from ref. [21]).
BASIS_TABLE = "phytoplankton_absorption_basis.csv"
#: File of ``data/`` with the Table 1 constants of eq 12 (Brewin et al. 2012).
TABLE1 = "particle_scattering_table1.csv"


def _table1_file() -> dict:
    """Table 1 as published (``data/particle_scattering_table1.csv``): a fresh dict."""
    _, rows = read_table(TABLE1)
    return {r[0].strip(): float(r[2]) for r in rows}


_T1 = _table1_file()


def _default_pure_water():
    wl, vals = read_spectral_table(PURE_WATER_TABLE)
    return wl, vals[:, 0]


def _default_basis():
    return read_spectral_table(BASIS_TABLE)


def _readonly(a) -> np.ndarray:
    out = np.array(a, dtype=float)
    out.setflags(write=False)
    return out


# --------------------------------------------------------------------------- the weight form
def chl_weight(c, p, e, g, h):
    """phi(C) = p C^e + g (1 - exp(-h C)): the one form of every chlorophyll weight.

    Parameters
    ----------
    c : float or array_like
        Chlorophyll concentration C, mg m^-3 (>= 0).
    p, e, g, h : float or array_like
        The coefficients of one row of :meth:`Water.chl_terms` (broadcast against ``c``):
        scale p, exponent e (dimensionless), saturation level g (mg m^-3) and rate h
        (m^3 mg^-1).

    Returns
    -------
    numpy.ndarray or float
        phi(C), broadcast shape of the inputs: m^-1 for the absorption terms (eqs 8, 10),
        mg m^-3 for the particle weights of eq 12.

    References
    ----------
    Blasinski & Farrell, eqs 8, 10 and 12 (Bricaud et al. 1998; Brewin et al. 2012).
    """
    # one expression for every row (a zero p or g adds an exact 0): numba compiles this same
    # function for the batch's engine (sca.fusedlm)
    return p * c ** e + g * -np.expm1(-h * c)


def chl_weight_derivative(c, p, e, g, h):
    """d phi / dC = p e C^(e-1) + g h exp(-h C), the slope of :func:`chl_weight`.

    Infinite at C = 0 where 0 < e < 1 and p > 0 (C^0.627, C^0.724): callers evaluate it at a
    small floor (:meth:`Water.chl_weights`).

    Parameters
    ----------
    c : float or array_like
        Chlorophyll concentration C, mg m^-3 (>= 0).
    p, e, g, h : float or array_like
        The coefficients of one row of :meth:`Water.chl_terms` (see :func:`chl_weight`).

    Returns
    -------
    numpy.ndarray or float
        d phi / dC, broadcast shape of the inputs, in phi's unit per mg m^-3.

    References
    ----------
    Blasinski & Farrell, eqs 8, 10 and 12 (derivatives of).
    """
    # one expression for every row (numba compiles this same function, sca.fusedlm); a row
    # with p = 0 has e = 1 (Water.chl_terms), so its first part is an exact 0 at C = 0 too
    return p * e * c ** (e - 1.0) + g * h * np.exp(-h * c)


@dataclass(frozen=True, eq=False)
class Water:
    """The sea-water model of eqs 4-12: constants, tables and path model (immutable).

    Two ``Water`` objects are equal when all their numbers are; a ``Water`` is hashable, so
    results computed from it can be cached safely. Change a constant with keywords,
    ``Water(cdom_slope=0.018)``, or :func:`dataclasses.replace`. Every parameter is also a
    (read-only) attribute of the same name; the defaults are the paper's (:data:`PAPER_WATER`).

    Parameters
    ----------
    path_model : {'beam', 'absorption', 'split'}
        'beam' (k = exp(-L c), c = a + b, eqs 3-4; default), 'absorption' (k = exp(-L a),
        eq 13 as printed) or 'split' (k = exp(-depth K_d - distance c): the daylight's way
        down with the diffuse attenuation K_d = (a + b_b) / mu_d, the camera's horizontal ray
        with the beam attenuation c). DECISIONS.md.
    reference_nm : float
        lambda_0 of eqs 6-8, 10 and 17, nm (440).
    cdom_slope : float
        S of eq 6, a_CDOM = a_CDOM(440) exp(-S (l - 440)), nm^-1 (0.014; Bricaud et al. 1981,
        ref. [19]: 0.014-0.019).
    nap_slope : float
        Slope of eq 7, nm^-1 (0.011; Roesler et al. 1989, ref. [20]: 0.006-0.014).
    nap_scale, nap_exponent : float
        Eq 8, a_NAP(440) = 0.0124 C^0.724 m^-1 with C in mg m^-3 (Bricaud et al. 1998, ref.
        [18]): the scale is a_NAP(440) in m^-1 at C = 1 mg m^-3, the exponent dimensionless.
    phyto_scale, phyto_exponent : float
        Eq 10 / 17, a_phi(440) = 0.0378 C^0.627 m^-1 with C in mg m^-3 (ref. [18]).
    c_12 : float
        C_12 of eq 12, mg m^-3 (Table 1: 0.78; Brewin et al. 2012, ref. [24]).
    s_12 : float
        S_12 of eq 12, m^3 mg^-1 (Table 1: 1.1449).
    b_p12_star : float
        b*_p,1,2 at lambda_0, m^2 mg^-1 (Table 1: 0.0046).
    b_p3_star : float
        b*_p,3 at lambda_0, m^2 mg^-1 (Table 1: 0.0005).
    b_k : float
        Background b_k at lambda_0 = 470 nm, m^-1 (Table 1: 0.00068).
    gamma_12, gamma_3, gamma_k : float
        Spectral exponents of eq 12, dimensionless (Table 1: 0.7, -0.2, 1.9).
    scattering_reference_nm : float
        lambda_0 of eq 12 and Table 1, nm (470).
    water_scattering, water_scattering_exponent : float
        b_w = 0.00288 (l / 500)^-4.32 m^-1 (eq 11; Morel 1974, ref. [23]): the scale in m^-1
        at 500 nm, the exponent dimensionless.
    water_backscatter_fraction : float
        b_bw / b_w for the veiling light (0.5: pure water scatters symmetrically).
    particle_backscatter_fraction : float
        b_bp / b_p for the veiling light (1: eq 12 *is* a backscattering model in its source,
        Brewin et al. 2012; DECISIONS.md).
    downwelling_cosine : float
        mu_d, the mean cosine of the downwelling light of the 'split' path model, dimensionless
        (0.75: K_d ~ (a + b_b) / mu_d, Gordon 1989; mu_d ~ 0.7-0.9 in the upper ocean, Kirk
        2011, ch. 6).
    pure_water_absorption_table : tuple (wavelengths, values) or str or os.PathLike
        (wavelength nm, a_w m^-1) of eq 5 (Smith & Baker 1981, ref. [16],
        ``data/pure_water_absorption_smith_baker_1981.csv``), linearly interpolated; or a CSV
        file with those two columns.
    phytoplankton_basis_table : tuple (wavelengths, values) or str or os.PathLike
        (wavelength nm, (n, z) basis T of eq 9) (``data/phytoplankton_absorption_basis.csv``,
        derived from ref. [21]), or a CSV file (wavelength, one column per basis function).

    Raises
    ------
    ValueError
        Naming the field: an unknown ``path_model``, a non-finite constant or one of the wrong
        sign (``reference_nm``, ``scattering_reference_nm``, ``phyto_scale`` and the exponents
        of eqs 8 and 10 must be > 0; ``nap_scale``, the Table 1 constants C_12, S_12, b*_p12,
        b*_p3, b_k, ``water_scattering`` and the fractions >= 0; the slopes and spectral
        exponents may have any sign), or a table that is not (strictly increasing wavelengths,
        one finite nonnegative row per wavelength).

    References
    ----------
    Blasinski & Farrell, eqs 3-14 and Table 1; Smith & Baker 1981; Morel 1974; Bricaud et al.
    1981; Roesler et al. 1989; Bricaud et al. 1998; Brewin et al. 2012; Fujiki & Taguchi 2002.
    """

    path_model: str = "beam"
    reference_nm: float = LAMBDA_0_NM
    cdom_slope: float = CDOM_SLOPE
    nap_slope: float = NAP_SLOPE
    nap_scale: float = 0.0124
    nap_exponent: float = 0.724
    phyto_scale: float = 0.0378
    phyto_exponent: float = 0.627
    c_12: float = _T1["C_12"]
    s_12: float = _T1["S_12"]
    b_p12_star: float = _T1["b_p12_star"]
    b_p3_star: float = _T1["b_p3_star"]
    b_k: float = _T1["b_k"]
    gamma_12: float = _T1["gamma_12"]
    gamma_3: float = _T1["gamma_3"]
    gamma_k: float = _T1["gamma_k"]
    scattering_reference_nm: float = _T1["lambda_0"]
    water_scattering: float = 0.00288
    water_scattering_exponent: float = 4.32
    water_backscatter_fraction: float = 0.5
    particle_backscatter_fraction: float = 1.0
    downwelling_cosine: float = 0.75
    pure_water_absorption_table: tuple = field(default_factory=_default_pure_water, repr=False)
    phytoplankton_basis_table: tuple = field(default_factory=_default_basis, repr=False)

    _POSITIVE = ("reference_nm", "phyto_scale", "phyto_exponent", "nap_exponent",
                 "scattering_reference_nm", "downwelling_cosine")
    _NONNEGATIVE = ("nap_scale", "c_12", "s_12", "b_p12_star", "b_p3_star", "b_k",
                    "water_scattering", "water_backscatter_fraction",
                    "particle_backscatter_fraction")
    _ANY_SIGN = ("cdom_slope", "nap_slope", "gamma_12", "gamma_3", "gamma_k",
                 "water_scattering_exponent")

    def __post_init__(self):
        if self.path_model not in PATH_MODELS:
            raise ValueError(f"path_model: must be one of {PATH_MODELS}, got {self.path_model!r}")
        for name in self._POSITIVE:
            object.__setattr__(self, name, validate.scalar(name, getattr(self, name), positive=True))
        for name in self._NONNEGATIVE:
            object.__setattr__(self, name, validate.scalar(name, getattr(self, name)))
        for name in self._ANY_SIGN:
            object.__setattr__(self, name,
                               validate.scalar(name, getattr(self, name), nonnegative=False))
        object.__setattr__(self, "pure_water_absorption_table",
                           self._table("pure_water_absorption_table", ncols=1))
        object.__setattr__(self, "phytoplankton_basis_table",
                           self._table("phytoplankton_basis_table", ncols=None))
        object.__setattr__(self, "_chl_terms", _readonly([
            [self.phyto_scale, self.phyto_exponent, 0.0, 0.0],   # eq 10
            [self.nap_scale, self.nap_exponent, 0.0, 0.0],       # eq 8
            [0.0, 1.0, self.c_12, self.s_12],                    # eq 12, pico + nano
            [1.0, 1.0, -self.c_12, self.s_12],                   # eq 12, micro
        ]))
        object.__setattr__(self, "_key", self._fingerprint())

    def _table(self, name, ncols):
        value = getattr(self, name)
        if is_path(value):
            wl, vals = read_spectral_csv(value, name=name)
        else:
            try:
                wl, vals = value
            except (TypeError, ValueError):
                raise ValueError(f"{name}: expected (wavelengths, values) or a CSV file") from None
        wl = validate.array(name, wl, ndim=1)
        vals = validate.array(name, vals, nonnegative=True)
        if vals.ndim == 1:
            vals = vals[:, None]
        if vals.ndim != 2 or vals.shape[0] != wl.size or (ncols and vals.shape[1] != ncols):
            raise ValueError(f"{name}: values must have one row per wavelength"
                             + (f" and {ncols} column" if ncols else ""))
        if wl.size < 2 or np.any(np.diff(wl) <= 0):
            raise ValueError(f"{name}: wavelengths must be strictly increasing (>= 2 rows)")
        return _readonly(wl), _readonly(vals[:, 0] if ncols == 1 else vals)

    def _fingerprint(self) -> str:
        h = hashlib.sha256()
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if isinstance(v, tuple):
                for a in v:
                    h.update(np.ascontiguousarray(a, dtype=float).tobytes())
                    h.update(repr(np.shape(a)).encode())
            else:
                h.update(f"{f.name}={v!r};".encode())
        return h.hexdigest()

    def __eq__(self, other):
        return isinstance(other, Water) and self._key == other._key

    def __hash__(self):
        return hash(self._key)

    # ------------------------------------------------------------------ constants and tables
    def table1(self) -> dict:
        """The Table 1 constants of this model (a fresh dict, the CSV's names).

        Returns
        -------
        dict of str to float
            'C_12' (mg m^-3), 'S_12' (m^3 mg^-1), 'b_p12_star', 'b_p3_star' (m^2 mg^-1),
            'b_k' (m^-1), 'gamma_12', 'gamma_3', 'gamma_k' (dimensionless) and 'lambda_0'
            (nm), as in ``data/particle_scattering_table1.csv``.

        References
        ----------
        Blasinski & Farrell, Table 1 and eq 12 (from Brewin et al. 2012).
        """
        return {"C_12": self.c_12, "S_12": self.s_12, "b_p12_star": self.b_p12_star,
                "b_p3_star": self.b_p3_star, "b_k": self.b_k, "gamma_12": self.gamma_12,
                "gamma_3": self.gamma_3, "gamma_k": self.gamma_k,
                "lambda_0": self.scattering_reference_nm}

    def constants(self) -> dict:
        """Every scalar field (JSON-ready): all fields but the two tables.

        Returns
        -------
        dict
            Field name -> value (``path_model`` a str, the constants floats, in the units of
            the class's parameters).
        """
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)
                if not isinstance(getattr(self, f.name), tuple)}

    def chl_terms(self) -> np.ndarray:
        """The (4, 4) table of (p, e, g, h) of the chlorophyll weights of :data:`CHL_TERMS`.

        Row j gives phi_j(C) = p C^e + g (1 - exp(-h C)) (:func:`chl_weight`).

        Returns
        -------
        numpy.ndarray, shape (4, 4)
            Read-only; rows phytoplankton (eq 10), NAP (eq 8), pico + nano and micro particles
            (eq 12); columns p, e (dimensionless), g (mg m^-3), h (m^3 mg^-1).

        References
        ----------
        Blasinski & Farrell, eqs 8, 10 and 12 (Bricaud et al. 1998; Brewin et al. 2012).
        """
        return self._chl_terms

    def chl_weights(self, chl, *, derivative: bool = False, floor: float = 0.0):
        """The four chlorophyll weights phi_j(C), in the order of :data:`CHL_TERMS`.

        Parameters
        ----------
        chl : float or array_like, shape S
            Chlorophyll concentration C, mg m^-3 (not checked here; >= 0).
        derivative : bool, optional
            Also return d phi / dC (default False).
        floor : float, optional
            d phi / dC is evaluated at max(C, ``floor``), mg m^-3 (default 0: infinite at
            C = 0 for the C^0.627 and C^0.724 terms).

        Returns
        -------
        phi : numpy.ndarray, shape S + (4,)
            a_phi(440) and a_NAP(440) in m^-1, then the two particle weights of eq 12 in
            mg m^-3.
        dphi : numpy.ndarray, shape S + (4,)
            d phi / dC (only with ``derivative=True``; then a tuple ``(phi, dphi)`` is
            returned).

        References
        ----------
        Blasinski & Farrell, eqs 8, 10 and 12.
        """
        c = np.asarray(chl, float)[..., None]
        p, e, g, h = self._chl_terms.T
        val = chl_weight(c, p, e, g, h)
        if not derivative:
            return val
        cf = np.maximum(c, floor)
        with np.errstate(divide="ignore"):
            d = chl_weight_derivative(cf, p, e, g, h)
        return val, np.where(p * e == 0, g * h * np.exp(-h * cf), d)

    def phytoplankton_440(self, chl, *, derivative: bool = False, floor: float = 0.0):
        """a_phi(440) = 0.0378 C^0.627 m^-1 (eq 10, the right side of eq 17).

        Parameters
        ----------
        chl : float or array_like, shape S
            Chlorophyll concentration C, mg m^-3 (not checked here; >= 0).
        derivative : bool, optional
            Also return d a_phi(440) / dC (default False).
        floor : float, optional
            The derivative is evaluated at max(C, ``floor``), mg m^-3 (default 0: infinite at
            C = 0).

        Returns
        -------
        value : numpy.ndarray, shape S
            a_phi(440 nm), m^-1.
        derivative : numpy.ndarray, shape S
            d a_phi(440) / dC, m^-1 per mg m^-3 (only with ``derivative=True``; then a tuple
            is returned).

        References
        ----------
        Blasinski & Farrell, eqs 10 and 17 (Bricaud et al. 1998).
        """
        out = self.chl_weights(chl, derivative=derivative, floor=floor)
        return (out[0][..., 0], out[1][..., 0]) if derivative else out[..., 0]

    # ------------------------------------------------------------------ spectra on a grid
    def on_grid(self, wavelengths=None, *, basis=None, weights=None) -> "WaterTerms":
        """The spectral terms of c(x) on ``wavelengths`` (see :class:`WaterTerms`).

        Without ``basis`` and ``weights`` the result is cached per (water, grid) and shared.

        Parameters
        ----------
        wavelengths : array_like, shape (q,), optional
            Wavelengths in nm (default: 400-700 nm at 1 nm).
        basis : array_like, shape (q,) or (q, z), or str or os.PathLike, optional
            A basis T of eq 9 on the grid, or a CSV file, replacing this model's basis table
            (see :func:`phytoplankton_basis`).
        weights : array_like, shape (z,), optional
            The shape w of eq 9 for z > 1 (rescaled so that eq 10 holds).

        Returns
        -------
        WaterTerms
            The read-only spectral terms of this water on the grid.

        References
        ----------
        Blasinski & Farrell, eqs 4-12.
        """
        wl = wavelength_grid(wavelengths)
        if basis is None and weights is None:
            return _terms_cached(self, tuple(wl))
        return WaterTerms.build(self, wl, basis, weights)


@functools.lru_cache(maxsize=64)
def _terms_cached(water: Water, wl_key: tuple) -> "WaterTerms":
    # keyed on the water's numbers (its hash and equality) and the grid: never stale
    return WaterTerms.build(water, np.array(wl_key), None, None)


#: The paper's model (all defaults). Immutable, so safe to share.
PAPER_WATER = Water()


def resolve_water(water=None, *, path_model=None, cdom_slope=None) -> Water:
    """Return ``water`` (default :data:`PAPER_WATER`) with ``path_model`` / ``cdom_slope`` replaced.

    The two keywords are the older ones of :func:`forward.simulate_chart` and
    :func:`sca.estimate`; a value equal to the water's own changes nothing.

    Parameters
    ----------
    water : Water, optional
        The water model (default: the paper's, :data:`PAPER_WATER`).
    path_model : {'beam', 'absorption'}, optional
        Replaces ``water.path_model`` when given.
    cdom_slope : float, optional
        Replaces ``water.cdom_slope`` (S of eq 6, nm^-1) when given.

    Returns
    -------
    Water
        ``water`` itself when nothing changes, else a new :class:`Water`.

    Raises
    ------
    ValueError
        If ``water`` is not a :class:`Water`, or a replacement is invalid.
    """
    if water is None:
        water = PAPER_WATER
    elif not isinstance(water, Water):
        raise ValueError(f"water: expected a forward.Water, got {type(water).__name__}")
    changes = {}
    if path_model is not None and path_model != water.path_model:
        changes["path_model"] = path_model
    if cdom_slope is not None and cdom_slope != water.cdom_slope:
        changes["cdom_slope"] = cdom_slope
    return dataclasses.replace(water, **changes) if changes else water


def phytoplankton_basis(wavelengths=None, basis=None, *, water: Water | None = None):
    """The phytoplankton absorption basis T of eq 9 on the grid, (q, z), and its row at 440 nm.

    Parameters
    ----------
    wavelengths : array_like, shape (q,), optional
        Wavelengths in nm (default: 400-700 nm at 1 nm).
    basis : array_like, shape (q,) or (q, z), or str or os.PathLike, optional
        ``None`` (default): the basis table of ``water`` (default: the single shape of
        ``data/phytoplankton_absorption_basis.csv``), normalised so that t(440 nm) = 1.
        Otherwise an array (q,) or (q, z) on the grid (the grid must then span 440 nm), or a
        CSV file (wavelength in nm, one column per basis function), used as given.
    water : Water, optional
        The water model whose table and reference wavelength (440 nm) are used (default: the
        paper's).

    Returns
    -------
    T : numpy.ndarray, shape (q, z)
        The basis functions on the grid (relative absorption shapes).
    t440 : numpy.ndarray, shape (z,)
        t(440 nm), read from the table (or interpolated linearly on the grid), used by eqs 10
        and 17.

    Raises
    ------
    ValueError
        For a basis with negative values, of the wrong shape, on a grid that does not span
        440 nm, or with every function zero at 440 nm.

    References
    ----------
    Blasinski & Farrell, eqs 9, 10 and 17; basis derived from Fujiki & Taguchi 2002 (ref. [21]).
    """
    wl = wavelength_grid(wavelengths)
    water = resolve_water(water)
    lam0 = water.reference_nm
    if basis is None or is_path(basis):
        if basis is None:
            src_wl, vals = water.phytoplankton_basis_table
        else:
            src_wl, vals = read_spectral_csv(basis, name="basis")
            if np.any(vals < 0):
                raise ValueError("basis: contains negative values")
        t440 = np.array([np.interp(lam0, src_wl, v) for v in vals.T])
        if basis is None:
            vals, t440 = vals / t440, np.ones(vals.shape[1])
        return resample(src_wl, vals, wl, name="basis"), t440
    T = on_grid(basis, wl, "basis", None)
    if not (wl[0] <= lam0 <= wl[-1]):
        raise ValueError("basis: the wavelength grid must contain 440 nm (eq 17) for an array basis")
    t440 = np.array([np.interp(lam0, wl, col) for col in T.T])
    if np.all(t440 <= 0):
        raise ValueError("basis: all basis functions are zero at 440 nm, so eq 17 cannot fix their scale")
    return T, t440


@dataclass(frozen=True, eq=False)
class WaterTerms:
    """The spectral terms of c(x) of one :class:`Water` on one grid (arrays read-only).

    The spectra of every term of c(x); :meth:`path_coefficient` adds the terms (c for 'beam',
    a for 'absorption'); with a free phytoplankton weight vector w (z basis functions, eq 9)
    the phytoplankton term is T w.

    Build one with :meth:`Water.on_grid` (cached) or :meth:`build`, not by hand. Every
    parameter is also an attribute of the same name. In the methods, ``chl`` is C in
    mg m^-3 and ``cdom`` a_CDOM(440 nm) in m^-1, scalars or arrays of one shape S (not checked
    here); spectra have shape S + (q,).

    Parameters
    ----------
    water : Water
        The model these terms belong to.
    wavelengths : numpy.ndarray, shape (q,)
        The grid, nm.
    pure_water_absorption : numpy.ndarray, shape (q,)
        a_w, m^-1 (eq 5).
    pure_water_scattering : numpy.ndarray, shape (q,)
        b_w, m^-1 (eq 11).
    background_scattering : numpy.ndarray, shape (q,)
        b_k (l/l0)^-g_k, m^-1 (eq 12, third term).
    particle_shapes : numpy.ndarray, shape (2, q)
        b*_p12 (l/l0)^-g12 and b*_p3 (l/l0)^-g3 (eq 12), m^2 mg^-1.
    cdom_shape : numpy.ndarray, shape (q,)
        exp(-S (l - 440)), dimensionless (eq 6).
    nap_shape : numpy.ndarray, shape (q,)
        exp(-S_NAP (l - 440)), dimensionless (eq 7).
    T : numpy.ndarray, shape (q, z)
        Basis of eq 9.
    t440 : numpy.ndarray, shape (z,)
        The basis at 440 nm.
    phyto_shape : numpy.ndarray, shape (q,)
        The phytoplankton shape a_phi / a_phi(440) (T w / t440 w), dimensionless.
    free_only : bool, optional
        True for a z > 1 basis given without weights: only the free-w form (``w=`` given) of
        the methods below can be used (default False).

    References
    ----------
    Blasinski & Farrell, eqs 4-12 and Table 1.
    """

    water: Water
    wavelengths: np.ndarray
    pure_water_absorption: np.ndarray
    pure_water_scattering: np.ndarray
    background_scattering: np.ndarray
    particle_shapes: np.ndarray
    cdom_shape: np.ndarray
    nap_shape: np.ndarray
    T: np.ndarray
    t440: np.ndarray
    phyto_shape: np.ndarray
    free_only: bool = False

    @classmethod
    def build(cls, water: Water, wl, basis=None, weights=None) -> "WaterTerms":
        """Compute the spectral terms of ``water`` on the grid ``wl`` (uncached).

        Parameters
        ----------
        water : Water
            The water model.
        wl : array_like, shape (q,)
            Wavelengths in nm (checked by :func:`forward.wavelength_grid`).
        basis : array_like, shape (q,) or (q, z), or str or os.PathLike, optional
            Replaces the water's phytoplankton basis table (see :func:`phytoplankton_basis`).
        weights : array_like, shape (z,), optional
            The shape w of eq 9 (default: equal weights 1/z); rescaled so that eq 10 holds.

        Returns
        -------
        WaterTerms
            The terms, every array read-only.

        Raises
        ------
        ValueError
            For an invalid grid, basis or weights (T w not positive at 440 nm or negative
            somewhere, eq 16).

        References
        ----------
        Blasinski & Farrell, eqs 4-12 and Table 1; Smith & Baker 1981 (a_w); Morel 1974 (b_w).
        """
        wl = wavelength_grid(wl)
        src_wl, a_w_src = water.pure_water_absorption_table
        a_w = resample(src_wl, a_w_src, wl, name="pure_water_absorption_table")
        b_w = water.water_scattering * (wl / 500.0) ** -water.water_scattering_exponent
        r = wl / water.scattering_reference_nm
        bk = water.b_k * r ** -water.gamma_k
        particles = np.stack([water.b_p12_star * r ** -water.gamma_12,
                              water.b_p3_star * r ** -water.gamma_3])
        cdom = np.exp(-water.cdom_slope * (wl - water.reference_nm))
        nap = np.exp(-water.nap_slope * (wl - water.reference_nm))
        T, t440 = phytoplankton_basis(wl, basis, water=water)
        z = T.shape[1]
        # without weights a z > 1 basis has no fixed shape: only the free-w form can be used
        free_only = weights is None and z > 1
        w = np.full(z, 1.0 / z) if weights is None else validate.array("weights", weights, shape=(z,))
        scale440 = float(t440 @ w)
        if scale440 <= 0:
            raise ValueError("weights: the basis combination T w must be positive at 440 nm")
        phyto = T @ w / scale440
        if np.any(phyto < -1e-12):
            raise ValueError("weights: T w is negative at some wavelength (violates eq 16)")
        arrays = [_readonly(x) for x in (wl, a_w, b_w, bk, particles, cdom, nap, T, t440, phyto)]
        return cls(water, *arrays, free_only)

    def subset(self, index) -> "WaterTerms":
        """These terms on the grid points ``index`` (a subset of this grid): every spectral
        array sliced, no value recomputed (the same numbers at those wavelengths).

        Parameters
        ----------
        index : array_like of int, (r,)
            Increasing indices into :attr:`wavelengths` (at least 3).

        Returns
        -------
        WaterTerms
            The terms on ``wavelengths[index]`` (arrays read-only).
        """
        idx = np.asarray(index, int)
        wl = self.wavelengths[idx]
        if idx.ndim != 1 or wl.size < 3 or np.any(np.diff(idx) <= 0):
            raise ValueError("index: expected at least 3 increasing grid indices")
        cut = [_readonly(a[..., idx]) for a in (self.pure_water_absorption,
                                                self.pure_water_scattering,
                                                self.background_scattering,
                                                self.particle_shapes, self.cdom_shape,
                                                self.nap_shape)]
        return WaterTerms(self.water, _readonly(wl), *cut, _readonly(self.T[idx]),
                          self.t440, _readonly(self.phyto_shape[idx]), self.free_only)

    @functools.cached_property
    def offset(self) -> np.ndarray:
        """lambda - 440 nm (the CDOM and NAP exponentials of eqs 6-7), nm."""
        return _readonly(self.wavelengths - self.water.reference_nm)

    @functools.cached_property
    def ratio(self) -> np.ndarray:
        """lambda / 470 nm (the power laws of eq 12), dimensionless."""
        return _readonly(self.wavelengths / self.water.scattering_reference_nm)

    def _check_shape(self, w):
        if w is None and self.free_only:
            raise ValueError(f"weights: required for a basis of z = {self.T.shape[1]} functions")

    # ---------------------------------------------------------------- the path coefficient
    def path_coefficient(self, chl, cdom, *, w=None, values=None, wrt=(), floor: float = 0.0,
                         terms=None):
        """The path coefficient c(x) and its analytic derivatives: the one place they are built.

        Parameters
        ----------
        chl : array_like, shape S
            Chlorophyll concentration C, mg m^-3.
        cdom : array_like, shape S
            a_CDOM(440 nm), m^-1.
        w : array_like, shape S + (z,), optional
            Free phytoplankton weights (a_phi = T w, eq 9). Default: a_phi from eq 10 with this
            grid's phytoplankton shape (w on eq 17).
        values : dict, optional
            Values (shape S or scalars) of :data:`COEFFICIENT_PARAMS` fields that replace this
            model's constants, e.g. ``{'cdom_slope': 0.018}``.
        wrt : sequence of str
            Names to differentiate by: 'chl', 'cdom', 'w' (z columns) or a field of
            :data:`COEFFICIENT_PARAMS`.
        floor : float
            d/dC is evaluated at max(C, floor): C^0.627 and C^0.724 have infinite slopes at 0.
        terms : sequence of term functions, optional
            Which terms to add (default: the path model's, :data:`PATH_TERMS`); e.g.
            :data:`ABSORPTION_TERMS` gives a, :data:`SCATTERING_TERMS` b.
        Returns
        -------
        c : ndarray, shape S + (q,)
            c(x) for the 'beam' path model, a(x) for 'absorption', m^-1 (eqs 4-12).
        derivatives : dict
            name -> d c / d name, shape S + (q,) (S + (q, z) for 'w').

        Raises
        ------
        ValueError
            For a name of ``values`` outside :data:`COEFFICIENT_PARAMS`, a name of ``wrt``
            that c(x) does not depend on, or (without ``w``) a z > 1 basis without weights.

        References
        ----------
        Blasinski & Farrell, eqs 4-12 and Table 1. Each term of :data:`PATH_TERMS` returns its
        value beside its derivatives.
        """
        values = dict(values or {})
        unknown = set(values) - set(COEFFICIENT_PARAMS)
        if unknown:
            raise ValueError(f"values: not a coefficient parameter: {sorted(unknown)}; "
                             f"choose from {COEFFICIENT_PARAMS}")
        bad = set(wrt) - set(COEFFICIENT_PARAMS) - {"chl", "cdom", "w"}
        if bad:
            raise ValueError(f"wrt: cannot differentiate c(x) by {sorted(bad)}")
        if w is None:
            self._check_shape(None)
        x = _TermInputs(self, np.asarray(chl, float)[..., None], np.asarray(cdom, float)[..., None],
                        None if w is None else np.asarray(w, float), values, floor)
        lead = x.chl.shape[:-1] if x.chl.shape == x.cdom.shape else \
            np.broadcast_shapes(x.chl.shape[:-1], x.cdom.shape[:-1])
        q = self.wavelengths.size
        pieces, by_name = [], {}
        for term in PATH_TERMS[self.water.path_model] if terms is None else terms:
            value, parts = term(x, wrt)
            pieces += value
            for name, d in parts.items():
                by_name.setdefault(name, []).append(d)
        c = _sum_pieces(pieces, lead, q)
        derivatives = {}
        for name in wrt:
            if name == "w":  # d/dw of the phytoplankton term: T (times a leg's factor)
                T = sum(by_name["w"]) if by_name.get("w") else self.T
                derivatives[name] = np.broadcast_to(T, lead + self.T.shape)
                continue
            found = [piece for d in by_name.get(name, []) for piece in d]
            derivatives[name] = _sum_pieces(found, lead, q) if found else \
                np.zeros(lead + (q,))
        return c, derivatives

    def optical_depth(self, chl, cdom, depth, distance, *, w=None, values=None, wrt=(),
                      floor: float = 0.0):
        """tau of k = exp(-tau) along the light's path, and its derivatives: the one place
        where the path model's legs are put together.

        Parameters
        ----------
        chl, cdom, w, values, floor :
            As :meth:`path_coefficient`.
        depth, distance : array_like, shape S
            The chart's depth and the camera-to-chart distance, m.
        wrt : sequence of str
            Names of :meth:`path_coefficient`, and 'depth' and 'distance'.
        Returns
        -------
        tau : ndarray, shape S + (q,)
            (depth + distance) c for the one-leg path models ('beam', 'absorption'), depth K_d +
            distance c for 'split' (dimensionless).
        derivatives : dict
            name -> d tau / d name, shape S + (q,) (S + (q, z) for 'w').

        References
        ----------
        Blasinski & Farrell, eqs 3, 4, 13, 14; H. R. Gordon, "Can the Lambert-Beer law be
        applied to the diffuse attenuation coefficient of ocean water?", Limnol. Oceanogr. 34
        (1989) 1389-1409 (K_d ~ (a + b_b) / mu_d).
        """
        depth = np.asarray(depth, float)[..., None]
        distance = np.asarray(distance, float)[..., None]
        spectral = tuple(n for n in wrt if n not in ("depth", "distance"))
        tau, out = 0.0, {}
        for terms, leg in PATH_LEGS[self.water.path_model]:
            coef, dcoef = self.path_coefficient(chl, cdom, w=w, values=values, wrt=spectral,
                                                floor=floor, terms=terms)
            length = depth + distance if leg == "path" else depth if leg == "depth" else distance
            tau = tau + length * coef
            for name, d in dcoef.items():
                term = (length[..., None] if name == "w" else length) * d
                out[name] = out[name] + term if name in out else term
            for geo in ("depth", "distance"):
                if geo in wrt and (leg == "path" or leg == geo):
                    out[geo] = out[geo] + coef if geo in out else coef
        return tau, out

    def coefficient(self, chl, cdom, w=None) -> np.ndarray:
        """The path coefficient (c for 'beam', a for 'absorption'), m^-1, shape S + (q,).

        Parameters
        ----------
        chl : float or array_like, shape S
            Chlorophyll concentration C, mg m^-3.
        cdom : float or array_like, shape S
            a_CDOM(440 nm), m^-1.
        w : array_like, shape S + (z,), optional
            Free phytoplankton weights (a_phi = T w, eq 9); default: a_phi from eq 10 with
            this grid's phytoplankton shape (see :meth:`path_coefficient`).

        Returns
        -------
        numpy.ndarray, shape S + (q,)
            c = a + b (eq 4) for the 'beam' path model, a (eq 5) for 'absorption', m^-1; a
            fresh writable array.

        References
        ----------
        Blasinski & Farrell, eqs 4-12.
        """
        return np.array(self.path_coefficient(chl, cdom, w=w)[0])

    def jacobian(self, chl, cdom, w=None, *, floor: float = 0.0) -> np.ndarray:
        """The derivative of the path coefficient by x = (C, a_CDOM[, w]).

        Parameters
        ----------
        chl : float or array_like, shape S
            Chlorophyll concentration C, mg m^-3.
        cdom : float or array_like, shape S
            a_CDOM(440 nm), m^-1.
        w : array_like, shape S + (z,), optional
            Free phytoplankton weights (eq 9); default: w on eq 10.
        floor : float, optional
            d/dC is evaluated at max(C, ``floor``), mg m^-3 (see :meth:`path_coefficient`).

        Returns
        -------
        numpy.ndarray, shape S + (q, 2) or S + (q, 2 + z)
            Columns d/dC (m^-1 per mg m^-3), d/d a_CDOM (dimensionless) and, with ``w`` given,
            d/dw_i.

        References
        ----------
        Blasinski & Farrell, eqs 4-12 (derivatives of).
        """
        wrt = ("chl", "cdom") + (("w",) if w is not None else ())
        _, d = self.path_coefficient(chl, cdom, w=w, wrt=wrt, floor=floor)
        cols = [d["chl"][..., None], d["cdom"][..., None]] + ([d["w"]] if w is not None else [])
        return np.concatenate(cols, axis=-1)

    # ---------------------------------------------------------------- individual terms
    def absorption(self, chl, cdom, w=None) -> np.ndarray:
        """Total absorption a = a_w + a_phi + a_CDOM + a_NAP (eq 5), m^-1.

        Parameters
        ----------
        chl : float or array_like, shape S
            Chlorophyll concentration C, mg m^-3.
        cdom : float or array_like, shape S
            a_CDOM(440 nm), m^-1.
        w : array_like, shape S + (z,), optional
            Free phytoplankton weights (a_phi = T w, eq 9); default: a_phi from eq 10.

        Returns
        -------
        numpy.ndarray, shape S + (q,)
            a, m^-1, whatever the path model.

        References
        ----------
        Blasinski & Farrell, eqs 5-10.
        """
        return np.array(self.path_coefficient(chl, cdom, w=w, terms=ABSORPTION_TERMS)[0])

    def particle_scattering(self, chl) -> np.ndarray:
        """Particle scattering b_p (eq 12, all three terms), m^-1.

        Parameters
        ----------
        chl : float or array_like, shape S
            Chlorophyll concentration C, mg m^-3.

        Returns
        -------
        numpy.ndarray, shape S + (q,)
            b_p, m^-1, whatever the path model.

        References
        ----------
        Blasinski & Farrell, eq 12 and Table 1 (Brewin et al. 2012).
        """
        return np.array(self.path_coefficient(chl, 0.0, terms=PARTICLE_TERMS)[0])

    def scattering(self, chl) -> np.ndarray:
        """Total scattering b = b_w + b_p (eq 11), m^-1.

        Parameters
        ----------
        chl : float or array_like, shape S
            Chlorophyll concentration C, mg m^-3.

        Returns
        -------
        numpy.ndarray, shape S + (q,)
            b, m^-1, whatever the path model.

        References
        ----------
        Blasinski & Farrell, eqs 11 and 12; Morel 1974 (b_w).
        """
        return np.array(self.path_coefficient(chl, 0.0, terms=SCATTERING_TERMS)[0])

    def beam_coefficient(self, chl, cdom, w=None) -> np.ndarray:
        """Beam attenuation coefficient c = a + b (eq 4), m^-1, whatever the path model.

        Parameters
        ----------
        chl : float or array_like, shape S
            Chlorophyll concentration C, mg m^-3.
        cdom : float or array_like, shape S
            a_CDOM(440 nm), m^-1.
        w : array_like, shape S + (z,), optional
            Free phytoplankton weights (eq 9); default: a_phi from eq 10.

        Returns
        -------
        numpy.ndarray, shape S + (q,)
            c, m^-1.

        References
        ----------
        Blasinski & Farrell, eqs 4-12.
        """
        return np.array(self.path_coefficient(chl, cdom, w=w,
                                              terms=ABSORPTION_TERMS + SCATTERING_TERMS)[0])

    def backscattering(self, chl) -> np.ndarray:
        """Backscattering b_b = f_w b_w + f_p b_p, m^-1 (the veiling light's scattering).

        f_w and f_p are ``water.water_backscatter_fraction`` (0.5) and
        ``water.particle_backscatter_fraction`` (1); DECISIONS.md.

        Parameters
        ----------
        chl : float or array_like, shape S
            Chlorophyll concentration C, mg m^-3.

        Returns
        -------
        numpy.ndarray, shape S + (q,)
            b_b, m^-1.

        References
        ----------
        Blasinski & Farrell, eq 2 (rho_b, for which the paper gives no model), eqs 11-12;
        Morel 1974; Brewin et al. 2012 (eq 12 is their b_bp).
        """
        wt = self.water
        return (wt.water_backscatter_fraction * self.pure_water_scattering
                + wt.particle_backscatter_fraction * self.particle_scattering(chl))


# =========================================================================== the terms of c(x)
#: ``forward.Water`` fields that enter the path coefficient c(x), so they can be estimated
#: (eqs 6-12, Table 1). The others do not enter the chart model (the wavelength references
#: move the grids; the backscatter fractions enter only the simulated veiling light).
COEFFICIENT_PARAMS = ("cdom_slope", "nap_slope", "nap_scale", "nap_exponent", "phyto_scale",
                      "phyto_exponent", "c_12", "s_12", "b_p12_star", "b_p3_star", "b_k",
                      "gamma_12", "gamma_3", "gamma_k", "water_scattering",
                      "water_scattering_exponent")


def _slope_guard(floor):
    """The context of d/dC: the slopes may be infinite (C^e at 0, e < 1) only where the floor
    is not positive, so numpy's warnings are silenced there and only there."""
    return np.errstate(divide="ignore", invalid="ignore") if not floor > 0 else \
        contextlib.nullcontext()


class _TermInputs:
    """The point x at which the terms of c(x) are evaluated (C and a_CDOM with a trailing
    wavelength axis; replaced constants looked up by name)."""

    def __init__(self, terms, chl, cdom, w, values, floor):
        self.terms, self.chl, self.cdom, self.w, self.values = terms, chl, cdom, w, values
        self.chl_floor = np.maximum(chl, floor)
        self.offset = terms.offset  # lambda - 440, nm
        self.ratio = terms.ratio  # lambda / 470
        self.guard = functools.partial(_slope_guard, floor)

    def given(self, name) -> bool:
        return name in self.values

    def get(self, name):
        if name in self.values:
            return np.asarray(self.values[name], float)[..., None]
        return getattr(self.terms.water, name)

    def phi(self, p, e, g, h):
        """The chlorophyll weight p C^e + g (1 - exp(-h C)) at this point (:func:`chl_weight`)."""
        return chl_weight(self.chl, p, e, g, h)

    def log_chl(self):
        """ln C, 0 where C = 0 (the factor of a d/d exponent term, C^e ln C -> 0)."""
        with np.errstate(divide="ignore"):
            return np.where(self.chl > 0, np.log(np.where(self.chl > 0, self.chl, 1.0)), 0.0)


# Each term returns its value and its derivatives as sums of (weight, spectrum) pieces: a
# weight is a scalar or of shape S + (1,), a spectrum (q,) or S + (q,).
# :meth:`WaterTerms.path_coefficient` adds the pieces up (those with one spectrum for all
# charts by one matrix product).
def _water_absorption_term(x, wrt):
    """a_w, pure-water absorption (eq 5; Smith & Baker 1981): no free constant."""
    return [(1.0, x.terms.pure_water_absorption)], {}


def _water_scattering_term(x, wrt):
    """b_w = 0.00288 (lambda/500)^-4.32, pure-water scattering (eq 11; Morel 1974)."""
    t, out = x.terms, {}
    if x.given("water_scattering") or x.given("water_scattering_exponent"):
        shape = (t.wavelengths / 500.0) ** -x.get("water_scattering_exponent")
        scale = x.get("water_scattering")
        parts = [(scale, shape)]
    else:
        parts = [(1.0, t.pure_water_scattering)]
        if not wrt:
            return parts, out
        shape = t.pure_water_scattering / t.water.water_scattering
        scale = t.water.water_scattering
    if "water_scattering" in wrt:
        out["water_scattering"] = [(1.0, shape)]
    if "water_scattering_exponent" in wrt:
        out["water_scattering_exponent"] = [(scale, -shape * np.log(t.wavelengths / 500.0))]
    return parts, out


def _background_term(x, wrt):
    """b_k (lambda/470)^-gamma_k, eq 12's third term."""
    t, out = x.terms, {}
    if x.given("b_k") or x.given("gamma_k"):
        shape = x.ratio ** -x.get("gamma_k")
        scale = x.get("b_k")
        parts = [(scale, shape)]
    else:
        parts = [(1.0, t.background_scattering)]
        if "b_k" not in wrt and "gamma_k" not in wrt:
            return parts, out
        shape, scale = x.ratio ** -t.water.gamma_k, t.water.b_k
    if "b_k" in wrt:
        out["b_k"] = [(1.0, shape)]
    if "gamma_k" in wrt:
        out["gamma_k"] = [(scale, -shape * np.log(x.ratio))]
    return parts, out


def _cdom_term(x, wrt):
    """a_CDOM(440) exp(-S (lambda - 440)) (eq 6)."""
    t, out = x.terms, {}
    shape = np.exp(-x.get("cdom_slope") * x.offset) if x.given("cdom_slope") else t.cdom_shape
    if "cdom" in wrt:
        out["cdom"] = [(1.0, shape)]
    if "cdom_slope" in wrt:
        out["cdom_slope"] = [(x.cdom, -x.offset * shape)]
    return [(x.cdom, shape)], out


def _phytoplankton_term(x, wrt):
    """a_phi = 0.0378 C^0.627 times the basis shape (eqs 9, 10), or T w for free weights."""
    t, out = x.terms, {}
    if x.w is not None:
        if "w" in wrt:
            out["w"] = t.T
        # T w; with one basis function (and w of shape S + (1,)) a product, not a one-term
        # matrix product: the same values, but for the sign of a zero product, which the
        # water's terms added to it erase
        one = t.T.shape[1] == 1 and x.w.shape[-1:] == (1,)
        return [(1.0, x.w * t.T[:, 0] if one else x.w @ t.T.T)], out
    scale, exponent = x.get("phyto_scale"), x.get("phyto_exponent")
    weight = x.phi(scale, exponent, 0.0, 0.0)
    shape = t.phyto_shape
    if "chl" in wrt:
        with x.guard():
            out["chl"] = [(chl_weight_derivative(x.chl_floor, scale, exponent, 0.0, 0.0), shape)]
    if "phyto_scale" in wrt:
        out["phyto_scale"] = [(x.chl ** exponent, shape)]
    if "phyto_exponent" in wrt:
        out["phyto_exponent"] = [(weight * x.log_chl(), shape)]
    return [(weight, shape)], out


def _nap_term(x, wrt):
    """a_NAP = 0.0124 C^0.724 exp(-0.011 (lambda - 440)) (eqs 7, 8)."""
    t, out = x.terms, {}
    scale, exponent = x.get("nap_scale"), x.get("nap_exponent")
    shape = np.exp(-x.get("nap_slope") * x.offset) if x.given("nap_slope") else t.nap_shape
    weight = x.phi(scale, exponent, 0.0, 0.0)
    if "chl" in wrt:
        with x.guard():
            out["chl"] = [(chl_weight_derivative(x.chl_floor, scale, exponent, 0.0, 0.0), shape)]
    if "nap_scale" in wrt:
        out["nap_scale"] = [(x.chl ** exponent, shape)]
    if "nap_exponent" in wrt:
        out["nap_exponent"] = [(weight * x.log_chl(), shape)]
    if "nap_slope" in wrt:
        out["nap_slope"] = [(weight, -x.offset * shape)]
    return [(weight, shape)], out


def _particle_term(x, wrt):
    """eq 12's two chlorophyll terms: C_12 (1 - e^(-S_12 C)) b*_p12 (l/l0)^-g12 (pico + nano)
    and (C - C_12 (1 - e^(-S_12 C))) b*_p3 (l/l0)^-g3 (micro)."""
    t, out = x.terms, {}
    c12, s12 = x.get("c_12"), x.get("s_12")
    if x.values and any(x.given(k) for k in ("b_p12_star", "gamma_12", "b_p3_star", "gamma_3")):
        small = x.get("b_p12_star") * x.ratio ** -x.get("gamma_12")
        large = x.get("b_p3_star") * x.ratio ** -x.get("gamma_3")
    else:
        small, large = t.particle_shapes
    w_small = x.phi(0.0, 1.0, c12, s12)
    w_large = x.phi(1.0, 1.0, -c12, s12)
    if "chl" in wrt:
        out["chl"] = [(chl_weight_derivative(x.chl_floor, 0.0, 1.0, c12, s12), small),
                      (chl_weight_derivative(x.chl_floor, 1.0, 1.0, -c12, s12), large)]
    if "c_12" in wrt:
        d = -np.expm1(-s12 * x.chl)
        out["c_12"] = [(d, small), (-d, large)]
    if "s_12" in wrt:
        d = c12 * x.chl * np.exp(-s12 * x.chl)
        out["s_12"] = [(d, small), (-d, large)]
    if "b_p12_star" in wrt:
        out["b_p12_star"] = [(w_small, x.ratio ** -x.get("gamma_12"))]
    if "gamma_12" in wrt:
        out["gamma_12"] = [(w_small, -small * np.log(x.ratio))]
    if "b_p3_star" in wrt:
        out["b_p3_star"] = [(w_large, x.ratio ** -x.get("gamma_3"))]
    if "gamma_3" in wrt:
        out["gamma_3"] = [(w_large, -large * np.log(x.ratio))]
    return [(w_small, small), (w_large, large)], out


#: Below this many charts the pieces are added one by one (a matrix product costs more).
_FEW_CHARTS = 8


def _sum_pieces(pieces, lead, q):
    """sum of weight x spectrum over ``pieces``, shape lead + (q,): the pieces whose spectrum
    is one for all charts by one matrix product (for many charts), constant ones once, the
    rest elementwise."""
    few = math.prod(lead) < _FEW_CHARTS
    weights, spectra, total = [], [], None
    owned = False  # total is an array made here (not a caller's spectrum): added to in place
    for w, sh in pieces:
        if few or sh.ndim > 1 or not isinstance(w, np.ndarray) or w.ndim == 0:
            unit = type(w) is float and w == 1.0  # 1.0 x is x, exactly: no product
            term = sh if unit else w * sh
            if total is None:
                total, owned = term, not unit
            elif owned and (term.shape == total.shape
                            or term.ndim == 1 and total.shape[-1:] == term.shape):
                total += term
            else:
                total, owned = total + term, True
        else:
            weights.append(w[..., 0] if w.shape[:-1] == lead else
                           np.broadcast_to(w, lead + (1,))[..., 0])
            spectra.append(sh)
    if weights:
        prod = np.stack(weights, axis=-1) @ np.stack(spectra)
        if total is not None:
            prod += total  # the same sum as total + prod (addition commutes exactly)
        total, owned = prod, True
    if total is None:
        return np.zeros(lead + (q,))
    if not owned:
        total = total.copy()
    return total if total.shape == lead + (q,) else np.broadcast_to(total, lead + (q,))


#: The terms of the absorption a (eq 5) and of the scattering b (eqs 11-12), each returning
#: its value and its derivatives by name; the path coefficient is a + b ('beam', eqs 3-4) or
#: a ('absorption', eq 13 as printed).
ABSORPTION_TERMS = (_water_absorption_term, _cdom_term, _phytoplankton_term, _nap_term)
#: The absorption of everything but water: CDOM, phytoplankton and NAP (a - a_w, eq 5).
NONWATER_ABSORPTION_TERMS = ABSORPTION_TERMS[1:]
PARTICLE_TERMS = (_background_term, _particle_term)
SCATTERING_TERMS = (_water_scattering_term,) + PARTICLE_TERMS
BEAM_TERMS = ABSORPTION_TERMS + SCATTERING_TERMS


def _scaled(term, factor):
    """``term`` with every weight (value and derivatives) times ``factor(x)``."""
    def scaled(x, wrt):
        f = factor(x)
        value, parts = term(x, wrt)
        parts = {k: (v * f if k == "w" else [(w * f, sh) for w, sh in v])
                 for k, v in parts.items()}
        return [(w * f, sh) for w, sh in value], parts
    scaled.__name__ = f"{term.__name__}_scaled"
    return scaled


def _per_mu(x):
    return 1.0 / x.terms.water.downwelling_cosine


#: K_d = (a + b_b) / mu_d (Gordon 1989): the absorption terms and the backscattering of pure
#: water and particles (fractions ``water_backscatter_fraction``, ``particle_backscatter_
#: fraction``), over the downwelling light's mean cosine: the 'split' path model's way down.
DIFFUSE_TERMS = tuple(_scaled(t, _per_mu) for t in ABSORPTION_TERMS) + (
    _scaled(_water_scattering_term,
            lambda x: x.terms.water.water_backscatter_fraction / x.terms.water.downwelling_cosine),
) + tuple(_scaled(t, lambda x: (x.terms.water.particle_backscatter_fraction
                                / x.terms.water.downwelling_cosine)) for t in PARTICLE_TERMS)
#: The path model's coefficient (one leg, length depth + distance) or, for 'split', the
#: horizontal leg's (distance; :data:`DIFFUSE_TERMS` for the depth).
PATH_TERMS = {"beam": BEAM_TERMS, "absorption": ABSORPTION_TERMS, "split": BEAM_TERMS}
#: Each path model's legs: (terms, the length they act over).
PATH_LEGS = {"beam": ((BEAM_TERMS, "path"),), "absorption": ((ABSORPTION_TERMS, "path"),),
             "split": ((DIFFUSE_TERMS, "depth"), (BEAM_TERMS, "distance"))}


# =========================================================================== public functions
# One function per physical term (each a view of Water; ``water=None`` is the paper's model).
def _terms(wavelengths, water, **kw) -> WaterTerms:
    return resolve_water(water, **kw).on_grid(wavelengths)


_conc = validate.nonnegative


def pure_water_absorption(wavelengths=None, *, water: Water | None = None) -> np.ndarray:
    """Pure-water absorption a_w(lambda) in m^-1, the first term of eq 5.

    Parameters
    ----------
    wavelengths : array_like, shape (q,), optional
        Wavelengths in nm (default: 400-700 nm at 1 nm).
    water : Water, optional
        The water model whose table is used (default: the paper's).

    Returns
    -------
    numpy.ndarray, shape (q,)
        a_w, m^-1 (a fresh copy).

    References
    ----------
    Blasinski & Farrell, eq 5. Smith & Baker (1981), Appl. Opt. 20(2):177-184, as tabulated by
    Mobley (1994) p. 90 (``data/pure_water_absorption_smith_baker_1981.csv``), linearly
    interpolated.
    """
    return _terms(wavelengths, water).pure_water_absorption.copy()


def phytoplankton_absorption_440(chl, *, derivative: bool = False, water: Water | None = None):
    """a_phi(440 nm) = 0.0378 C^0.627 in m^-1 (eq 10; the right side of eq 17).

    Parameters
    ----------
    chl : float or array_like, shape S
        Chlorophyll concentration C, mg m^-3 (>= 0).
    derivative : bool, optional
        Also return d a_phi(440) / dC (default False).
    water : Water, optional
        The water model (default: the paper's).

    Returns
    -------
    value : numpy.ndarray, shape S
        a_phi(440 nm), m^-1.
    derivative : numpy.ndarray, shape S
        d value / dC, m^-1 per mg m^-3 (only with ``derivative=True``; then a tuple is
        returned). Infinite at C = 0 (the estimator evaluates it at a small floor, see
        DECISIONS.md).

    Raises
    ------
    ValueError
        If ``chl`` is negative or not finite.

    References
    ----------
    Blasinski & Farrell, eqs 10 and 17; Bricaud et al. 1998 (ref. [18]).
    """
    return resolve_water(water).phytoplankton_440(_conc("chl", chl), derivative=derivative)


def phytoplankton_absorption(wavelengths=None, chl=1.0, *, basis=None, weights=None,
                             water: Water | None = None) -> np.ndarray:
    """Phytoplankton absorption a_phi(lambda) = T w in m^-1 (eq 9), scaled by eq 10.

    Parameters
    ----------
    wavelengths : array_like, shape (q,), optional
        Wavelengths in nm (default: 400-700 nm at 1 nm).
    chl : float or array_like, shape S
        Chlorophyll concentration C, mg m^-3 (default 1).
    basis : array_like, shape (q,) or (q, z), or str or os.PathLike, optional
        The T of eq 9 on the grid (default: the water's table); see
        :func:`phytoplankton_basis`.
    weights : array_like, shape (z,), optional
        The shape for z > 1 basis functions, rescaled so that (T w)(440) = 0.0378 C^0.627.
        Required for z > 1.
    water : Water, optional
        The water model (default: the paper's).

    Returns
    -------
    numpy.ndarray, shape S + (q,)
        a_phi, m^-1.

    Raises
    ------
    ValueError
        For a negative ``chl``, an invalid basis or weights, or a z > 1 basis without weights.

    References
    ----------
    Blasinski & Farrell, eqs 9, 10 and 17; Bricaud et al. 1998; basis from Fujiki & Taguchi
    2002.
    """
    wl = wavelength_grid(wavelengths)
    water = resolve_water(water)
    terms = water.on_grid(wl, basis=basis, weights=weights)
    terms._check_shape(None)
    return np.multiply.outer(water.phytoplankton_440(_conc("chl", chl)), terms.phyto_shape)


def cdom_absorption(wavelengths=None, cdom=0.1, *, slope: float | None = None,
                    water: Water | None = None) -> np.ndarray:
    """CDOM absorption a_CDOM(lambda) = a_CDOM,440 exp(-S (lambda - 440)) in m^-1 (eq 6).

    Parameters
    ----------
    wavelengths : array_like, shape (q,), optional
        Wavelengths in nm (default: 400-700 nm at 1 nm).
    cdom : float or array_like, shape S
        a_CDOM(440 nm), m^-1 (default 0.1).
    slope : float, optional
        S, nm^-1; replaces ``water.cdom_slope`` (default: the water's, 0.014).
    water : Water, optional
        The water model (default: the paper's).

    Returns
    -------
    numpy.ndarray, shape S + (q,)
        a_CDOM, m^-1.

    Raises
    ------
    ValueError
        If ``cdom`` is negative or not finite, or ``slope`` is not a finite number.

    References
    ----------
    Blasinski & Farrell, eq 6; Bricaud et al. 1981 (ref. [19]).
    """
    s = None if slope is None else validate.scalar("slope", slope, nonnegative=False)
    return np.multiply.outer(_conc("cdom", cdom), _terms(wavelengths, water, cdom_slope=s).cdom_shape)


def nap_absorption_440(chl, *, derivative: bool = False, water: Water | None = None):
    """a_NAP(440 nm) = 0.0124 C^0.724 in m^-1 (eq 8).

    Parameters
    ----------
    chl : float or array_like, shape S
        Chlorophyll concentration C, mg m^-3 (>= 0).
    derivative : bool, optional
        Also return d a_NAP(440) / dC (default False).
    water : Water, optional
        The water model (default: the paper's).

    Returns
    -------
    value : numpy.ndarray, shape S
        a_NAP(440 nm), m^-1.
    derivative : numpy.ndarray, shape S
        d value / dC, m^-1 per mg m^-3, infinite at C = 0 (only with ``derivative=True``; then
        a tuple is returned).

    Raises
    ------
    ValueError
        If ``chl`` is negative or not finite.

    References
    ----------
    Blasinski & Farrell, eq 8; Bricaud et al. 1998 (ref. [18]).
    """
    out = resolve_water(water).chl_weights(_conc("chl", chl), derivative=derivative)
    return (out[0][..., 1], out[1][..., 1]) if derivative else out[..., 1]


def nap_absorption(wavelengths=None, chl=1.0, *, derivative: bool = False,
                   water: Water | None = None):
    """Non-algal particle absorption a_NAP(lambda) = a_NAP,440 exp(-0.011 (lambda - 440)) (eqs 7, 8).

    Parameters
    ----------
    wavelengths : array_like, shape (q,), optional
        Wavelengths in nm (default: 400-700 nm at 1 nm).
    chl : float or array_like, shape S
        Chlorophyll concentration C, mg m^-3 (default 1).
    derivative : bool, optional
        Also return d a_NAP / dC (default False).
    water : Water, optional
        The water model (default: the paper's).

    Returns
    -------
    value : numpy.ndarray, shape S + (q,)
        a_NAP, m^-1.
    derivative : numpy.ndarray, shape S + (q,)
        d value / dC, m^-1 per mg m^-3 (only with ``derivative=True``; then a tuple
        ``(value, derivative)`` is returned).

    Raises
    ------
    ValueError
        If ``chl`` is negative or not finite.

    References
    ----------
    Blasinski & Farrell, eqs 7 and 8; Roesler et al. 1989 (ref. [20], the slope); Bricaud
    et al. 1998 (ref. [18], eq 8).
    """
    shape = _terms(wavelengths, water).nap_shape
    if not derivative:
        return np.multiply.outer(nap_absorption_440(chl, water=water), shape)
    v, d = nap_absorption_440(chl, derivative=True, water=water)
    return np.multiply.outer(v, shape), np.multiply.outer(d, shape)


def absorption(wavelengths=None, chl=1.0, cdom=0.1, *, basis=None, weights=None,
               phytoplankton=None, cdom_slope: float | None = None,
               water: Water | None = None) -> np.ndarray:
    """Total absorption a = a_w + a_phi + a_CDOM + a_NAP in m^-1 (eq 5).

    Parameters
    ----------
    wavelengths : array_like, shape (q,), optional
        Wavelengths in nm (default: 400-700 nm at 1 nm).
    chl : float or array_like, shape S
        Chlorophyll concentration C, mg m^-3 (default 1); sets a_NAP (eq 8) and, unless
        ``phytoplankton`` is given, a_phi (eq 10).
    cdom : float or array_like, shape S
        a_CDOM(440 nm), m^-1 (default 0.1).
    basis : array_like, shape (q,) or (q, z), or str or os.PathLike, optional
        The T of eq 9 (default: the water's table); see :func:`phytoplankton_basis`.
    weights : array_like, shape (z,), optional
        The shape w of eq 9 for z > 1 basis functions (rescaled so that eq 10 holds).
    phytoplankton : array_like, shape (..., q), optional
        a_phi in m^-1, given directly instead of computed from ``chl``.
    cdom_slope : float, optional
        S of eq 6, nm^-1; replaces ``water.cdom_slope``.
    water : Water, optional
        The water model (default: the paper's).

    Returns
    -------
    numpy.ndarray, shape S + (q,)
        a, m^-1.

    Raises
    ------
    ValueError
        For negative or non-finite ``chl`` / ``cdom`` / ``phytoplankton``, or an invalid grid,
        basis or weights.

    References
    ----------
    Blasinski & Farrell, eqs 5-10; Smith & Baker 1981; Bricaud et al. 1981, 1998; Roesler et
    al. 1989.
    """
    wl = wavelength_grid(wavelengths)
    water = resolve_water(water, cdom_slope=cdom_slope)
    terms = water.on_grid(wl, basis=basis, weights=weights)
    chl, cdom = _conc("chl", chl), _conc("cdom", cdom)
    a = terms.absorption(chl, cdom)
    if phytoplankton is not None:
        a_phi = validate.array("phytoplankton", phytoplankton)
        a = a - np.multiply.outer(water.phytoplankton_440(chl), terms.phyto_shape) + a_phi
    return a


def pure_water_scattering(wavelengths=None, *, water: Water | None = None) -> np.ndarray:
    """Pure sea-water scattering b_w(lambda) = 0.00288 (lambda / 500)^-4.32 in m^-1 (eq 11).

    Parameters
    ----------
    wavelengths : array_like, shape (q,), optional
        Wavelengths in nm (default: 400-700 nm at 1 nm).
    water : Water, optional
        The water model whose ``water_scattering`` constants are used (default: the paper's).

    Returns
    -------
    numpy.ndarray, shape (q,)
        b_w, m^-1 (a fresh copy).

    References
    ----------
    Blasinski & Farrell, eq 11. Morel (1974), "Optical properties of pure water and pure sea
    water" (ref. [23]).
    """
    return _terms(wavelengths, water).pure_water_scattering.copy()


def table1(water: Water | None = None) -> dict:
    """The constants of Table 1 (eq 12) of ``water``; a fresh dict each call.

    Parameters
    ----------
    water : Water, optional
        The water model (default: as published, from ``data/particle_scattering_table1.csv``).

    Returns
    -------
    dict of str to float
        See :meth:`Water.table1` (C_12 mg m^-3, S_12 m^3 mg^-1, b*_p m^2 mg^-1, b_k m^-1,
        exponents dimensionless, lambda_0 nm).

    References
    ----------
    Blasinski & Farrell, Table 1; Brewin et al. 2012 (ref. [24]).
    """
    return resolve_water(water).table1()


def particle_scattering_terms(wavelengths=None, *, water: Water | None = None):
    """The three spectral terms of eq 12 (Table 1 constants).

    Parameters
    ----------
    wavelengths : array_like, shape (q,), optional
        Wavelengths in nm (default: 400-700 nm at 1 nm).
    water : Water, optional
        The water model (default: the paper's).

    Returns
    -------
    small : numpy.ndarray, shape (q,)
        b*_p12 (l/l0)^-g12, m^2 mg^-1 (m^-1 per mg m^-3 of weight).
    large : numpy.ndarray, shape (q,)
        b*_p3 (l/l0)^-g3, m^2 mg^-1.
    background : numpy.ndarray, shape (q,)
        b_k (l/l0)^-gk, m^-1.

    References
    ----------
    Blasinski & Farrell, eq 12 and Table 1; Brewin et al. 2012.
    """
    t = _terms(wavelengths, water)
    return t.particle_shapes[0].copy(), t.particle_shapes[1].copy(), t.background_scattering.copy()


def particle_scattering_weights(chl, *, derivative: bool = False, water: Water | None = None):
    """The chlorophyll weights of eq 12's first two terms, in mg m^-3.

    Parameters
    ----------
    chl : float or array_like, shape S
        Chlorophyll concentration C, mg m^-3 (>= 0).
    derivative : bool, optional
        Also return their d/dC (default False).
    water : Water, optional
        The water model (default: the paper's).

    Returns
    -------
    weights : tuple of numpy.ndarray, each shape S
        (C12 (1 - e^(-S12 C)), C - C12 (1 - e^(-S12 C))): pico + nano and micro, mg m^-3.
    derivatives : tuple of numpy.ndarray, each shape S
        Their d/dC, dimensionless (only with ``derivative=True``; then ``(weights,
        derivatives)`` is returned).

    Raises
    ------
    ValueError
        If ``chl`` is negative or not finite.

    References
    ----------
    Blasinski & Farrell, eq 12 and Table 1; Brewin et al. 2012.
    """
    out = resolve_water(water).chl_weights(_conc("chl", chl), derivative=derivative)
    if not derivative:
        return out[..., 2], out[..., 3]
    return (out[0][..., 2], out[0][..., 3]), (out[1][..., 2], out[1][..., 3])


def particle_scattering(wavelengths=None, chl=1.0, *, derivative: bool = False,
                        water: Water | None = None):
    """Particle scattering b_p(lambda) in m^-1, eq 12 with the Table 1 constants (lambda_0 = 470 nm).

    The Table 1 constants come from Brewin et al. (2012), who fit particle *back*scattering;
    the paper (and this function) use them as b_p (DECISIONS.md).

    Parameters
    ----------
    wavelengths : array_like, shape (q,), optional
        Wavelengths in nm (default: 400-700 nm at 1 nm).
    chl : float or array_like, shape S
        Chlorophyll concentration C, mg m^-3 (default 1).
    derivative : bool, optional
        Also return d b_p / dC (default False).
    water : Water, optional
        The water model (default: the paper's).

    Returns
    -------
    value : numpy.ndarray, shape S + (q,)
        b_p (all three terms of eq 12, the background b_k included), m^-1.
    derivative : numpy.ndarray, shape S + (q,)
        d b_p / dC, m^-1 per mg m^-3 (only with ``derivative=True``; then a tuple is
        returned).

    Raises
    ------
    ValueError
        If ``chl`` is negative or not finite.

    References
    ----------
    Blasinski & Farrell, eq 12 and Table 1; Brewin et al. 2012 (ref. [24]).
    """
    t = _terms(wavelengths, water)
    chl = _conc("chl", chl)
    if not derivative:
        return t.particle_scattering(chl)
    _, d = resolve_water(water).chl_weights(chl, derivative=True)
    return t.particle_scattering(chl), d[..., 2:] @ t.particle_shapes


def scattering(wavelengths=None, chl=1.0, *, water: Water | None = None) -> np.ndarray:
    """Total scattering b = b_w + b_p in m^-1 (eq 11).

    Parameters
    ----------
    wavelengths : array_like, shape (q,), optional
        Wavelengths in nm (default: 400-700 nm at 1 nm).
    chl : float or array_like, shape S
        Chlorophyll concentration C, mg m^-3 (default 1).
    water : Water, optional
        The water model (default: the paper's).

    Returns
    -------
    numpy.ndarray, shape S + (q,)
        b, m^-1.

    Raises
    ------
    ValueError
        If ``chl`` is negative or not finite.

    References
    ----------
    Blasinski & Farrell, eqs 11 and 12; Morel 1974; Brewin et al. 2012.
    """
    return _terms(wavelengths, water).scattering(_conc("chl", chl))


def backscattering(wavelengths=None, chl=1.0, *, water: Water | None = None) -> np.ndarray:
    """Backscattering coefficient b_b = 0.5 b_w + b_bp in m^-1, used by the veiling light (eq 2).

    Pure water scatters symmetrically (half backwards). For particles we take eq 12 itself as
    b_bp, which is what Brewin et al. (2012), the source of Table 1, fitted (DECISIONS.md).
    The fractions 0.5 and 1 are ``water.water_backscatter_fraction`` and
    ``water.particle_backscatter_fraction``.

    Parameters
    ----------
    wavelengths : array_like, shape (q,), optional
        Wavelengths in nm (default: 400-700 nm at 1 nm).
    chl : float or array_like, shape S
        Chlorophyll concentration C, mg m^-3 (default 1).
    water : Water, optional
        The water model (default: the paper's).

    Returns
    -------
    numpy.ndarray, shape S + (q,)
        b_b, m^-1.

    Raises
    ------
    ValueError
        If ``chl`` is negative or not finite.

    References
    ----------
    Blasinski & Farrell, eq 2 (which gives no model for rho_b) and eqs 11-12; Morel 1974;
    Brewin et al. 2012.
    """
    return _terms(wavelengths, water).backscattering(_conc("chl", chl))


def attenuation_coefficient(wavelengths=None, chl=1.0, cdom=0.1, *, basis=None, weights=None,
                            phytoplankton=None, cdom_slope: float | None = None,
                            water: Water | None = None) -> np.ndarray:
    """Beam attenuation coefficient c = a + b in m^-1 (eq 4), whatever ``water.path_model``.

    Parameters
    ----------
    wavelengths : array_like, shape (q,), optional
        Wavelengths in nm (default: 400-700 nm at 1 nm).
    chl : float or array_like, shape S
        Chlorophyll concentration C, mg m^-3 (default 1).
    cdom : float or array_like, shape S
        a_CDOM(440 nm), m^-1 (default 0.1).
    basis, weights, phytoplankton, cdom_slope : optional
        As for :func:`absorption`: the basis T and weights w of eq 9, a_phi given directly
        (m^-1), and the CDOM slope S of eq 6 (nm^-1).
    water : Water, optional
        The water model (default: the paper's).

    Returns
    -------
    numpy.ndarray, shape S + (q,)
        c, m^-1.

    Raises
    ------
    ValueError
        As :func:`absorption` and :func:`scattering`.

    References
    ----------
    Blasinski & Farrell, eqs 4-12 and Table 1.
    """
    wl = wavelength_grid(wavelengths)
    a = absorption(wl, chl, cdom, basis=basis, weights=weights, phytoplankton=phytoplankton,
                   cdom_slope=cdom_slope, water=water)
    return a + scattering(wl, chl, water=water)
