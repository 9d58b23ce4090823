"""One rule per kind of claim: the verdicts of REPRODUCTION.md and the criteria of the
paper-like search (:mod:`experiments.paper_like`) are these functions, so the two cannot
disagree.

Kinds of claim and their rule (each verdict is "yes", "partly" or "no"):

* **level** ("about 2 %"): yes within a factor :data:`LEVEL_FACTOR` of the paper's number,
  partly within its square, no otherwise (:func:`verdict_level`).
* **accuracy** ("matches the ground truth"): the error at most the paper's own level, by the
  same factors (:func:`verdict_at_most`).
* **bound** ("consistently above 0.7"): yes if every value is above it, no otherwise
  (:func:`verdict_above`).
* **range of r²** ("r² varies between 1 and 0.7"): yes if r² at the shallowest depth is at
  least :data:`R2_TOP` and the lowest r² within :data:`R2_LOW_RANGE`; partly if r² falls below
  :data:`R2_TOP` but not to about 0.7; no if it does not fall below :data:`R2_TOP` (it does not
  vary) or starts below it (:func:`verdict_r2_range`).
* **trend** ("decreases with depth", "lower with lower CDOM"): the values rounded to the
  precision the tables print (:data:`R2_DECIMALS` decimals of r², :data:`SIG_DIGITS`
  significant digits otherwise); "no (flat)" if they are then all equal; else Spearman's rank
  correlation rho of the variable and the values, signed so that the paper's direction is
  positive: yes if rho >= :data:`TREND_RHO`, partly if rho > 0, no otherwise
  (:func:`verdict_trend`). Fig 10's "increases slightly with larger depths and target
  distances" is two trends and a size (:func:`verdict_rises_slightly`).
* **comparison** ("much more pronounced with depth; distance a much smaller effect"): yes if
  the first effect is at least :data:`MUCH_MORE` times the second, no if it is not larger,
  partly between (:func:`verdict_comparison`).
* **hue** ("bluish", "greenish"): the HSV hue of the white patch as the figure draws it, named
  by the six 60° sectors centred on red (0°), yellow, green (120°), cyan (180°), blue (240°)
  and magenta; "grey" below :data:`MIN_SATURATION`. yes if the name is the paper's, partly if
  the neighbouring sector, no otherwise (:func:`verdict_hue`); a change "from blue to green"
  (Fig 8) or "stronger green" (Fig 6 against Fig 5) also needs the hue to move towards the
  named colour (:func:`verdict_hue_change`).
* **independence** ("does not depend on the specific medium"): the largest over the smallest
  of the values per class (C classes, a_CDOM classes), yes within :data:`LEVEL_FACTOR`, partly
  within its square (:func:`verdict_independent`).
* **correction** (Fig 11: the estimated attenuation as "a good model for the ambient
  illumination" for a von Kries correction): yes if the correction with the estimated k is no
  worse than both model-free baselines (grey-world, white-patch) and within :data:`DE00_JND` of
  the same correction with the true k (the control), partly if one of the two, no if neither
  (:func:`verdict_correction`).
* **ranked** (a real-camera number against two baselines, a strong and a weak one): yes if no
  worse than the strong, partly if no worse than the weak, no otherwise
  (:func:`verdict_ranked`).

A verdict that a perfect estimator would get by construction says nothing about the paper's
claim: a one-sided bound whose every value is at its ceiling as printed (r = 1.000) is marked
not discriminating (:func:`discriminates_bound`) and not counted.

Issue 39 (fourth pass) made every rule able to fail: Fig 9's "matches" is judged two-sided
against the paper's own level (the level rule), Fig 11 lost its always-true "halved" half and
gained the true-k control, and Figs 12-13 are judged on log10 values.

These rules were unified in the third pass (issue 20), after the second pass's numbers were
known; where the search's criteria and the report's rules differed, the search's thresholds were
kept (it was the older, published ranking), and the search was rerun with the new estimation
grid only afterwards. The criteria a setting was chosen on are flagged "tuned" in the table.
"""

from __future__ import annotations

import colorsys
import math

import numpy as np

__all__ = ["verdict_level", "verdict_at_most", "verdict_above", "verdict_r2_range",
           "verdict_trend", "verdict_rises_slightly", "verdict_comparison", "hue_of",
           "hue_name", "verdict_hue", "verdict_hue_stronger", "verdict_hue_change", "spearman_rounded", "worst",
           "verdict_independent", "verdict_correction", "verdict_ranked", "discriminates_bound",
           "DE00_JND", "BOUND_DECIMALS", "LEVEL_FACTOR", "R2_TOP", "R2_LOW_RANGE", "R2_DECIMALS", "SIG_DIGITS", "TREND_RHO",
           "SLIGHT_MAX_RATIO", "MUCH_MORE", "MIN_SATURATION", "HUES", "VERDICTS"]

