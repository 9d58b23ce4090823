"""A photon-counting camera sensor in the spirit of ISET (Farrell et al. 2012, ref. [13]).

The paper simulated its camera with ISET but does not publish the settings; the defaults here
describe a consumer APS-C Bayer camera (pixel pitch of a 16 MP APS-C sensor, f/4 lens) and are
listed, with their reasons, in decision 0019-sensor-defaults.

Signal chain for one patch and channel (model signal ``m`` from eq 1, in units where a white
reflector in air gives 1 in the most sensitive channel):

1. surface illuminance ``illuminance_lux`` -> absolute spectral irradiance -> sensor-plane
   irradiance of a white Lambertian patch through an f/N lens (E T / 4N^2) -> electrons per
   second per pixel in the reference channel: the gain ``G`` (e-/s per model unit);
2. auto-exposure: t = min(max_exposure_s, target_fraction * full_well / (G max m))
   (``exposure_mode='capped'``, the default: deeper scenes get darker and noisier), or, as ISET's
   auto-exposure does (``exposure_mode='iset'``), t = 0.95 full_well / (G max m) with no cap:
   every image then has the same photon budget whatever the light;
3. each of ``pixels_per_patch`` pixels: Poisson(G t m) electrons + Normal(0, read_noise) ->
   clipped to [0, full_well] -> ``adc_bits`` quantisation (round to nearest code);
4. the patch value is the mean code over its pixels, exposure-normalised back to model units:
   rgb = mean_code * LSB / (G t). Noise-free, rgb equals m exactly.
"""

from __future__ import annotations

import functools
from dataclasses import asdict, dataclass

import numpy as np

from . import validate
from .spectra import cie_1931_cmfs, quadrature_weights
from forward.errors import InputError

__all__ = [
    "EXPOSURE_MODES",
    "ISET_EXPOSURE_FRACTION",
    "LUMINOUS_EFFICACY",
    "PLANCK_H",
    "SPEED_OF_LIGHT",
    "SensorSettings",
    "auto_exposure",
    "capture",
    "electrons_per_second",
    "noise_model",
    "pixel_variance_e2",
    "sensor_noise",
]

#: Planck's constant, J s (SI 2019, exact).
PLANCK_H = 6.62607015e-34  # J s
#: Speed of light in vacuum, m s^-1 (exact).
SPEED_OF_LIGHT = 2.99792458e8  # m s^-1
#: Maximum luminous efficacy of photopic vision, lm W^-1 (at 555 nm).
LUMINOUS_EFFICACY = 683.0  # lm W^-1
#: Exposure modes: 'capped' (target_fraction, at most max_exposure_s) and 'iset' (the brightest
#: value at ISET_EXPOSURE_FRACTION of full well, no time limit; Farrell et al. 2012, ref. [13]).
EXPOSURE_MODES = ("capped", "iset")
#: Fraction of full well that the brightest expected value reaches in 'iset' exposure mode.
ISET_EXPOSURE_FRACTION = 0.95


