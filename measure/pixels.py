"""The compiled pixel kernels of ``measure``: a RAW mosaic unpacked, demosaiced and corrected
pixel by pixel (numba, parallel over rows).

They live in one file because a cached kernel may call only compiled functions of its own file
(numba keys a cache entry on its function's file, yet compiles its callees into it: a callee in
another file could change under a stale entry; ``tests/test_structure.py``). They hold no number
of a model: tables and arrays arrive as arguments.
"""

from __future__ import annotations

import numpy as np

from sca.compiled import njit, prange

__all__ = ["bilinear_pixel", "bilinear_all", "census_rows", "correct_pixels", "unpack"]


@njit(parallel=True, cache=True)
def unpack(mosaic, colors, lut, blacks, white, data, channel, clipped):  # pragma: no cover
    """One pass over the mosaic (parallel over rows): data = mosaic - blacks[colour] (float32,
    as numpy's float32 subtraction), channel = lut[colour], clipped = mosaic >= white."""
    H, W = mosaic.shape
    for y in prange(H):
        for x in range(W):
            c = colors[y, x]
            v = mosaic[y, x]
            data[y, x] = np.float32(v) - blacks[c]
            channel[y, x] = lut[c]
            clipped[y, x] = v >= white


@njit(parallel=True, cache=True)
def census_rows(a, counts):  # pragma: no cover - compiled
    """One pass over a map (parallel over rows): counts[y] = how many of row y's values are
    known (finite, > 0), NaN, 0, negative (finite), -inf and +inf."""
    H, W = a.shape
    for y in prange(H):
        known = nan = zero = negative = neg_inf = pos_inf = 0
        for x in range(W):
            v = a[y, x]
            if v != v:
                nan += 1
            elif v == np.inf:
                pos_inf += 1
            elif v == -np.inf:
                neg_inf += 1
            elif v > 0:
                known += 1
            elif v == 0:
                zero += 1
            else:
                negative += 1
        counts[y, 0] = known
        counts[y, 1] = nan
        counts[y, 2] = zero
        counts[y, 3] = negative
        counts[y, 4] = neg_inf
        counts[y, 5] = pos_inf


@njit(cache=True, inline="always")
def bilinear_pixel(data, channel, y, x, H, W, gains, offset):  # pragma: no cover - compiled
    """One pixel of the bilinear demosaic (:func:`demosaic`'s kernel, and measure.correct's):
    (value - offset[c]) gains[c] of each channel's pixels in the 3 x 3 neighbourhood, weighted
    [1 2 1] x [1 2 1] and normalised per channel, edges mirrored; (red, green, blue)."""
    num0 = num1 = num2 = 0.0
    den0 = den1 = den2 = 0.0
    for dy in range(-1, 2):
        yy = y + dy
        if yy < 0:
            yy = -yy
        elif yy >= H:
            yy = 2 * H - 2 - yy
        wy = 2.0 if dy == 0 else 1.0
        for dx in range(-1, 2):
            xx = x + dx
            if xx < 0:
                xx = -xx
            elif xx >= W:
                xx = 2 * W - 2 - xx
            w = wy * (2.0 if dx == 0 else 1.0)
            c = channel[yy, xx]
            v = (data[yy, xx] - offset[c]) * gains[c] * w
            if c == 0:
                num0 += v
                den0 += w
            elif c == 1:
                num1 += v
                den1 += w
            else:
                num2 += v
                den2 += w
    return (num0 / den0 if den0 > 0 else 0.0, num1 / den1 if den1 > 0 else 0.0,
            num2 / den2 if den2 > 0 else 0.0)


@njit(parallel=True, cache=True)
def bilinear_all(data, channel, gains, offset, out, to_uint16, step):  # pragma: no cover
    """:func:`bilinear_pixel` at every ``step``-th row and column (out: (ceil(H / step),
    ceil(W / step), 3)), rounded and clipped to uint16 or as float."""
    H, W = data.shape
    for yi in prange(out.shape[0]):
        y = yi * step
        for xi in range(out.shape[1]):
            x = xi * step
            vals = bilinear_pixel(data, channel, y, x, H, W, gains, offset)
            for c in range(3):
                v = vals[c]
                if to_uint16:
                    v = min(max(v + 0.5, 0.0), 65535.0)
                    out[yi, xi, c] = int(v)
                else:
                    out[yi, xi, c] = v


