"""Locating the ColorChecker Classic in a photograph and sampling its 24 patches.

The user gives the chart's four outer corners in pixels, in this order: next to patch 1 (dark
skin), next to patch 6 (bluish green), next to patch 24 (black), next to patch 19 (white). The
projective map (homography) from the chart's layout to the image places every patch; the inner
part of each patch is sampled. Per patch and channel: a robust mean (the mean after iterative
clipping at ``CLIP_SIGMA`` robust standard deviations, MAD-based), its standard error from the
pixel spread (the estimator's ``sigma``), the pixel count and the clipped fraction.

Clipped pixels (at the sensor's white level) are left out pixel by pixel, not patch by patch: a
glint or a speck of marine snow clips a few pixels far above the patch's own spread, and the
robust mean of the others is the patch's value. The value itself counts as clipped (and the
patch's ``clipped`` fraction is reported) only when the white level lies within
``CLIP_SIGMA`` robust standard deviations of that mean -- the clip then cuts into the patch's
own pixel distribution and the mean of what is left is biased low -- or when fewer than
``MIN_PIXELS`` pixels are left.

Orientation: the corners of a rectangle can be given in 8 orders; the 4 that keep the long side
first are the chart and its 180° rotation and two mirror images. The grey row (patches 19-24:
white to black) falls monotonically in every channel under any water (its reflectances do, and
the water's attenuation and veiling light are the same for every patch), which the other
three orientations' bottom rows do not; :func:`orientations` tests each.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from forward.errors import InputError

__all__ = ["ChartLayout", "LAYOUTS", "parse_corners", "homography", "PatchSample",
           "sample_patches", "orientations", "grey_row_ok", "corners_outside", "pose",
           "describe_pose", "ORIENTATIONS",
           "CORNER_PATCHES", "CLIP_SIGMA", "MIN_PIXELS", "GREY_STEP_SE", "MAX_BOX_PIXELS"]

#: Iterative clipping of a patch's pixels at this many robust standard deviations (MAD x
#: MAD_TO_SD)
CLIP_SIGMA = 4.0
#: The median absolute deviation times this is the standard deviation of a normal sample
#: (1 / Phi^-1(3/4); Rousseeuw & Croux 1993)
MAD_TO_SD = 1.4826
#: At most this many rounds of clipping per patch and channel (it stops earlier when a round
#: removes nothing)
MAX_CLIP_ROUNDS = 5
#: Four corners closer to a line than this (smallest singular value of the DLT system relative
#: to the largest) are refused as degenerate
DEGENERATE_SV = 1e-9
#: Fewest pixels of one channel in a patch's sampled box
MIN_PIXELS = 4
#: The grey row's steps must exceed this many standard errors to count as a fall
GREY_STEP_SE = 3.0
#: A sampled box larger than this many pixels is read on an odd-stride lattice (odd, so that
#: every CFA position is still visited) with about this many pixels: ~10^4 per channel bound
#: the standard error far below any other term, and a 24-megapixel photo samples in
#: milliseconds.
MAX_BOX_PIXELS = 40000


@dataclass(frozen=True)
class ChartLayout:
    """Geometry of a 6 x 4 patch chart in units of the patch pitch.

    The given corners are the outer corners of a frame ``margin_x`` / ``margin_y`` pitches wider
    than the patch grid on each side.

    Attributes
    ----------
    columns, rows : int
        Patches per row and rows (6 x 4 for the ColorChecker Classic).
    margin_x, margin_y : float
        Frame beyond the patch grid on each side, in patch pitches.
    sample : float
        Side of the centred square sampled in each patch, fraction of the pitch.
    """

    columns: int = 6
    rows: int = 4
    margin_x: float = 0.0
    margin_y: float = 0.0
    sample: float = 0.5

    @property
    def size(self):
        """(width, height) of the framed chart in patch pitches."""
        return (self.columns + 2 * self.margin_x, self.rows + 2 * self.margin_y)


#: 'patches': the corners are the outer corners of the patch grid (default: they are what one
#: sees best in an underwater photo); 'card': the corners of the X-Rite ColorChecker Classic card
#: (about 279 x 216 mm around a grid of ~44 mm pitch: margins ~0.17 and ~0.45 pitch).
LAYOUTS = {"patches": ChartLayout(), "card": ChartLayout(margin_x=0.17, margin_y=0.45)}

#: corner orders tried (indices into the given four corners) and their names: the given order,
#: the chart rotated 180°, mirrored left-right, mirrored top-bottom
ORIENTATIONS = {"as given": (0, 1, 2, 3), "rotated 180°": (2, 3, 0, 1),
                "mirrored left-right": (1, 0, 3, 2), "mirrored top-bottom": (3, 2, 1, 0)}
#: the patch each corner is next to, in the corners' order
CORNER_PATCHES = (1, 6, 24, 19)


def parse_corners(text) -> np.ndarray:
    """Parse the chart's four corners.

    Parameters
    ----------
    text : str or array_like
        ``'x1,y1 x2,y2 x3,y3 x4,y4'`` (pixels; ``;`` also separates) or a (4, 2) array.

    Returns
    -------
    numpy.ndarray, (4, 2)
        The corners (x, y) in pixels, float.

    Raises
    ------
    ValueError
        Naming ``corners``, when there are not four finite (x, y) pairs.
    """
    if isinstance(text, str):
        try:
            pts = [tuple(float(v) for v in tok.split(",")) for tok in text.replace(";", " ").split()]
        except ValueError:
            pts = None
        if not pts or any(len(p) != 2 for p in pts) or len(pts) != 4:
            raise InputError("corners", f"expected 'x1,y1 x2,y2 x3,y3 x4,y4' (four x,y pixel pairs), "
                             f"got {text!r}")
        arr = np.array(pts, float)
    else:
        arr = np.asarray(text, float)
        if arr.shape != (4, 2):
            raise InputError("corners", f"expected four (x, y) pairs, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError("corners", "must be finite numbers")
    return arr


def homography(src, dst) -> np.ndarray:
    """The projective map (homography) taking four points to four others.

    Parameters
    ----------
    src, dst : array_like, (4, 2)
        Corresponding points (any units, e.g. chart pitches and pixels).

    Returns
    -------
    numpy.ndarray, (3, 3)
        H with dst ~ H src in homogeneous coordinates, normalised to H[2, 2] = 1.

    Raises
    ------
    ValueError
        When the points are degenerate (three on a line, or repeated).

    References
    ----------
    R. Hartley and A. Zisserman, *Multiple View Geometry in Computer Vision*, 2nd ed.,
    Cambridge University Press, 2004, Sec. 4.1 (the direct linear transform).
    """
    A = []
    for (x, y), (u, v) in zip(np.asarray(src, float), np.asarray(dst, float)):
        A.append([x, y, 1, 0, 0, 0, -u * x, -u * y, -u])
        A.append([0, 0, 0, x, y, 1, -v * x, -v * y, -v])
    _, sv, vt = np.linalg.svd(np.array(A))
    if sv[-2] < DEGENERATE_SV * sv[0]:
        raise InputError("corners", "degenerate (three of them on a line, or repeated)")
    H = vt[-1].reshape(3, 3)
    return H / H[2, 2]


def _apply(H, pts):
    pts = np.asarray(pts, float)
    q = np.c_[pts, np.ones(len(pts))] @ H.T
    return q[:, :2] / q[:, 2:3]


def corners_outside(corners, size) -> list:
    """Which corners lie outside the image.

    Parameters
    ----------
    corners : numpy.ndarray, (4, 2)
        Pixels (x right, y down).
    size : tuple of int
        The image's (width, height), pixels.

    Returns
    -------
    list of int
        1-based indices of the corners outside pixel centres 0..W-1, 0..H-1 (empty: all in).
    """
    W, H = size
    return [i + 1 for i, (x, y) in enumerate(corners) if not (0 <= x <= W - 1 and 0 <= y <= H - 1)]


def pose(corners) -> dict:
    """How the chart lies in the photo: turned, and seen in a mirror or not.

    Parameters
    ----------
    corners : array_like, (4, 2)
        Pixels (x right, y down) next to patch 1, 6, 24, 19, or those patches' centres.

    Returns
    -------
    dict
        ``rotation_deg``: degrees clockwise on screen, in (-180, 180], by which the upright
        chart (patch 1 top left, patch 6 top right) is turned, after the mirror when there is
        one; ``mirrored``: the chart is seen in a mirror image (its columns reversed: patch 6
        left of patch 1 before the turn; patch 1 -> 6 -> 24 runs anticlockwise).
    """
    c = np.asarray(corners, float)
    row, down = c[1] - c[0], c[2] - c[1]
    mirrored = bool(row[0] * down[1] - row[1] * down[0] < 0)
    if mirrored:
        row = -row  # the mirror image's own row runs from patch 6 to patch 1
    rot = round(float(np.degrees(np.arctan2(row[1], row[0]))), 1)
    return {"rotation_deg": rot + 360.0 if rot <= -180.0 else rot, "mirrored": mirrored}


def describe_pose(p: dict) -> str:
    """:func:`pose` in words: ``'rotated 177° clockwise, mirrored'``, ``'not rotated, not
    mirrored'``.

    Parameters
    ----------
    p : dict
        ``rotation_deg`` and ``mirrored`` (:func:`pose`).

    Returns
    -------
    str
        The turn to the nearest degree and whether the chart is mirrored.
    """
    deg = round(p["rotation_deg"])
    turn = ("not rotated" if deg == 0 else "rotated 180°" if abs(deg) == 180 else
            f"rotated {abs(deg)}° {'clockwise' if deg > 0 else 'anticlockwise'}")
    return f"{turn}, {'mirrored' if p['mirrored'] else 'not mirrored'}"


def _check_geometry(corners, size):
    """Refuse corners outside the image or not a convex quadrilateral in order."""
    W, H = size
    bad = corners_outside(corners, size)
    if bad:
        raise InputError("corners", f"corner(s) {bad} lie outside the image ({W} x {H} pixels)")
    cross = []
    for i in range(4):
        a, b, c = corners[i], corners[(i + 1) % 4], corners[(i + 2) % 4]
        u, v = b - a, c - b
        cross.append(u[0] * v[1] - u[1] * v[0])
    if not (all(v > 0 for v in cross) or all(v < 0 for v in cross)):
        raise InputError("corners", "they do not form a convex quadrilateral in the order given "
                         "(next to patch 1, patch 6, patch 24, patch 19: around the chart)")


def _long_side_first(corners):
    """True when corner 1 -> 2 (six patches) is longer than 2 -> 3 (four)."""
    a = np.linalg.norm(corners[1] - corners[0]) + np.linalg.norm(corners[2] - corners[3])
    b = np.linalg.norm(corners[2] - corners[1]) + np.linalg.norm(corners[3] - corners[0])
    return a > b


@dataclass
class PatchSample:
    """Sampled patch values, ColorChecker order (row by row from patch 1).

    Attributes
    ----------
    rgb : numpy.ndarray, (3, 24)
        Robust mean of each patch and channel, raw units (DN above the black level).
    sigma : numpy.ndarray, (3, 24)
        Its standard error from the pixel spread, raw units.
    n_pixels : numpy.ndarray, (3, 24)
        Pixels kept after clipping.
    clipped : numpy.ndarray, (3, 24)
        Where the patch value is clipped (see the module docstring): the fraction of the sampled
        pixels at the white level (0-1); 0 where the value is not clipped.
    boxes : numpy.ndarray, (24, 4, 2)
        The sampled squares' corners in pixels.
    excluded : numpy.ndarray, (3, 24), optional
        Where the value is not clipped: the fraction of the sampled pixels at the white level
        that were left out of it (glints, marine snow); 0 elsewhere.

    Patches not sampled (``sample_patches(..., patches=...)``) are NaN.
    """

    rgb: np.ndarray
    sigma: np.ndarray
    n_pixels: np.ndarray
    clipped: np.ndarray
    boxes: np.ndarray
    excluded: np.ndarray | None = None


def _robust_mean(v):
    """Mean and standard error after iterative clipping at CLIP_SIGMA robust SDs."""
    keep = v
    for _ in range(MAX_CLIP_ROUNDS):
        med = np.median(keep)
        mad = MAD_TO_SD * np.median(np.abs(keep - med))
        if not mad > 0:
            break
        new = v[np.abs(v - med) <= CLIP_SIGMA * mad]
        if new.size == keep.size:
            break
        keep = new
    n = keep.size
    sd = float(np.std(keep, ddof=1)) if n > 1 else np.inf
    return float(np.mean(keep)), sd / np.sqrt(n), n


def _patch_value(vals, clipped, white):
    """(mean, standard error, pixels kept, clipped fraction, excluded fraction) of one patch
    and channel: the robust mean of the unclipped pixels; the value is clipped when the white
    level lies within CLIP_SIGMA robust SDs of it, or too few pixels are left (then the robust
    mean of them all)."""
    frac = float(np.mean(clipped))
    good = vals[~clipped]
    if good.size >= MIN_PIXELS:
        mean, se, cnt = _robust_mean(good)
        sd = se * np.sqrt(cnt) if np.isfinite(se) else 0.0
        if frac == 0 or mean + CLIP_SIGMA * sd < white:
            return mean, se, cnt, 0.0, frac
    mean, se, cnt = _robust_mean(vals)
    return mean, se, cnt, frac, 0.0


def sample_patches(photo, corners, layout: ChartLayout = LAYOUTS["patches"],
                   patches=None) -> PatchSample:
    """Sample the patches of a chart in a photograph.

    The homography from the layout to ``corners`` places each patch; the centred square of side
    ``layout.sample`` is read (on an odd-stride lattice when it holds more than
    :data:`MAX_BOX_PIXELS` pixels), each channel from its own CFA pixels for a RAW photo. Per
    patch and channel: the mean of the unclipped pixels after iterative clipping at
    :data:`CLIP_SIGMA` robust standard deviations (median absolute deviation x
    :data:`MAD_TO_SD`), its standard error, the pixel count, and the fraction of clipped pixels
    -- as ``clipped`` where they clip the value itself (the white level within
    :data:`CLIP_SIGMA` robust SDs of the mean), as ``excluded`` where they were outliers
    (glints, marine snow) left out pixel by pixel.

    Parameters
    ----------
    photo : measure.Photo
        The photograph (raw units).
    corners : str or array_like, (4, 2)
        The chart's corners in pixels, next to patch 1, 6, 24, 19 (:func:`parse_corners`).
    layout : ChartLayout, optional
        The chart's geometry (default ``LAYOUTS["patches"]``: the corners of the patch grid).
    patches : iterable of int, optional
        0-based indices to sample (default all); the others are NaN.

    Returns
    -------
    PatchSample
        Patch values and standard errors in raw units, pixel counts, clipped and excluded
        fractions, boxes.

    Raises
    ------
    ValueError
        Naming ``corners``, when they lie outside the image, are not a convex quadrilateral in
        order, or a patch covers fewer than :data:`MIN_PIXELS` pixels of a channel.

    References
    ----------
    P. J. Rousseeuw and C. Croux, "Alternatives to the median absolute deviation", J. Amer.
    Statist. Assoc. 88(424), 1273-1283, 1993 (the MAD as a robust scale).
    """
    corners = parse_corners(corners)
    _check_geometry(corners, photo.size)
    Wc, Hc = layout.size
    H = homography(np.array([[0, 0], [Wc, 0], [Wc, Hc], [0, Hc]], float), corners)
    Hinv = np.linalg.inv(H)
    n = layout.columns * layout.rows
    rgb = np.zeros((3, n))
    sigma = np.zeros((3, n))
    npx = np.zeros((3, n), dtype=int)
    clip = np.zeros((3, n))
    excluded = np.zeros((3, n))
    boxes = np.zeros((n, 4, 2))
    h = layout.sample / 2
    rgb[:] = sigma[:] = clip[:] = excluded[:] = np.nan
    for j in (range(n) if patches is None else patches):
        r, c = divmod(j, layout.columns)
        cx, cy = layout.margin_x + c + 0.5, layout.margin_y + r + 0.5
        sq = np.array([[cx - h, cy - h], [cx + h, cy - h], [cx + h, cy + h], [cx - h, cy + h]])
        box = _apply(H, sq)
        boxes[j] = box
        x0, y0 = np.floor(box.min(axis=0)).astype(int)
        x1, y1 = np.ceil(box.max(axis=0)).astype(int)
        x0, y0 = max(x0, 0), max(y0, 0)
        x1, y1 = min(x1, photo.size[0] - 1), min(y1, photo.size[1] - 1)
        step = int(np.ceil(np.sqrt((x1 - x0 + 1) * (y1 - y0 + 1) / MAX_BOX_PIXELS)))
        step += 1 - step % 2  # odd
        ys, xs = np.mgrid[y0:y1 + 1:step, x0:x1 + 1:step]
        uv = _apply(Hinv, np.c_[xs.ravel(), ys.ravel()])
        inside = (np.abs(uv[:, 0] - cx) <= h) & (np.abs(uv[:, 1] - cy) <= h)
        yy, xx = ys.ravel()[inside], xs.ravel()[inside]
        for ch in range(3):
            if photo.kind == "raw":
                sel = photo.channel[yy, xx] == ch
                vals = photo.data[yy[sel], xx[sel]]
                clipped = photo.clipped[yy[sel], xx[sel]]
            else:
                vals = photo.data[yy, xx, ch]
                clipped = photo.clipped[yy, xx]
            if vals.size < MIN_PIXELS:
                raise InputError("corners", f"patch {j + 1} covers {vals.size} pixels of channel "
                                 f"{'RGB'[ch]} (at least {MIN_PIXELS} needed): the chart is too "
                                 "small in the image or the corners are wrong")
            value = _patch_value(vals.astype(float), np.asarray(clipped, bool),
                                 float(photo.white[ch]))
            rgb[ch, j], sigma[ch, j], npx[ch, j], clip[ch, j], excluded[ch, j] = value
    return PatchSample(rgb, sigma, npx, clip, boxes, excluded)


def grey_row_ok(sample: PatchSample, layout: ChartLayout = LAYOUTS["patches"]) -> bool:
    """Whether the bottom row (patches 19-24) falls from white to black in every channel.

    Parameters
    ----------
    sample : PatchSample
        At least the bottom row sampled (raw units).
    layout : ChartLayout, optional
        The chart's geometry.

    Returns
    -------
    bool
        True when each step along the row falls by more than :data:`GREY_STEP_SE` standard
        errors in every channel (a clipped value counts as falling).
    """
    row = slice(layout.columns * (layout.rows - 1), layout.columns * layout.rows)
    v, se = sample.rgb[:, row], sample.sigma[:, row]
    clip = sample.clipped[:, row] > 0
    steps = v[:, :-1] - v[:, 1:]
    tol = GREY_STEP_SE * np.hypot(se[:, :-1], se[:, 1:])
    return bool(np.all((steps > tol) | clip[:, :-1]))


def orientations(photo, corners, layout: ChartLayout = LAYOUTS["patches"]):
    """The grey row sampled in every corner order of :data:`ORIENTATIONS`.

    Parameters
    ----------
    photo : measure.Photo
        The photograph.
    corners : str or array_like, (4, 2)
        The corners in pixels, as given (:func:`parse_corners`).
    layout : ChartLayout, optional
        The chart's geometry.

    Returns
    -------
    dict
        {name: (corners (4, 2) in that order, :class:`PatchSample` of the grey row only,
        :func:`grey_row_ok` of it)}.

    Raises
    ------
    ValueError
        Naming ``corners``, when the first side is the short one (the chart turned 90°), or as
        :func:`sample_patches`.
    """
    corners = parse_corners(corners)
    _check_geometry(corners, photo.size)
    if not _long_side_first(corners):
        raise InputError("corners", "the first side (corner 1 -> 2, along patches 1-6) is the "
                         "short one: the chart's six-patch side comes first (order: next to "
                         "patch 1, patch 6, patch 24, patch 19)")
    out = {}
    grey = range(layout.columns * (layout.rows - 1), layout.columns * layout.rows)
    for name, order in ORIENTATIONS.items():
        c = corners[list(order)]
        s = sample_patches(photo, c, layout, patches=grey)
        out[name] = (c, s, grey_row_ok(s, layout))
    return out
