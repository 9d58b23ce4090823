"""Finding the ColorChecker Classic in a photograph (when ``--corners`` is not given).

The detector looks for the chart's structure, not its colours, so that a dark, colour-cast
underwater photo is no harder than one in air; the colours only choose among the grid's eight
orientations, and the grey row has the final word (:func:`measure.chart.orientations`):

1. A working image: linear camera RGB (a RAW mosaic averaged over its 2 x 2 CFA cells, or
   demosaiced when that would be small), resized to at most :data:`WORK_PIXELS` on its long
   side, each channel divided by its :data:`DISPLAY_PERCENTILE`-th percentile and encoded with a
   display gamma (:data:`DISPLAY_GAMMA`), so that dark patches have edges as strong as bright
   ones.
2. Square candidates: the largest colour gradient (Sobel, over the channels) is thresholded at
   several quantiles (:data:`EDGE_QUANTILES`), and the luma at its local mean over several
   blocks (:data:`ADAPTIVE_BLOCKS`: patches are brighter than the card's black gaps); each
   connected region that is about as convex (:data:`MIN_SOLIDITY`), rectangular
   (:data:`MIN_FILL`) and square (:data:`MAX_ASPECT`) as a patch seen in perspective is a
   candidate.
3. A lattice: from each candidate with two roughly perpendicular neighbours at about a patch
   pitch, a lattice is grown: the candidates whose centres fall within :data:`LATTICE_TOL` of
   a lattice point of the current fit (affine, then a homography) join, ring by ring.
4. The chart: every placement of a 6 x 4 (or 4 x 6) box on the lattice that holds the most
   candidates is sampled at its 24 cell centres; each of the eight orientations (4 rotations x
   mirror) is scored by how well the ColorChecker's colours explain the 24 samples (the R^2,
   pooled over the channels, of a linear map with offset from the reference's linear sRGB to
   the camera's channels: invariant to the water's colour cast, veiling light and exposure).
   The best placement and orientation win; a homography fitted to the candidates' centres
   (RANSAC) gives the corners.
5. On a :class:`measure.Photo`, the grey row decides last: when the chosen order's grey row
   does not fall from white to black and exactly one other order's does
   (:func:`measure.chart.orientations`), that order is taken.

Confidence (0-1): the share of the grid's 24 cells where a square patch was segmented,
saturating at :data:`FULL_SHARE`, times the colour agreement R^2 of the chosen orientation. The
chart is "not found" (:class:`ChartNotFound`) with fewer than :data:`MIN_PATCHES` squares on one
lattice or a colour agreement below :data:`MIN_R2`.

Candidates evaluated before writing this (see decision 0035-chart-detection and
``python -m experiments.detect_eval``): colour-checker-detection's segmentation detector (its
templated one needs scikit-learn) and OpenCV's ``mcc`` module (absent from the installed
opencv-python build).

References
----------
R. Hartley and A. Zisserman, *Multiple View Geometry in Computer Vision*, 2nd ed., Cambridge
University Press, 2004 (homographies, RANSAC). S. Suzuki and K. Abe, "Topological structural
analysis of digitized binary images by border following", CVGIP 30(1), 32-46, 1985 (OpenCV's
findContours).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from forward import spectra

from .chart import CORNER_PATCHES, LAYOUTS, ChartLayout, corners_outside, orientations, pose
from forward.errors import InputError

__all__ = [
    "ADAPTIVE_BLOCKS",
    "DISPLAY_GAMMA",
    "DISPLAY_PERCENTILE",
    "EDGE_QUANTILES",
    "FULL_SHARE",
    "LATTICE_TOL",
    "MAX_ASPECT",
    "MIN_FILL",
    "MIN_PATCHES",
    "MIN_R2",
    "MIN_SOLIDITY",
    "WORK_PIXELS",
    "ChartNotFound",
    "Detection",
    "detection_image",
    "find_chart",
    "reference_rgb",
]

#: Long side of the working image, pixels (a patch of a chart 10 % of the frame wide is then
#: ~20 px)
WORK_PIXELS = 1600
#: Each channel is divided by this percentile of its values before the display gamma (a few
#: glints or clipped pixels do not set the scale)
DISPLAY_PERCENTILE = 99.0
#: Display encoding: value ** (1 / DISPLAY_GAMMA) (the sRGB-like gamma of a viewer)
DISPLAY_GAMMA = 2.2
#: Smoothing before the gradient, working pixels (Gaussian sigma): photon noise of a dark photo
SMOOTH_PX = 1.0
#: The gradient is thresholded at these quantiles of its values (several: the contrast of the
#: patches' edges against their noise varies from photo to photo)
EDGE_QUANTILES = (0.55, 0.7, 0.8, 0.9)
#: Block sizes (working pixels, odd) of the adaptive threshold of the luma: a patch is
#: brighter than the mean of a block that spans it and the black gaps around it
ADAPTIVE_BLOCKS = (11, 21, 41, 81)
#: Smallest patch candidate, working pixels of area (a ~6 x 6 px flat square)
MIN_AREA_PX = 30
#: Largest patch candidate, fraction of the working image's area (a chart 70 % of the frame)
MAX_AREA_FRACTION = 0.02
#: Candidate tests: area / convex hull area, area / minimum-area rectangle's area, and the
#: rectangle's long / short side (a square in perspective)
MIN_SOLIDITY = 0.9
MIN_FILL = 0.75
MAX_ASPECT = 1.8
#: Neighbours of a candidate: centre distance between these multiples of its side, side ratio
#: below NEIGHBOUR_SIDE_RATIO
NEIGHBOUR_DISTANCE = (0.9, 2.2)
NEIGHBOUR_SIDE_RATIO = 1.6
#: Two directions are perpendicular enough for a lattice seed when |cos| is below this
MAX_SEED_COS = 0.4
#: A candidate joins a lattice when its centre maps within this of a lattice point (pitches)
LATTICE_TOL = 0.25
#: Fewest squares on one lattice for a chart
MIN_PATCHES = 8
#: Lowest colour agreement (R^2 pooled over the channels) for a chart
MIN_R2 = 0.5
#: Placements with at most this many fewer squares than the best are scored by colour too
PLACEMENT_SLACK = 2
#: The found share saturates (confidence factor 1) at this share of the 24 cells
FULL_SHARE = 0.5
#: Each cell is sampled on a SAMPLE_POINTS x SAMPLE_POINTS grid over the central
#: SAMPLE_SPAN of the pitch; the median is the cell's colour
SAMPLE_POINTS = 5
SAMPLE_SPAN = 0.5
#: RANSAC reprojection threshold of the final homography, pitches
RANSAC_PITCH = 0.25
#: Reference chart: colour-science's ColorChecker (X-Rite, after November 2014), its xyY under
#: its own illuminant converted to linear sRGB
REFERENCE_CHART = spectra.SRGB_REFERENCE_CHART


class ChartNotFound(ValueError):
    """No ColorChecker in the photograph (the message starts ``no chart found``)."""


@dataclass
class Detection:
    """A chart found in a photograph.

    Attributes
    ----------
    corners : numpy.ndarray, (4, 2)
        Pixels of the photo (x right, y down), next to patch 1, 6, 24, 19, at the layout's
        corners (the patch grid's for 'patches', the card's for 'card').
    orientation : dict
        ``rotation_deg`` (degrees clockwise on screen) and ``mirrored`` (a mirror image: patch
        1 -> 6 -> 24 runs anticlockwise), :func:`measure.chart.pose`; ``grey_row``: True/False
        when the grey-row test ran on a Photo (None on an RGB array).
    confidence : float
        0-1: min(1, found / (24 FULL_SHARE)) x R^2 (module docstring).
    method : str
        How it was found (``'grid'``; ``'+grey-row'`` when the grey row changed the order).
    patches_found : int
        Grid cells where a square patch was segmented.
    colour_r2 : float
        Colour agreement of the chosen orientation (R^2 pooled over the channels).
    runner_up_r2 : float
        The agreement of the best other orientation or placement of the grid.
    pitch : float
        Mean patch pitch, photo pixels.
    centres : numpy.ndarray, (24, 2)
        Patch centres, photo pixels, ColorChecker order.
    """

    corners: np.ndarray
    orientation: dict
    confidence: float
    method: str
    patches_found: int
    colour_r2: float
    runner_up_r2: float
    pitch: float
    centres: np.ndarray = field(repr=False)

    def to_dict(self) -> dict:
        """JSON-ready summary (``Measurement.inputs['chart']``)."""
        return {"corners": np.round(self.corners, 2).tolist(), "detected": True,
                "confidence": round(float(self.confidence), 4), "method": self.method,
                "orientation": self.orientation, "patches_found": int(self.patches_found),
                "colour_r2": round(float(self.colour_r2), 4),
                "runner_up_r2": round(float(self.runner_up_r2), 4),
                "pitch_px": round(float(self.pitch), 2)}

    def check_in_frame(self, size) -> None:
        """Refuse a chart that the frame cuts: measuring needs every patch in the photo.

        Parameters
        ----------
        size : tuple of int
            The photo's (width, height), pixels.

        Raises
        ------
        ValueError
            Naming ``image``, when a corner found lies outside the photo (the detector
            extrapolates the grid from the patches it sees).
        """
        bad = corners_outside(self.corners, size)
        if bad:
            near = ", ".join(str(CORNER_PATCHES[i - 1]) for i in bad)
            raise InputError("image", f"the chart found lies partly outside the frame (its corners "
                             f"next to patch {near} fall beyond the {size[0]} x {size[1]} "
                             "pixels); every patch must be in the photo: take it again with "
                             "the whole chart inside the frame")


def reference_rgb() -> np.ndarray:
    """Linear sRGB of the ColorChecker's 24 patches (colour-science, after November 2014).

    colour-science's values, cached in the package data
    (:func:`forward.spectra.reference_chart_linear_srgb`; ``tests/test_wait.py`` compares them
    with colour-science), so detecting a chart does not import it.

    Returns
    -------
    numpy.ndarray, (24, 3)
        ColorChecker reading order (a read-only array).
    """
    return spectra.reference_chart_linear_srgb()


def _linear_rgb(image):
    """(linear RGB (h, w, 3) float32, scale, offset): photo pixel = scale * pixel + offset."""
    from .image import Photo, demosaic

    if isinstance(image, Photo):
        if image.kind == "rgb":
            return np.asarray(image.data, np.float32), 1.0, 0.0
        from .output import _quick_rgb

        if max(image.size) // 2 >= WORK_PIXELS:
            quick = _quick_rgb(image)
            if quick.shape[0] < image.size[1]:  # 2 x 2 cells averaged: half size
                return quick, 2.0, 0.5
            return quick, 1.0, 0.0
        return demosaic(image), 1.0, 0.0
    arr = np.asarray(image)
    if arr.ndim != 3 or arr.shape[-1] < 3 or arr.shape[0] < 16 or arr.shape[1] < 16:
        raise InputError("image", f"expected a measure.Photo or linear RGB (height, width, 3), got "
                         f"shape {arr.shape}")
    return np.asarray(arr[..., :3], np.float32), 1.0, 0.0


def detection_image(rgb) -> tuple:
    """The working image of the detector.

    Parameters
    ----------
    rgb : numpy.ndarray, (H, W, 3)
        Linear RGB (any units).

    Returns
    -------
    linear : numpy.ndarray, (h, w, 3) float32
        Linear RGB resized (area average) to at most :data:`WORK_PIXELS` on the long side.
    display : numpy.ndarray, (h, w, 3) float32
        Each channel over its :data:`DISPLAY_PERCENTILE`-th percentile, clipped to 0-1, to the
        power 1 / :data:`DISPLAY_GAMMA`.
    factor : float
        Input pixels per working pixel (>= 1).
    """
    import cv2

    H, W = rgb.shape[:2]
    factor = max(1.0, max(H, W) / WORK_PIXELS)
    rgb = np.nan_to_num(np.asarray(rgb, np.float32), nan=0.0, posinf=0.0, neginf=0.0)
    if factor > 1:
        size = (max(1, round(W / factor)), max(1, round(H / factor)))
        lin = cv2.resize(rgb, size, interpolation=cv2.INTER_AREA)
        factor = W / size[0]
    else:
        lin = rgb.copy()
    lin = np.maximum(lin, 0)
    top = np.percentile(lin.reshape(-1, 3)[::7], DISPLAY_PERCENTILE, axis=0)
    top = np.where(top > 0, top, 1.0).astype(np.float32)
    disp = np.clip(lin / top, 0, 1) ** np.float32(1 / DISPLAY_GAMMA)
    return lin, disp.astype(np.float32), float(factor)


@dataclass
class _Cand:
    centre: np.ndarray
    side: float
    fill: float


def _flat_masks(display):
    """Binary masks whose regions may be patches: the flat parts of the image (colour
    gradient below each of EDGE_QUANTILES) and the parts brighter than their surroundings
    (adaptive threshold of the luma over ADAPTIVE_BLOCKS: the card's black gaps)."""
    import cv2

    sm = cv2.GaussianBlur(display, (0, 0), SMOOTH_PX)
    grad = np.zeros(sm.shape[:2], np.float32)
    for c in range(3):
        gx = cv2.Sobel(sm[..., c], cv2.CV_32F, 1, 0, ksize=3)
        gy = cv2.Sobel(sm[..., c], cv2.CV_32F, 0, 1, ksize=3)
        grad = np.maximum(grad, gx * gx + gy * gy)
    kernel = np.ones((3, 3), np.uint8)
    for t in np.quantile(grad[::3, ::3], EDGE_QUANTILES):
        yield cv2.erode((grad < t).astype(np.uint8), kernel)
    luma = (np.clip(sm.mean(axis=-1), 0, 1) * 255).astype(np.uint8)
    for block in ADAPTIVE_BLOCKS:
        if block < min(luma.shape):
            yield cv2.adaptiveThreshold(luma, 1, cv2.ADAPTIVE_THRESH_MEAN_C, cv2.THRESH_BINARY,
                                        block, 0)


def _candidates(display) -> list:
    """Square flat regions of the display image (:func:`_flat_masks`)."""
    import cv2

    max_area = MAX_AREA_FRACTION * display.shape[0] * display.shape[1]
    found = []
    for flat in _flat_masks(display):
        contours, hier = cv2.findContours(flat, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_SIMPLE)
        if hier is None:
            continue
        for cnt, h in zip(contours, hier[0]):
            if h[3] != -1 or len(cnt) < 4:
                continue
            area = cv2.contourArea(cnt)
            if not MIN_AREA_PX <= area <= max_area:
                continue
            _, (w, hh), _ = cv2.minAreaRect(cnt)
            if min(w, hh) <= 0 or max(w, hh) / min(w, hh) > MAX_ASPECT:
                continue
            fill = area / (w * hh)
            if fill < MIN_FILL:
                continue
            hull = cv2.contourArea(cv2.convexHull(cnt))
            if hull <= 0 or area / hull < MIN_SOLIDITY:
                continue
            m = cv2.moments(cnt)
            found.append(_Cand(np.array([m["m10"] / m["m00"], m["m01"] / m["m00"]]),
                               float(np.sqrt(area)), float(fill)))
    found.sort(key=lambda c: -c.fill)
    kept = []
    for c in found:  # the same patch at several thresholds: keep the best-filled
        if all(np.hypot(*(c.centre - k.centre)) > 0.4 * min(c.side, k.side) for k in kept):
            kept.append(c)
    return kept


def _fit_map(lat, img):
    """Lattice -> image: homography from >= 6 points spanning >= 2 x 2, else affine; None
    when degenerate."""
    import cv2

    lat, img = np.asarray(lat, float), np.asarray(img, float)
    if len(lat) >= 6 and np.ptp(lat[:, 0]) >= 2 and np.ptp(lat[:, 1]) >= 2:
        H, _ = cv2.findHomography(lat, img, 0)
        if H is not None and np.all(np.isfinite(H)):
            return H
    A = np.c_[lat, np.ones(len(lat))]
    if np.linalg.matrix_rank(A) < 3:
        return None
    sol = np.linalg.lstsq(A, img, rcond=None)[0]
    return np.vstack([sol.T, [0, 0, 1]])


def _map(H, pts):
    q = np.c_[np.asarray(pts, float), np.ones(len(pts))] @ H.T
    return q[:, :2] / q[:, 2:3]


def _grow(seed, u, v, pts, sides):
    """({index: (a, b)}, H) of the lattice grown ring by ring from candidate ``seed`` with
    pitch vectors u, v."""
    H = np.array([[u[0], v[0], pts[seed, 0]], [u[1], v[1], pts[seed, 1]], [0, 0, 1]])
    assigned = {seed: (0, 0)}
    for _ in range(12):
        try:
            lat = _map(np.linalg.inv(H), pts)
        except np.linalg.LinAlgError:
            break
        near = np.rint(lat)
        err = np.hypot(*(lat - near).T)
        have = np.array(list(assigned.values()))
        lo, hi = have.min(axis=0) - 1, have.max(axis=0) + 1
        pitch = np.hypot(*(_map(H, near + [0.5, 0]) - _map(H, near - [0.5, 0])).T)
        ok = ((err < LATTICE_TOL) & np.all((near >= lo) & (near <= hi), axis=1)
              & (sides > 0.45 * pitch) & (sides < 1.05 * pitch))
        best = {}
        for i in np.flatnonzero(ok):
            key = (int(near[i, 0]), int(near[i, 1]))
            if key not in best or err[i] < err[best[key]]:
                best[key] = i
        new = {i: k for k, i in best.items()}
        if not new or new == assigned:
            break
        fit = _fit_map(list(new.values()), pts[list(new)])
        if fit is None:
            break
        assigned, H = new, fit
    return assigned, H


def _lattices(cands):
    """Lattices of >= MIN_PATCHES candidates: list of ({index: (a, b)}, H)."""
    from scipy.spatial import cKDTree

    if len(cands) < MIN_PATCHES:
        return []
    pts = np.array([c.centre for c in cands])
    sides = np.array([c.side for c in cands])
    tree = cKDTree(pts)
    seeds = []
    for i, s in enumerate(sides):
        idx = [j for j in tree.query_ball_point(pts[i], NEIGHBOUR_DISTANCE[1] * s) if j != i]
        d = pts[idx] - pts[i]
        r = np.hypot(*d.T) if idx else np.zeros(0)
        good = [k for k in range(len(idx)) if r[k] >= NEIGHBOUR_DISTANCE[0] * s
                and 1 / NEIGHBOUR_SIDE_RATIO < sides[idx[k]] / s < NEIGHBOUR_SIDE_RATIO]
        if len(good) >= 2:
            seeds.append((-len(good), i, d[good], r[good]))
    seeds.sort(key=lambda t: (t[0], t[1]))
    used, out = set(), []
    for _, i, d, r in seeds:
        if i in used:
            continue
        order = np.argsort(r)
        u = d[order[0]]
        perp = [k for k in order[1:] if abs(np.dot(d[k], u)) / (r[k] * np.hypot(*u)) < MAX_SEED_COS]
        if not perp:
            continue
        v = d[perp[0]]
        assigned, H = _grow(i, u, v, pts, sides)
        used.add(i)
        if len(assigned) >= MIN_PATCHES:
            used.update(assigned)
            out.append((assigned, H))
    return out


def _orient_maps(shape):
    """The 8 maps of chart (col, row) to box cells: list of (name, mirrored, f) with f giving
    (i, j) box-cell indices of chart cell (col, row); ``shape`` (na, nb) of the box."""
    na, nb = shape
    cols, rows = 6, 4
    maps = []
    if (na, nb) == (cols, rows):
        for flip_a in (False, True):
            for flip_b in (False, True):
                maps.append(lambda c, r, fa=flip_a, fb=flip_b:
                            (cols - 1 - c if fa else c, rows - 1 - r if fb else r))
    else:
        for flip_a in (False, True):
            for flip_b in (False, True):
                maps.append(lambda c, r, fa=flip_a, fb=flip_b:
                            (rows - 1 - r if fa else r, cols - 1 - c if fb else c))
    return maps


def _sample_cells(lin, H, a0, b0, na, nb):
    """Median linear RGB at the centres of the box's cells: (na, nb, 3)."""
    g = (np.arange(SAMPLE_POINTS) / (SAMPLE_POINTS - 1) - 0.5) * SAMPLE_SPAN
    da, db = np.meshgrid(g, g)
    out = np.zeros((na, nb, 3))
    h, w = lin.shape[:2]
    for i in range(na):
        for j in range(nb):
            p = _map(H, np.c_[a0 + i + da.ravel(), b0 + j + db.ravel()])
            x = np.clip(np.rint(p[:, 0]).astype(int), 0, w - 1)
            y = np.clip(np.rint(p[:, 1]).astype(int), 0, h - 1)
            out[i, j] = np.median(lin[y, x], axis=0)
    return out


def _r2(values, ref):
    """R^2 of the 24 patches' values (24, 3) explained by a linear map with offset of the
    reference (24, 3), pooled over the channels (1 - sum of residual squares / sum of squares
    about each channel's mean): a channel with little signal (red, deep down) weighs little."""
    X = np.c_[ref, np.ones(len(ref))]
    res = values - X @ np.linalg.lstsq(X, values, rcond=None)[0]
    total = float(np.sum((values - values.mean(axis=0)) ** 2))
    return 1.0 - float(np.sum(res ** 2)) / total if total > 0 else 0.0


def _score_lattice(assigned, H, lin, ref):
    """Best (r2, runner-up r2, count, cell -> chart map, a0, b0, shape) over placements."""
    keys = np.array(list(assigned.values()))
    placements = []
    for na, nb in ((6, 4), (4, 6)):
        for a0 in range(keys[:, 0].min() - na + 1, keys[:, 0].max() + 1):
            for b0 in range(keys[:, 1].min() - nb + 1, keys[:, 1].max() + 1):
                inside = np.sum((keys[:, 0] >= a0) & (keys[:, 0] < a0 + na)
                                & (keys[:, 1] >= b0) & (keys[:, 1] < b0 + nb))
                placements.append((int(inside), a0, b0, na, nb))
    top = max(p[0] for p in placements)
    if top < MIN_PATCHES:
        return None
    scored = []
    for count, a0, b0, na, nb in placements:
        if count < top - PLACEMENT_SLACK:
            continue
        cells = _sample_cells(lin, H, a0, b0, na, nb)
        for k, f in enumerate(_orient_maps((na, nb))):
            vals = np.array([cells[f(c, r)] for r in range(4) for c in range(6)])
            scored.append((_r2(vals, ref), count, a0, b0, na, nb, k))
    scored.sort(key=lambda s: (-s[0], -s[1]))
    best = scored[0]
    runner = scored[1][0] if len(scored) > 1 else 0.0
    return best, runner


def _corners_of(assigned, pts, best, layout, factor, scale, offset):
    """Corners and centres in photo pixels from the candidates inside the chosen box."""
    import cv2

    _, count, a0, b0, na, nb, k = best
    f = _orient_maps((na, nb))[k]
    inverse = {}
    for r in range(4):
        for c in range(6):
            i, j = f(c, r)
            inverse[(a0 + i, b0 + j)] = (c + 0.5, r + 0.5)
    src, dst = [], []
    for idx, key in assigned.items():
        if key in inverse:
            src.append(inverse[key])
            dst.append(pts[idx])
    src, dst = np.array(src, float), np.array(dst, float)
    H0 = _fit_map(src, dst)
    pitch = float(np.median(np.hypot(*(_map(H0, src + [0.5, 0]) - _map(H0, src - [0.5, 0])).T)))
    H, mask = cv2.findHomography(src, dst, cv2.RANSAC, RANSAC_PITCH * pitch)
    if H is None or mask is None or mask.sum() < MIN_PATCHES:
        H = H0
    else:
        keep = mask.ravel() > 0
        H = _fit_map(src[keep], dst[keep])
    mx, my = layout.margin_x, layout.margin_y
    box = np.array([[-mx, -my], [6 + mx, -my], [6 + mx, 4 + my], [-mx, 4 + my]], float)
    rows, cols = np.divmod(np.arange(24), 6)
    corners = scale * (factor * (_map(H, box) + 0.5) - 0.5) + offset
    centres = scale * (factor * (_map(H, np.c_[cols + 0.5, rows + 0.5]) + 0.5) - 0.5) + offset
    return corners, centres, int(count)


def _layout(layout) -> ChartLayout:
    if not isinstance(layout, ChartLayout):
        if layout not in LAYOUTS:
            raise InputError("layout", f"must be one of {sorted(LAYOUTS)} or a ChartLayout, got "
                             f"{layout!r}")
        layout = LAYOUTS[layout]
    if (layout.columns, layout.rows) != (6, 4):
        raise InputError("layout", f"the detector finds the 6 x 4 ColorChecker Classic, not "
                         f"{layout.columns} x {layout.rows}; give --corners")
    return layout


def find_chart(image, layout="patches") -> Detection:
    """Find the ColorChecker Classic in a photograph.

    Parameters
    ----------
    image : measure.Photo or numpy.ndarray
        A photo read by :func:`measure.read_image` (RAW mosaic or RGB), or linear RGB
        (H, W, 3) in any units (decode a JPEG's transfer function first).
    layout : str or ChartLayout, optional
        Whose corners to return: 'patches' (the patch grid, default), 'card', or a
        :class:`measure.ChartLayout`.

    Returns
    -------
    Detection
        Corners (photo pixels, next to patch 1, 6, 24, 19), orientation, confidence, method.

    Raises
    ------
    ChartNotFound
        ``no chart found`` with the reason (too few square patches on a grid, or their colours
        do not match a ColorChecker in any orientation).
    ValueError
        Naming ``image`` or ``layout`` when malformed.

    References
    ----------
    R. Hartley and A. Zisserman, *Multiple View Geometry in Computer Vision*, 2nd ed.,
    Cambridge University Press, 2004, Sec. 4.7 (robust homography estimation, RANSAC).
    """
    from .image import Photo

    lay = _layout(layout)
    rgb, scale, offset = _linear_rgb(image)
    lin, disp, factor = detection_image(rgb)
    cands = _candidates(disp)
    lattices = _lattices(cands)
    where = f" in {image.path}" if isinstance(image, Photo) else ""
    if not lattices:
        raise ChartNotFound(f"no chart found{where}: no grid of at least {MIN_PATCHES} square "
                            f"patches ({len(cands)} square regions in the image)")
    ref = reference_rgb()
    pts = np.array([c.centre for c in cands])
    results = []
    for assigned, H in lattices:
        scored = _score_lattice(assigned, H, lin, ref)
        if scored is not None:
            results.append((scored, assigned))
    if not results:
        raise ChartNotFound(f"no chart found{where}: no 6 x 4 box holds {MIN_PATCHES} square "
                            "patches of one grid")
    results.sort(key=lambda t: -t[0][0][0])
    (best, runner), assigned = results[0]
    if best[0] < MIN_R2:
        raise ChartNotFound(f"no chart found{where}: the best grid of square patches does not "
                            f"have a ColorChecker's colours (R^2 {best[0]:.2f} < {MIN_R2})")
    corners, centres, count = _corners_of(assigned, pts, best, lay, factor, scale, offset)
    method = "grid"
    grey = None
    if isinstance(image, Photo):
        corners, centres, grey, changed = _grey_row(image, corners, centres, lay)
        method += "+grey-row" if changed else ""
    orient = pose(centres[[0, 5, 23, 18]]) | {"grey_row": grey}
    conf = min(1.0, count / (24 * FULL_SHARE)) * max(0.0, best[0])
    return Detection(corners, orient, float(conf), method, count, float(best[0]), float(runner),
                     float(np.mean(np.hypot(*np.diff(centres.reshape(4, 6, 2), axis=1).T))),
                     centres)


#: centre index permutations of the 4 corner orders of measure.chart.ORIENTATIONS
_CENTRE_ORDER = {"as given": lambda g: g, "rotated 180°": lambda g: g[::-1, ::-1],
                 "mirrored left-right": lambda g: g[:, ::-1],
                 "mirrored top-bottom": lambda g: g[::-1, :]}


def _grey_row(photo, corners, centres, lay):
    """The grey row's verdict: (corners, centres, passes, changed)."""
    try:
        cands = orientations(photo, corners, lay)
    except ValueError:
        return corners, centres, None, False
    if cands["as given"][2]:
        return corners, centres, True, False
    passing = [k for k, v in cands.items() if v[2]]
    if len(passing) != 1:
        return corners, centres, False, False
    name = passing[0]
    grid = _CENTRE_ORDER[name](centres.reshape(4, 6, 2)).reshape(24, 2)
    return cands[name][0], grid, True, True
