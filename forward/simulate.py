"""Simulate what a camera records of a Macbeth chart underwater (eqs 1-14 and the sensor)."""

from __future__ import annotations

import json
from dataclasses import dataclass, field

import numpy as np

from . import validate
from .imaging import ChartSetup, camera_response, path_length, resolve_setup, veiling_light
from .sensor import SensorSettings, capture
from .spectra import DEFAULT_CAMERA
from .water import Water, resolve_water
from forward.errors import InputError

__all__ = ["ChartSimulation", "simulate_chart"]


@dataclass
class ChartSimulation:
    """One simulated chart capture (returned by :func:`simulate_chart`).

    ``rgb`` (m, n) are exposure-normalised patch values in model units: noise-free they equal
    ``P^T diag(i) diag(k) R + s`` with ``camera`` = P, ``illuminant`` = i, ``reflectances`` = R,
    ``attenuation`` = k and ``backscatter`` = s. ``rgb_sigma`` (m, n) is the standard deviation
    of each value under the sensor's noise (also when ``noise=False``), the ``sigma=`` of
    :func:`sca.estimate`; ``saturation`` is the value (model units) of a full pixel well: values
    there are clipped. Every parameter is also an attribute of the same name.

    Parameters
    ----------
    rgb : numpy.ndarray, shape (m, n)
        Recorded patch values, exposure-normalised, model units (a white reflector in air = 1
        in the most sensitive channel).
    rgb_sigma : numpy.ndarray, shape (m, n)
        Standard deviation of each ``rgb`` value under the sensor's noise, model units.
    saturation : float
        Model-unit value of a full pixel well.
    rgb_expected : numpy.ndarray, shape (m, n)
        Noise-free patch values P^T diag(i) diag(k) R + s 1^T (eq 15), model units.
    attenuation : numpy.ndarray, shape (q,)
        Path attenuation k = exp(-(depth + distance) c), dimensionless (c or a by the path
        model; eqs 3, 13, 14).
    backscatter : numpy.ndarray, shape (m,)
        Veiling light per channel s = P^T rho_b, model units (zero with ``backscatter=False``).
    wavelengths : numpy.ndarray, shape (q,)
        The grid, nm.
    camera : numpy.ndarray, shape (q, m)
        P of eq 15 (:attr:`forward.ChartSetup.sensitivities`).
    illuminant : numpy.ndarray, shape (q,)
        Relative SPD i of the surface illuminant (max 1).
    reflectances : numpy.ndarray, shape (q, n)
        R.
    chl : float
        Chlorophyll concentration C, mg m^-3.
    cdom : float
        a_CDOM(440 nm), m^-1.
    depth : float
        Depth of the chart below the surface, m.
    distance : float
        Camera-to-chart distance, m.
    camera_name : str
        The camera's name (or 'custom').
    attenuation_coefficient : numpy.ndarray, shape (q,)
        Beam attenuation coefficient c = a + b (eq 4), m^-1, whatever the path model.
    veiling_light : numpy.ndarray, shape (q,)
        rho_b of eq 2 (:func:`forward.veiling_light`), in the units of i x reflectance.
    exposure_s : float
        Exposure time, s.
    codes : numpy.ndarray, shape (m, n)
        Mean raw ADC codes per patch.
    noise : bool
        Whether sensor noise was added.
    seed : int or None
        Seed of the noise generator.
    path_model : str
        The path model used for k ('beam' or 'absorption').
    sensor : forward.SensorSettings
        The sensor.
    setup : forward.ChartSetup
        The P, i, R of eq 15.
    water : forward.Water, optional
        The water model (every constant of eqs 4-12).

    References
    ----------
    Blasinski & Farrell, eqs 1-15.
    """

    rgb: np.ndarray
    rgb_sigma: np.ndarray
    saturation: float
    rgb_expected: np.ndarray
    attenuation: np.ndarray
    backscatter: np.ndarray
    wavelengths: np.ndarray
    camera: np.ndarray
    illuminant: np.ndarray
    reflectances: np.ndarray
    chl: float
    cdom: float
    depth: float
    distance: float
    camera_name: str
    attenuation_coefficient: np.ndarray
    veiling_light: np.ndarray
    exposure_s: float
    codes: np.ndarray
    noise: bool
    seed: int | None
    path_model: str
    sensor: SensorSettings
    setup: ChartSetup = field(repr=False)
    water: Water = field(repr=False, default=None)

    def to_dict(self) -> dict:
        """A JSON-ready dict of the inputs and results (arrays as nested lists).

        Returns
        -------
        dict
            ``chl``, ``cdom``, ``depth``, ``distance``, ``camera_name``, ``noise``, ``seed``,
            ``path_model``, ``exposure_s``, ``saturation``; the arrays ``wavelengths``,
            ``rgb``, ``rgb_sigma``, ``rgb_expected``, ``attenuation``, ``backscatter``,
            ``attenuation_coefficient``, ``codes`` as lists; ``sensor``
            (:meth:`forward.SensorSettings.to_dict`) and ``water``
            (:meth:`forward.Water.constants`). Units as the attributes.
        """
        out = {}
        for key in ("chl", "cdom", "depth", "distance", "camera_name", "noise", "seed",
                    "path_model", "exposure_s"):
            out[key] = getattr(self, key)
        out["saturation"] = self.saturation
        for key in ("wavelengths", "rgb", "rgb_sigma", "rgb_expected", "attenuation", "backscatter",
                    "attenuation_coefficient", "codes"):
            out[key] = np.asarray(getattr(self, key)).tolist()
        out["sensor"] = self.sensor.to_dict()
        out["water"] = self.water.constants()
        return out

    def to_json(self) -> str:
        """The simulation as JSON text (:meth:`to_dict`, indented by 1).

        Returns
        -------
        str
            The JSON document.
        """
        return json.dumps(self.to_dict(), indent=1)


