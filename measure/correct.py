"""The colour correction from the measured water: at the chart's distance (the paper's Fig 11
von Kries correction, :func:`correction`) and every pixel along its own range.

The model (Blasinski & Farrell eqs 1-3 and 15, with the veiling light of eq 2 modelled as the
simulator does) of a pixel of channel c at range r, in raw units:

    raw_c = gain W_c(r) rho_c + s_c(r),

W_c(r) the camera's channel-c response to a white reflector at range r at the photo's depth
(the light that reached the depth, along the path model's legs, times the camera's curves), and
rho_c the object's reflectance seen by channel c. The correction inverts it per channel,

    J_c = (raw_c - s_c(r)) / (gain t_c(r)),   t_c(r) = W_c(r) / W_c(air),

J in the camera's units *in air* (a white reflector in air = 1 in the most sensitive channel):
the paper's von Kries correction (Fig 11; :func:`correction`) generalised from one
distance to every pixel's own. Nothing is restated: W_c(r) is the estimators' own model
function (:meth:`sca.model.ChartModel.predict` of a white reflector: the water's
:meth:`forward.WaterTerms.optical_depth` with the fit's path model, Water constants, the
camera's fitted ``balance`` and ``camera_shift`` and the ``daylight`` shift) on a table of
ranges, and each pixel interpolates the table (no spectral integral per pixel).

The veiling light s_c(r): the fit measured s_c(r0) along the chart's ray (r0 the chart's
distance). Its shape in r is the simulator's single-scattering model
(:func:`forward.veiling_light`, rho_b = i exp(-K depth) (b_b / c)(1 - exp(-c r))) projected on
the camera's channels, V_c(r) = P^T rho_b(r), and anchored to the measurement:
s_c(r) = s_c(r0) V_c(r) / V_c(r0). The model's b_b only enters as the spectral shape of the
veil, not as its level (decision 0047-per-pixel-correction).

Far and unknown ranges: the correction along a range amplifies the direct signal (and its
noise) by 1 / t_c(r). Ranges beyond ``max_range``, or beyond the range at which a channel's
transmission along the range alone, t_c(r) / t_c(0), falls below 1 / ``max_gain``, are
corrected as at that range (the cap, :data:`MAX_GAIN`; +inf in a map too); unknown ranges (0,
NaN, -inf or negative in a map) as at ``unknown`` (default the chart's distance: today's
single-distance correction). Both are counted and reported (decision 0063-range-map-checks).

Not modelled: the object's own depth where it differs from the photo's (the light that reaches
a deeper object has come further down; a seafloor seen from above is lit as at the camera's
depth), forward scattering (blur and the glow around bright objects), the light's angle (the
daylight comes straight down; no shading, no shadow), artificial light, and a veiling light
that varies across the frame otherwise than with the range.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

import forward
from forward.water import COEFFICIENT_PARAMS
from sca.compiled import KERNEL_LOCK

from .correct_matrix import TRAINING_SETS, check_method, colour_matrices, model_response
from .correctcamera import check_photo_camera
from .correctwater import CorrectionWater, correction_water
from .image import UINT16_MAX, Photo, read_image
from .pixels import correct_pixels
from .rangemap import VALUE_KINDS, range_and_census
from forward.errors import InputError

__all__ = ["MAX_GAIN", "SEARCH_RANGE_M", "WHITE_TARGET", "SRGB_LUT_BITS", "TABLE_SIZE",
           "Corrected", "CorrectionTable", "correct_image", "correction", "correction_table",
           "linear_factor",
           "seathru_coefficients", "srgb_encoding_lut"]

#: corrected.tiff: the corrected white patch's brightest channel is put at this fraction of
#: full scale (a common factor of the gains; the correction's colour is its ratios).
WHITE_TARGET = 0.8
#: Ranges in the transmission table (0 to the cap, evenly spaced); linear interpolation
#: between them is within 1e-4 of the model for a cap of 20 m in the clearest and the most
#: turbid of the paper's waters (tests/test_correct.py)
TABLE_SIZE = 512
#: The largest factor by which the correction along the range may amplify a channel's direct
#: signal, t_c(0) / t_c(r): beyond it the range is capped (decision
#: 0048-correction-cap: 16, 4 stops, held the far charts' ΔE00 of CORRECTION.md without amplifying
#: the open water's noise)
MAX_GAIN = 16.0
#: The cap is searched for up to this range, m (beyond it nothing of a photo is corrected)
SEARCH_RANGE_M = 100.0
#: The 16-bit sRGB encoding is a table of 2^SRGB_LUT_BITS linear levels (a step of 1e-6 in
#: linear light: under one 16-bit code even at black, where the encoding's slope is 12.92)
SRGB_LUT_BITS = 20
#: IEC 61966-2-1:1999 sRGB encoding: 12.92 x below 0.0031308, 1.055 x^(1/2.4) - 0.055 above
SRGB_THRESHOLD, SRGB_LINEAR_SLOPE, SRGB_GAMMA, SRGB_OFFSET = 0.0031308, 12.92, 2.4, 0.055


@dataclass
class CorrectionTable:
    """The correction on a table of ranges (:func:`correction_table`).

    Attributes
    ----------
    ranges : numpy.ndarray, (n,)
        0 to ``cap``, m, evenly spaced.
    transmission : numpy.ndarray, (n, 3)
        t_c(r) = W_c(r) / W_c(air), dimensionless (the light at the depth along the range).
    veil : numpy.ndarray, (n, 3)
        s_c(r), raw units.
    veil_infinity : numpy.ndarray, (3,)
        The veiling light of an infinitely long ray, raw units (B-infinity of Sea-thru).
    gain : float
        Raw units per model unit.
    cap : float
        Ranges beyond are corrected as at ``cap``, m.
    cap_reason : str
        'max_gain', 'max_range' or 'none' (the search range).
    unknown : float
        The range unknown pixels are corrected at, m.
    reference : float
        The chart's distance r0, m.
    water : CorrectionWater
        The water it was made from.
    method : str
        'matrix' (the colour matrix per range, :mod:`measure.correct_matrix`) or 'diagonal'.
    matrices : numpy.ndarray, (n, 3, 3)
        M(r), applied after the diagonal correction (the identity for 'diagonal').
    """

    ranges: np.ndarray
    transmission: np.ndarray
    veil: np.ndarray
    veil_infinity: np.ndarray
    gain: float
    cap: float
    cap_reason: str
    unknown: float
    reference: float
    water: CorrectionWater = field(repr=False)
    method: str = "diagonal"
    matrices: np.ndarray | None = field(default=None, repr=False)

    @property
    def step(self) -> float:
        """The table's range step, m."""
        return float(self.ranges[1] - self.ranges[0])

    def factors(self):
        """(A, B) of J = (raw - B) A per table row: A (n, 3) model units per raw unit, B (n, 3)
        raw units."""
        return 1.0 / (self.gain * self.transmission), self.veil

    def kernel(self):
        """(C, B) of J = C (raw - B) per table row: C (n, 3, 3) = M(r) diag(A), model units per
        raw unit (diagonal for 'diagonal'), B (n, 3) raw units."""
        A, B = self.factors()
        if self.matrices is None:
            return A[:, :, None] * np.eye(3), B
        return self.matrices * A[:, None, :], B

    def apply(self, raw, ranges) -> np.ndarray:
        """The correction of raw values at given ranges (numpy; for a few values).

        Parameters
        ----------
        raw : array_like, (..., 3)
            Raw camera values (black subtracted), raw units.
        ranges : array_like, (...)
            Ranges, m (NaN or <= 0: unknown).

        Returns
        -------
        numpy.ndarray, (..., 3)
            J, model units in air.
        """
        r = np.asarray(ranges, float)
        r = np.where(np.isfinite(r) & (r > 0), r, self.unknown)
        r = np.clip(r, 0.0, self.cap)
        C, B = self.kernel()
        c = np.stack([np.interp(r, self.ranges, C[:, i, j]) for i in range(3) for j in range(3)],
                     axis=-1).reshape(r.shape + (3, 3))
        b = np.stack([np.interp(r, self.ranges, B[:, i]) for i in range(3)], axis=-1)
        return np.einsum("...ij,...j->...i", c, np.asarray(raw, float) - b)