@dataclass(frozen=True)
class SensorSettings:
    """Camera and scene-light settings (SI units in the names). Defaults: decision
    0019-sensor-defaults.

    The defaults describe a consumer APS-C Bayer camera (pixel pitch of a 16 MP APS-C sensor,
    f/4 lens) in daylight. Immutable; every parameter is also an attribute.

    Parameters
    ----------
    illuminance_lux : float
        Surface illuminance of the daylight, lx (default 20000).
    f_number : float
        Lens f-number N (default 4).
    optics_transmittance : float
        Lens transmittance T, in (0, 1] (default 0.9).
    pixel_pitch_um : float
        Pixel pitch, micrometres (default 4.8: 16 MP APS-C, e.g. Nikon D5100).
    peak_quantum_efficiency : float
        Quantum efficiency at the reference channel's peak, including the colour filter, in
        (0, 1] (default 0.4).
    full_well_e : float
        Full-well capacity, electrons (default 40000).
    read_noise_e : float
        Read noise standard deviation, electrons (default 3; >= 0).
    adc_bits : int
        ADC resolution, bits, 1-24 (default 14).
    target_fraction : float
        Auto-exposure: brightest value to this fraction of full well, in (0, 1] (default 0.8).
    max_exposure_s : float
        Longest exposure, s (default 1/30).
    pixels_per_patch : int
        Pixels averaged per patch (default 100: a 10 x 10 pixel window at each patch centre).
    exposure_mode : {'capped', 'iset'}
        'capped' (default: ``target_fraction``, at most ``max_exposure_s``) or 'iset'
        (:data:`ISET_EXPOSURE_FRACTION` of full well, no time limit); :data:`EXPOSURE_MODES`.

    Raises
    ------
    ValueError
        Naming the setting, for an unknown exposure mode or a value out of range.

    References
    ----------
    Farrell et al., "Digital camera simulation", Appl. Opt. 51:A80-A90, 2012 (ISET, ref. [13]).
    """

    illuminance_lux: float = 20000.0  # surface illuminance of the daylight (lx)
    f_number: float = 4.0
    optics_transmittance: float = 0.9
    pixel_pitch_um: float = 4.8  # 16 MP APS-C, e.g. Nikon D5100
    peak_quantum_efficiency: float = 0.4  # including the colour filter
    full_well_e: float = 40000.0
    read_noise_e: float = 3.0
    adc_bits: int = 14
    target_fraction: float = 0.8  # auto-exposure: brightest value to this fraction of full well
    max_exposure_s: float = 1.0 / 30.0
    pixels_per_patch: int = 100  # a 10 x 10 pixel window read at each patch centre
    exposure_mode: str = "capped"  # or 'iset' (see EXPOSURE_MODES)

    def __post_init__(self):
        if self.exposure_mode not in EXPOSURE_MODES:
            raise InputError("exposure_mode", f"must be one of {EXPOSURE_MODES}, got {self.exposure_mode!r}")
        for name in ("illuminance_lux", "f_number", "optics_transmittance", "pixel_pitch_um",
                     "peak_quantum_efficiency", "full_well_e", "target_fraction", "max_exposure_s"):
            validate.scalar(name, getattr(self, name), positive=True)
        validate.scalar("read_noise_e", self.read_noise_e)
        if self.target_fraction > 1:
            raise InputError("target_fraction", f"must be in (0, 1], got {self.target_fraction}")
        if self.optics_transmittance > 1 or self.peak_quantum_efficiency > 1:
            raise InputError("optics_transmittance, peak_quantum_efficiency", "must be <= 1")
        if int(self.adc_bits) != self.adc_bits or not 1 <= self.adc_bits <= 24:
            raise InputError("adc_bits", f"must be an integer in 1..24, got {self.adc_bits}")
        if int(self.pixels_per_patch) != self.pixels_per_patch or self.pixels_per_patch < 1:
            raise InputError("pixels_per_patch", f"must be a positive integer, got {self.pixels_per_patch}")

    def to_dict(self) -> dict:
        """The settings as a dict (JSON-ready).

        Returns
        -------
        dict
            Field name -> value, in the units of the names.
        """
        return asdict(self)

    @property
    def lsb_e(self) -> float:
        """Electrons per ADC code: full_well_e / (2^adc_bits - 1).

        Returns
        -------
        float
            The least significant bit, electrons.
        """
        return self.full_well_e / (2 ** int(self.adc_bits) - 1)