VERDICTS = ("yes", "partly", "no")
#: "about X": yes within this factor of X, partly within its square
LEVEL_FACTOR = 2.0
#: "r² varies between 1 and 0.7": r² at the shallowest depth at least R2_TOP, the lowest r²
#: within R2_LOW_RANGE
R2_TOP = 0.9
R2_LOW_RANGE = (0.6, 0.85)
#: Trends are judged at the precision the tables print: r² to R2_DECIMALS decimals, other
#: quantities to SIG_DIGITS significant digits
R2_DECIMALS = 2
SIG_DIGITS = 2
#: A trend is "yes" at this Spearman rho (in the paper's direction) or above
TREND_RHO = 0.8
#: "slightly": the last value at most this multiple of the first
SLIGHT_MAX_RATIO = 3.0
#: "much more": at least this multiple
MUCH_MORE = 1.5
#: Below this HSV saturation a colour has no hue ("grey")
MIN_SATURATION = 0.1
#: The hue names, sector centres 0, 60, ..., 300 degrees
HUES = ("red", "yellow", "green", "cyan", "blue", "magenta")
#: A just-noticeable colour difference, CIEDE2000 units (Fig 11's control: the estimator's share
#: of the error is negligible below it; e.g. Sharma, Wu & Dalal 2005, Color Res. Appl. 30:21)
DE00_JND = 1.0
#: Correlations are printed to this many decimals (a bound "above X" met by r = 1.000 as
#: printed is met by construction)
BOUND_DECIMALS = 3


def worst(*verdicts) -> str:
    """The weakest of several verdicts ("no" < "partly" < "yes"; "no (flat)" counts as "no")."""
    rank = {v: i for i, v in enumerate(VERDICTS)}
    return max((v.split(" ")[0] for v in verdicts), key=lambda v: rank[v])


# --------------------------------------------------------------------------- levels
def verdict_level(value, target) -> str:
    """"About ``target``": yes within a factor LEVEL_FACTOR, partly within its square."""
    if not (value > 0 and math.isfinite(value)):
        return "no"
    f = max(value / target, target / value)
    return "yes" if f <= LEVEL_FACTOR else "partly" if f <= LEVEL_FACTOR ** 2 else "no"


def verdict_at_most(value, target) -> str:
    """An error "no larger than the paper's ``target``": yes up to LEVEL_FACTOR x target,
    partly up to its square."""
    if not math.isfinite(value):
        return "no"
    return ("yes" if value <= LEVEL_FACTOR * target else
            "partly" if value <= LEVEL_FACTOR ** 2 * target else "no")


def verdict_above(values, bound) -> str:
    """"Consistently above ``bound``": yes if every value is, no otherwise."""
    v = np.asarray(values, float)
    return "yes" if v.size and bool(np.all(v > bound)) else "no"


def discriminates_bound(values, ceiling: float = 1.0, decimals: int = BOUND_DECIMALS) -> bool:
    """False when every value is at the ceiling a perfect estimator reaches, as printed.

    Parameters
    ----------
    values : array_like
        The values a bound is judged on (e.g. Pearson's r per depth).
    ceiling : float, optional
        The value of a perfect estimate (default 1: r of an exact fit).
    decimals : int, optional
        The printed precision (default :data:`BOUND_DECIMALS`).

    Returns
    -------
    bool
        Whether the bound's verdict says anything a perfect estimator would not get anyway.
    """
    v = np.round(np.asarray(values, float), decimals)
    return not (v.size and bool(np.all(v == round(ceiling, decimals))))


def verdict_independent(values) -> str:
    """"Does not depend on" the class: the largest over the smallest class value, yes within
    LEVEL_FACTOR, partly within its square, no otherwise (or for a non-positive value)."""
    v = np.asarray(values, float)
    if v.size == 0 or not np.all(np.isfinite(v)) or not np.all(v > 0):
        return "no"
    f = float(v.max() / v.min())
    return "yes" if f <= LEVEL_FACTOR else "partly" if f <= LEVEL_FACTOR ** 2 else "no"


def verdict_correction(de_estimated, de_true, de_baselines) -> str:
    """Fig 11: a von Kries correction with the estimated attenuation (mean ΔE00
    ``de_estimated``) against the same with the true attenuation (``de_true``) and model-free
    baselines (``de_baselines``): yes if no worse than every baseline and within DE00_JND of the
    control, partly if one of the two, no if neither."""
    if not (math.isfinite(de_estimated) and math.isfinite(de_true)):
        return "no"
    beats = bool(de_estimated <= min(de_baselines))
    near = bool(de_estimated - de_true <= DE00_JND)
    return "yes" if beats and near else "partly" if beats or near else "no"


def verdict_ranked(value, strong, weak) -> str:
    """A number where lower is better against a strong and a weak baseline: yes if no larger
    than ``strong``, partly if no larger than ``weak``, no otherwise (and for a NaN)."""
    if not math.isfinite(value):
        return "no"
    return "yes" if value <= strong else "partly" if value <= weak else "no"


def verdict_r2_range(r2_by_depth) -> str:
    """"r² varies between 1 and 0.7" for r² in order of depth (see the module docstring)."""
    r2 = np.asarray(r2_by_depth, float)
    if r2.size == 0 or not np.all(np.isfinite(r2)) or r2[0] < R2_TOP:
        return "no"
    low = r2.min()
    if low >= R2_TOP:
        return "no"
    return "yes" if R2_LOW_RANGE[0] <= low <= R2_LOW_RANGE[1] else "partly"