def _white_response(cw: CorrectionWater, ranges) -> np.ndarray:
    """W_c(r) (n, 3): a white reflector at each range, unit gain, no veil (the model function
    of every estimator, :func:`measure.correct_matrix.model_response`)."""
    return model_response(cw, ranges, np.ones((cw.setup.wavelengths.size, 1)))[:, :, 0]


def _veil_shape(cw: CorrectionWater, ranges) -> np.ndarray:
    """V_c(r) (n, 3): the simulator's veiling light projected on the camera's channels."""
    setup = cw.setup
    light = setup.illuminant
    shift = cw.nuisance.get("daylight")
    if shift:
        from forward.daylight import DaylightTilt

        light = light * np.exp(DaylightTilt(setup.wavelengths, setup.daylight_cct)
                               .log_ratio(float(shift)))
    consts = {k: float(v) for k, v in cw.nuisance.items() if k in COEFFICIENT_PARAMS}
    water = dataclasses.replace(cw.water, **consts) if consts else cw.water
    rho = forward.veiling_light(setup.wavelengths, cw.chl, cw.cdom, cw.depth,
                                np.asarray(ranges, float), illuminant=light, water=water)
    return rho @ setup.sensitivities


def correction(estimate, setup, white_value=None, full_scale=65535.0):
    """The paper's von Kries colour correction from the estimated attenuation.

    corrected = gains * (raw - offset): offset the estimated veiling light, gains the ratio
    (P^T i) / ((1 + beta) (P_delta^T diag(i r) k)) of a white's response in air to its response
    through the water as the fit found it (r: the surface daylight's change of colour, where the
    budget has the ``daylight`` term; beta and delta: the camera's fitted channel balance and
    curve shifts, where it has ``balance`` and ``camera_shift``, P_delta = P - delta dP/dlambda
    to first order as :mod:`sca.model` takes them; the corrected white is that of the given
    illuminant and the camera's nominal curves), times one common factor that puts the
    corrected white patch's brightest channel at :data:`WHITE_TARGET` x ``full_scale``.

    Parameters
    ----------
    estimate : sca.Estimate
        A fit with ``attenuation`` k (q,) and ``backscatter`` (3,) in raw units.
    setup : forward.ChartSetup
        Camera sensitivities P and illuminant i of the fit.
    white_value : array_like, (3,), optional
        The white patch's raw values (raw units); without it no common factor is applied.
    full_scale : float, optional
        Full scale of the corrected image, raw units (default 65535, 16 bits).

    Returns
    -------
    gains : numpy.ndarray, (3,)
        Channel gains, dimensionless.
    offset : numpy.ndarray, (3,)
        Offsets, raw units.

    References
    ----------
    H. Blasinski and J. Farrell, "A Three Parameter Underwater Image Formation Model", IS&T
    Electronic Imaging 2016, Fig 11 (von Kries correction with the estimated attenuation).
    """
    P, i = setup.sensitivities, setup.illuminant
    light = i * estimate.attenuation
    nuisance = estimate.nuisance or {}
    shift = nuisance.get("daylight")
    if shift:  # the surface light's colour as the fit found it (the budget's daylight term)
        from forward.daylight import DaylightTilt

        light = light * np.exp(DaylightTilt(setup.wavelengths,
                                            setup.daylight_cct).log_ratio(float(shift)))
    # the white through the water as the fit saw it: with the camera's fitted curve shifts (to
    # first order, as sca.model takes them) and channel balance (the budget's camera terms), so
    # that the correction inverts the whole colour path the fit found, not the water's part alone
    P_fit = P
    delta = nuisance.get("camera_shift")
    if delta is not None:
        from sca.model import curve_shift_derivative

        P_fit = P + np.asarray(delta, float)[None, :] * curve_shift_derivative(P, setup.wavelengths)
    through = P_fit.T @ light
    balance = nuisance.get("balance")
    if balance is not None:
        through = through * (1.0 + np.asarray(balance, float))
    vk = (P.T @ i) / through
    offset = np.asarray(estimate.backscatter, float)
    if white_value is not None:
        top = float(np.max(vk * (np.asarray(white_value, float) - offset)))
        if top > 0:
            vk = vk * (WHITE_TARGET * full_scale / top)
    return vk, offset


