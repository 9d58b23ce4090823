"""uw3p forward model: what a camera records of a Macbeth chart underwater.

Blasinski & Farrell, "A Three Parameter Underwater Image Formation Model" (eqs 1-14, Table 1).

Units throughout: wavelengths in nm, absorption / scattering / attenuation coefficients in
m^-1, chlorophyll ``chl`` (C) in mg m^-3, ``cdom`` = a_CDOM(440 nm) in m^-1, lengths
(``depth``, ``distance``) in m; camera values in model units (a white reflector in air = 1 in
the most sensitive channel).
"""

from . import validate
from .validate import InputError
from .imaging import (
    PATH_MODELS,
    ChartSetup,
    attenuation,
    camera_response,
    chart_setup,
    path_length,
    resolve_setup,
    veiling_light,
)
from .render import camera_to_xyz_matrix, chart_image, chart_xyz, patch_srgb, patches_image
from .sensor import SensorSettings, capture, sensor_noise
from .simulate import ChartSimulation, simulate_chart
from .spectra import (
    DEFAULT_CAMERA,
    LAMBDA_0_NM,
    MODEL_RANGE_NM,
    camera_sensitivities,
    chart_reflectances,
    cie_1931_cmfs,
    illuminant_spd,
    quadrature_weights,
    wavelength_grid,
)
from .water import (
    CDOM_SLOPE,
    CHL_TERMS,
    NAP_SLOPE,
    PAPER_WATER,
    Water,
    WaterTerms,
    phytoplankton_basis,
    resolve_water,
    table1,
    absorption,
    attenuation_coefficient,
    backscattering,
    cdom_absorption,
    nap_absorption,
    nap_absorption_440,
    particle_scattering,
    phytoplankton_absorption,
    phytoplankton_absorption_440,
    pure_water_absorption,
    pure_water_scattering,
    scattering,
)

__all__ = [
    "CDOM_SLOPE",
    "CHL_TERMS",
    "DEFAULT_CAMERA",
    "InputError",
    "LAMBDA_0_NM",
    "MODEL_RANGE_NM",
    "NAP_SLOPE",
    "PAPER_WATER",
    "PATH_MODELS",
    "ChartSetup",
    "ChartSimulation",
    "SensorSettings",
    "Water",
    "WaterTerms",
    "absorption",
    "attenuation",
    "attenuation_coefficient",
    "backscattering",
    "camera_response",
    "camera_sensitivities",
    "camera_to_xyz_matrix",
    "capture",
    "cdom_absorption",
    "chart_image",
    "chart_reflectances",
    "chart_setup",
    "chart_xyz",
    "cie_1931_cmfs",
    "illuminant_spd",
    "imaging",
    "nap_absorption",
    "nap_absorption_440",
    "particle_scattering",
    "patch_srgb",
    "patches_image",
    "path_length",
    "phytoplankton_absorption",
    "phytoplankton_absorption_440",
    "phytoplankton_basis",
    "pure_water_absorption",
    "pure_water_scattering",
    "quadrature_weights",
    "render",
    "resolve_setup",
    "resolve_water",
    "scattering",
    "sensor",
    "sensor_noise",
    "simulate",
    "simulate_chart",
    "spectra",
    "table1",
    "validate",
    "veiling_light",
    "water",
    "wavelength_grid",
]
