"""The spectral terms of c(x) of one :class:`forward.water.Water` on one wavelength grid
(:class:`WaterTerms`): each term's spectrum, and the path coefficient with its derivatives by
name, assembled from the term table of :mod:`forward.water.terms`.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from .. import validate
from ..spectra import (
    resample,
    wavelength_grid,
)
from .model import Water, _readonly, phytoplankton_basis
from .terms import (
    ABSORPTION_TERMS,
    COEFFICIENT_PARAMS,
    PARTICLE_TERMS,
    PATH_LEGS,
    PATH_TERMS,
    SCATTERING_TERMS,
    _sum_pieces,
    _TermInputs,
)
from forward.errors import InputError


__all__ = ["WaterTerms"]

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
            raise InputError("weights", "the basis combination T w must be positive at 440 nm")
        phyto = T @ w / scale440
        if np.any(phyto < -1e-12):
            raise InputError("weights", "T w is negative at some wavelength (violates eq 16)")
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
            raise InputError("index", "expected at least 3 increasing grid indices")
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
            raise InputError("weights", f"required for a basis of z = {self.T.shape[1]} functions")

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
            raise InputError("values", f"not a coefficient parameter: {sorted(unknown)}; "
                             f"choose from {COEFFICIENT_PARAMS}")
        bad = set(wrt) - set(COEFFICIENT_PARAMS) - {"chl", "cdom", "w"}
        if bad:
            raise InputError("wrt", f"cannot differentiate c(x) by {sorted(bad)}")
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
        ``water.particle_backscatter_fraction`` (1); decision 0015-eq12-backscattering.

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
