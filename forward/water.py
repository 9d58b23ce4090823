"""Inherent optical properties of sea water (eqs 4-12): one immutable :class:`Water` model.

Every constant of eqs 6-12 and Table 1, and the two tables they use (pure-water absorption and
the phytoplankton absorption basis), are fields of :class:`Water`; the paper's values are the
defaults. :class:`Water` alone assembles the attenuation coefficient c(x) and its derivative
on a wavelength grid (:meth:`Water.on_grid` -> :class:`WaterTerms`); the simulator and every
estimator (the cvxpy loop, the scipy path, both batched engines) take their numbers from it.

The model is linear in a few scalar weights:

    c(lambda) = base(lambda) + a_CDOM(440) e_CDOM(lambda) + sum_j phi_j(C) S_j(lambda)

with base = a_w [+ b_w + b_k (l/l0)^-g_k for the 'beam' path model], e_CDOM the eq 6 shape and
four chlorophyll terms j (their weights phi_j(C) and spectral shapes S_j):

    j  term                     phi_j(C)                             S_j(lambda)
    0  phytoplankton (eqs 9-10) 0.0378 C^0.627                       (T w)(l) / (T w)(440)
    1  NAP (eqs 7-8)            0.0124 C^0.724                       exp(-0.011 (l - 440))
    2  pico + nano (eq 12)      C12 (1 - exp(-S12 C))                b*_p12 (l/l0)^-g12  [beam]
    3  micro (eq 12)            C - C12 (1 - exp(-S12 C))            b*_p3 (l/l0)^-g3    [beam]

Every weight has the one form phi(C) = p C^e + g (1 - exp(-h C)); :meth:`Water.chl_terms`
gives the (4, 4) table of (p, e, g, h), so compiled code can evaluate the weights from numbers
passed in (:mod:`sca.batch`) instead of restating the formulas.

Wavelengths in nm, coefficients in m^-1, chlorophyll ``chl`` (C) in mg m^-3, ``cdom`` is
a_CDOM(440 nm) in m^-1. ``chl`` and ``cdom`` may be scalars or arrays (shape S); a spectrum then
has shape S + (q,).

Reference: H. Blasinski and J. Farrell, "A Three Parameter Underwater Image Formation Model".
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
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

#: Path models for the attenuation k: 'beam' uses c = a + b (eqs 3, 4), 'absorption' the
#: literal eq 13 / 14 (absorption a only).
PATH_MODELS = ("beam", "absorption")
#: CDOM spectral slope of eq 6 (nm^-1); the paper uses 0.014 (range 0.014-0.019).
CDOM_SLOPE = 0.014
#: NAP spectral slope of eq 7 (nm^-1); the paper uses 0.011 (range 0.006-0.014).
NAP_SLOPE = 0.011
#: Names of the chlorophyll terms (rows of :meth:`Water.chl_terms`, of ``WaterTerms.shapes``).
CHL_TERMS = ("phytoplankton", "nap", "particles_small", "particles_large")

PURE_WATER_TABLE = "pure_water_absorption_smith_baker_1981.csv"
BASIS_TABLE = "phytoplankton_absorption_basis.csv"
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
    """phi(C) = p C^e + g (1 - exp(-h C)): the one form of every chlorophyll weight."""
    return p * c ** e + g * -np.expm1(-h * c)


def chl_weight_derivative(c, p, e, g, h):
    """d phi / dC = p e C^(e-1) + g h exp(-h C) (infinite at C = 0 where 0 < e < 1 and p > 0)."""
    return p * e * c ** (e - 1.0) + g * h * np.exp(-h * c)


@dataclass(frozen=True, eq=False)
class Water:
    """The sea-water model of eqs 4-12: constants, tables and path model (immutable).

    Two ``Water`` objects are equal when all their numbers are; a ``Water`` is hashable, so
    results computed from it can be cached safely. Change a constant with keywords,
    ``Water(cdom_slope=0.018)``, or :func:`dataclasses.replace`.

    Attributes
    ----------
    path_model : 'beam' (k = exp(-L c), c = a + b, eqs 3-4; default) or 'absorption'
        (k = exp(-L a), eq 13 as printed). DECISIONS.md.
    reference_nm : lambda_0 of eqs 6-8, 10 and 17, nm (440).
    cdom_slope : S of eq 6, a_CDOM = a_CDOM(440) exp(-S (l - 440)), nm^-1 (0.014; Bricaud et al.
        1981, ref. [19]: 0.014-0.019).
    nap_slope : slope of eq 7, nm^-1 (0.011; Roesler et al. 1989, ref. [20]: 0.006-0.014).
    nap_scale, nap_exponent : eq 8, a_NAP(440) = 0.0124 C^0.724 m^-1 (Bricaud et al. 1998, [18]).
    phyto_scale, phyto_exponent : eq 10 / 17, a_phi(440) = 0.0378 C^0.627 m^-1 ([18]).
    c_12 : C_12 of eq 12, mg m^-3 (Table 1: 0.78; Brewin et al. 2012, ref. [24]).
    s_12 : S_12 of eq 12, m^3 mg^-1 (Table 1: 1.1449).
    b_p12_star : b*_p,1,2 at lambda_0, m^2 mg^-1 (Table 1: 0.0046).
    b_p3_star : b*_p,3 at lambda_0, m^2 mg^-1 (Table 1: 0.0005).
    b_k : background b_k at lambda_0 = 470 nm, m^-1 (Table 1: 0.00068).
    gamma_12, gamma_3, gamma_k : spectral exponents of eq 12 (Table 1: 0.7, -0.2, 1.9).
    scattering_reference_nm : lambda_0 of eq 12 and Table 1, nm (470).
    water_scattering, water_scattering_exponent : b_w = 0.00288 (l / 500)^-4.32 m^-1 (eq 11;
        Morel 1974, ref. [23]).
    water_backscatter_fraction : b_bw / b_w for the veiling light (0.5: pure water scatters
        symmetrically).
    particle_backscatter_fraction : b_bp / b_p for the veiling light (1: eq 12 *is* a
        backscattering model in its source, Brewin et al. 2012; DECISIONS.md).
    pure_water_absorption_table : (wavelength nm, a_w m^-1) of eq 5 (Smith & Baker 1981, ref.
        [16], ``data/pure_water_absorption_smith_baker_1981.csv``), linearly interpolated.
    phytoplankton_basis_table : (wavelength nm, (n, z) basis T of eq 9)
        (``data/phytoplankton_absorption_basis.csv``, derived from ref. [21]).
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
    pure_water_absorption_table: tuple = field(default_factory=_default_pure_water, repr=False)
    phytoplankton_basis_table: tuple = field(default_factory=_default_basis, repr=False)

    _POSITIVE = ("reference_nm", "phyto_scale", "phyto_exponent", "nap_exponent",
                 "scattering_reference_nm")
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
        """The Table 1 constants of this model (a fresh dict, the CSV's names)."""
        return {"C_12": self.c_12, "S_12": self.s_12, "b_p12_star": self.b_p12_star,
                "b_p3_star": self.b_p3_star, "b_k": self.b_k, "gamma_12": self.gamma_12,
                "gamma_3": self.gamma_3, "gamma_k": self.gamma_k,
                "lambda_0": self.scattering_reference_nm}

    def constants(self) -> dict:
        """Every scalar field (JSON-ready)."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)
                if not isinstance(getattr(self, f.name), tuple)}

    def chl_terms(self) -> np.ndarray:
        """(4, 4) read-only table of (p, e, g, h): phi_j(C) = p C^e + g (1 - exp(-h C)) for the
        terms of :data:`CHL_TERMS` (eqs 10, 8, 12, 12)."""
        return self._chl_terms

    def chl_weights(self, chl, *, derivative: bool = False, floor: float = 0.0):
        """phi(C), shape S + (4,), in the order of :data:`CHL_TERMS`; ``derivative=True`` also
        returns d phi / dC evaluated at max(C, ``floor``) (``floor=0``: infinite at C = 0)."""
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
        """a_phi(440) = 0.0378 C^0.627 m^-1 (eq 10, the right side of eq 17); with
        ``derivative``, also d/dC at max(C, floor)."""
        out = self.chl_weights(chl, derivative=derivative, floor=floor)
        return (out[0][..., 0], out[1][..., 0]) if derivative else out[..., 0]

    # ------------------------------------------------------------------ spectra on a grid
    def on_grid(self, wavelengths=None, *, basis=None, weights=None) -> "WaterTerms":
        """The spectral terms of c(x) on ``wavelengths`` (see :class:`WaterTerms`).

        ``basis``: a (q, z) array on the grid or a CSV file replacing this model's basis table;
        ``weights`` (z,): the shape w of eq 9 for z > 1 (rescaled so that eq 10 holds).
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
    """``water`` (default :data:`PAPER_WATER`), with ``path_model`` / ``cdom_slope`` replaced
    when given (the older keywords of :func:`forward.simulate_chart` and :func:`sca.estimate`)."""
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

    ``None``: the basis table of ``water`` (default: the single shape of
    ``data/phytoplankton_absorption_basis.csv``), normalised so that t(440 nm) = 1. Otherwise an
    array (q,) or (q, z) on the grid, or a CSV file (wavelength, one column per basis
    function). The second value is t(440 nm), (z,), read from the table (or interpolated
    linearly on the grid), used by eqs 10 and 17.
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

    c = base + a_CDOM cdom_shape + phi(C) @ shapes  (the path coefficient: c for 'beam', a for
    'absorption'); with a free phytoplankton weight vector w (z basis functions, eq 9) the
    phytoplankton row is replaced by T w.

    Attributes
    ----------
    water, wavelengths (q,) nm.
    pure_water_absorption : a_w (q,) m^-1 (eq 5).
    pure_water_scattering : b_w (q,) m^-1 (eq 11).
    background_scattering : b_k (l/l0)^-g_k (q,) m^-1 (eq 12, third term).
    particle_shapes : (2, q) b*_p12 (l/l0)^-g12 and b*_p3 (l/l0)^-g3 (eq 12), m^2 mg^-1.
    cdom_shape : exp(-S (l - 440)) (q,) (eq 6).
    nap_shape : exp(-S_NAP (l - 440)) (q,) (eq 7).
    T : (q, z) basis of eq 9; t440 : (z,) its value at 440 nm; phyto_shape : (q,) the
        phytoplankton shape a_phi / a_phi(440) (T w / t440 w).
    free_only : a z > 1 basis given without weights: only the free-w form (``w=`` given) of
        the methods below can be used.
    shapes : (4, q) S_j of the path coefficient (rows of :data:`CHL_TERMS`; the particle rows
        are zero for the 'absorption' path model).
    base : (q,) the C- and CDOM-independent part of the path coefficient.
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
    shapes: np.ndarray
    base: np.ndarray
    free_only: bool = False

    @classmethod
    def build(cls, water: Water, wl, basis=None, weights=None) -> "WaterTerms":
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
        beam = water.path_model == "beam"
        shapes = np.vstack([phyto, nap, particles * beam])
        base = a_w + (b_w + bk if beam else 0.0)
        arrays = [_readonly(x) for x in (wl, a_w, b_w, bk, particles, cdom, nap, T, t440, phyto,
                                         shapes, base)]
        return cls(water, *arrays, free_only)

    def _check_shape(self, w):
        if w is None and self.free_only:
            raise ValueError(f"weights: required for a basis of z = {self.T.shape[1]} functions")

    # ---------------------------------------------------------------- the path coefficient
    def path_coefficient(self, chl, cdom, *, w=None, values=None, wrt=(), floor: float = 0.0):
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

        Returns
        -------
        c : ndarray, shape S + (q,)
            c(x) for the 'beam' path model, a(x) for 'absorption', m^-1 (eqs 4-12).
        derivatives : dict
            name -> d c / d name, shape S + (q,) (S + (q, z) for 'w').

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
        c = 0.0
        derivatives = {}
        for term in PATH_TERMS:
            value, parts = term(x, wrt)
            c = c + value
            for name, d in parts.items():
                derivatives[name] = derivatives[name] + d if name in derivatives else d
        shape = np.broadcast_shapes(np.shape(chl), np.shape(cdom)) + self.wavelengths.shape
        c = np.broadcast_to(c, shape)
        for name in wrt:
            full = shape + ((self.T.shape[1],) if name == "w" else ())
            derivatives[name] = np.broadcast_to(derivatives.get(name, 0.0), full)
        return c, derivatives

    def coefficient(self, chl, cdom, w=None) -> np.ndarray:
        """The path coefficient (c for 'beam', a for 'absorption'), m^-1, shape S + (q,).

        ``w`` (S + (z,)): free phytoplankton weights (a_phi = T w, eq 9); default: a_phi from
        eq 10 with this grid's phytoplankton shape (see :meth:`path_coefficient`).
        """
        return np.array(self.path_coefficient(chl, cdom, w=w)[0])

    def jacobian(self, chl, cdom, w=None, *, floor: float = 0.0) -> np.ndarray:
        """d(path coefficient)/dx, shape S + (q, 2) for x = (C, a_CDOM) (w on eq 10) or
        S + (q, 2 + z) for x = (C, a_CDOM, w) with ``w`` given; dC evaluated at max(C, floor)
        (see :meth:`path_coefficient`)."""
        wrt = ("chl", "cdom") + (("w",) if w is not None else ())
        _, d = self.path_coefficient(chl, cdom, w=w, wrt=wrt, floor=floor)
        cols = [d["chl"][..., None], d["cdom"][..., None]] + ([d["w"]] if w is not None else [])
        return np.concatenate(cols, axis=-1)

    # ---------------------------------------------------------------- individual terms
    def absorption(self, chl, cdom, w=None) -> np.ndarray:
        """a = a_w + a_phi + a_CDOM + a_NAP (eq 5), m^-1."""
        self._check_shape(w)
        phi = self.water.chl_weights(chl)
        a_phi = (phi[..., :1] @ self.shapes[:1] if w is None
                 else np.asarray(w, float) @ self.T.T)
        return (self.pure_water_absorption + a_phi + phi[..., 1:2] @ self.shapes[1:2]
                + np.multiply.outer(np.asarray(cdom, float), self.cdom_shape))

    def particle_scattering(self, chl) -> np.ndarray:
        """b_p (eq 12), m^-1."""
        phi = self.water.chl_weights(chl)
        return phi[..., 2:] @ self.particle_shapes + self.background_scattering

    def scattering(self, chl) -> np.ndarray:
        """b = b_w + b_p (eq 11), m^-1."""
        return self.pure_water_scattering + self.particle_scattering(chl)

    def beam_coefficient(self, chl, cdom, w=None) -> np.ndarray:
        """c = a + b (eq 4), m^-1, whatever the path model."""
        return self.absorption(chl, cdom, w) + self.scattering(chl)

    def backscattering(self, chl) -> np.ndarray:
        """b_b = f_w b_w + f_p b_p, m^-1 (the veiling light's scattering; DECISIONS.md)."""
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