@njit(cache=True, inline="always")
def _row(C, i, w, k, d0, d1, d2):  # pragma: no cover - compiled
    """Row k of C interpolated between table rows i and i + 1 (weight w), times (d0, d1, d2)."""
    return ((C[i, k, 0] + w * (C[i + 1, k, 0] - C[i, k, 0])) * d0
            + (C[i, k, 1] + w * (C[i + 1, k, 1] - C[i, k, 1])) * d1
            + (C[i, k, 2] + w * (C[i + 1, k, 2] - C[i, k, 2])) * d2)


@njit(parallel=True, cache=True)
def correct_pixels(mosaic, channel, rgb, raw, H, W, ranges, has_map, const_r, unknown, cap, step,
                   C, B, M, lut, lin_scale, lin16, srgb, flt, modes,
                   stats):  # pragma: no cover - compiled
    """Per pixel: demosaic the RAW ``mosaic`` or read the RGB ``rgb`` (the other a dummy), the
    range (map, or const_r), the table row interpolated, J = C (v - B) (C (n, 3, 3): a diagonal
    for the von Kries correction, the colour matrix times it for the spectral); then linear uint16
    (J lin_scale), sRGB (the table lut of clip(M J): uint16 codes, or uint8 ones into a uint8
    ``srgb``) and float J, as ``modes`` (lin, srgb, float) ask. ``stats`` (H, 4) gets each row's
    count of unknown ranges (not > 0), of ranges beyond the cap, and its least and largest
    finite range (+inf, -inf for none), as given."""
    n = C.shape[0]
    top = lut.shape[0] - 1
    ones = np.ones(3, np.float32)
    zeros = np.zeros(3, np.float32)
    for y in prange(H):
        n_unknown = 0.0
        n_capped = 0.0
        lo = np.inf
        hi = -np.inf
        for x in range(W):
            if raw:
                v0, v1, v2 = bilinear_pixel(mosaic, channel, y, x, H, W, ones, zeros)
            else:
                v0, v1, v2 = rgb[y, x, 0], rgb[y, x, 1], rgb[y, x, 2]
            r = ranges[y, x] if has_map else const_r
            if abs(r) < np.inf:  # finite (NaN is not)
                lo = min(lo, r)
                hi = max(hi, r)
            if r > cap:  # +inf too
                n_capped += 1.0
                r = cap
            elif not (r > 0.0):  # NaN or 0: unknown
                n_unknown += 1.0
                r = min(unknown, cap)
            f = r / step
            i = int(f)
            if i >= n - 1:
                i = n - 2
                w = 1.0
            else:
                w = f - i
            d0 = v0 - (B[i, 0] + w * (B[i + 1, 0] - B[i, 0]))
            d1 = v1 - (B[i, 1] + w * (B[i + 1, 1] - B[i, 1]))
            d2 = v2 - (B[i, 2] + w * (B[i + 1, 2] - B[i, 2]))
            j0 = _row(C, i, w, 0, d0, d1, d2)
            j1 = _row(C, i, w, 1, d0, d1, d2)
            j2 = _row(C, i, w, 2, d0, d1, d2)
            if modes[0]:
                lin16[y, x, 0] = int(min(max(j0 * lin_scale + 0.5, 0.0), 65535.0))
                lin16[y, x, 1] = int(min(max(j1 * lin_scale + 0.5, 0.0), 65535.0))
                lin16[y, x, 2] = int(min(max(j2 * lin_scale + 0.5, 0.0), 65535.0))
            if modes[1]:
                for c in range(3):
                    s = M[c, 0] * j0 + M[c, 1] * j1 + M[c, 2] * j2
                    s = min(max(s, 0.0), 1.0)
                    srgb[y, x, c] = lut[int(s * top + 0.5)]
            if modes[2]:
                flt[y, x, 0] = j0
                flt[y, x, 1] = j1
                flt[y, x, 2] = j2
        stats[y, 0] = n_unknown
        stats[y, 1] = n_capped
        stats[y, 2] = lo
        stats[y, 3] = hi
