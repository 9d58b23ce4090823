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

The package holds one concept per module: :mod:`forward.water.model` (the :class:`Water`
constants and tables, the weight form), :mod:`forward.water.terms` (each term of c(x) beside
its derivative, the path models' legs), :mod:`forward.water.grid` (:class:`WaterTerms`, the
terms on one grid) and :mod:`forward.water.functions` (one public function per physical term).
"""

from __future__ import annotations

from .model import (  # noqa: F401
    BASIS_TABLE,
    CDOM_SLOPE,
    CHL_TERMS,
    NAP_SLOPE,
    PAPER_WATER,
    PATH_MODELS,
    PURE_WATER_TABLE,
    TABLE1,
    Water,
    chl_weight,
    chl_weight_derivative,
    phytoplankton_basis,
    resolve_water,
)
from .terms import (  # noqa: F401
    ABSORPTION_TERMS,
    BEAM_TERMS,
    COEFFICIENT_PARAMS,
    DIFFUSE_TERMS,
    NONWATER_ABSORPTION_TERMS,
    PARTICLE_TERMS,
    PATH_LEGS,
    PATH_TERMS,
    SCATTERING_TERMS,
)
from .grid import (  # noqa: F401
    WaterTerms,
)
from .functions import (  # noqa: F401
    absorption,
    attenuation_coefficient,
    backscattering,
    cdom_absorption,
    nap_absorption,
    nap_absorption_440,
    particle_scattering,
    particle_scattering_terms,
    particle_scattering_weights,
    phytoplankton_absorption,
    phytoplankton_absorption_440,
    pure_water_absorption,
    pure_water_scattering,
    scattering,
    table1,
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