@functools.lru_cache(maxsize=64)
def electrons_per_second(setup, settings: SensorSettings) -> float:
    """Gain G (electrons s^-1 per model unit) of the reference channel for a white patch in air.

    The illuminant i (relative) is scaled to ``illuminance_lux`` with the CIE 1931 V(lambda) on
    the model grid; a Lambertian white patch seen through an f/N lens gives the sensor-plane
    irradiance E T / (4 N^2); photons are counted at each wavelength and weighted by the
    reference channel's sensitivity times the peak quantum efficiency. The reference channel is
    the most sensitive one (largest :attr:`ChartSetup.white_response`). Cached per (setup,
    settings).

    Parameters
    ----------
    setup : forward.ChartSetup
        The wavelength grid (nm), illuminant and camera sensitivities.
    settings : SensorSettings
        Illuminance (lx), optics, pixel size and quantum efficiency.

    Returns
    -------
    float
        G, electrons per second per pixel per model unit.

    References
    ----------
    Farrell et al. 2012 (ISET, ref. [13]); CIE 1931 V(lambda).
    """
    wl = setup.wavelengths
    v = cie_1931_cmfs(wl)[:, 1]
    wq = quadrature_weights(wl)
    i = setup.illuminant
    kappa = settings.illuminance_lux / (LUMINOUS_EFFICACY * np.sum(i * v * wq))  # W m^-2 nm^-1 per unit i
    e_sensor = kappa * i * settings.optics_transmittance / (4 * settings.f_number ** 2)
    area = (settings.pixel_pitch_um * 1e-6) ** 2
    photons = e_sensor * area * (wl * 1e-9) / (PLANCK_H * SPEED_OF_LIGHT)  # photons s^-1 nm^-1
    ref = int(np.argmax(setup.white_response))
    rate = settings.peak_quantum_efficiency * np.sum(setup.raw_sensitivities[:, ref] * photons * wq)
    return float(rate / setup.white_response[ref])


def auto_exposure(expected, gain: float, settings: SensorSettings):
    """Exposure time in s that brings the brightest expected value near full well.

    'capped' mode: brightest expected value to ``target_fraction`` of full well, capped at
    ``max_exposure_s``; 'iset' mode: to 95 % of full well with no cap. A chart with no signal
    gets ``max_exposure_s`` ('capped') or 1 s ('iset').

    Parameters
    ----------
    expected : array_like, shape (m, n) or (..., m, n)
        Noise-free model signals of one chart or a stack of charts.
    gain : float
        G, electrons s^-1 per model unit (:func:`electrons_per_second`).
    settings : SensorSettings
        Exposure mode, target fraction, full well and longest exposure.

    Returns
    -------
    float or numpy.ndarray, shape (...)
        Exposure time, s: a float for one chart, one time per chart for a stack.
    """
    peak = np.max(np.asarray(expected, float), axis=(-2, -1)) * gain
    with np.errstate(divide="ignore"):
        if settings.exposure_mode == "iset":
            t = np.where(peak > 0, ISET_EXPOSURE_FRACTION * settings.full_well_e / peak, 1.0)
        else:
            t = np.where(peak > 0, np.minimum(settings.max_exposure_s,
                                              settings.target_fraction * settings.full_well_e / peak),
                         settings.max_exposure_s)
    return float(t) if t.ndim == 0 else t


def sensor_noise(expected_e, settings: SensorSettings, rng: np.random.Generator) -> np.ndarray:
    """Mean ADC code over ``pixels_per_patch`` noisy pixels for each expected electron count.

    Shot noise (Poisson), read noise (Gaussian, e-), full-well clipping and rounding to
    ``adc_bits`` codes, pixel by pixel.

    Parameters
    ----------
    expected_e : array_like
        Expected electrons per pixel (any shape).
    settings : SensorSettings
        Read noise, full well, ADC bits and pixels per patch.
    rng : numpy.random.Generator
        The random generator.

    Returns
    -------
    numpy.ndarray
        Mean codes as floats (in [0, 2^adc_bits - 1]), same shape as ``expected_e``.
    """
    lam = np.asarray(expected_e, dtype=float)
    n = int(settings.pixels_per_patch)
    e = rng.poisson(np.broadcast_to(lam[..., None], lam.shape + (n,))).astype(float)
    e += rng.normal(0.0, settings.read_noise_e, size=e.shape)
    np.clip(e, 0.0, settings.full_well_e, out=e)
    codes = np.clip(np.rint(e / settings.lsb_e), 0, 2 ** int(settings.adc_bits) - 1)
    return codes.mean(axis=-1)