class _TermInputs:
    """The point x at which the terms of c(x) are evaluated (C and a_CDOM with a trailing
    wavelength axis; replaced constants looked up by name)."""

    def __init__(self, terms, chl, cdom, w, values, floor):
        self.terms, self.chl, self.cdom, self.w, self.values = terms, chl, cdom, w, values
        self.beam = terms.water.path_model == "beam"
        self.chl_floor = np.maximum(chl, floor)
        self.offset = terms.wavelengths - terms.water.reference_nm  # lambda - 440, nm
        self.ratio = terms.wavelengths / terms.water.scattering_reference_nm  # lambda / 470

    def given(self, name) -> bool:
        return name in self.values

    def get(self, name):
        if name in self.values:
            return np.asarray(self.values[name], float)[..., None]
        return getattr(self.terms.water, name)

    def log_chl(self):
        """ln C, 0 where C = 0 (the factor of a d/d exponent term, C^e ln C -> 0)."""
        with np.errstate(divide="ignore"):
            return np.where(self.chl > 0, np.log(np.where(self.chl > 0, self.chl, 1.0)), 0.0)


def _pure_water_term(x, wrt):
    """a_w (eq 5) and, for the 'beam' path model, b_w = 0.00288 (lambda/500)^-4.32 (eq 11)."""
    t, out = x.terms, {}
    if not x.beam:
        return t.pure_water_absorption, out
    if not (x.given("water_scattering") or x.given("water_scattering_exponent")):
        b_w, shape = t.pure_water_scattering, None
    else:
        shape = (t.wavelengths / 500.0) ** -x.get("water_scattering_exponent")
        b_w = x.get("water_scattering") * shape
    if "water_scattering" in wrt:
        out["water_scattering"] = (t.wavelengths / 500.0) ** -x.get("water_scattering_exponent")
    if "water_scattering_exponent" in wrt:
        out["water_scattering_exponent"] = -b_w * np.log(t.wavelengths / 500.0)
    return t.pure_water_absorption + b_w, out