def _with_chart_physics(setup, terms, chl, cdom, depth, distance, in_water, scatter, tilt):
    """The set-up with the opt-in chart physics of :mod:`forward.chart_physics` applied (the
    set-up itself when none is asked for)."""
    import dataclasses

    from . import chart_physics as cp

    if not isinstance(in_water, (bool, np.bool_)) or not isinstance(scatter, (bool, np.bool_)):
        raise InputError("chart_in_water, forward_scatter", "expected True or False")
    R, light = setup.reflectances, setup.illuminant
    if in_water:
        R = cp.in_water_reflectance(R)
    if scatter:  # eq 12 with Table 1: the particles' backscattering (REALWATER.md)
        bbp = terms.particle_scattering(chl)
        R = cp.forward_scatter_reflectance(R, cp.forward_scatter_fraction(bbp, distance), distance)
    if tilt is not None:
        tilt = validate.scalar("chart_tilt_deg", tilt)
        light = light * cp.tilted_chart_light(setup.wavelengths,
                                              terms.beam_coefficient(chl, cdom), depth, tilt)
    if R is setup.reflectances and light is setup.illuminant:
        return setup
    return dataclasses.replace(setup, reflectances=R, illuminant=light)


def simulate_chart(chl, cdom, depth, distance, *, camera=DEFAULT_CAMERA, noise: bool = True,
                   seed=None, wavelengths=None, illuminant=None, reflectances=None, basis=None,
                   weights=None, water: Water | None = None, cdom_slope: float | None = None,
                   path_model: str | None = None, backscatter: bool = True,
                   sensor: SensorSettings | None = None,
                   setup: ChartSetup | None = None, chart_in_water: bool = False,
                   forward_scatter: bool = False,
                   chart_tilt_deg: float | None = None) -> ChartSimulation:
    """Simulate the camera's patch values of a chart at ``depth`` m seen from ``distance`` m.

    Parameters
    ----------
    chl : float
        Chlorophyll concentration C, mg m^-3.
    cdom : float
        CDOM absorption at 440 nm, a_CDOM(440), m^-1.
    depth, distance : float
        Lengths in m; light travels ``depth`` down and ``distance`` to the camera.
    camera, illuminant, reflectances, wavelengths : optional
        See :func:`forward.imaging.chart_setup` (defaults Nikon 5100 (NPL), D65, BabelColor
        Average, 400-700 nm at 1 nm). A prebuilt ``setup`` replaces all four.
    noise : bool, optional
        Sensor noise on (default) or the exact expectation.
    seed : int, optional
        Seed of the noise generator (``numpy.random.default_rng``), >= 0.
    basis, weights : array_like, optional
        Phytoplankton basis T (eq 9) on the grid and weights for z > 1.
    water : forward.Water, optional
        Every constant and table of eqs 4-12 and the path model (default: the paper's).
    cdom_slope : float, optional
        Shortcut that replaces that field of ``water``: eq 6's slope, nm^-1.
    path_model : {'beam', 'absorption', 'split'}, optional
        Shortcut that replaces that field of ``water``: 'beam' (k = exp(-L c), default),
        'absorption' (the literal eq 13) or 'split' (K_d down, c along the view).
    backscatter : bool, optional
        Include the veiling light of eq 2 (default True).
    sensor : forward.SensorSettings, optional
        The sensor (defaults: decision 0019-sensor-defaults).
    setup : forward.ChartSetup, optional
        Prebuilt P, i, R (:func:`forward.chart_setup`); replaces ``camera``, ``illuminant``,
        ``reflectances`` (``wavelengths``, if given, must be its grid).
    chart_in_water : bool, optional
        Opt-in (issue 39): the chart's reflectance under water
        (:func:`forward.chart_physics.in_water_reflectance`, Saunderson with the binder's and
        sea water's indices) instead of its reflectance in air (default False: the paper's).
    forward_scatter : bool, optional
        Opt-in: the blur of forward scattering on the patch means
        (:func:`forward.chart_physics.forward_scatter_reflectance`; default False).
    chart_tilt_deg : float, optional
        Opt-in: the light on a chart tilted by this angle from horizontal towards the sun
        (:func:`forward.chart_physics.tilted_chart_light`; default None: the paper's light).

    Returns
    -------
    ChartSimulation
        The recorded values, their noise, and every intermediate (k, s, rho_b, c).

    Raises
    ------
    ValueError
        Naming the argument, for an invalid or out-of-range input.

    References
    ----------
    Blasinski & Farrell, eqs 1-15 (k and the water of eqs 3-14, the chart model of eq 15, the
    veiling light of eq 2 as in decision 0016-veiling-light); the sensor after ISET (Farrell et al.
    2012).

    Examples
    --------
    >>> import forward
    >>> sim = forward.simulate_chart(2.0, 0.1, depth=5, distance=1, seed=0)
    >>> sim.rgb.shape                      # 3 channels x 24 patches
    (3, 24)
    >>> i490 = int(abs(sim.wavelengths - 490).argmin())
    >>> print(f"{sim.attenuation_coefficient[i490]:.3f}")   # the path's c(490), m^-1
    0.130
    """
    chl = validate.scalar("chl", chl)
    cdom = validate.scalar("cdom", cdom)
    depth = validate.scalar("depth", depth)
    distance = validate.scalar("distance", distance)
    setup = resolve_setup(setup, camera, illuminant, reflectances, wavelengths)
    sensor = SensorSettings() if sensor is None else sensor
    if not isinstance(sensor, SensorSettings):
        raise InputError("sensor", "expected a forward.SensorSettings")
    water = resolve_water(water, path_model=path_model, cdom_slope=cdom_slope)
    wl = setup.wavelengths
    terms = water.on_grid(wl, basis=basis, weights=weights)
    path_length(depth, distance)  # checks both lengths
    setup = _with_chart_physics(setup, terms, chl, cdom, depth, distance, chart_in_water,
                                forward_scatter, chart_tilt_deg)
    k = np.exp(-terms.optical_depth(chl, cdom, depth, distance)[0])
    c = terms.beam_coefficient(chl, cdom)
    if backscatter:
        rho_b = veiling_light(wl, chl, cdom, depth, distance, illuminant=setup.illuminant,
                              water=water, basis=basis, weights=weights)
    else:
        rho_b = np.zeros_like(wl)
    s = setup.sensitivities.T @ rho_b
    expected = camera_response(setup.sensitivities, setup.illuminant, k, setup.reflectances, s)
    if not isinstance(noise, (bool, np.bool_)):
        raise InputError("noise", f"expected True or False, got {noise!r}")
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0):
        raise InputError("seed", f"expected a non-negative integer or None, got {seed!r}")
    rng = np.random.default_rng(seed)
    cap = capture(expected, setup, sensor, noise=bool(noise), rng=rng)
    return ChartSimulation(
        rgb=cap["rgb"], rgb_sigma=cap["sigma"], saturation=float(cap["saturation"]),
        rgb_expected=expected, attenuation=k, backscatter=s, wavelengths=wl,
        camera=setup.sensitivities, illuminant=setup.illuminant, reflectances=setup.reflectances,
        chl=chl, cdom=cdom, depth=depth, distance=distance, camera_name=setup.camera,
        attenuation_coefficient=c, veiling_light=rho_b, exposure_s=cap["exposure_s"],
        codes=cap["codes"], noise=bool(noise), seed=seed, path_model=water.path_model,
        sensor=sensor, setup=setup, water=water,
    )
