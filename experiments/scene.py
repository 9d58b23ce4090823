"""Whole photographs of a ColorChecker on a reef, for testing chart detection.

A renderer of its own: it shares no code with :mod:`forward`, :mod:`sca` or :mod:`measure` (it
imports numpy and OpenCV only; the patch values are given by the caller, e.g. from the second
renderer :mod:`experiments.independent_world`). :func:`render_scene` draws the ColorChecker
Classic card -- 24 patches on a black card, in ColorChecker reading order -- at four given card
corners through a homography (``cv2.warpPerspective``) onto a textured, dark, colour-cast
background: smooth multi-scale noise in the water's colour, a gradient of light from above,
"rocks" (textured polygons of other colours), a few square distractor tiles, specular glints,
vignetting, photon and read noise, clipping at the white level. ``chart=False`` renders the
same frame without the chart. :func:`card_corners` places the card in the frame (size as a
fraction of the frame width, rotation, foreshortening, mirror image). :func:`write_dng` and
:func:`write_tiff` write the linear image as a Bayer RAW DNG (through
:func:`measure.synthetic_photo.write_dng`, the project's DNG fixture writer: a file writer,
no physics) or a 16-bit linear TIFF.

Coordinates: pixels, x right, y down, a pixel's centre at its integer index (the convention of
:mod:`measure.chart`). Corner order everywhere: next to patch 1 (dark skin), patch 6 (bluish
green), patch 24 (black), patch 19 (white).
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "CARD_MARGINS",
    "COLUMNS",
    "PATCH_SIDE",
    "ROWS",
    "card_corners",
    "render_scene",
    "write_dng",
    "write_tiff",
]

#: Patches per row and rows of the ColorChecker Classic
COLUMNS, ROWS = 6, 4
#: The card beyond the patch grid on each side (x, y), in patch pitches: the X-Rite
#: ColorChecker Classic card is 279.4 x 215.9 mm around a grid of ~44 mm pitch
CARD_MARGINS = (0.17, 0.45)
#: Side of a painted patch, fraction of the pitch (40 mm squares at ~44 mm pitch)
PATCH_SIDE = 0.9
#: The black card's value, fraction of the black patch's (the card is as dark as patch 24)
CARD_FACTOR = 0.8
#: Full scale in photo-electrons (photon noise) and read noise in electrons
ELECTRONS_FULL_SCALE = 8000.0
READ_NOISE_E = 4.0
#: Water colours (relative R, G, B) of the background casts
CASTS = {"blue": (0.12, 0.55, 1.0), "green": (0.25, 1.0, 0.55), "turbid": (0.45, 1.0, 0.7)}
#: Optical blur of the lens, pixels (Gaussian sigma)
LENS_BLUR_PX = 0.7
#: A glint's Gaussian is added within this many radii of its centre: beyond about 14.5 radii
#: its value (3 exp(-d^2 / 2 r^2)) is far below half a float32 step of any pixel it is added to
#: (and below the smallest float32 subnormal), so the image is the same
GLINT_REACH = 16.0
#: Rows per block of the noise draws (bounds the render's memory at 24 MP)
NOISE_ROWS = 256


def _homography(src, dst):
    import cv2

    return cv2.getPerspectiveTransform(np.asarray(src, np.float32), np.asarray(dst, np.float32))


def _apply(H, pts):
    pts = np.asarray(pts, float)
    q = np.c_[pts, np.ones(len(pts))] @ np.asarray(H, float).T
    return q[:, :2] / q[:, 2:3]


def _card_box():
    """The card's corners in grid coordinates (pitches; the patch grid spans 0-6 x 0-4)."""
    mx, my = CARD_MARGINS
    return np.array([[-mx, -my], [COLUMNS + mx, -my], [COLUMNS + mx, ROWS + my], [-mx, ROWS + my]])