def _background_term(x, wrt):
    """b_k (lambda/470)^-gamma_k, eq 12's third term ('beam' only)."""
    t, out = x.terms, {}
    if not x.beam:
        return 0.0, out
    if x.given("b_k") or x.given("gamma_k"):
        value = x.get("b_k") * x.ratio ** -x.get("gamma_k")
    else:
        value = t.background_scattering
    if "b_k" in wrt:
        out["b_k"] = x.ratio ** -x.get("gamma_k")
    if "gamma_k" in wrt:
        out["gamma_k"] = -value * np.log(x.ratio)
    return value, out


def _cdom_term(x, wrt):
    """a_CDOM(440) exp(-S (lambda - 440)) (eq 6)."""
    t, out = x.terms, {}
    shape = np.exp(-x.get("cdom_slope") * x.offset) if x.given("cdom_slope") else t.cdom_shape
    value = x.cdom * shape
    if "cdom" in wrt:
        out["cdom"] = shape
    if "cdom_slope" in wrt:
        out["cdom_slope"] = -x.offset * value
    return value, out


def _phytoplankton_term(x, wrt):
    """a_phi = 0.0378 C^0.627 times the basis shape (eqs 9, 10), or T w for free weights."""
    t, out = x.terms, {}
    if x.w is not None:
        if "w" in wrt:
            out["w"] = t.T
        return x.w @ t.T.T, out
    scale, exponent = x.get("phyto_scale"), x.get("phyto_exponent")
    weight = chl_weight(x.chl, scale, exponent, 0.0, 0.0)
    if "chl" in wrt:
        with np.errstate(divide="ignore"):
            out["chl"] = chl_weight_derivative(x.chl_floor, scale, exponent, 0.0, 0.0) * t.phyto_shape
    if "phyto_scale" in wrt:
        out["phyto_scale"] = x.chl ** exponent * t.phyto_shape
    if "phyto_exponent" in wrt:
        out["phyto_exponent"] = weight * x.log_chl() * t.phyto_shape
    return weight * t.phyto_shape, out