def correction_table(water, *, max_gain: float = MAX_GAIN, max_range: float | None = None,
                     unknown="reference", size: int = TABLE_SIZE, method: str = "matrix",
                     **water_options) -> CorrectionTable:
    """The per-channel correction on a table of ranges.

    Parameters
    ----------
    water : CorrectionWater or anything :func:`measure.correctwater.correction_water` takes
        The water, light and camera.
    max_gain : float, optional
        The cap: the largest t_c(0) / t_c(r) a range is corrected with (default
        :data:`MAX_GAIN`; ``inf``: no cap but ``max_range``).
    max_range : float, optional
        Ranges beyond are corrected as at it, m (default: only ``max_gain`` caps).
    unknown : 'reference' or float, optional
        The range unknown pixels are corrected at: the chart's distance (default) or a range
        in m.
    size : int, optional
        Rows of the table (default :data:`TABLE_SIZE`).
    method : 'matrix' or 'diagonal', optional
        'matrix' (default): the diagonal then the colour matrix M(r) per range
        (:mod:`measure.correct_matrix`); 'diagonal': the von Kries division by t_c(r) alone.
    **water_options
        For :func:`correction_water` when ``water`` is not a :class:`CorrectionWater`.

    Returns
    -------
    CorrectionTable

    Raises
    ------
    ValueError
        Naming ``max_gain``, ``max_range``, ``unknown``, ``size`` or ``method``.
    """
    check_method(method)
    cw = water if isinstance(water, CorrectionWater) else correction_water(water, **water_options)
    if not (max_gain > 1):
        raise InputError("max_gain", f"must be > 1 (or inf), got {max_gain!r}")
    if max_range is not None and not (math.isfinite(max_range) and max_range > 0):
        raise InputError("max_range", f"must be finite and > 0 m, got {max_range!r}")
    if int(size) != size or size < 16:
        raise InputError("size", f"an integer >= 16, got {size!r}")
    air = cw.setup.white_response
    # the cap: where t_c(r) / t_c(0) first falls below 1 / max_gain in some channel
    search = np.linspace(0.0, SEARCH_RANGE_M if max_range is None else max_range, 2001)
    t = _white_response(cw, search) / air
    rel = t / t[:1]
    below = np.flatnonzero(np.any(rel < 1.0 / max_gain, axis=1))
    if below.size:
        i = below[0]  # interpolate the crossing in the channel that crosses first
        c = int(np.argmin(rel[i]))
        lo, hi = np.log(rel[i - 1, c]), np.log(rel[i, c])
        f = (np.log(1.0 / max_gain) - lo) / (hi - lo) if hi != lo else 1.0
        cap, why = float(search[i - 1] + f * (search[i] - search[i - 1])), "max_gain"
    else:
        cap, why = float(search[-1]), "max_range" if max_range is not None else "none"
    ranges = np.linspace(0.0, cap, int(size))
    trans = _white_response(cw, ranges) / air
    r0 = cw.distance
    shape = _veil_shape(cw, np.concatenate([ranges, [r0, 1e6]]))
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = np.where(shape[-2] > 0, cw.backscatter / shape[-2], 0.0)
    veil = shape[:-2] * scale
    if unknown == "reference":
        unk = r0
    else:
        try:
            unk = float(unknown)
        except (TypeError, ValueError):
            unk = math.nan
        if not (math.isfinite(unk) and unk > 0):
            raise InputError("unknown", f"'reference' or a range > 0 m, got {unknown!r}")
    mats = colour_matrices(cw, ranges, trans) if method == "matrix" else None
    return CorrectionTable(ranges, trans, veil, shape[-1] * scale, float(cw.gain), cap, why,
                           min(unk, cap), r0, cw, method, mats)