def card_corners(size, *, width_fraction=0.3, rotation_deg=0.0, perspective=(0.0, 0.0),
                 mirrored=False, centre=(0.5, 0.5)) -> np.ndarray:
    """The card's four corners for a chart placed in a frame.

    Parameters
    ----------
    size : tuple of int
        The frame's (height, width), pixels.
    width_fraction : float
        The card's width (its long side, before foreshortening), fraction of the frame width.
    rotation_deg : float
        Rotation of the card, degrees clockwise on screen.
    perspective : tuple of float
        Foreshortening (px, py): the card's local scale varies as 1 / (1 + px x + py y), x and
        y in -1..1 across the card (0.3: one side ~1.9 times the other).
    mirrored : bool
        A mirror image of the chart (its reading order runs anticlockwise).
    centre : tuple of float
        The card's centre, fractions of the frame's (width, height).

    Returns
    -------
    numpy.ndarray, (4, 2)
        Pixels, next to patch 1, 6, 24, 19.
    """
    H, W = size
    box = _card_box()
    hw = width_fraction * W / 2
    hh = hw * (box[2, 1] - box[0, 1]) / (box[1, 0] - box[0, 0])
    xy = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])
    den = 1.0 + perspective[0] * xy[:, 0] + perspective[1] * xy[:, 1]
    local = xy / den[:, None] * [hw, hh]
    if mirrored:
        local[:, 0] *= -1
    t = np.deg2rad(rotation_deg)
    rot = np.array([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]])
    return local @ rot.T + [centre[0] * W, centre[1] * H]


def _smooth_noise(rng, shape, scale_px):
    """Zero-mean, unit-sd noise smooth on ``scale_px`` pixels."""
    import cv2

    small = (max(2, int(shape[1] / scale_px) + 2), max(2, int(shape[0] / scale_px) + 2))
    field = rng.standard_normal((small[1], small[0])).astype(np.float32)
    big = cv2.resize(field, (shape[1], shape[0]), interpolation=cv2.INTER_CUBIC)
    return (big - big.mean()) / (big.std() + 1e-12)


def _background(rng, shape, cast, level):
    """A reef seen through water: water colour times multi-scale texture, light from above,
    rocks and tiles of other colours."""
    import cv2

    H, W = shape
    tone = np.zeros((H, W), np.float32)
    for scale, amp in ((W / 3, 0.6), (W / 12, 0.35), (W / 50, 0.25), (4.0, 0.12)):
        tone += amp * _smooth_noise(rng, shape, scale)
    y = np.linspace(1.0, -1.0, H, dtype=np.float32)[:, None]
    light = np.exp(0.6 * y + tone)
    img = light[..., None] * np.asarray(cast, np.float32) * level
    layer = np.zeros_like(img)
    mask = np.zeros((H, W), np.float32)
    for _ in range(int(rng.integers(6, 14))):  # rocks and corals
        c = rng.uniform([0, 0.3 * H], [W, H])
        r = rng.uniform(0.03, 0.18) * W
        ang = np.sort(rng.uniform(0, 2 * np.pi, int(rng.integers(5, 10))))
        rad = r * rng.uniform(0.5, 1.0, ang.size)
        poly = np.c_[c[0] + rad * np.cos(ang), c[1] + rad * np.sin(ang)].astype(np.int32)
        m = np.zeros((H, W), np.uint8)
        cv2.fillPoly(m, [poly], 1)
        colour = rng.uniform(0.05, 1.0, 3) * np.asarray(cast) ** 0.5 * level * 1.5
        layer[m > 0] = colour
        mask[m > 0] = 1
    for _ in range(int(rng.integers(2, 6))):  # square tiles (distractors)
        c = rng.uniform([0.05 * W, 0.05 * H], [0.95 * W, 0.95 * H])
        s = rng.uniform(0.01, 0.06) * W
        box = cv2.boxPoints(((float(c[0]), float(c[1])), (s, s), float(rng.uniform(0, 90))))
        m = np.zeros((H, W), np.uint8)
        cv2.fillPoly(m, [box.astype(np.int32)], 1)
        layer[m > 0] = rng.uniform(0.1, 1.0, 3) * level * 2
        mask[m > 0] = 1
    fine = np.exp(0.3 * _smooth_noise(rng, shape, 2.0))[..., None]
    layer *= light[..., None]  # in place, in the order of layer * light * fine
    layer *= fine
    img *= fine
    np.copyto(img, layer, where=mask[..., None] > 0)
    return img.astype(np.float32, copy=False)


def _card_texture(patch_rgb, px_per_pitch):
    """The card in its own pixels (grid coordinates x px_per_pitch, offset by the margins)."""
    mx, my = CARD_MARGINS
    T = px_per_pitch
    w, h = round((COLUMNS + 2 * mx) * T), round((ROWS + 2 * my) * T)
    tex = np.empty((h, w, 3), np.float32)
    tex[:] = CARD_FACTOR * patch_rgb[:, COLUMNS * ROWS - 1]
    half = PATCH_SIDE * T / 2
    for j in range(COLUMNS * ROWS):
        r, c = divmod(j, COLUMNS)
        cx, cy = (mx + c + 0.5) * T, (my + r + 0.5) * T
        tex[round(cy - half):round(cy + half),
            round(cx - half):round(cx + half)] = patch_rgb[:, j]
    return tex