def _nap_term(x, wrt):
    """a_NAP = 0.0124 C^0.724 exp(-0.011 (lambda - 440)) (eqs 7, 8)."""
    t, out = x.terms, {}
    scale, exponent = x.get("nap_scale"), x.get("nap_exponent")
    shape = np.exp(-x.get("nap_slope") * x.offset) if x.given("nap_slope") else t.nap_shape
    weight = chl_weight(x.chl, scale, exponent, 0.0, 0.0)
    value = weight * shape
    if "chl" in wrt:
        with np.errstate(divide="ignore", invalid="ignore"):
            out["chl"] = chl_weight_derivative(x.chl_floor, scale, exponent, 0.0, 0.0) * shape
    if "nap_scale" in wrt:
        out["nap_scale"] = x.chl ** exponent * shape
    if "nap_exponent" in wrt:
        out["nap_exponent"] = value * x.log_chl()
    if "nap_slope" in wrt:
        out["nap_slope"] = -x.offset * value
    return value, out


def _particle_term(x, wrt):
    """eq 12's two chlorophyll terms ('beam' only): C_12 (1 - e^(-S_12 C)) b*_p12 (l/l0)^-g12
    (pico + nano) and (C - C_12 (1 - e^(-S_12 C))) b*_p3 (l/l0)^-g3 (micro)."""
    t, out = x.terms, {}
    if not x.beam:
        return 0.0, out
    c12, s12 = x.get("c_12"), x.get("s_12")
    if any(x.given(k) for k in ("b_p12_star", "gamma_12", "b_p3_star", "gamma_3")):
        small = x.get("b_p12_star") * x.ratio ** -x.get("gamma_12")
        large = x.get("b_p3_star") * x.ratio ** -x.get("gamma_3")
    else:
        small, large = t.particle_shapes
    w_small = chl_weight(x.chl, 0.0, 1.0, c12, s12)
    w_large = chl_weight(x.chl, 1.0, 1.0, -c12, s12)
    if "chl" in wrt:
        out["chl"] = (chl_weight_derivative(x.chl_floor, 0.0, 1.0, c12, s12) * small
                      + chl_weight_derivative(x.chl_floor, 1.0, 1.0, -c12, s12) * large)
    if "c_12" in wrt:
        out["c_12"] = -np.expm1(-s12 * x.chl) * (small - large)
    if "s_12" in wrt:
        out["s_12"] = c12 * x.chl * np.exp(-s12 * x.chl) * (small - large)
    if "b_p12_star" in wrt:
        out["b_p12_star"] = w_small * x.ratio ** -x.get("gamma_12")
    if "gamma_12" in wrt:
        out["gamma_12"] = -w_small * small * np.log(x.ratio)
    if "b_p3_star" in wrt:
        out["b_p3_star"] = w_large * x.ratio ** -x.get("gamma_3")
    if "gamma_3" in wrt:
        out["gamma_3"] = -w_large * large * np.log(x.ratio)
    return w_small * small + w_large * large, out