# --------------------------------------------------------------------------- pixels
_LUT = {}


def srgb_encoding_lut(bits: int = SRGB_LUT_BITS) -> np.ndarray:
    """16-bit codes of the sRGB encoding at 2^bits evenly spaced linear levels 0-1.

    Parameters
    ----------
    bits : int, optional
        log2 of the table's length (default :data:`SRGB_LUT_BITS`).

    Returns
    -------
    numpy.ndarray, uint16, (2^bits,)
        round(65535 V(x)), V the IEC 61966-2-1 encoding (read-only, cached).

    References
    ----------
    IEC 61966-2-1:1999, Multimedia systems and equipment - Colour measurement and management -
    Default RGB colour space - sRGB (the encoding's two pieces).
    """
    if bits not in _LUT:
        x = np.linspace(0.0, 1.0, 2 ** bits)
        v = np.where(x <= SRGB_THRESHOLD, SRGB_LINEAR_SLOPE * x,
                     (1.0 + SRGB_OFFSET) * x ** (1.0 / SRGB_GAMMA) - SRGB_OFFSET)
        lut = np.rint(np.clip(v, 0, 1) * UINT16_MAX).astype(np.uint16)
        lut.setflags(write=False)
        _LUT[bits] = lut
    return _LUT[bits]


def _srgb_lut_8bit() -> np.ndarray:
    """:func:`srgb_encoding_lut`'s codes in 8 bits (:func:`measure.imagefiles.to_8bit`)."""
    if "8bit" not in _LUT:
        from .imagefiles import to_8bit

        lut = to_8bit(srgb_encoding_lut())
        lut.setflags(write=False)
        _LUT["8bit"] = lut
    return _LUT["8bit"]


