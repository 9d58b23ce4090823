"""The terms of the path coefficient c(x) (eqs 5-12), each returning its value beside its
analytic derivative by parameter name; which terms each path model adds along which leg
(:data:`PATH_TERMS`, :data:`PATH_LEGS`); the :class:`forward.water.Water` fields that enter
c(x) (:data:`COEFFICIENT_PARAMS`).
"""

from __future__ import annotations

import contextlib
import functools
import math

import numpy as np

from .model import chl_weight, chl_weight_derivative


__all__ = ["ABSORPTION_TERMS", "BEAM_TERMS", "COEFFICIENT_PARAMS", "DIFFUSE_TERMS",
           "NONWATER_ABSORPTION_TERMS", "PARTICLE_TERMS", "PATH_LEGS", "PATH_TERMS",
           "SCATTERING_TERMS"]

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