#: The terms of c(x) (eqs 4-12), each returning its value and its derivatives by name.
PATH_TERMS = (_pure_water_term, _background_term, _cdom_term, _phytoplankton_term, _nap_term,
              _particle_term)


# =========================================================================== public functions
# One function per physical term (each a view of Water; ``water=None`` is the paper's model).
def _terms(wavelengths, water, **kw) -> WaterTerms:
    return resolve_water(water, **kw).on_grid(wavelengths)


_conc = validate.nonnegative


def pure_water_absorption(wavelengths=None, *, water: Water | None = None) -> np.ndarray:
    """Pure-water absorption a_w(lambda) in m^-1, the first term of eq 5.

    Smith & Baker (1981), Appl. Opt. 20(2):177-184, as tabulated by Mobley (1994) p. 90
    (``data/pure_water_absorption_smith_baker_1981.csv``), linearly interpolated.
    """
    return _terms(wavelengths, water).pure_water_absorption.copy()


def phytoplankton_absorption_440(chl, *, derivative: bool = False, water: Water | None = None):
    """a_phi(440 nm) = 0.0378 C^0.627 in m^-1 (eq 10; the right side of eq 17).

    With ``derivative=True`` returns (value, d value / dC); the derivative is infinite at C = 0
    (the estimator evaluates it at a small floor, see DECISIONS.md).
    """
    return resolve_water(water).phytoplankton_440(_conc("chl", chl), derivative=derivative)