def srgb_matrix(setup, white: float = 1.0) -> np.ndarray:
    """Camera model units in air -> linear sRGB (3, 3): :func:`forward.camera_to_xyz_matrix`
    then colour-science's XYZ -> sRGB (D65, :func:`forward.spectra.srgb_8bit`), a white
    reflector in air at Y = ``white``.

    Parameters
    ----------
    setup : forward.ChartSetup
    white : float, optional
        Y (0-1) of a perfect white reflector (default 1).

    Returns
    -------
    numpy.ndarray, (3, 3)
    """
    from forward.spectra import srgb_8bit

    xyz_to_srgb, _ = srgb_8bit()
    return xyz_to_srgb @ forward.camera_to_xyz_matrix(setup) * float(white)


@dataclass
class Corrected:
    """A photo corrected along every pixel's range (:func:`correct_image`).

    Attributes
    ----------
    linear : numpy.ndarray or None
        uint16 (H, W, 3) camera RGB in air, a white reflector at ``white_linear`` x 65535 in the
        most sensitive channel.
    srgb : numpy.ndarray or None
        uint16 (or uint8, ``srgb_bits=8``) (H, W, 3) sRGB (IEC 61966-2-1), a white reflector in
        air at Y = ``white``.
    values : numpy.ndarray or None
        float32 (H, W, 3) J, camera model units in air (``float_output=True``).
    table : CorrectionTable
    photo : Photo
    ranges : dict
        What the range was: ``kind``, the finite min / max (m), ``unknown_fraction`` and
        ``capped_fraction`` (of the photo's pixels, as corrected), the cap and, for a map,
        ``map_values`` (:func:`measure.rangemap.census`) and ``map_values_treated``.
    notes : list of str
    """

    linear: np.ndarray | None
    srgb: np.ndarray | None
    values: np.ndarray | None
    table: CorrectionTable
    photo: Photo = field(repr=False)
    ranges: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)