def render_scene(patch_rgb, corners, *, size=(600, 900), background="reef", seed=0, glints=0,
                 cast="blue", exposure=0.3, background_level=0.25, vignetting=0.3,
                 chart=True) -> dict:
    """Render an underwater photograph of a ColorChecker Classic on a reef.

    Parameters
    ----------
    patch_rgb : array_like, (3, 24)
        Linear camera RGB of the 24 patches, ColorChecker reading order (any units; scaled so
        that the largest is ``exposure``).
    corners : array_like, (4, 2)
        The card's outer corners in pixels, next to patch 1, 6, 24, 19 (:func:`card_corners`).
    size : tuple of int
        (height, width) of the frame, pixels.
    background : {'reef', 'flat'}
        Textured reef or a flat field of water colour.
    seed : int
        Randomness of the background, noise and glints.
    glints : int
        Number of specular glints (small clipped spots) in the frame.
    cast : str or array_like, (3,)
        The water's colour: a name of :data:`CASTS` or relative (R, G, B).
    exposure : float
        The brightest patch, fraction of full scale (small: a dark photo).
    background_level : float
        The background's mean level relative to the brightest patch.
    vignetting : float
        Relative fall of the light at the frame's corners.
    chart : bool
        False: the same frame without the chart.

    Returns
    -------
    dict
        ``image`` (H, W, 3) float32 linear, 0-1 (1 = the white level; clipped there);
        ``grid_corners`` (4, 2) the patch grid's corners and ``card_corners`` the card's,
        pixels, next to patch 1, 6, 24, 19; ``centres`` (24, 2) the patch centres, pixels;
        ``pitch`` the mean patch pitch, pixels; ``chart`` as given.

    Raises
    ------
    ValueError
        Naming ``patch_rgb``, ``corners``, ``size`` or ``cast`` when malformed.
    """
    import cv2

    patch_rgb = np.asarray(patch_rgb, float)
    if patch_rgb.shape != (3, COLUMNS * ROWS) or not np.all(np.isfinite(patch_rgb)):
        raise ValueError(f"patch_rgb: expected finite (3, 24), got shape {patch_rgb.shape}")
    corners = np.asarray(corners, float)
    if corners.shape != (4, 2):
        raise ValueError(f"corners: expected (4, 2), got {corners.shape}")
    H, W = (int(v) for v in size)
    if H < 16 or W < 16:
        raise ValueError(f"size: too small, got {size}")
    cast = np.asarray(CASTS[cast] if isinstance(cast, str) and cast in CASTS else cast, float)
    if cast.shape != (3,):
        raise ValueError(f"cast: one of {sorted(CASTS)} or (R, G, B), got {cast!r}")
    rng = np.random.default_rng(seed)
    patch = np.clip(patch_rgb, 0, None) * (exposure / max(patch_rgb.max(), 1e-12))
    level = background_level * exposure / max(cast.max(), 1e-12)
    if background == "reef":
        img = _background(rng, (H, W), cast, level)
    elif background == "flat":
        img = np.broadcast_to(cast * level, (H, W, 3)).astype(np.float32).copy()
    else:
        raise ValueError(f"background: 'reef' or 'flat', got {background!r}")
    to_img = _homography(_card_box(), corners)
    grid = _apply(to_img, [[0, 0], [COLUMNS, 0], [COLUMNS, ROWS], [0, ROWS]])
    rows, cols = np.divmod(np.arange(COLUMNS * ROWS), COLUMNS)
    centres = _apply(to_img, np.c_[cols + 0.5, rows + 0.5])
    pitch = float(np.mean(np.linalg.norm(np.diff(centres.reshape(ROWS, COLUMNS, 2), axis=1),
                                         axis=-1)))
    if chart:
        T = int(np.clip(np.ceil(1.5 * pitch), 16, 240))
        mx, my = CARD_MARGINS
        # texture pixel i has its centre at grid coordinate (i + 0.5) / T - margin
        tex_to_grid = np.array([[1 / T, 0, 0.5 / T - mx], [0, 1 / T, 0.5 / T - my], [0, 0, 1]])
        M = to_img @ tex_to_grid
        tex = _card_texture(patch, T)
        warped = cv2.warpPerspective(tex, M, (W, H), flags=cv2.INTER_LINEAR,
                                     borderMode=cv2.BORDER_CONSTANT)
        alpha = cv2.warpPerspective(np.ones(tex.shape[:2], np.float32), M, (W, H),
                                    flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
        img *= (1 - alpha)[..., None]  # in place: the same float32 products and sums
        img += warped
        del warped, alpha
    yy = np.arange(H, dtype=np.float32)[:, None]  # the pixel grid, broadcast (not stored)
    xx = np.arange(W, dtype=np.float32)[None, :]
    r2 = ((xx - W / 2) ** 2 + (yy - H / 2) ** 2) / ((W / 2) ** 2 + (H / 2) ** 2)
    img *= (1 - vignetting * r2)[..., None]
    del r2
    for _ in range(int(glints)):
        cx, cy = rng.uniform([0, 0], [W, H])
        rad = rng.uniform(0.7, 3.0)
        # beyond GLINT_REACH radii the float32 Gaussian adds nothing to a pixel
        x0, x1 = (int(np.clip(v, 0, W)) for v in (cx - GLINT_REACH * rad, cx + GLINT_REACH * rad + 1))
        y0, y1 = (int(np.clip(v, 0, H)) for v in (cy - GLINT_REACH * rad, cy + GLINT_REACH * rad + 1))
        img[y0:y1, x0:x1] += (3.0 * np.exp(-((xx[:, x0:x1] - cx) ** 2 + (yy[y0:y1] - cy) ** 2)
                                           / (2 * rad ** 2)))[..., None]
    img = cv2.GaussianBlur(img.astype(np.float32, copy=False), (0, 0), LENS_BLUR_PX)
    # photon then read noise, drawn block by block of rows in the order of one whole-image draw
    # each (the same numbers, without the whole image's int64 and float64 temporaries)
    electrons = np.empty(img.shape, np.float32)
    for lo in range(0, H, NOISE_ROWS):
        electrons[lo:lo + NOISE_ROWS] = rng.poisson(
            np.clip(img[lo:lo + NOISE_ROWS], 0, 2) * ELECTRONS_FULL_SCALE)
    del img
    for lo in range(0, H, NOISE_ROWS):
        electrons[lo:lo + NOISE_ROWS] += rng.normal(
            0, READ_NOISE_E, electrons[lo:lo + NOISE_ROWS].shape).astype(np.float32)
    electrons /= ELECTRONS_FULL_SCALE
    image = np.clip(electrons, 0, 1, out=electrons)
    return {"image": image, "grid_corners": grid, "card_corners": corners, "centres": centres,
            "pitch": pitch, "chart": bool(chart)}


def write_tiff(path, rgb_linear) -> str:
    """Write linear RGB (0-1) as a 16-bit TIFF that :func:`measure.read_image` reads.

    Parameters
    ----------
    path : str or os.PathLike
        The file (``.tif``).
    rgb_linear : numpy.ndarray, (H, W, 3)
        Linear RGB, 1 = full scale.

    Returns
    -------
    str
        The path written.
    """
    import tifffile

    data = np.clip(np.rint(np.asarray(rgb_linear, float) * 65535), 0, 65535).astype(np.uint16)
    tifffile.imwrite(str(path), data, photometric="rgb")
    return str(path)


def write_dng(path, rgb_linear, *, black=(512, 510, 514, 516), white=2 ** 14 - 1) -> str:
    """Write linear RGB (0-1) as an RGGB Bayer RAW DNG that rawpy reads.

    Each pixel keeps its CFA channel's value (R at even row and column, B at odd row and
    column, G elsewhere), scaled to ``white - black`` DN above the black level.

    Parameters
    ----------
    path : str or os.PathLike
        The file (``.dng``).
    rgb_linear : numpy.ndarray, (H, W, 3)
        Linear RGB, 1 = the white level.
    black : tuple of int
        Black levels (DN) at RGGB positions (0,0) (0,1) (1,0) (1,1).
    white : int
        White level, DN.

    Returns
    -------
    str
        The path written.
    """
    from measure.synthetic_photo import write_dng as _write

    rgb = np.asarray(rgb_linear)
    H, W = rgb.shape[:2]
    H, W = H - H % 2, W - W % 2
    value = np.empty((H, W))  # each pixel's CFA channel (R G / G B), then clipped to 0-1
    for dy, dx, ch in ((0, 0, 0), (0, 1, 1), (1, 0, 1), (1, 1, 2)):
        value[dy:H:2, dx:W:2] = rgb[dy:H:2, dx:W:2, ch]
    np.clip(value, 0, 1, out=value)
    blk = np.tile(np.asarray(black, float).reshape(2, 2), (H // 2, W // 2))
    mosaic = np.clip(np.rint(blk + value * (white - blk)), 0, white).astype(np.uint16)
    return _write(mosaic, path, black=black, white=white)