def phytoplankton_absorption(wavelengths=None, chl=1.0, *, basis=None, weights=None,
                             water: Water | None = None) -> np.ndarray:
    """Phytoplankton absorption a_phi(lambda) = T w in m^-1 (eq 9), scaled by eq 10.

    ``basis`` is the T of eq 9 on the grid (default: the water's table); ``weights`` (z,) give
    the shape for z > 1 basis functions and are rescaled so that (T w)(440) = 0.0378 C^0.627.
    """
    wl = wavelength_grid(wavelengths)
    water = resolve_water(water)
    terms = water.on_grid(wl, basis=basis, weights=weights)
    terms._check_shape(None)
    return np.multiply.outer(water.phytoplankton_440(_conc("chl", chl)), terms.phyto_shape)


def cdom_absorption(wavelengths=None, cdom=0.1, *, slope: float | None = None,
                    water: Water | None = None) -> np.ndarray:
    """CDOM absorption a_CDOM(lambda) = a_CDOM,440 exp(-S (lambda - 440)) in m^-1 (eq 6)."""
    s = None if slope is None else validate.scalar("slope", slope, nonnegative=False)
    return np.multiply.outer(_conc("cdom", cdom), _terms(wavelengths, water, cdom_slope=s).cdom_shape)


def nap_absorption_440(chl, *, derivative: bool = False, water: Water | None = None):
    """a_NAP(440 nm) = 0.0124 C^0.724 in m^-1 (eq 8). ``derivative=True``: also d/dC."""
    out = resolve_water(water).chl_weights(_conc("chl", chl), derivative=derivative)
    return (out[0][..., 1], out[1][..., 1]) if derivative else out[..., 1]


