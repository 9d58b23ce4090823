"""The correction's own uncertainty: how far the corrected colours move across the water's
95 % intervals.

The water's C and a_CDOM(440) are known to their 95 % intervals; the correction is redone with
the water at the four ends of the two intervals, each end's partner (a_CDOM at an end of C's
interval, C at an end of a_CDOM's) chosen as the profile likelihood would: the value that best
keeps the chart's colour, i.e. the camera's response to a white along the chart's path (C and
a_CDOM trade off along a valley; the corners of the box of the two intervals lie far outside
the joint confidence region and would overstate the spread several times). Each is corrected
with its exposure gain refitted so that the chart's white patch keeps its luminance (the fit's
gain moves with the water). The spread is the CIEDE2000 colour difference (scikit-image's ``skimage.color.deltaE_ciede2000``,
equal to colour-science's ``colour.delta_E(..., method="CIE 2000")``, tests/test_correct.py;
scikit-image because a photo's measurement must not import colour-science, about 3 s:
decision 0007-start-up) of the corrected colours from those of the fitted water:

- of the chart's 24 patches at the chart's distance (median and largest over the patches, of
  the largest over the corners);
- of an 18 % grey at each range of :data:`GREY_RANGES_M` (the largest over the corners).

Lab is computed from the camera's values in air through :func:`forward.camera_to_xyz_matrix`
(a white reflector Y = 1) under D65 (``skimage.color.xyz2lab``). An open interval (``inf``) leaves the spread unbounded
(reported as None with a note).

A photo corrected at a depth outside the depths the water was measured at
(:attr:`measure.correctwater.CorrectionWater.extrapolated`) keeps the measured veiling light;
:func:`extrapolation_spread` is what that costs if the veil changes with depth as the model
says: the ΔE00 of the 18 % grey corrected with the measured veil, seen with the veil scaled by
the model's V_c(r0) at the photo's depth over that at the nearest measured depth.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

import forward
import sca
from forward.spectra import WHITE_PATCH

from .correct import MAX_GAIN, _veil_shape, _white_response, correction_table
from .correctwater import CorrectionWater

__all__ = ["GREY_RANGES_M", "GREY_REFLECTANCE", "correction_spread", "extrapolation_spread"]

#: Ranges at which a grey's spread is reported, m (a diver's near field to the visibility
#: limit of clear water)
GREY_RANGES_M = (0.5, 1.0, 2.0, 3.0, 5.0, 8.0)
#: The grey: 18 % reflectance (a photographer's mid grey card)
GREY_REFLECTANCE = 0.18


def _lab(setup, J):
    """CIELAB (D65, 2 degree observer) of camera values in air (model units)."""
    from skimage.color import xyz2lab

    xyz = np.asarray(J, float) @ forward.camera_to_xyz_matrix(setup).T
    return xyz2lab(np.atleast_2d(xyz), illuminant="D65", observer="2",
                   channel_axis=-1).reshape(xyz.shape)


def _de(a, b):
    """CIEDE2000 between two arrays of Lab."""
    from skimage.color import deltaE_ciede2000

    a, b = np.broadcast_arrays(np.asarray(a, float), np.asarray(b, float))
    return np.asarray(deltaE_ciede2000(np.atleast_2d(a), np.atleast_2d(b), channel_axis=-1),
                      float).reshape(a.shape[:-1])


def _partner(water: CorrectionWater, name: str, value: float, upper: float) -> float:
    """The other of (C, a_CDOM) that, with ``name`` at ``value``, best keeps the response
    to a white along the chart's path (least squares in the log of the three channels)."""
    from scipy.optimize import minimize_scalar

    target = np.log(_white_response(water, [water.distance])[0])

    def cost(x):
        w = water.with_water(value, x) if name == "chl" else water.with_water(x, value)
        return float(np.sum((np.log(_white_response(w, [water.distance])[0]) - target) ** 2))
    res = minimize_scalar(cost, bounds=(0.0, upper), method="bounded",
                          options={"xatol": 1e-5 * max(upper, 1e-3)})
    return float(res.x)