def correct_image(image, water, range, *, max_gain: float = MAX_GAIN,  # noqa: A002
                  max_range: float | None = None, unknown="reference", white: float = 1.0,
                  white_linear: float = WHITE_TARGET, linear: bool = True, srgb: bool = True,
                  float_output: bool = False, black_level=None, white_level=None,
                  method: str = "matrix", srgb_bits: int = 16, **water_options) -> Corrected:
    """Correct a photo pixel by pixel along each pixel's range, from the measured water.

    Parameters
    ----------
    image : str, os.PathLike or Photo
        A RAW (LibRaw) or linear TIFF (:func:`measure.read_image`), or a :class:`Photo`.
    water : CorrectionWater, Measurement, dict, str or os.PathLike
        The water (:func:`measure.correctwater.correction_water`: measurement.json, joint.json
        or a survey record).
    range : float, str, os.PathLike or numpy.ndarray
        A distance (m), a range map (float TIFF m, 16-bit PNG mm, .npy m; 0, NaN, -inf or
        negative unknown, +inf beyond the cap; the photo's aspect) or ``"plane:A,B,C"``
        (:func:`measure.rangemap.range_and_census`).
    max_gain, max_range, unknown :
        The cap and the unknown ranges (:func:`correction_table`).
    white : float, optional
        Y of a perfect white reflector in the sRGB image (default 1).
    white_linear : float, optional
        A perfect white reflector's most sensitive channel in the linear image, fraction of
        full scale (default :data:`WHITE_TARGET`).
    linear, srgb, float_output : bool, optional
        Which images to make.
    srgb_bits : {16, 8}, optional
        The sRGB image's codes: 16-bit (default) or 8-bit, round(code16 255 / 65535) of the
        same image (:func:`measure.imagefiles.to_8bit`; what a JPEG takes), made by the kernel
        itself.
    black_level, white_level : optional
        For :func:`measure.read_image`.
    method : 'matrix' or 'diagonal', optional
        'matrix' (default): the colour matrix per range after the diagonal
        (:mod:`measure.correct_matrix`, decision 0076-spectral-matrix-correction); 'diagonal':
        the per-channel division alone (``table.method`` records which).
    **water_options
        For :func:`measure.correctwater.correction_water` (``setup``, ``depth``, ``photo``,
        ``exposure_ratio``, ``model``, ``camera``, ``quantal``, ``illuminant``, ``profile``).
        The photo's EXIF Make and Model are checked against the water's recorded camera
        (:func:`measure.correctcamera.check_photo_camera`): another camera is refused naming
        ``camera`` unless ``camera`` (other curves) is given.

    Returns
    -------
    Corrected

    Raises
    ------
    ValueError
        Naming the argument: ``image``, ``water``, ``range``, ``max_gain``, ``max_range``,
        ``unknown``, ``white``, ``white_linear``, ``method``, ``camera``, ``profile``,
        ``depth``.

    References
    ----------
    H. Blasinski and J. Farrell, "A Three Parameter Underwater Image Formation Model", IS&T
    Electronic Imaging 2016, eqs 1-3, 15 and Fig 11 (the von Kries correction generalised to
    every pixel's range). D. Akkaynak and T. Treibitz, "Sea-thru: A method for removing water
    from underwater images", CVPR 2019 (the per-pixel range correction this parallels).

    Examples
    --------
    >>> out = correct_image("DIVE_03.dng", "results/DIVE_01/measurement.json",
    ...                     "DIVE_03_range.tif")  # doctest: +SKIP
    Examples
    --------
    A photo measured, then corrected along a range map that runs from 1 m to 6 m across it:

    >>> import tempfile, pathlib, numpy as np, measure
    >>> from measure.synthetic_photo import Scene, default_corners, render_mosaic, write_dng
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> corners = default_corners(360, 240)
    >>> photo = write_dng(render_mosaic(Scene(chl=2.0, cdom=0.1, depth=5.0, distance=1.5,
    ...                                       gain=30000, width=360, height=240, seed=2), corners),
    ...                   folder / "reef.dng")
    >>> m = measure.measure(photo, corners=corners, depth=5.0, distance=1.5)
    >>> ranges = np.tile(np.linspace(1.0, 6.0, 360, dtype=np.float32), (240, 1))
    >>> out = measure.correct_image(m.photo, m, ranges)
    >>> out.srgb.shape, out.srgb.dtype
    ((240, 360, 3), dtype('uint16'))
    """
    for name, v in (("white", white), ("white_linear", white_linear)):
        if not (math.isfinite(v) and 0 < v <= 1):
            raise InputError(name, f"must be in (0, 1], got {v!r}")
    check_method(method)
    if srgb_bits not in (8, 16):
        raise InputError("srgb_bits", f"8 or 16, got {srgb_bits!r}")
    photo = image if isinstance(image, Photo) else read_image(image, black_level=black_level,
                                                              white_level=white_level)
    rng, counts = range_and_census(range, photo.size)  # a refusal before the table
    table = correction_table(water, max_gain=max_gain, max_range=max_range, unknown=unknown,
                             method=method, **water_options)
    use = table.water.camera
    if use is not None:  # the photo's camera against the water's (EXIF Make and Model)
        check_photo_camera(photo.camera, use, other_curves=water_options.get("camera") is not None)
    has_map = not isinstance(rng, float)
    H, W = photo.data.shape[:2]
    C, B = table.kernel()
    M = srgb_matrix(table.water.setup, white)
    lut = srgb_encoding_lut() if srgb_bits == 16 else _srgb_lut_8bit()
    empty16 = np.zeros((1, 1, 3), np.uint16)
    lin16 = np.empty((H, W, 3), np.uint16) if linear else empty16
    s16 = np.empty((H, W, 3) if srgb else (1, 1, 3), lut.dtype)
    stats = np.empty((H, 4))
    flt = np.empty((H, W, 3), np.float32) if float_output else np.zeros((1, 1, 3), np.float32)
    raw = photo.kind == "raw"
    mosaic = photo.data if raw else np.zeros((1, 1), np.float32)
    rgb = np.zeros((1, 1, 3), np.float32) if raw else photo.data
    channel = photo.channel if raw else np.zeros((1, 1), np.int8)
    rmap = np.ascontiguousarray(rng, np.float32) if has_map else np.zeros((1, 1), np.float32)
    with KERNEL_LOCK:
        correct_pixels(mosaic, channel, rgb, raw, H, W, rmap, has_map, 0.0 if has_map else float(rng),
                 float(table.unknown), float(table.cap), table.step, C, B, M, lut,
                 float(white_linear * UINT16_MAX), lin16, s16, flt,
                 np.array([linear, srgb, float_output]), stats)
    summary, notes = _range_summary(has_map, stats, H * W, counts, table,
                                    () if use is None else use.notes)
    return Corrected(lin16 if linear else None, s16 if srgb else None,
                     flt if float_output else None, table, photo, summary, notes)