def nap_absorption(wavelengths=None, chl=1.0, *, derivative: bool = False,
                   water: Water | None = None):
    """Non-algal particle absorption a_NAP(lambda) = a_NAP,440 exp(-0.011 (lambda - 440)) (eqs 7, 8).

    ``derivative=True`` returns (value, d value / dC).
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

    ``phytoplankton`` may give a_phi (shape (..., q)) directly; otherwise it is computed from
    ``chl`` (eq 10) with the basis (and ``weights``) of eq 9.
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

    Morel (1974), "Optical properties of pure water and pure sea water" (ref. [23]).
    """
    return _terms(wavelengths, water).pure_water_scattering.copy()


def table1(water: Water | None = None) -> dict:
    """The constants of Table 1 (eq 12) of ``water`` (default: as published, from
    ``data/particle_scattering_table1.csv``); a fresh dict each call."""
    return resolve_water(water).table1()


def particle_scattering_terms(wavelengths=None, *, water: Water | None = None):
    """The three spectral terms of eq 12 (Table 1 constants), each (q,) in m^-1 per unit weight:
    b*_p12 (l/l0)^-g12, b*_p3 (l/l0)^-g3, b_k (l/l0)^-gk."""
    t = _terms(wavelengths, water)
    return t.particle_shapes[0].copy(), t.particle_shapes[1].copy(), t.background_scattering.copy()


def particle_scattering_weights(chl, *, derivative: bool = False, water: Water | None = None):
    """The chlorophyll weights of eq 12's first two terms: (C12 (1 - e^(-S12 C)),
    C - C12 (1 - e^(-S12 C))) in mg m^-3; ``derivative=True`` also returns their d/dC."""
    out = resolve_water(water).chl_weights(_conc("chl", chl), derivative=derivative)
    if not derivative:
        return out[..., 2], out[..., 3]
    return (out[0][..., 2], out[0][..., 3]), (out[1][..., 2], out[1][..., 3])


def particle_scattering(wavelengths=None, chl=1.0, *, derivative: bool = False,
                        water: Water | None = None):
    """Particle scattering b_p(lambda) in m^-1, eq 12 with the Table 1 constants (lambda_0 = 470 nm).

    The Table 1 constants come from Brewin et al. (2012), who fit particle *back*scattering;
    the paper (and this function) use them as b_p (DECISIONS.md). ``derivative=True`` also
    returns d b_p / dC.
    """
    t = _terms(wavelengths, water)
    chl = _conc("chl", chl)
    if not derivative:
        return t.particle_scattering(chl)
    _, d = resolve_water(water).chl_weights(chl, derivative=True)
    return t.particle_scattering(chl), d[..., 2:] @ t.particle_shapes


def scattering(wavelengths=None, chl=1.0, *, water: Water | None = None) -> np.ndarray:
    """Total scattering b = b_w + b_p in m^-1 (eq 11)."""
    return _terms(wavelengths, water).scattering(_conc("chl", chl))


def backscattering(wavelengths=None, chl=1.0, *, water: Water | None = None) -> np.ndarray:
    """Backscattering coefficient b_b = 0.5 b_w + b_bp in m^-1, used by the veiling light (eq 2).

    Pure water scatters symmetrically (half backwards). For particles we take eq 12 itself as
    b_bp, which is what Brewin et al. (2012), the source of Table 1, fitted (DECISIONS.md).
    """
    return _terms(wavelengths, water).backscattering(_conc("chl", chl))


def attenuation_coefficient(wavelengths=None, chl=1.0, cdom=0.1, *, basis=None, weights=None,
                            phytoplankton=None, cdom_slope: float | None = None,
                            water: Water | None = None) -> np.ndarray:
    """Beam attenuation coefficient c = a + b in m^-1 (eq 4), whatever ``water.path_model``."""
    wl = wavelength_grid(wavelengths)
    a = absorption(wl, chl, cdom, basis=basis, weights=weights, phytoplankton=phytoplankton,
                   cdom_slope=cdom_slope, water=water)
    return a + scattering(wl, chl, water=water)