def correction_spread(water: CorrectionWater, *, chart_rgb=None, ranges=GREY_RANGES_M,
                      max_gain: float = MAX_GAIN, method: str = "matrix") -> dict:
    """The ΔE00 spread of the correction over the water's 95 % intervals.

    Parameters
    ----------
    water : measure.correctwater.CorrectionWater
        The fitted water (its ``chl_ci``, ``cdom_ci``).
    chart_rgb : array_like, (3, 24), optional
        The chart's patch values (raw units) at the chart's distance; without it only the grey
        is reported.
    ranges : sequence of float, optional
        Ranges (m) of the grey (default :data:`GREY_RANGES_M`).
    max_gain : float, optional
        The correction's cap (:func:`measure.correct.correction_table`).
    method : 'matrix' or 'diagonal', optional
        The correction's method (:func:`measure.correct.correction_table`): each end's
        correction is redone whole, its colour matrices recomputed through that end's water.

    Returns
    -------
    dict
        ``chart_de00`` {median, max} or None, ``grey_de00`` [{range_m, de00}], ``samples``
        (the (C, a_CDOM) used), ``method``, ``notes``.
    """
    lo_c, hi_c = (float(v) for v in water.chl_ci)
    lo_a, hi_a = (float(v) for v in water.cdom_ci)
    out = {"method": "the correction redone at the ends of the 95 % intervals of C and "
                     "a_CDOM(440) (the other profiled on the chart's white), the gain refitted to "
                     f"the chart's white, the {method} method; CIEDE2000 (scikit-image) against "
                     "the fitted water's",
           "chart_de00": None, "grey_de00": [{"range_m": float(r), "de00": None} for r in ranges],
           "samples": [], "notes": []}
    if not all(math.isfinite(v) for v in (lo_c, hi_c, lo_a, hi_a)) or \
            hi_c > sca.assess.CHL_MAX or hi_a > sca.assess.CDOM_MAX:
        out["notes"].append("an interval of the water is open: the correction's spread is "
                            "unbounded")
        return out
    setup = water.setup
    nominal = correction_table(water, max_gain=max_gain, method=method)
    r = np.asarray(ranges, float)
    air = setup.white_response
    # the grey as the fitted water shows it (exact for a flat reflectance: gain rho W_c(r) + s_c)
    rows = np.stack([np.interp(np.clip(r, 0, nominal.cap), nominal.ranges,
                               nominal.transmission[:, c]) for c in range(3)], axis=-1)
    veil = np.stack([np.interp(np.clip(r, 0, nominal.cap), nominal.ranges, nominal.veil[:, c])
                     for c in range(3)], axis=-1)
    grey_raw = nominal.gain * GREY_REFLECTANCE * rows * air + veil
    grey_air = _lab(setup, GREY_REFLECTANCE * air)
    chart = None if chart_rgb is None else np.asarray(chart_rgb, float).T  # (24, 3)
    r0 = np.full(24, water.distance)
    chart_nom = None if chart is None else nominal.apply(chart, r0)
    to_xyz = forward.camera_to_xyz_matrix(setup)
    worst_chart = np.zeros(24)
    worst_grey = np.zeros(r.size)
    ref = int(np.argmax(air))
    ends = [(c, _partner(water, "chl", c, max(4 * hi_a, 1.0))) for c in (lo_c, hi_c)]
    ends += [(_partner(water, "cdom", a, max(4 * hi_c, 10.0)), a) for a in (lo_a, hi_a)]
    for c, a in ends:
        out["samples"].append([c, a])
        tab = correction_table(water.with_water(c, a), max_gain=max_gain, method=method)
        # the gain refitted: the chart's white patch keeps its luminance (or, without the
        # chart, a white at the chart's distance keeps the reference channel)
        if chart is not None:
            jw = tab.apply(chart[WHITE_PATCH], water.distance)
            k = float((to_xyz @ chart_nom[WHITE_PATCH])[1] / (to_xyz @ jw)[1])
        else:
            t_n = np.interp(water.distance, nominal.ranges, nominal.transmission[:, ref])
            t_s = np.interp(water.distance, tab.ranges, tab.transmission[:, ref])
            k = float(t_n / t_s)
        worst_grey = np.maximum(worst_grey, _de(_lab(setup, k * tab.apply(grey_raw, r)),
                                                grey_air))
        if chart is not None:
            worst_chart = np.maximum(worst_chart, _de(_lab(setup, k * tab.apply(chart, r0)),
                                                      _lab(setup, chart_nom)))
    if chart is not None:
        out["chart_de00"] = {"median": float(np.median(worst_chart)),
                             "max": float(worst_chart.max())}
    out["grey_de00"] = [{"range_m": float(rr), "de00": float(d)} for rr, d in zip(r, worst_grey)]
    return out


def _interp(table, r, values) -> np.ndarray:
    """(n, 3) a table's per-range values at the ranges r (clipped to the cap)."""
    rr = np.clip(r, 0, table.cap)
    return np.stack([np.interp(rr, table.ranges, values[:, c]) for c in range(3)], axis=-1)


def extrapolation_spread(water: CorrectionWater, *, ranges=GREY_RANGES_M,
                         max_gain: float = MAX_GAIN) -> dict | None:
    """The ΔE00 a depth outside the measured ones may cost: an 18 % grey corrected with the
    measured veiling light, seen with the veil the model predicts at the photo's depth.

    Parameters
    ----------
    water : measure.correctwater.CorrectionWater
        Its ``extrapolated`` and ``span``.
    ranges : sequence of float, optional
        Ranges (m) of the grey (default :data:`GREY_RANGES_M`).
    max_gain : float, optional
        The correction's cap.

    Returns
    -------
    dict or None
        ``depth_m``, ``measured_depth_m`` (the nearest measured), ``veil_ratio`` (3,),
        ``grey_de00`` [{range_m, de00}], ``method``; None when the depth is not extrapolated.
    """
    if water.extrapolated is None:
        return None
    near = float(np.clip(water.depth, *water.span))
    r0 = [water.distance]
    ratio = _veil_shape(water, r0)[0] / _veil_shape(dataclasses.replace(water, depth=near), r0)[0]
    ratio = np.where(np.isfinite(ratio), ratio, 1.0)
    used = correction_table(water, max_gain=max_gain)
    r = np.asarray(ranges, float)
    air = water.setup.white_response
    seen = (used.gain * GREY_REFLECTANCE * _interp(used, r, used.transmission) * air
            + ratio * _interp(used, r, used.veil))
    de = _de(_lab(water.setup, used.apply(seen, r)), _lab(water.setup, GREY_REFLECTANCE * air))
    return {"method": "an 18 % grey corrected with the measured veiling light, seen with it "
                      "scaled by the model's veil at the photo's depth over the nearest measured "
                      "depth's; CIEDE2000 against the grey in air",
            "depth_m": water.depth, "measured_depth_m": near, "veil_ratio": ratio.tolist(),
            "grey_de00": [{"range_m": float(a), "de00": float(d)} for a, d in zip(r, de)]}