def _range_summary(has_map, stats, pixels, counts, table: CorrectionTable, camera_notes=()):
    """What the range was and what was done with it: the ``ranges`` of :class:`Corrected`
    (fractions of the photo's pixels, as the pixels were corrected: NaN at ``unknown``, beyond
    the cap, +inf included, at the cap; ``map_values``: the map's :func:`measure.rangemap.census`
    as given) and the notes (the water's, the camera's, then the range's), from the kernel's
    ``stats`` per row (:func:`measure.pixels.correct_pixels`: no other pass over the map)."""
    lo, hi = float(stats[:, 2].min()), float(stats[:, 3].max())
    summary = {"kind": "map" if has_map else "constant",
               "min_m": lo if np.isfinite(lo) else None, "max_m": hi if np.isfinite(hi) else None,
               "unknown_fraction": float(stats[:, 0].sum() / pixels),
               "capped_fraction": float(stats[:, 1].sum() / pixels)}
    if counts is not None:
        summary.update(map_values=counts, map_values_treated=dict(VALUE_KINDS))
    summary.update(cap_m=table.cap, cap_reason=table.cap_reason, unknown_m=table.unknown)
    notes = list(table.water.notes) + list(camera_notes)
    no_range = [k for k, v in VALUE_KINDS.items() if v == "no range"]
    if summary["capped_fraction"] > 0:
        notes.append(f"{100 * summary['capped_fraction']:.1f} % of the pixels lie beyond "
                     f"{table.cap:.2f} m ({table.cap_reason}{_odd_values(counts, ['+inf'])}): "
                     "corrected as at that range")
    if summary["unknown_fraction"] > 0:
        notes.append(f"{100 * summary['unknown_fraction']:.1f} % of the pixels have no range"
                     f"{_odd_values(counts, no_range)}: corrected as at {table.unknown:.2f} m")
    return summary, notes


def _odd_values(counts, kinds) -> str:
    """The map's values of ``kinds`` that it holds, counted (text for a note; '' for no map)."""
    held = [f"{k} {counts[k]}" for k in kinds if counts[k]] if counts else []
    return f"; of the map's {counts['pixels']} values: {', '.join(held)}" if held else ""


def linear_factor(table: CorrectionTable, white_linear: float = WHITE_TARGET) -> np.ndarray:
    """The factor per channel from a raw value (above black and the veiling light) to the
    linear corrected image's value (corrected.tiff, :func:`correct_image`) at the table's
    reference distance: the quantity of ``measure.Measurement.gains`` (the von Kries gains of
    ``uw3p measure``'s corrected.tiff, which put the white patch rather than a perfect white at
    ``white_linear``), for a photo corrected without a chart of its own.

    Parameters
    ----------
    table : CorrectionTable
    white_linear : float, optional
        A perfect white reflector's most sensitive channel in the linear image, fraction of full
        scale (default :data:`WHITE_TARGET`, :func:`correct_image`'s).

    Returns
    -------
    numpy.ndarray, (3,)
        corrected.tiff units per raw unit.
    """
    t = [np.interp(table.reference, table.ranges, table.transmission[:, c]) for c in range(3)]
    return white_linear * UINT16_MAX / (table.gain * np.asarray(t))


