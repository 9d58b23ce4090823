"""uw3p forward model: what a camera records of a Macbeth chart underwater.

Blasinski & Farrell, "A Three Parameter Underwater Image Formation Model" (eqs 1-14, Table 1).

Units throughout: wavelengths in nm, absorption / scattering / attenuation coefficients in
m^-1, chlorophyll ``chl`` (C) in mg m^-3, ``cdom`` = a_CDOM(440 nm) in m^-1, lengths
(``depth``, ``distance``) in m; camera values in model units (a white reflector in air = 1 in
the most sensitive channel).

The public names are loaded on first use (PEP 562 module ``__getattr__``, as :mod:`sca` and
:mod:`measure`): importing :mod:`forward` costs nothing until a name is asked for, and
``forward.errors.InputError`` loads without the numerics (decision 0007-start-up).
"""

from __future__ import annotations

from .lazy import lazy_exports

#: Where each public name lives (submodule of ``forward``).
_HOME = {
    "InputError": "errors",
    "PATH_MODELS": "imaging", "ChartSetup": "imaging", "attenuation": "imaging",
    "camera_response": "imaging", "chart_setup": "imaging", "path_length": "imaging",
    "resolve_setup": "imaging", "veiling_light": "imaging",
    "camera_to_xyz_matrix": "render", "chart_image": "render", "chart_xyz": "render",
    "patch_srgb": "render", "patches_image": "render",
    "SensorSettings": "sensor", "capture": "sensor", "sensor_noise": "sensor",
    "ChartSimulation": "simulate", "simulate_chart": "simulate",
    "DEFAULT_CAMERA": "spectra", "LAMBDA_0_NM": "spectra", "MODEL_RANGE_NM": "spectra",
    "camera_sensitivities": "spectra", "chart_reflectances": "spectra", "cie_1931_cmfs": "spectra",
    "illuminant_spd": "spectra", "quadrature_weights": "spectra", "wavelength_grid": "spectra",
    "CDOM_SLOPE": "water", "CHL_TERMS": "water", "NAP_SLOPE": "water", "PAPER_WATER": "water",
    "Water": "water", "WaterTerms": "water", "phytoplankton_basis": "water",
    "resolve_water": "water", "table1": "water", "absorption": "water",
    "attenuation_coefficient": "water", "backscattering": "water", "cdom_absorption": "water",
    "nap_absorption": "water", "nap_absorption_440": "water", "particle_scattering": "water",
    "phytoplankton_absorption": "water", "phytoplankton_absorption_440": "water",
    "pure_water_absorption": "water", "pure_water_scattering": "water", "scattering": "water",
}
#: The public names: every name of :data:`_HOME` (the submodules load as attributes too:
#: ``forward.water``).
__all__ = list(_HOME)

__getattr__, __dir__ = lazy_exports(__name__, globals(), _HOME, __all__)
