"""Synthetic photographs of a chart, rendered with the package's own forward model, for tests
and benchmarks (no real photographs ship with the package).

:func:`render_mosaic` draws the ColorChecker (patch values from :func:`forward.simulate_chart`,
noise-free, with the given camera -- e.g. one with a channel balance unlike its published
curves) into an RGGB Bayer mosaic: black level per CFA position, an exposure gain (raw units per
model unit), vignetting and a light gradient across the chart (both achromatic), Poisson and
read noise, rounding and clipping at the white level (14 bits by default).
:func:`write_dng` writes it as a DNG with ``pidng`` that rawpy reads back.

It lives in ``measure`` (not on the replication side, ``experiments``, which the wheel does not
ship: decision 0082-installed-packages) because the library's doctests and ``python -m
uw3p.warm`` make their photographs with it. Only :func:`write_dng` needs ``pidng`` (the
``[test]`` extra, which ``make install`` installs), imported when it is called: the package
itself does not need it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

import forward
from measure.chart import LAYOUTS, ChartLayout, homography

__all__ = ["Scene", "render_mosaic", "mosaic_from_values", "write_dng", "default_corners",
           "BLACK_LEVELS_DN", "WHITE_LEVEL_DN"]

#: the RGGB Bayer pattern: channel of each position of the 2 x 2 tile
RGGB = np.array([[0, 1], [1, 2]])
#: reflectance of the card between the patches (the ColorChecker's black frame, roughly)
FRAME_REFLECTANCE = 0.03
#: side of a painted patch, fraction of the pitch
PATCH_SIDE = 0.85
#: Black level (DN) at the RGGB positions (0,0) (0,1) (1,0) (1,1): deliberately unequal, so that
#: a reader that takes one black level for all positions is caught
BLACK_LEVELS_DN = (512, 510, 514, 516)
#: White level (DN) of a 14-bit sensor
WHITE_LEVEL_DN = 2 ** 14 - 1
#: TIFF/EXIF tag ISOSpeedRatings (not among pidng's named tags)
ISO_SPEED_RATINGS_TAG = 34855


@dataclass
class Scene:
    """What the synthetic camera sees and how it records it (raw units = DN)."""

    chl: float = 1.0
    cdom: float = 0.1
    depth: float = 5.0
    distance: float = 1.0
    width: int = 360
    height: int = 240
    gain: float = 8000.0  # DN per model unit (the unknown exposure)
    black: tuple = BLACK_LEVELS_DN  # DN at the RGGB positions (0,0) (0,1) (1,0) (1,1)
    white: int = WHITE_LEVEL_DN
    electrons_per_dn: float = 2.0
    read_noise_dn: float = 2.0
    vignetting: float = 0.0  # relative fall of the light at the image corners (r = 1)
    gradient: float = 0.0  # relative change of the light across the chart's width (left->right)
    seed: int = 0
    noise: bool = True


def default_corners(width, height, layout: ChartLayout = LAYOUTS["patches"], fill=0.8,
                    rotate_deg=5.0) -> np.ndarray:
    """Corners (next to patch 1, 6, 24, 19) of a chart centred in the image, ``fill`` of its
    width, turned by ``rotate_deg``."""
    Wc, Hc = layout.size
    w = fill * width
    h = w * Hc / Wc
    if h > fill * height:
        h = fill * height
        w = h * Wc / Hc
    pts = np.array([[-w / 2, -h / 2], [w / 2, -h / 2], [w / 2, h / 2], [-w / 2, h / 2]])
    t = np.deg2rad(rotate_deg)
    rot = np.array([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]])
    return pts @ rot.T + np.array([width / 2, height / 2])


def render_mosaic(scene: Scene, corners, *, setup=None, water=None,
                  layout: ChartLayout = LAYOUTS["patches"]) -> np.ndarray:
    """The raw mosaic (height, width) uint16 of ``scene`` with the chart at ``corners``."""
    setup = forward.chart_setup() if setup is None else setup
    sim = forward.simulate_chart(scene.chl, scene.cdom, scene.depth, scene.distance, noise=False,
                                 setup=setup, water=water)
    patches = sim.rgb_expected  # (3, 24) model units, veiling light included
    s = sim.backscatter
    white_through = setup.sensitivities.T @ (setup.illuminant * sim.attenuation)
    frame = FRAME_REFLECTANCE * white_through + s
    return mosaic_from_values(scene, corners, patches, frame, s, layout=layout)


def mosaic_from_values(scene: Scene, corners, patches, frame, veil, *,
                       layout: ChartLayout = LAYOUTS["patches"]) -> np.ndarray:
    """The raw mosaic (height, width) uint16 of a chart whose patch values are given.

    Parameters
    ----------
    scene : Scene
        Size, exposure gain (DN per unit of ``patches``), black and white levels, noise,
        vignetting and light gradient (its water fields are not used).
    corners : array_like, (4, 2)
        The patch grid's corners in pixels (next to patch 1, 6, 24, 19).
    patches : array_like, (3, 24)
        Each patch's value per channel (flat over the painted square), veiling light included.
    frame : array_like, (3,)
        The card between the patches, veiling light included.
    veil : array_like, (3,)
        The veiling light (also the open water around the card): the part of every value that
        the light gradient does not modulate.
    layout : measure.ChartLayout, optional
        The chart's geometry (default the patch grid).

    Returns
    -------
    numpy.ndarray, (height, width) uint16
        RGGB mosaic in DN, black level added, rounded and clipped at the white level.
    """
    patches = np.asarray(patches, float)
    frame = np.asarray(frame, float)
    s = np.asarray(veil, float)
    H, W = scene.height, scene.width
    ys, xs = np.mgrid[0:H, 0:W].astype(np.float64)
    Wc, Hc = layout.size
    Hm = homography(np.asarray(corners, float), np.array([[0, 0], [Wc, 0], [Wc, Hc], [0, Hc]]))
    q = np.stack([xs.ravel(), ys.ravel(), np.ones(xs.size)], axis=1) @ Hm.T
    u = (q[:, 0] / q[:, 2]).reshape(H, W)
    v = (q[:, 1] / q[:, 2]).reshape(H, W)
    chan = np.tile(RGGB, (H // 2 + 1, W // 2 + 1))[:H, :W]
    value = s[chan]  # open water: the veiling light
    on_card = (u >= 0) & (u <= Wc) & (v >= 0) & (v <= Hc)
    value = np.where(on_card, frame[chan], value)
    gu, gv = u - layout.margin_x, v - layout.margin_y
    col, row = np.floor(gu).astype(int), np.floor(gv).astype(int)
    fu, fv = gu - col, gv - row
    half = PATCH_SIDE / 2
    in_patch = on_card & (col >= 0) & (col < layout.columns) & (row >= 0) & (row < layout.rows) \
        & (np.abs(fu - 0.5) <= half) & (np.abs(fv - 0.5) <= half)
    idx = np.clip(row, 0, layout.rows - 1) * layout.columns + np.clip(col, 0, layout.columns - 1)
    value = np.where(in_patch, patches[chan, idx], value)
    # light: a gradient across the chart (it lights the chart, not the water between) and
    # vignetting (the lens: everything)
    light = np.where(on_card, 1.0 + scene.gradient * (u / Wc - 0.5), 1.0)
    r2 = ((xs - W / 2) ** 2 + (ys - H / 2) ** 2) / ((W / 2) ** 2 + (H / 2) ** 2)
    light = light * (1.0 - scene.vignetting * r2)
    signal = np.where(on_card, value - s[chan], 0.0) * light + s[chan] * (1.0 - scene.vignetting * r2)
    dn = scene.gain * signal
    if scene.noise:
        rng = np.random.default_rng(scene.seed)
        e = rng.poisson(np.maximum(dn, 0) * scene.electrons_per_dn) / scene.electrons_per_dn
        dn = e + rng.normal(0.0, scene.read_noise_dn, dn.shape)
    black = np.tile(np.asarray(scene.black, float).reshape(2, 2), (H // 2 + 1, W // 2 + 1))[:H, :W]
    return np.clip(np.rint(dn + black), 0, scene.white).astype(np.uint16)


def write_dng(mosaic, path, *, black=BLACK_LEVELS_DN, white=WHITE_LEVEL_DN,
              exposure_s=1 / 125, f_number=5.6, iso=400, make="uw3p", model="synthetic") -> str:
    """Write an RGGB mosaic as an uncompressed 16-bit DNG (pidng), its EXIF Make and Model
    ``make`` and ``model``; returns the path written (pidng appends '.dng')."""
    from pidng.core import RAW2DNG, DNGTags, Tag
    from pidng.defs import CalibrationIlluminant, CFAPattern, DNGVersion, PhotometricInterpretation
    from pidng.dng import Type

    H, W = mosaic.shape
    t = DNGTags()
    t.set(Tag.ImageWidth, W)
    t.set(Tag.ImageLength, H)
    t.set(Tag.TileWidth, W)
    t.set(Tag.TileLength, H)
    t.set(Tag.Orientation, 1)
    t.set(Tag.PhotometricInterpretation, PhotometricInterpretation.Color_Filter_Array)
    t.set(Tag.SamplesPerPixel, 1)
    t.set(Tag.BitsPerSample, 16)
    t.set(Tag.CFARepeatPatternDim, [2, 2])
    t.set(Tag.CFAPattern, CFAPattern.RGGB)
    t.set(Tag.BlackLevelRepeatDim, [2, 2])
    t.set(Tag.BlackLevel, [int(b) for b in black])
    t.set(Tag.WhiteLevel, int(white))
    t.set(Tag.ColorMatrix1, [[1, 1], [0, 1], [0, 1], [0, 1], [1, 1], [0, 1], [0, 1], [0, 1], [1, 1]])
    t.set(Tag.CalibrationIlluminant1, CalibrationIlluminant.D65)
    t.set(Tag.AsShotNeutral, [[1, 1], [1, 1], [1, 1]])
    t.set(Tag.Make, make)
    t.set(Tag.Model, model)
    t.set(Tag.UniqueCameraModel, f"{make} {model}")
    t.set(Tag.ExposureTime, [[1, int(round(1 / exposure_s))]])
    t.set(Tag.FNumber, [[int(round(f_number * 10)), 10]])
    t.set((ISO_SPEED_RATINGS_TAG, Type.Short), int(iso))
    t.set(Tag.DNGVersion, DNGVersion.V1_4)
    t.set(Tag.DNGBackwardVersion, DNGVersion.V1_2)
    r = RAW2DNG()
    r.options(t, path="", compress=False)
    stem = str(path)[:-4] if str(path).lower().endswith(".dng") else str(path)
    r.convert(np.ascontiguousarray(mosaic, dtype=np.uint16), filename=stem)
    return stem + ".dng"