def pixel_variance_e2(expected_e, settings: SensorSettings) -> np.ndarray:
    """Variance (e^2) of one pixel's value: shot noise, read noise and the ADC's rounding.

    Shot noise is Poisson (variance = the mean), read noise ``read_noise_e^2``, and rounding
    uniform over one code (LSB^2 / 12).

    Parameters
    ----------
    expected_e : array_like
        Expected electrons per pixel (any shape).
    settings : SensorSettings
        Read noise, full well and ADC bits.

    Returns
    -------
    numpy.ndarray
        Variance, electrons^2, same shape as ``expected_e``.
    """
    return (np.asarray(expected_e, dtype=float) + settings.read_noise_e ** 2
            + settings.lsb_e ** 2 / 12.0)


def noise_model(expected, setup, settings: SensorSettings):
    """The sensor's noise on model signals ``expected``: sigma, saturation, exposure and gain.

    Used by :func:`capture` and by the precision bound (``sca.precision``).

    Parameters
    ----------
    expected : array_like, shape (m, n) or (..., m, n)
        Noise-free model signals of one chart or a stack.
    setup : forward.ChartSetup
        The chart setup (for the gain, :func:`electrons_per_second`).
    settings : SensorSettings
        The sensor.

    Returns
    -------
    sigma : numpy.ndarray, shape of ``expected``
        The standard deviation of each patch value (:func:`pixel_variance_e2` over
        ``pixels_per_patch`` pixels), model units.
    saturation : numpy.ndarray, shape (...)
        The model-unit value of a full well (0-d for one chart).
    exposure_s : numpy.ndarray, shape (...)
        The exposure time(s), s (:func:`auto_exposure`; 0-d for one chart).
    gain_e_per_s : float
        G, electrons s^-1 per model unit.
    """
    gain = electrons_per_second(setup, settings)
    t = np.asarray(auto_exposure(expected, gain, settings))
    gt = (gain * t)[..., None, None]
    expected_e = np.asarray(expected, dtype=float) * gt
    sigma = np.sqrt(pixel_variance_e2(expected_e, settings) / settings.pixels_per_patch) / gt
    saturation = settings.full_well_e / (gain * t)
    return sigma, saturation, t, gain


def capture(expected, setup, settings: SensorSettings, *, noise: bool = True, rng=None) -> dict:
    """Expose and read out model signals ``expected`` (m, n).

    Parameters
    ----------
    expected : array_like, shape (m, n)
        Noise-free model signals of one chart (:func:`forward.camera_response`).
    setup : forward.ChartSetup
        The chart setup (for the gain).
    settings : SensorSettings
        The sensor.
    noise : bool, optional
        Add the sensor's noise (default True).
    rng : numpy.random.Generator, optional
        The random generator (default: a fresh ``numpy.random.default_rng()``).

    Returns
    -------
    dict
        ``rgb`` (exposure-normalised, model units), ``sigma`` (the standard deviation of each
        ``rgb`` value under this sensor: :func:`pixel_variance_e2` over ``pixels_per_patch``
        pixels, in model units), ``saturation`` (the model-unit value of a full well: values
        there are clipped), ``codes`` (mean raw codes per patch), ``exposure_s`` (s),
        ``gain_e_per_s`` and ``expected_e`` (expected electrons per pixel). With
        ``noise=False`` ``rgb`` is ``expected`` itself and ``codes`` its noise-free code value
        (not rounded; clipped at full well); ``sigma`` is the same.

    References
    ----------
    Farrell et al. 2012 (ISET, ref. [13]); the signal chain is in this module's
    docstring.
    """
    sigma, saturation, t, gain = noise_model(expected, setup, settings)
    t = float(t)
    expected_e = np.asarray(expected, dtype=float) * gain * t
    if noise:
        if rng is None:
            rng = np.random.default_rng()
        codes = sensor_noise(expected_e, settings, rng)
        rgb = codes * settings.lsb_e / (gain * t)
    else:
        codes = np.minimum(expected_e, settings.full_well_e) / settings.lsb_e
        rgb = np.array(expected, dtype=float)
    return {"rgb": rgb, "sigma": sigma, "saturation": saturation, "codes": codes, "exposure_s": t,
            "gain_e_per_s": gain, "expected_e": expected_e}
