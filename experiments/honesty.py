"""The acceptance experiment of "never a confident wrong answer": ``HONESTY.md``.

``python -m experiments.honesty [--quick] [--n N] [--seed S]`` renders sets of ColorChecker
photographs with the independent renderer (:mod:`experiments.independent_world`, which shares
no code with ``forward``), fits each set with :func:`sca.estimate_batch` (``gain='free'``: the
unknown exposure of a photograph) once with the default uncertainty budget
(:data:`sca.budget.DEFAULT_UNCERTAIN`, or the world's own budget) and, for the worlds the
estimator should handle, once with the paper's exact model (``uncertain={}``), and reports per
world and budget:

* n, the fraction ``reliable``;
* the coverage of the 95 % intervals among the reliable charts, for C, for a_CDOM(440) and
  jointly; "confident wrong" = reliable charts with the truth outside either interval (two 95 %
  intervals: nominally at most about 10 % of the reliable ones);
* the median relative half-width of the C interval, (hi - lo) / 2 / C_true, among reliable
  charts (the price of honesty);
* the median share of the largest source of the variance of C (and the most common one).

Every world draws the same chart conditions (a paired design): C log-uniform 0.05-10 mg m^-3,
a_CDOM log-uniform 0.01-1 m^-1, depth uniform 1-15 m, distance uniform 0.5-3 m, exposure
uniform 0.2-0.9, photon and read noise on. The worlds (:func:`worlds`):

1. ``clean``: realistic tolerances (PCHIP on a 0.5 nm grid, per-patch reflectance sd 0.5 %,
   camera curves shifted with sd 0.5 nm, channel gains sd 0.5 %, single-scattering veil);
2. ``priors``: the default budget's own priors (told depth and distance off by N(0, 0.2 m) and
   N(0, 5 %), slopes drawn N(0.014, 0.0025) and N(0.011, 0.0025) nm^-1, gains sd 1 %,
   reflectance sd 1 %);
3. the ends of the paper's ranges: S_NAP 0.006 and 0.014, S_CDOM 0.019, a yellowed chart, a
   1 % channel-balance error;
4. geometry told wrong within its stated sd: depth +0.3 m (budget depth sd 0.3 m), distance
   x 1.10 (budget distance sd 10 %);
5. garbage that must never be reliable: a sampling grid shifted half a patch, another camera,
   another illuminant, four occluded patches;

and, without a criterion, a diagnostic twin of each world 1-4 without its camera-curve shifts
(``<name>/no-shift``, default budget only), which separates the effect of those shifts from
the world's own.

Acceptance (:func:`acceptance`) tests the number of misses among the reliable charts against
the nominal rate with a one-sided binomial test at level :data:`CONSISTENCY_P`.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np
from scipy import stats

import sca
from sca.budget import DEFAULT_UNCERTAIN

from . import independent_world as iw

__all__ = [
    "CDOM_RANGE",
    "CHARTS_FULL",
    "CHARTS_QUICK",
    "CHL_RANGE",
    "CLEAN_OPTIONS",
    "CONSISTENCY_P",
    "DEFAULT_LABEL",
    "DEPTH_RANGE",
    "DISTANCE_RANGE",
    "EXACT",
    "EXACT_LABEL",
    "EXPOSURE_RANGE",
    "HONEST_GROUPS",
    "MIN_RELIABLE_CLEAN",
    "NOMINAL_JOINT",
    "miss_p",
    "NOMINAL_SINGLE",
    "PIXELS_PER_PATCH",
    "SEED",
    "WRONG_CAMERA",
    "WRONG_ILLUMINANT",
    "World",
    "acceptance",
    "draw_conditions",
    "fit_set",
    "main",
    "render_set",
    "report",
    "run",
    "summarise",
    "worlds",
    "write_outputs",
]

ROOT = Path(__file__).resolve().parents[1]
#: Charts per world in the full run and with ``--quick``.
CHARTS_FULL = 200
CHARTS_QUICK = 30
#: Seed of the conditions and of every render.
SEED = 20240611
#: C range (log-uniform), mg m^-3.
CHL_RANGE = (0.05, 10.0)
#: a_CDOM(440) range (log-uniform), m^-1.
CDOM_RANGE = (0.01, 1.0)
#: Depth range (uniform), m.
DEPTH_RANGE = (1.0, 15.0)
#: Camera-to-chart distance range (uniform), m.
DISTANCE_RANGE = (0.5, 3.0)
#: Unknown exposure range (uniform).
EXPOSURE_RANGE = (0.2, 0.9)
#: Pixels averaged per patch (the renderer's default; a render takes ~30 ms).
PIXELS_PER_PATCH = 1000
#: The clean world's realistic tolerances (:class:`experiments.independent_world.WorldOptions`).
CLEAN_OPTIONS = {"step_nm": 0.5, "interpolation": "pchip", "reflectance_sd": 0.005,
                 "camera_shift_nm_sd": 0.5, "camera_gain_sd": 0.005,
                 "backscatter": "single_scatter", "noise": True,
                 "pixels_per_patch": PIXELS_PER_PATCH}
#: The camera of the wrong-camera world (the only other one in colour-science 0.4's
#: ``MSDS_CAMERA_SENSITIVITIES``); the estimator assumes 'Nikon 5100 (NPL)'.
WRONG_CAMERA = "Sigma SDMerill (NPL)"
#: The illuminant of the wrong-illuminant world (the estimator assumes D65).
WRONG_ILLUMINANT = "A"
#: Nominal coverage of one 95 % interval.
NOMINAL_SINGLE = 0.95
#: Nominal joint coverage of two 95 % intervals (Bonferroni: at least 90 %).
NOMINAL_JOINT = 0.90
#: One-sided binomial p-value below which the misses exceed the nominal rate.
CONSISTENCY_P = 0.01
#: The clean world's acceptance: at least this fraction reliable with the default budget.
MIN_RELIABLE_CLEAN = 0.90
#: The paper's exact model (photon noise only).
EXACT: dict = {}
#: The groups fitted with the exact model too, and given diagnostic twins without the
#: camera-curve shifts (worlds 1-4).
HONEST_GROUPS = ("clean", "priors", "ends", "geometry")
#: Budget labels in the outputs.
DEFAULT_LABEL, EXACT_LABEL = "default", "exact"


@dataclasses.dataclass(frozen=True)
class World:
    """One world: how its charts are rendered, what the estimator is told, and its budget.

    Parameters
    ----------
    name : str
        Short name (the row of the table).
    group : str
        'clean', 'priors', 'ends', 'geometry' or 'garbage' (the acceptance criterion),
        'limitation' (a stated limit of the model, no criterion), or
        'diagnostic' (no criterion: an ablation that locates a failure).
    description : str
        One line for the report.
    options : dict
        Renderer options on top of :data:`CLEAN_OPTIONS`.
    uncertain : dict or None
        The budget of the honest fit (None: the default budget).
    draw_slopes : bool
        Draw S_CDOM and S_NAP per chart from the default budget's priors.
    geometry_errors : bool
        Tell depth and distance with N(0, sd) errors of the default budget.
    depth_bias : float
        Added to the told depth, m.
    distance_factor : float
        Multiplies the told distance.
    occlude : int
        Random patches hidden by a hand per chart.
    """

    name: str
    group: str
    description: str
    options: dict = dataclasses.field(default_factory=dict)
    uncertain: dict | None = None
    draw_slopes: bool = False
    geometry_errors: bool = False
    depth_bias: float = 0.0
    distance_factor: float = 1.0
    occlude: int = 0

    @property
    def garbage(self) -> bool:
        """True for a world whose charts must never be reliable."""
        return self.group == "garbage"


def worlds() -> list[World]:
    """The worlds of the experiment, in report order.

    Returns
    -------
    list of World
    """
    gains = (1.01, 1.0, 0.99)
    main = [
        World("clean", "clean", "realistic tolerances, single-scattering veil"),
        World("priors", "priors", "told geometry and slopes drawn from the default priors; "
              "gains and reflectances sd 1 %", {"camera_gain_sd": 0.01, "reflectance_sd": 0.01},
              draw_slopes=True, geometry_errors=True),
        World("nap_slope_0.006", "ends", "S_NAP = 0.006 nm^-1", {"nap_slope": 0.006}),
        World("nap_slope_0.014", "ends", "S_NAP = 0.014 nm^-1", {"nap_slope": 0.014}),
        World("cdom_slope_0.019", "ends", "S_CDOM = 0.019 nm^-1", {"cdom_slope": 0.019}),
        World("yellowing_0.03", "ends", "aged chart, yellowing 0.03", {"yellowing": 0.03}),
        World("balance_1%", "ends", f"channel gains {gains}", {"camera_gains": gains}),
        World("path_split", "ends", "daylight attenuated by K_d on its way down (the "
              "renderer's own split path, b_bp/b_p 0.0183)", {"path": "split"}),
        World("depth_told_+0.3m", "geometry", "depth told +0.3 m; budget depth sd 0.3 m",
              uncertain={**DEFAULT_UNCERTAIN, "depth": 0.3}, depth_bias=0.3),
        World("distance_told_x1.10", "geometry", "distance told x 1.10; budget distance sd 10 %",
              uncertain={**DEFAULT_UNCERTAIN, "distance": "10%"}, distance_factor=1.10),
        World("corner_shift_0.5", "garbage", "sampling grid shifted half a patch",
              {"corner_shift": 0.5}),
        World("wrong_camera", "garbage", f"rendered with {WRONG_CAMERA}, fitted as Nikon 5100",
              {"camera": WRONG_CAMERA}),
        World("wrong_illuminant", "limitation", f"rendered under {WRONG_ILLUMINANT}, fitted as "
              "D65 (the light at the surface is an input, not a measurement)",
              {"illuminant": WRONG_ILLUMINANT}),
        World("occluded_4", "garbage", "4 random patches occluded by a hand", occlude=4),
    ]
    return main + [_without_shift(w) for w in main if w.group in HONEST_GROUPS]


def _without_shift(world: World) -> World:
    """The diagnostic twin of ``world`` without the camera-curve shifts."""
    return dataclasses.replace(
        world, name=f"{world.name}/no-shift", group="diagnostic",
        description=f"{world.description}; without camera-curve shifts",
        options={**world.options, "camera_shift_nm_sd": 0.0})


def _log_uniform(rng, lo_hi, n):
    return np.exp(rng.uniform(np.log(lo_hi[0]), np.log(lo_hi[1]), n))


def draw_conditions(rng: np.random.Generator, n: int) -> dict:
    """The conditions of ``n`` charts (shared by every world: a paired design).

    Parameters
    ----------
    rng : numpy.random.Generator
    n : int

    Returns
    -------
    dict
        (n,) arrays 'chl', 'cdom', 'depth', 'distance', 'exposure', 'cdom_slope' and
        'nap_slope' (drawn from the default budget's priors), 'depth_error' (m) and
        'distance_error' (relative) (drawn with the default budget's sds).
    """
    return {
        "chl": _log_uniform(rng, CHL_RANGE, n),
        "cdom": _log_uniform(rng, CDOM_RANGE, n),
        "depth": rng.uniform(*DEPTH_RANGE, n),
        "distance": rng.uniform(*DISTANCE_RANGE, n),
        "exposure": rng.uniform(*EXPOSURE_RANGE, n),
        "cdom_slope": rng.normal(iw.CDOM_SLOPE_PER_NM, DEFAULT_UNCERTAIN["cdom_slope"], n),
        "nap_slope": rng.normal(iw.NAP_SLOPE_PER_NM, DEFAULT_UNCERTAIN["nap_slope"], n),
        "depth_error": rng.normal(0.0, DEFAULT_UNCERTAIN["depth"], n),
        "distance_error": rng.normal(0.0, _percent(DEFAULT_UNCERTAIN["distance"]), n),
    }


def _percent(text: str) -> float:
    return float(text.rstrip("%")) / 100.0


def _chart_options(world: World, cond: dict, i: int, rng) -> dict:
    """The renderer options of chart ``i`` of ``world``."""
    opts = {**CLEAN_OPTIONS, **world.options, "exposure": float(cond["exposure"][i])}
    if world.draw_slopes:
        opts.update(cdom_slope=float(cond["cdom_slope"][i]), nap_slope=float(cond["nap_slope"][i]))
    if world.occlude:
        opts["occluded"] = tuple(int(j) for j in rng.choice(24, world.occlude, replace=False))
    return opts


def render_set(world: World, cond: dict, rng: np.random.Generator) -> dict:
    """Render every chart of ``cond`` in ``world``.

    Parameters
    ----------
    world : World
    cond : dict
        From :func:`draw_conditions`.
    rng : numpy.random.Generator
        The world's stream (one child per chart).

    Returns
    -------
    dict
        'rgb' and 'sigma' (N, 3, 24), the told 'depth' and 'distance' (N,), 'saturated' (N,)
        and 'render_s' (wall-clock seconds).
    """
    t0 = time.perf_counter()
    n = cond["chl"].size
    streams = rng.spawn(n)
    rgb, sigma, saturated = [], [], []
    for i in range(n):
        opts = _chart_options(world, cond, i, streams[i])
        out = iw.render_chart(cond["chl"][i], cond["cdom"][i], cond["depth"][i],
                              cond["distance"][i], rng=streams[i], **opts)
        rgb.append(out["rgb"])
        sigma.append(out["sigma"])
        saturated.append(out["saturated"])
    depth, distance = cond["depth"] + world.depth_bias, cond["distance"] * world.distance_factor
    if world.geometry_errors:
        depth = depth + cond["depth_error"]
        distance = distance * (1.0 + cond["distance_error"])
    return {"rgb": np.array(rgb), "sigma": np.array(sigma), "depth": depth, "distance": distance,
            "saturated": np.array(saturated), "render_s": time.perf_counter() - t0}


def fit_set(rendered: dict, uncertain):
    """Fit a rendered set with the free exposure gain and the budget ``uncertain``.

    Parameters
    ----------
    rendered : dict
        From :func:`render_set`.
    uncertain : dict or None
        The budget (None: :data:`sca.budget.DEFAULT_UNCERTAIN`; ``{}``: the exact model).

    Returns
    -------
    sca.batch.BatchEstimate
    """
    # a patch mean below the black level is read noise around 0: taken as 0, as measure does
    return sca.estimate_batch(np.maximum(rendered["rgb"], 0.0), depth=rendered["depth"],
                              distance=rendered["distance"], sigma=rendered["sigma"],
                              gain="free", uncertain=uncertain)


def _inside(ci, truth):
    """Truth inside a (N, 2) interval (NaN ends: outside)."""
    with np.errstate(invalid="ignore"):
        return (ci[:, 0] <= truth) & (truth <= ci[:, 1])


def _median(x):
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    return float(np.median(x)) if x.size else None


def _largest_share(est, keep):
    """Median largest share of the variance of C among ``keep`` and the commonest source."""
    shares = (est.budget or {}).get("chl", {}).get("shares", {})
    if not shares or not keep.any():
        return None, None
    names = list(shares)
    S = np.column_stack([np.asarray(shares[k], float) for k in names])[keep]
    ok = np.all(np.isfinite(S), axis=1)
    if not ok.any():
        return None, None
    top = Counter(names[j] for j in np.argmax(S[ok], axis=1)).most_common(1)[0][0]
    return float(np.median(S[ok].max(axis=1))), top


def miss_p(misses, n, nominal):
    """One-sided binomial p-value of >= ``misses`` misses in ``n`` at the rate 1 - nominal."""
    return float(stats.binom.sf(misses - 1, n, 1.0 - nominal)) if n else None


def _clopper_pearson(k, n, level=0.95):
    """Exact binomial interval of a proportion k / n."""
    if n == 0:
        return None
    a = (1.0 - level) / 2.0
    lo = stats.beta.ppf(a, k, n - k + 1) if k > 0 else 0.0
    hi = stats.beta.ppf(1 - a, k + 1, n - k) if k < n else 1.0
    return [float(lo), float(hi)]


def summarise(est, cond: dict, path=None) -> dict:
    """The numbers of one world and budget.

    Parameters
    ----------
    est : sca.batch.BatchEstimate
    cond : dict
        The true conditions (:func:`draw_conditions`).
    path : (N,) array, optional
        The told path depth + distance, m (for the a_CDOM optical-depth error).

    Returns
    -------
    dict
        n, reliable (count, fraction), coverage of C, a_CDOM and joint among the reliable charts
        with misses and binomial p-values, confident_wrong, median relative half-width of C,
        median largest C-budget share and source, the median error of the a_CDOM optical depth
        (a_CDOM - a_CDOM_true) x path among reliable charts (with ``path``), flag counts,
        non-converged and NaN-interval counts.
    """
    rel = np.asarray(est.reliable, bool)
    in_c, in_a = _inside(est.chl_ci, cond["chl"]), _inside(est.cdom_ci, cond["cdom"])
    n_rel = int(rel.sum())
    hits = {"chl": int((in_c & rel).sum()), "cdom": int((in_a & rel).sum()),
            "joint": int((in_c & in_a & rel).sum())}
    nominal = {"chl": NOMINAL_SINGLE, "cdom": NOMINAL_SINGLE, "joint": NOMINAL_JOINT}
    coverage = {k: {"covered": h, "fraction": h / n_rel if n_rel else None,
                    "misses": n_rel - h, "nominal": nominal[k],
                    "p_excess_misses": miss_p(n_rel - h, n_rel, nominal[k]),
                    "ci95": _clopper_pearson(h, n_rel)} for k, h in hits.items()}
    half = (est.chl_ci[:, 1] - est.chl_ci[:, 0]) / 2.0 / cond["chl"]
    share, source = _largest_share(est, rel)
    nan_ci = ~np.all(np.isfinite(est.chl_ci) | np.isinf(est.chl_ci), axis=1) | \
        ~np.all(np.isfinite(est.cdom_ci) | np.isinf(est.cdom_ci), axis=1)
    return {"n": int(rel.size), "reliable": n_rel, "reliable_fraction": n_rel / rel.size,
            "reliable_ci95": _clopper_pearson(n_rel, int(rel.size)), "coverage": coverage,
            "confident_wrong": n_rel - hits["joint"],
            "median_rel_halfwidth_chl": _median(half[rel]),
            "median_largest_share_chl": share, "commonest_largest_source_chl": source,
            "median_cdom_path_error": None if path is None else _median(
                ((est.cdom - cond["cdom"]) * np.asarray(path, float))[rel]),
            "not_converged": int((~np.asarray(est.converged, bool)).sum()),
            "nan_intervals": int(nan_ci.sum()),
            "flags": dict(Counter(f for t in est.flags for f in t).most_common()),
            "fit_s": float(est.elapsed_s)}


def _charts(est, cond, rendered) -> dict:
    """The per-chart raw numbers of one fit (for the JSON)."""
    def r(a):
        return np.round(np.asarray(a, float), 6).tolist()
    return {"chl_true": r(cond["chl"]), "cdom_true": r(cond["cdom"]),
            "depth_told": r(rendered["depth"]), "distance_told": r(rendered["distance"]),
            "chl": r(est.chl), "cdom": r(est.cdom), "chl_ci": r(est.chl_ci),
            "cdom_ci": r(est.cdom_ci), "reliable": np.asarray(est.reliable, bool).tolist(),
            "chi2_dof": r(est.chi2_dof), "flags": [list(t) for t in est.flags]}


def _budgets(world: World) -> list[tuple[str, object]]:
    """(label, uncertain) of the fits of ``world``: its budget, and the exact model (worlds
    1-4 only)."""
    out = [(DEFAULT_LABEL, world.uncertain)]
    return [*out, (EXACT_LABEL, EXACT)] if world.group in HONEST_GROUPS else out


def run(n: int = CHARTS_FULL, seed: int = SEED, *, charts: bool = True, only=None,
        log=None) -> dict:
    """Render and fit every world.

    Parameters
    ----------
    n : int
        Charts per world.
    seed : int
        Seed of the conditions and renders.
    charts : bool
        Keep the per-chart numbers.
    only : sequence of str, optional
        World names to run (default all).
    log : callable, optional
        Called with one progress line per world.

    Returns
    -------
    dict
        'config', 'results' (world name -> {'group', 'description', 'uncertain',
        'render_s', 'fits': {label: summary}, 'charts': {label: per-chart numbers}}) and
        'elapsed_s'.
    """
    t0 = time.perf_counter()
    root = np.random.default_rng(seed)
    cond_rng, render_root = root.spawn(2)
    cond = draw_conditions(cond_rng, n)
    chosen = [w for w in worlds() if only is None or w.name in only]
    streams = dict(zip([w.name for w in worlds()], render_root.spawn(len(worlds())), strict=True))
    results = {}
    for world in chosen:
        results[world.name] = _run_world(world, cond, streams[world.name], charts)
        if log:
            log(_progress(world.name, results[world.name]))
    return {"config": _config(n, seed), "results": results,
            "elapsed_s": time.perf_counter() - t0}


def _run_world(world: World, cond: dict, rng, charts: bool) -> dict:
    """Render ``world`` once and fit it with each of its budgets."""
    rendered = render_set(world, cond, rng)
    entry = {"group": world.group, "description": world.description,
             "uncertain": _jsonable(world.uncertain), "render_s": rendered["render_s"],
             "fits": {}, "charts": {}}
    for label, uncertain in _budgets(world):
        est = fit_set(rendered, uncertain)
        entry["fits"][label] = summarise(est, cond, rendered["depth"] + rendered["distance"])
        if charts:
            entry["charts"][label] = _charts(est, cond, rendered)
    return entry


def _jsonable(uncertain):
    return "default" if uncertain is None else dict(uncertain)


def _progress(name, entry):
    parts = [f"{name}: render {entry['render_s']:.1f} s"]
    for label, s in entry["fits"].items():
        parts.append(f"{label} reliable {s['reliable']}/{s['n']} wrong {s['confident_wrong']} "
                     f"fit {s['fit_s']:.1f} s")
    return "; ".join(parts)


def _config(n, seed) -> dict:
    return {"charts_per_world": n, "seed": seed, "chl_range": CHL_RANGE,
            "cdom_range": CDOM_RANGE, "depth_range": DEPTH_RANGE,
            "distance_range": DISTANCE_RANGE, "exposure_range": EXPOSURE_RANGE,
            "clean_options": CLEAN_OPTIONS, "default_uncertain": DEFAULT_UNCERTAIN,
            "gain": "free", "nominal_single": NOMINAL_SINGLE, "nominal_joint": NOMINAL_JOINT,
            "consistency_p": CONSISTENCY_P, "min_reliable_clean": MIN_RELIABLE_CLEAN}


def _honest(summary) -> bool:
    """No coverage's misses significantly above its nominal rate (vacuous with none reliable)."""
    return all(c["p_excess_misses"] is None or c["p_excess_misses"] >= CONSISTENCY_P
               for c in summary["coverage"].values())


def acceptance(results: dict) -> list[dict]:
    """Each acceptance criterion: whether it holds, per world (default budget).

    Parameters
    ----------
    results : dict
        ``run(...)['results']``.

    Returns
    -------
    list of dict
        {'criterion', 'worlds': {name: bool}, 'holds': bool} in the order of the groups.
    """
    rules = {
        "clean": ("1. clean world: >= 90 % reliable and coverage consistent with nominal",
                  lambda s: s["reliable_fraction"] >= MIN_RELIABLE_CLEAN and _honest(s)),
        "priors": ("2. priors world: covered at the nominal rate", _honest),
        "ends": ("3. ends of the paper's ranges: honest (reliable ones covered, or flagged)",
                 _honest),
        "geometry": ("4. geometry told wrong within its stated sd: truth inside the interval",
                     _honest),
        "garbage": ("5. garbage: never reliable", lambda s: s["reliable"] == 0),
    }
    out = []
    for group, (text, rule) in rules.items():
        verdicts = {name: bool(rule(e["fits"][DEFAULT_LABEL])) for name, e in results.items()
                    if e["group"] == group}
        if verdicts:
            out.append({"criterion": text, "group": group, "worlds": verdicts,
                        "holds": all(verdicts.values())})
    return out


def _pct(x, digits=0):
    return "-" if x is None else f"{100 * x:.{digits}f} %"


def _num(x, fmt="{:.2f}"):
    return "-" if x is None else fmt.format(x)


def _row(name, label, s) -> str:
    cov = s["coverage"]
    share = "-" if s["median_largest_share_chl"] is None else (
        f"{s['median_largest_share_chl']:.2f} ({s['commonest_largest_source_chl']})")
    wrong = f"{s['confident_wrong']}" + (f" ({_pct(s['confident_wrong'] / s['reliable'])})"
                                          if s["reliable"] else "")
    return (f"| {name} | {label} | {s['n']} | {_pct(s['reliable_fraction'])} | "
            f"{_pct(cov['chl']['fraction'])} | {_pct(cov['cdom']['fraction'])} | "
            f"{_pct(cov['joint']['fraction'])} | {wrong} | "
            f"{_num(s['median_rel_halfwidth_chl'])} | {share} |")


def _table(results) -> list[str]:
    header = ("| world | budget | n | reliable | C covered | a_CDOM covered | both covered | "
              "confident wrong | median C half-width / C | median largest C share (source) |")
    lines = [header, "|---|---|---|---|---|---|---|---|---|---|"]
    for name, e in results.items():
        for label, s in e["fits"].items():
            lines.append(_row(name, label, s))
    return lines


def _world_sentence(name, s) -> str:
    cov = s["coverage"]
    text = (f"`{name}`: {s['reliable']}/{s['n']} reliable ({_pct(s['reliable_fraction'])}); ")
    if not s["reliable"]:
        return text + "no reliable chart to cover."
    parts = [f"{label} {cov[k]['covered']}/{s['reliable']} (p = {cov[k]['p_excess_misses']:.2g})"
             for k, label in (("chl", "covered C"), ("cdom", "a_CDOM"), ("joint", "both"))]
    return text + ", ".join(parts) + f"; {s['confident_wrong']} confident wrong."


def _limitation_text(results) -> list[str]:
    rows = [(n, e) for n, e in results.items() if e["group"] == "limitation"]
    if not rows:
        return []
    lines = ["", "**Known limitation: the illuminant** (no criterion). The light at the surface "
             "is an input of the model (D65 daylight by default), not something one chart can "
             "measure: under tungsten light (illuminant A) its red tilt is indistinguishable from "
             "CDOM absorption along the path, and the fit is good. The result is conditional on "
             "the illuminant given (`illuminant=`, `--illuminant`). The issue's garbage case, a "
             "wrong illuminant in the in-air *calibration*, is caught: the calibration's "
             "per-patch systematic term is 13 % against at most 3 % (`systematic`, "
             "tests/test_budget.py).", ""]
    for name, e in rows:
        s = e["fits"][DEFAULT_LABEL]
        lines.append(f"- `{name}`: {_world_sentence(name, s)}{_garbage_note(s)}")
    return lines


def _criteria_text(results, verdicts) -> list[str]:
    lines = []
    for v in verdicts:
        lines += ["", f"**{v['criterion']}** — {'holds' if v['holds'] else 'FAILS'}.", ""]
        for name, ok in v["worlds"].items():
            s = results[name]["fits"][DEFAULT_LABEL]
            extra = (_garbage_note(s) if v["group"] == "garbage" else
                     _twin_note(results, name))
            lines.append(f"- {'holds' if ok else 'FAILS'} — {_world_sentence(name, s)}{extra}")
    return lines


def _garbage_note(s) -> str:
    text = f" Flags raised most: {_top_flags(s)}."
    if s["reliable"] and s.get("median_cdom_path_error") is not None:
        text += (" Median a_CDOM optical-depth error (a_CDOM - truth) x (depth + distance) "
                 f"among the reliable: {s['median_cdom_path_error']:.2f}.")
    return text


def _twin_note(results, name) -> str:
    twin = results.get(f"{name}/no-shift")
    if twin is None:
        return ""
    s = twin["fits"][DEFAULT_LABEL]
    if not s["reliable"]:
        return f" Without the camera-curve shifts (`{name}/no-shift`): none reliable."
    return (f" Without the camera-curve shifts (`{name}/no-shift`): {s['reliable']}/{s['n']} "
            f"reliable, both covered {s['coverage']['joint']['covered']}/{s['reliable']}, "
            f"{s['confident_wrong']} confident wrong ({'honest' if _honest(s) else 'NOT honest'}).")


def _top_flags(s, k=3) -> str:
    return ", ".join(f"{f} {c}" for f, c in list(s["flags"].items())[:k]) or "none"


def _contrast_text(results) -> list[str]:
    title = "**The exact model (`uncertain={}`) for contrast** (worlds 1-4, the old behaviour):"
    lines = ["", title, ""]
    for name, e in results.items():
        s = e["fits"].get(EXACT_LABEL)
        if s is not None:
            lines.append(f"- {_world_sentence(name, s)}")
    return lines


def _diagnostic_text(results) -> list[str]:
    rows = [(n, e) for n, e in results.items() if e["group"] == "diagnostic"]
    if not rows:
        return []
    title = ("**Diagnostic** (no criterion): worlds 1-4 again, the same conditions without the "
             "camera-curve shifts (`camera_shift_nm_sd` 0), default budget:")
    lines = ["", title, ""]
    for name, e in rows:
        s = e["fits"][DEFAULT_LABEL]
        verdict = "honest" if _honest(s) else "NOT honest"
        lines.append(f"- {verdict} — {_world_sentence(name, s)}")
    return lines


def _health_text(results) -> list[str]:
    bad = [(n, lab, s) for n, e in results.items() for lab, s in e["fits"].items()
           if s["not_converged"] or s["nan_intervals"]]
    if not bad:
        return ["", "Every fit converged and no interval is NaN."]
    return ["", "Fits that did not converge or returned NaN intervals:", ""] + [
        f"- `{n}` ({lab}): {s['not_converged']} not converged, {s['nan_intervals']} NaN "
        "intervals" for n, lab, s in bad]


def _intro(out) -> str:
    cfg = out["config"]
    return (
        f"{cfg['charts_per_world']} charts per world (seed {cfg['seed']}), rendered by the "
        "independent renderer (`experiments/independent_world.py`, no code shared with "
        "`forward`) and fitted by `sca.estimate_batch(..., gain='free')` with the default "
        "budget (`default`: `sca.budget.DEFAULT_UNCERTAIN`, or the world's stated budget in "
        "world 4) and with the paper's exact model (`exact`: `uncertain={}`). Every world "
        "uses the same conditions: C log-uniform 0.05-10 mg m^-3, a_CDOM log-uniform "
        "0.01-1 m^-1, depth 1-15 m, distance 0.5-3 m, exposure 0.2-0.9 (unknown to the fit), "
        f"{PIXELS_PER_PATCH} pixels per patch with photon and read noise. Coverage, confident "
        "wrong (truth outside either interval), half-width and budget shares are among the "
        "reliable charts; half-width is (hi - lo) / 2 / C_true. The verdicts test the misses "
        "among the reliable charts against the nominal rate (5 % per interval, 10 % jointly) "
        f"with a one-sided binomial test at p < {CONSISTENCY_P} (the p-values below). "
        f"Run time {out['elapsed_s']:.0f} s ({_timing(out['results'])}).")


def _world_list(results) -> str:
    return ("Worlds 2-5 add their change to the clean world's tolerances (camera-curve shifts "
            "included); each world 1-4 has a diagnostic twin `<name>/no-shift` without the "
            "camera-curve shifts (same conditions, default budget only). Worlds: " +
            "; ".join(f"`{w.name}` {w.description}" for w in worlds()
                      if w.name in results and w.group != "diagnostic") + ".")


def report(out: dict) -> str:
    """The text of ``HONESTY.md`` from :func:`run`'s result (a pure function of it).

    Parameters
    ----------
    out : dict
        ``run(...)``, with 'elapsed_s'.

    Returns
    -------
    str
    """
    results = out["results"]
    head = ["# Honesty: never a confident wrong answer", "",
            "Generated by `python -m experiments.honesty`; do not edit.", "",
            _intro(out), "", _world_list(results), ""]
    return "\n".join(head + _table(results) + ["", "## Acceptance"] +
                     _criteria_text(results, acceptance(results)) + _limitation_text(results) +
                     _contrast_text(results) +
                     _diagnostic_text(results) + _health_text(results)) + "\n"


def _timing(results) -> str:
    render = sum(e["render_s"] for e in results.values())
    fit = sum(s["fit_s"] for e in results.values() for s in e["fits"].values())
    return f"rendering {render:.0f} s, fitting {fit:.0f} s"


def _write_atomic(path: Path, text: str):
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)


def write_outputs(out: dict, report_path, json_path):
    """Write ``HONESTY.md`` and the JSON, each whole or not at all (temporary file, then
    ``os.replace``).

    Parameters
    ----------
    out : dict
        :func:`run`'s result.
    report_path, json_path : str or pathlib.Path
    """
    text = report(out)
    data = json.dumps({**out, "acceptance": acceptance(out["results"])}, indent=1)
    _write_atomic(Path(json_path), data)
    _write_atomic(Path(report_path), text)


def main(argv=None) -> int:
    """``python -m experiments.honesty [--quick] [--n N] [--seed S] [--report P] [--json P]
    [--per-chart] [--strict]``.

    Parameters
    ----------
    argv : list of str, optional
        Arguments (default ``sys.argv[1:]``).

    Returns
    -------
    int
        0 (with ``--strict``: 1 when an acceptance criterion fails; the outputs are written
        either way).
    """
    parser = argparse.ArgumentParser(prog="python -m experiments.honesty",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help=f"{CHARTS_QUICK} charts per world instead of {CHARTS_FULL}")
    parser.add_argument("--n", type=int, default=None, help="charts per world")
    parser.add_argument("--seed", type=int, default=SEED)
    parser.add_argument("--report", default=str(ROOT / "HONESTY.md"))
    parser.add_argument("--json", default=str(ROOT / "benchmarks" / "honesty.json"))
    parser.add_argument("--strict", action="store_true",
                        help="exit 1 when an acceptance criterion fails")
    parser.add_argument("--per-chart", action="store_true",
                        help="also write every chart's truth and estimate into the JSON")
    args = parser.parse_args(argv)
    n = args.n or (CHARTS_QUICK if args.quick else CHARTS_FULL)
    out = run(n, args.seed, charts=args.per_chart, log=lambda line: print(line, flush=True))
    write_outputs(out, args.report, args.json)
    verdicts = acceptance(out["results"])
    for v in verdicts:
        print(f"{'holds' if v['holds'] else 'FAILS'}: {v['criterion']}")
    print(f"{out['elapsed_s']:.0f} s; wrote {args.report} and {args.json}")
    return 0 if all(v["holds"] for v in verdicts) or not args.strict else 1


if __name__ == "__main__":
    sys.exit(main())