# --------------------------------------------------------------------------- trends
def _round(values, r2: bool):
    v = np.asarray(values, float)
    if r2:
        return np.round(v, R2_DECIMALS)
    out = np.empty_like(v)
    for i, x in enumerate(v):
        out[i] = 0.0 if x == 0 or not math.isfinite(x) else \
            round(x, SIG_DIGITS - 1 - int(math.floor(math.log10(abs(x)))))
    return out


def spearman_rounded(x, values, *, r2: bool = False) -> float:
    """Spearman's rho of ``x`` and ``values`` rounded to the printed precision; NaN if the
    rounded values are all equal (flat) or fewer than two."""
    from scipy.stats import spearmanr

    v = _round(values, r2)
    if v.size < 2 or np.all(v == v[0]):
        return float("nan")
    if v.size == 2:
        return float(np.sign((v[1] - v[0]) * (np.asarray(x, float)[1] - np.asarray(x, float)[0])))
    return float(spearmanr(x, v).statistic)


def verdict_trend(x, values, direction: int, *, r2: bool = False) -> str:
    """A trend in the paper's ``direction`` (+1 rises, -1 falls) of ``values`` over ``x``:
    "no (flat)" if equal at the printed precision, else by Spearman's rho (module docstring)."""
    rho = spearman_rounded(x, values, r2=r2)
    if not math.isfinite(rho):
        return "no (flat)"
    rho *= direction
    return "yes" if rho >= TREND_RHO else "partly" if rho > 0 else "no"


def verdict_rises_slightly(depths, by_depth, distances, by_distance) -> str:
    """Fig 10's "increases slightly with larger depths and target distances": a rising trend
    over depth and over distance (:func:`verdict_trend`), each by at most SLIGHT_MAX_RATIO
    (last over first). yes if both rise slightly; no if neither rises; partly otherwise."""
    trends = [verdict_trend(depths, by_depth, +1), verdict_trend(distances, by_distance, +1)]
    ratios = [by_depth[-1] / by_depth[0], by_distance[-1] / by_distance[0]]
    if all(t == "yes" for t in trends) and all(r <= SLIGHT_MAX_RATIO for r in ratios):
        return "yes"
    if all(t.startswith("no") for t in trends):
        return "no"
    return "partly"


def verdict_comparison(effect_a, effect_b) -> str:
    """"A much more than B" for two effects >= 1 (factors): yes if A >= MUCH_MORE x B, no if
    A <= B, partly between."""
    return "yes" if effect_a >= MUCH_MORE * effect_b else "no" if effect_a <= effect_b else "partly"


# --------------------------------------------------------------------------- hue
def hue_of(rgb) -> tuple:
    """(hue in degrees, HSV saturation) of an sRGB triple as drawn."""
    r, g, b = (float(np.clip(v, 0.0, None)) for v in rgb)
    top = max(r, g, b)
    if top <= 0:
        return float("nan"), 0.0
    h, s, _ = colorsys.rgb_to_hsv(r / top, g / top, b / top)
    return 360.0 * h, s


def hue_name(rgb) -> str:
    """The name of the 60° hue sector of ``rgb`` (module docstring), or "grey"."""
    h, s = hue_of(rgb)
    if s < MIN_SATURATION or not math.isfinite(h):
        return "grey"
    return HUES[int(((h + 30.0) % 360.0) // 60.0)]


def verdict_hue(rgb, named: str) -> str:
    """yes if the hue of ``rgb`` is ``named``, partly if it is a neighbouring sector."""
    got = hue_name(rgb)
    if got == named:
        return "yes"
    if got == "grey":
        return "no"
    d = abs(HUES.index(got) - HUES.index(named)) % 6
    return "partly" if min(d, 6 - d) == 1 else "no"


def _angle_to(h, named):
    d = abs(h - 60.0 * HUES.index(named)) % 360.0
    return min(d, 360.0 - d)


def verdict_hue_stronger(rgb_ref, rgb, named: str) -> str:
    """``rgb`` has a "stronger ``named`` tint" than ``rgb_ref``: :func:`verdict_hue` of
    ``rgb``, and "no" unless its hue is nearer ``named`` than ``rgb_ref``'s."""
    h0, _ = hue_of(rgb_ref)
    h1, _ = hue_of(rgb)
    if not (math.isfinite(h0) and math.isfinite(h1)) or _angle_to(h1, named) >= _angle_to(h0, named):
        return "no"
    return verdict_hue(rgb, named)


def verdict_hue_change(rgb_from, rgb_to, named_from, named_to) -> str:
    """A change of hue "from ``named_from`` to ``named_to``": the weaker of the two ends'
    verdicts, and "no" unless the hue moves towards ``named_to``."""
    return worst(verdict_hue(rgb_from, named_from), verdict_hue_stronger(rgb_from, rgb_to, named_to))
