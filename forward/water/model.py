"""The water model (eqs 4-12, Table 1): one immutable :class:`Water` whose fields are every
constant and table of the equations, the paper's values its defaults; :func:`resolve_water`;
the one weight form phi(C) = p C^e + g (1 - exp(-h C)) of the chlorophyll terms with its
derivative; the phytoplankton basis T of eq 9.

Wavelengths in nm, coefficients in m^-1, C in mg m^-3, a_CDOM(440) in m^-1.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
from dataclasses import dataclass, field

import numpy as np

from .. import validate
from typing import TYPE_CHECKING

from ..spectra import (
    LAMBDA_0_NM,
    is_path,
    on_grid,
    read_spectral_csv,
    read_spectral_table,
    read_table,
    resample,
    wavelength_grid,
)
from forward.errors import InputError

if TYPE_CHECKING:
    from .grid import WaterTerms


__all__ = ["BASIS_TABLE", "CDOM_SLOPE", "CHL_TERMS", "NAP_SLOPE", "PAPER_WATER", "PATH_MODELS",
           "PURE_WATER_TABLE", "TABLE1", "Water", "chl_weight", "chl_weight_derivative",
           "phytoplankton_basis", "resolve_water"]

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
        with the beam attenuation c). Decision 0013-geometry-path-length.
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
        Brewin et al. 2012; decision 0015-eq12-backscattering).
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
            raise InputError("path_model", f"must be one of {PATH_MODELS}, got {self.path_model!r}")
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
                raise InputError(name, "expected (wavelengths, values) or a CSV file") from None
        wl = validate.array(name, wl, ndim=1)
        vals = validate.array(name, vals, nonnegative=True)
        if vals.ndim == 1:
            vals = vals[:, None]
        if vals.ndim != 2 or vals.shape[0] != wl.size or (ncols and vals.shape[1] != ncols):
            raise InputError(name, "values must have one row per wavelength"
                             + (f" and {ncols} column" if ncols else ""))
        if wl.size < 2 or np.any(np.diff(wl) <= 0):
            raise InputError(name, "wavelengths must be strictly increasing (>= 2 rows)")
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
        from .grid import WaterTerms  # the grid's evaluator sits above the model

        return WaterTerms.build(self, wl, basis, weights)


@functools.lru_cache(maxsize=64)
def _terms_cached(water: Water, wl_key: tuple) -> "WaterTerms":
    # keyed on the water's numbers (its hash and equality) and the grid: never stale
    from .grid import WaterTerms  # the grid's evaluator sits above the model

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
        raise InputError("water", f"expected a forward.Water, got {type(water).__name__}")
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
                raise InputError("basis", "contains negative values")
        t440 = np.array([np.interp(lam0, src_wl, v) for v in vals.T])
        if basis is None:
            vals, t440 = vals / t440, np.ones(vals.shape[1])
        return resample(src_wl, vals, wl, name="basis"), t440
    T = on_grid(basis, wl, "basis", None)
    if not (wl[0] <= lam0 <= wl[-1]):
        raise InputError("basis", "the wavelength grid must contain 440 nm (eq 17) for an array basis")
    t440 = np.array([np.interp(lam0, wl, col) for col in T.T])
    if np.all(t440 <= 0):
        raise InputError("basis", "all basis functions are zero at 440 nm, so eq 17 cannot fix their scale")
    return T, t440