def applied(table: CorrectionTable, water_file=None) -> dict:
    """What a correction applied, for correction.json: the water's file and its SHA-256
    (:func:`measure.camera.file_digest`; None for a water given in memory), the camera and
    calibration (:meth:`measure.correctcamera.CameraUse.to_dict`), the depths the water was
    measured at, whether the photo's depth lies outside them (``extrapolated``) and the
    ``method`` ('matrix' with its ``training`` reflectances, or 'diagonal')."""
    from .camera import file_digest

    w = table.water
    return {"water_file": None if water_file is None else {
                "path": str(water_file), "sha256": file_digest(water_file)},
            "camera": None if w.camera is None else w.camera.to_dict(),
            "depth_span_m": list(w.span), "extrapolated": w.extrapolated,
            "method": table.method, "training": (
                [f"colour.quality.datasets.{db}[{name!r}]" for db, name in TRAINING_SETS]
                if table.method == "matrix" else None)}


def seathru_coefficients(table: CorrectionTable) -> dict:
    """The correction in the form of Sea-thru's image formation model, per channel.

        I_c = J_c exp(-beta_D_c z) + B_inf_c (1 - exp(-beta_B_c z)),

    z the range (m), J_c the scene at the photo's depth seen from range 0 (raw units),
    fitted to the table (least squares in the logarithm through z = 0, over 0 to the cap);
    ``white_balance`` maps J to the white of air (1 / (gain t_c(0))); ``exposure_factor`` is
    :func:`linear_factor`. The exact per-range table is given beside.

    Parameters
    ----------
    table : CorrectionTable

    Returns
    -------
    dict
        ``beta_D`` (3,) m^-1, ``beta_B`` (3,) m^-1, ``B_inf`` (3,) raw units, ``white_balance``
        (3,) model units per raw unit, ``exposure_factor`` (3,) corrected.tiff units per raw
        unit (:func:`linear_factor`), ``table`` (ranges, transmission, veil), units, and how
        well the exponentials fit (``rms_log``).

    References
    ----------
    D. Akkaynak and T. Treibitz, "Sea-thru: A method for removing water from underwater
    images", CVPR 2019, eq 2 (the revised model, Akkaynak & Treibitz CVPR 2018).
    """
    z = table.ranges
    t = table.transmission
    ln_t = np.log(t / t[:1])
    zz = float(z @ z)
    beta_d = -(z @ ln_t) / zz
    binf = table.veil_infinity
    with np.errstate(divide="ignore", invalid="ignore"):
        frac = np.where(binf > 0, 1.0 - table.veil / binf, 1.0)
        ln_b = np.log(np.clip(frac, 1e-300, None))
    beta_b = -(z @ ln_b) / zz
    rms_d = np.sqrt(np.mean((ln_t + np.outer(z, beta_d)) ** 2, axis=0))
    rms_b = np.sqrt(np.mean((ln_b + np.outer(z, beta_b)) ** 2, axis=0))
    w = table.water
    return {
        "model": "I_c = J_c exp(-beta_D_c z) + B_inf_c (1 - exp(-beta_B_c z)); corrected = "
                 "white_balance_c J_c",
        "channels": ["red", "green", "blue"],
        "beta_D": beta_d.tolist(), "beta_B": beta_b.tolist(), "B_inf": binf.tolist(),
        "white_balance": (1.0 / (table.gain * t[0])).tolist(),
        "exposure_factor": linear_factor(table).tolist(),
        "rms_log": {"beta_D": rms_d.tolist(), "beta_B": rms_b.tolist()},
        "range_m": [0.0, float(table.cap)],
        "table": {"range_m": z[:: max(1, z.size // 64)].tolist(),
                  "transmission": t[:: max(1, z.size // 64)].tolist(),
                  "veil": table.veil[:: max(1, z.size // 64)].tolist()},
        "cap_m": table.cap, "cap_reason": table.cap_reason, "unknown_m": table.unknown,
        "reference_distance_m": table.reference, "depth_m": w.depth, "gain": table.gain,
        "water": {"chl": w.chl, "cdom": w.cdom, "chl_ci": list(w.chl_ci),
                  "cdom_ci": list(w.cdom_ci), "path_model": w.water.path_model,
                  "source": w.source, "reliable": w.reliable},
        "units": {"beta_D": "m^-1", "beta_B": "m^-1", "B_inf": "raw units (DN above black)",
                  "white_balance": "model units in air per raw unit",
                  "exposure_factor": "corrected.tiff units per raw unit above the veiling "
                                     "light, at the reference distance", "range_m": "m",
                  "transmission": "dimensionless, t_c(z) = W_c(z) / W_c(air)",
                  "veil": "raw units", "gain": "raw units per model unit"},
    }
