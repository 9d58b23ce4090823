"""Is the joint estimate of a dive honest on a world we did not make?  (DIVE.md)

    python -m experiments.dive_honesty [--dives 40] [--clean 6] [--reference 10] [--quick]
                                       [--out DIVE.md]

Every photo is rendered by the independent renderer (:mod:`experiments.independent_world`, no
code shared with ``forward``) and every dive fitted by :func:`sca.joint.estimate_joint`, each
photo alone by :func:`sca.estimate_batch` (the same budget). Two kinds of dive:

1. **Budget-prior dives** (:func:`draw_dive`): one water per dive (C and a_CDOM log-uniform),
   every term of the default budget drawn from its prior -- the chart's per-patch reflectance
   error split as the dive's budget splits it (a part shared by the photos, sd
   sqrt(rho) x ``patch``, and each photo's own, sd sqrt(1 - rho) x ``patch``, rho =
   :data:`sca.joint.PATCH_CORRELATION`), the channel gains, the curves' shifts, the daylight's
   colour temperature and both slopes once per dive, the told depth and distance per photo --,
   a single-scattering veil, per photo its own depth (2-15 m), distance (1-3 m) and exposure;
   the camera is not calibrated (default budget). Coverage is tested **two-sided** (the world
   is drawn from the budget's priors: too few misses fails too). Mixed dives (one photo from
   another water, C x ``MIXED_FACTOR``) check that the heterogeneity test finds them.
2. **Clean dives, camera calibrated in air** (:func:`draw_clean_dive`; issue 37's case): one
   water of :data:`CLEAN_WATERS` with the nominal slopes, the clean world's tolerances (chart
   0.5 %, curves 0.5 nm, gains 0.5 %, drawn once per dive), a single-scattering veil, depths
   and distances told exactly: the issue's geometry (:data:`ISSUE_DEPTHS` x
   :data:`ISSUE_DISTANCES`) and random ones in 2-15 m x 1-3 m. The camera is calibrated from
   the renderer's photo of the same chart in air (:func:`measure.calibrate`) and the dive
   fitted with the budget ``measure`` gives it (:func:`measure.budget_for`) -- once with the
   rule before issue 37 (the calibration's in-air per-patch term as the underwater one, all
   of it shared by the photos) and once with the current one (decisions
   0053-patch-floor and 0054-patch-correlation). Criterion: no dive reliable with the truth outside
   (must be 0).

3. **Dives with the reference shot** (:func:`run_reference`; issue 47's dive
   criterion): six photos, a reference shot of the same chart in air measured
   (:func:`sca.reference.measure_light`), the sky changed within its stated sd, the joint fit
   with ``with_reference(None, light)`` beside the default budget's on the same photos; the c
   bands' half-widths against ±5 % and the Cramér-Rao bound that limits them.

The report gives, for each kind, the fraction reliable, each quantity's coverage (C,
a_CDOM(440), the path's attenuation coefficient at 443-670 nm, a_nw(440)) with its
binomial test, the median joint 95 % half-width of each, and the joint C interval's width
against the median single photo's.

The dives with the reference shot (section 3). Each dive is a budget-prior dive (:func:`experiments.dive_worlds.draw_dive`, :data:`REF_PHOTOS`
photos, the daylight drawn from the default budget's 30-mired prior) with a reference shot:

1. the same chart and camera (the dive's chart factors, channel gains and curve shifts)
   photographed in air under the surface light by the independent renderer
   (:func:`experiments.independent_world.render_calibration`) and the light measured by
   :func:`sca.reference.measure_light` (with the chart's response);
2. the sky changed before the photos by a draw within the stated sd
   (:func:`sca.reference.sky_sd` at :data:`sca.reference.REFERENCE_MINUTES`,
   :func:`experiments.honesty._sky_change`); every photo rendered under the changed light;
3. each photo's own part of the per-patch error is the reference budget's own part,
   sd sqrt(1 - rho) x :data:`sca.reference.REFERENCE_PATCH` (the world drawn from the budget
   the fit states: what the shot cannot see), the chart's part (which it sees) as
   :func:`draw_dive` draws it;
4. the dive fitted by :func:`sca.joint.estimate_joint` with
   ``uncertain=with_reference(None, light)`` and, on the same photos, with the default budget.

Criterion (issue 47): c(443/490/555) within ±5 % (joint 95 % half-width, :data:`REF_C_TARGET`)
with the truth inside at the nominal rate (two-sided). Where the widths miss the target,
:func:`reference_bounds` gives the Cramér-Rao bound of each dive (:func:`sca.joint.dive_precision` at the
truth, with the reference budget) as stated and with one term at a time removed
(:data:`REF_ABLATIONS`): what limits it.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from forward.files import write_atomic
from . import independent_world as iw
from .honesty import _sky_change
from .dive_worlds import (DIVE_DEPTHS, DIVE_DISTANCES, MIXED_FACTOR, PHOTOS, draw_dive,
                          photo_options)
from .honesty import (CLEAN_OPTIONS, CONSISTENCY_P, EXPOSURE_RANGE, NOMINAL_SINGLE,
                      JOINT_QUANTITIES as QUANTITIES,
                      TESTED, coverage_p, true_quantities)

__all__ = ["REF_ABLATIONS", "REF_AIR_EXPOSURE", "REF_C_BANDS", "REF_C_TARGET", "REF_DIVES_FULL", "REF_DIVES_QUICK", "REF_LABELS", "REF_PHOTOS", "reference_bounds", "reference_covered", "draw_reference_dive", "fit_reference_dive", "one_reference_dive", "render_reference_dive", "run_reference", "reference_section", "summarise_reference", "reference_target_met", 
    "CLEAN_DIVES_FULL",
    "CLEAN_DIVES_QUICK",
    "CLEAN_WATERS",
    "DIVES_FULL",
    "DIVES_QUICK",
    "ISSUE_DEPTHS",
    "ISSUE_DISTANCES",
    "MIXED_FACTOR",
    "PHOTOS",
    "RULES",
    "SEED",
    "clean_acceptance",
    "draw_clean_dive",
    "draw_dive",
    "fit_clean_dive",
    "fit_dive",
    "honest",
    "main",
    "photo_options",
    "render_dive",
    "report",
    "run",
    "run_clean",
    "summarise",
    "summarise_clean",
]

ROOT = Path(__file__).resolve().parents[1]
#: Budget-prior dives in the full run and with ``--quick`` (one-water dives; as many mixed
#: ones / 4).
DIVES_FULL, DIVES_QUICK = 40, 8
#: Seed of every draw.
SEED = 20261122
#: The clean dives' waters: C (mg m^-3), a_CDOM(440) (m^-1): INSTRUMENT.md's clear and coastal
#: types, issue 37's water and a greener one.
CLEAN_WATERS = {"clear": (0.1, 0.01), "issue 37": (1.0, 0.08), "coastal": (1.0, 0.1),
                "green": (3.0, 0.3)}
#: Issue 37's dive: every depth with every distance (8 photos), m.
ISSUE_DEPTHS, ISSUE_DISTANCES = (2.0, 5.0, 10.0, 15.0), (1.0, 3.0)
#: Clean dives per water (the first with the issue's geometry, the others 8 photos at random
#: depths and distances), full and ``--quick``.
CLEAN_DIVES_FULL, CLEAN_DIVES_QUICK = 6, 2
#: The rules of the clean dives' budget: before issue 37 (the calibration's per-patch term,
#: all of it shared by the photos) and now (measure's budget: decision 0053-patch-floor).
RULES = ("before", "now")


# --------------------------------------------------------------------------- budget-prior dives
def render_dive(dive: dict, rng: np.random.Generator) -> dict:
    """Render every photo's chart: 'rgb', 'sigma' (n, 3, 24) and 'truth' (the water's value
    of every quantity of :data:`experiments.honesty.QUANTITIES`, from the first photo of the
    dive's water: the paper's path, so the coefficient is the beam attenuation c, the same at
    every depth)."""
    rgb, sig, truth = [], [], None
    for i, stream in enumerate(rng.spawn(dive["depth"].size)):
        out = iw.render_chart(dive["chl_photo"][i], dive["cdom"], dive["depth"][i],
                              dive["distance"][i], rng=stream, **photo_options(dive, i))
        rgb.append(np.maximum(out["rgb"], 0.0))
        sig.append(out["sigma"])
        truth = truth or true_quantities(out)
    return {"rgb": np.array(rgb), "sigma": np.array(sig), "truth": truth}


def _joint_numbers(j) -> dict:
    """Plain numbers of a JointEstimate: every quantity's estimate and interval."""
    return {"chl": j.chl, "cdom": j.cdom, "reliable": bool(j.reliable), "flags": list(j.flags),
            "intervals": {"chl": list(j.chl_ci), "cdom": list(j.cdom_ci),
                          **{k: list(v) for k, v in j.quantity_intervals.items()}},
            "one_water": j.heterogeneity["one_water"], "disagree": j.heterogeneity["disagree"],
            "chi2": j.chi2, "dof": j.dof, "photo_scatter": j.photo_scatter,
            "nuisance": {k: np.asarray(v, float).tolist() for k, v in j.nuisance.items()},
            "uncertain": {k: v for k, v in j.uncertain.items()}}


def joint_fit(dive: dict, rendered: dict, uncertain=None) -> dict:
    """The dive's joint fit (the default camera set-up, the told geometry, budget
    ``uncertain``: None the default); plain numbers and its time 'joint_s'."""
    import forward
    from forward.imaging import resolve_setup
    from sca.joint import estimate_joint

    t0 = time.perf_counter()
    setup = resolve_setup(None, forward.DEFAULT_CAMERA, None, None, None)
    names = [f"photo {i + 1}" for i in range(dive["depth"].size)]
    j = estimate_joint(rendered["rgb"], depth=dive["depth_told"], distance=dive["distance_told"],
                       sigma=rendered["sigma"], setup=setup, names=names, uncertain=uncertain)
    return {**_joint_numbers(j), "joint_s": time.perf_counter() - t0}


def fit_dive(dive: dict, rendered: dict) -> dict:
    """The joint fit and every photo's own fit (default budget); plain numbers."""
    import sca

    joint = joint_fit(dive, rendered)
    b = sca.estimate_batch(rendered["rgb"], depth=dive["depth_told"],
                           distance=dive["distance_told"], sigma=rendered["sigma"], gain="free")
    return {**joint, "truth": rendered["truth"], "single_chl_ci": b.chl_ci.tolist(),
            "single_reliable": b.reliable.tolist()}


def _one(args):
    kind, dive, seed = args
    rng = np.random.default_rng(seed)
    if kind == "clean":
        return fit_clean_dive(dive, render_clean_dive(dive, rng))
    return fit_dive(dive, render_dive(dive, rng))


def _pool_map(tasks, workers, task=None):
    """``task`` (default the dives' own, a module-level function) of every one of ``tasks`` in
    ``workers`` processes."""
    with ProcessPoolExecutor(workers) as pool:
        return list(pool.map(task or _one, tasks))


def run(dives: int = DIVES_FULL, seed: int = SEED, workers: int | None = None) -> dict:
    """Draw, render and fit ``dives`` one-water budget-prior dives and ``dives // 4`` mixed
    ones."""
    rng = np.random.default_rng(seed)
    truth = [draw_dive(rng) for _ in range(dives)] + [draw_dive(rng, mixed=True)
                                                      for _ in range(max(dives // 4, 1))]
    seeds = rng.integers(0, 2 ** 31, len(truth))
    workers = workers or min(2, os.cpu_count() or 1)
    t0 = time.perf_counter()
    fits = _pool_map([("prior", t, int(s)) for t, s in zip(truth, seeds)], workers)
    return {"truth": truth, "fits": fits, "seconds": time.perf_counter() - t0,
            "dives": dives, "seed": seed, "workers": workers}


def _inside(ci, x):
    return ci is not None and ci[0] <= x <= ci[1]


def _coverage(pairs, test: str) -> dict:
    """Per quantity, among ``pairs`` (truth, joint numbers) of reliable dives: covered, n,
    fraction, the test's p-value and the median relative half-width."""
    out = {}
    for key, _ in QUANTITIES:
        rows = [(t[key], f["intervals"].get(key)) for t, f in pairs if f["intervals"].get(key)]
        n = len(rows)
        k = sum(_inside(ci, x) for x, ci in rows)
        half = [(ci[1] - ci[0]) / 2.0 / x for x, ci in rows if x > 0]
        out[key] = {"covered": k, "n": n, "fraction": k / n if n else None,
                    "p": coverage_p(k, n, NOMINAL_SINGLE, test),
                    "median_half_width": float(np.median(half)) if half else None}
    return out


def _width_ratio(f) -> float | None:
    """The joint C interval's width over the median single photo's (finite ones)."""
    w = np.array(f["single_chl_ci"], float)
    width = w[:, 1] - w[:, 0]
    width = width[np.isfinite(width)]
    jw = f["intervals"]["chl"][1] - f["intervals"]["chl"][0]
    return float(jw / np.median(width)) if width.size and np.isfinite(jw) else None


def summarise(out: dict) -> dict:
    """The budget-prior dives' numbers."""
    one = [(t, f) for t, f in zip(out["truth"], out["fits"]) if not t["mixed"]]
    mixed = [(t, f) for t, f in zip(out["truth"], out["fits"]) if t["mixed"]]
    rel = [(f["truth"], f) for _, f in one if f["reliable"]]
    ratio = [r for r in (_width_ratio(f) for _, f in one) if r is not None]
    wrong = sum(not (_inside(f["intervals"]["chl"], t["chl"])
                     and _inside(f["intervals"]["cdom"], t["cdom"])) for t, f in rel)
    return {
        "dives": len(one), "mixed_dives": len(mixed), "photos": PHOTOS, "reliable": len(rel),
        "reliable_wrong": wrong, "coverage": _coverage(rel, "two-sided"),
        "width_ratio_median": float(np.median(ratio)) if ratio else None,
        "narrower": int(sum(r < 1 for r in ratio)), "compared": len(ratio),
        "false_alarms": sum(not f["one_water"] for _, f in one),
        "mixed_found": sum(not f["one_water"] for _, f in mixed),
        "mixed_named": sum(f["disagree"] == [f"photo {PHOTOS}"] for _, f in mixed),
        "mixed_reliable": sum(f["reliable"] for _, f in mixed),
        "joint_s_median": float(np.median([f["joint_s"] for f in out["fits"]])),
        "seconds": out["seconds"], "workers": out["workers"], "seed": out["seed"],
    }


def _tested_ok(cov) -> bool:
    return all(cov[k]["p"] is None or cov[k]["p"] >= CONSISTENCY_P for k in TESTED if k in cov)


def honest(s: dict) -> bool:
    """The budget-prior dives' acceptance: every tested quantity's reliable joint intervals hold
    the truth at the nominal rate (two-sided binomial p >= CONSISTENCY_P), they are narrower
    than the median photo's in most dives, and no mixed dive is called reliable."""
    return (_tested_ok(s["coverage"]) and s["narrower"] > s["compared"] / 2
            and s["mixed_reliable"] == 0)


# --------------------------------------------------------------------------- clean dives
def draw_clean_dive(rng: np.random.Generator, water: str, issue_geometry: bool) -> dict:
    """A clean dive of issue 37's kind: one water of :data:`CLEAN_WATERS` with the nominal
    slopes, the clean world's tolerances drawn once, depths and distances told exactly.

    Parameters
    ----------
    rng : numpy.random.Generator
    water : str
        A key of :data:`CLEAN_WATERS`.
    issue_geometry : bool
        The issue's 8 photos (every depth of :data:`ISSUE_DEPTHS` with every distance of
        :data:`ISSUE_DISTANCES`), else 8 photos at random in 2-15 m x 1-3 m.

    Returns
    -------
    dict
        As :func:`draw_dive` (no per-photo factors; told = true geometry), with 'water' and
        'geometry' ('issue' or 'random').
    """
    chl, cdom = CLEAN_WATERS[water]
    opts = {**CLEAN_OPTIONS,
            "reflectance_factors": tuple(1 + rng.normal(0, CLEAN_OPTIONS["reflectance_sd"], 24)),
            "camera_gains": tuple(1 + rng.normal(0, CLEAN_OPTIONS["camera_gain_sd"], 3)),
            "camera_shift_nm": tuple(rng.normal(0, CLEAN_OPTIONS["camera_shift_nm_sd"], 3))}
    if issue_geometry:
        depth = np.repeat(np.array(ISSUE_DEPTHS), len(ISSUE_DISTANCES))
        distance = np.tile(np.array(ISSUE_DISTANCES), len(ISSUE_DEPTHS))
    else:
        depth = rng.uniform(*DIVE_DEPTHS, 8)
        distance = rng.uniform(*DIVE_DISTANCES, 8)
    n = depth.size
    return {"chl": chl, "cdom": cdom, "chl_photo": np.full(n, chl), "options": opts,
            "photo_factors": None, "depth": depth, "distance": distance,
            "exposure": rng.uniform(*EXPOSURE_RANGE, n), "depth_told": depth.copy(),
            "distance_told": distance.copy(), "mixed": False, "water": water,
            "geometry": "issue" if issue_geometry else "random"}


def render_clean_dive(dive: dict, rng: np.random.Generator) -> dict:
    """:func:`render_dive`, and the same chart and camera in air (exposure 0.7): 'calibration'
    (3, 24) values and standard errors."""
    photos_rng, air_rng = rng.spawn(2)
    out = render_dive(dive, photos_rng)
    air = iw.render_calibration(rng=air_rng, **{**dive["options"], "exposure": 0.7})
    out["calibration"] = {"rgb": air["rgb"], "sigma": air["sigma"]}
    return out


def _clean_budget(profile, rule: str):
    """(uncertain, patch_correlation) of a rule: 'before' the calibration's in-air per-patch
    term, all shared by the photos; 'now' measure's budget and the joint fit's default."""
    import measure
    import sca.joint

    if rule == "before":
        return measure.budget_for(None, profile, patch_floor=0.0), 1.0
    return measure.budget_for(None, profile), sca.joint.PATCH_CORRELATION


def fit_clean_dive(dive: dict, rendered: dict) -> dict:
    """Calibrate the camera in air, then fit the dive jointly under each rule of :data:`RULES`
    and each photo alone (the current rule); plain numbers."""
    import measure
    import sca
    from sca.joint import estimate_joint

    cal = rendered["calibration"]
    profile = measure.calibrate(SimpleNamespace(rgb=cal["rgb"], sigma=cal["sigma"],
                                                clipped=np.zeros(cal["rgb"].shape)))
    setup = measure.camera_setup(gains=profile.gains)
    out = {"truth": rendered["truth"], "water": dive["water"], "geometry": dive["geometry"],
           "depth": dive["depth"].tolist(), "distance": dive["distance"].tolist(),
           "calibration_patch": profile.patch_sd, "rules": {}}
    for rule in RULES:
        uncertain, rho = _clean_budget(profile, rule)
        t0 = time.perf_counter()
        j = estimate_joint(rendered["rgb"], depth=dive["depth_told"],
                           distance=dive["distance_told"], sigma=rendered["sigma"], setup=setup,
                           uncertain=uncertain, patch_correlation=rho)
        out["rules"][rule] = {**_joint_numbers(j), "joint_s": time.perf_counter() - t0,
                              "patch_correlation": rho}
    uncertain, _ = _clean_budget(profile, RULES[-1])
    b = sca.estimate_batch(rendered["rgb"], depth=dive["depth_told"], setup=setup,
                           distance=dive["distance_told"], sigma=rendered["sigma"], gain="free",
                           uncertain=uncertain)
    out["single_chl_ci"] = b.chl_ci.tolist()
    out["single_reliable"] = b.reliable.tolist()
    return out


def run_clean(per_water: int = CLEAN_DIVES_FULL, seed: int = SEED,
              workers: int | None = None) -> dict:
    """Draw, render and fit ``per_water`` clean dives of every water of
    :data:`CLEAN_WATERS` (the first of each with the issue's geometry)."""
    rng = np.random.default_rng([seed, 37])
    dives = [draw_clean_dive(rng, water, k == 0) for water in CLEAN_WATERS
             for k in range(per_water)]
    seeds = rng.integers(0, 2 ** 31, len(dives))
    workers = workers or min(2, os.cpu_count() or 1)
    t0 = time.perf_counter()
    fits = _pool_map([("clean", d, int(s)) for d, s in zip(dives, seeds)], workers)
    return {"dives": dives, "fits": fits, "seconds": time.perf_counter() - t0,
            "per_water": per_water, "seed": seed, "workers": workers}


def _wrong(f, rule) -> bool:
    r = f["rules"][rule]
    t = f["truth"]
    return bool(r["reliable"] and not (_inside(r["intervals"]["chl"], t["chl"])
                                       and _inside(r["intervals"]["cdom"], t["cdom"])))


def summarise_clean(out: dict) -> dict:
    """The clean dives' numbers, per rule: reliable, reliable-and-wrong, coverage (two-sided
    test) and median joint widths of every quantity, the width ratio to the median photo's;
    per water; and each issue-geometry dive."""
    fits = out["fits"]
    rules = {}
    for rule in RULES:
        rel = [(f["truth"], f["rules"][rule]) for f in fits if f["rules"][rule]["reliable"]]
        ratio = [r for r in (_width_ratio({**f["rules"][rule], "single_chl_ci":
                                           f["single_chl_ci"]}) for f in fits) if r is not None]
        rules[rule] = {
            "dives": len(fits), "reliable": len(rel),
            "reliable_wrong": sum(_wrong(f, rule) for f in fits),
            "coverage": _coverage(rel, "two-sided"),
            "width_ratio_median": float(np.median(ratio)) if ratio else None,
            "narrower": int(sum(r < 1 for r in ratio)), "compared": len(ratio),
            "by_water": {w: {"dives": sum(f["water"] == w for f in fits),
                             "reliable": sum(f["water"] == w and f["rules"][rule]["reliable"]
                                             for f in fits),
                             "reliable_wrong": sum(f["water"] == w and _wrong(f, rule)
                                                   for f in fits)} for w in CLEAN_WATERS}}
    issue = [{"water": f["water"], "truth": {k: f["truth"][k] for k in ("chl", "cdom")},
              "calibration_patch": f["calibration_patch"],
              **{rule: {k: f["rules"][rule][k] for k in ("chl", "cdom", "reliable", "chi2",
                                                          "dof")}
                 | {"chl_ci": f["rules"][rule]["intervals"]["chl"],
                    "cdom_ci": f["rules"][rule]["intervals"]["cdom"],
                    "cdom_slope": f["rules"][rule]["nuisance"].get("cdom_slope"),
                    "patch": f["rules"][rule]["uncertain"].get("patch"),
                    "patch_correlation": f["rules"][rule]["patch_correlation"]}
                 for rule in RULES}} for f in fits if f["geometry"] == "issue"]
    return {"rules": rules, "issue_dives": issue, "per_water": out["per_water"],
            "calibration_patch_median": float(np.median([f["calibration_patch"] for f in fits])),
            "seconds": out["seconds"], "seed": out["seed"], "workers": out["workers"]}


def clean_acceptance(c: dict) -> bool:
    """The clean dives' acceptance: with the current rule no dive is reliable with the truth
    outside, and the joint C interval is narrower than the median photo's in most dives."""
    now = c["rules"][RULES[-1]]
    return now["reliable_wrong"] == 0 and now["narrower"] > now["compared"] / 2


# --------------------------------------------------------------------------- report
def _pct(x, digits=0):
    return "-" if x is None else f"{100 * x:.{digits}f} %"


def _p(x):
    return "-" if x is None else f"{x:.2g}"


def _coverage_table(cov) -> list[str]:
    lines = ["| quantity | covered | binomial p (two-sided) | median joint half-width |",
             "|---|---|---|---|"]
    for key, label in QUANTITIES:
        v = cov[key]
        tested = "" if key in TESTED else " (not tested)"
        lines.append(f"| {label}{tested} | {v['covered']} / {v['n']} ({_pct(v['fraction'])}) "
                     f"| {_p(v['p'])} | ±{_pct(v['median_half_width'], 1)} |")
    return lines


def _prior_section(s: dict, command: str) -> list[str]:
    from sca.joint import PATCH_CORRELATION

    lines = [
        "## 1. Budget-prior dives: coverage tested on both sides",
        "",
        f"{s['dives']} one-water dives of {s['photos']} photos each and {s['mixed_dives']} mixed "
        f"dives (the last photo from water with C x {MIXED_FACTOR:g}), every term of the "
        "default budget drawn from its prior once per dive (both slopes, the channel gains sd "
        "1 %, the curves' shifts sd 1 nm, the daylight's colour temperature sd 30 mired) or per "
        "photo (the told depth, sd 0.2 m, and distance, 5 %), the chart's per-patch "
        f"reflectance error split as the dive's budget splits it (shared by the photos, sd "
        f"{100 * np.sqrt(PATCH_CORRELATION):.2g} %, and each photo's own, sd "
        f"{100 * np.sqrt(1 - PATCH_CORRELATION):.2g} %: `sca.joint.PATCH_CORRELATION` = "
        f"{PATCH_CORRELATION:g}); C log-uniform 0.05-10 mg m^-3, a_CDOM 0.01-1 m^-1; each photo "
        "its own depth (2-15 m), distance (1-3 m), exposure and single-scattering veil. Each "
        "dive fitted by `sca.joint.estimate_joint` (default budget, no calibration), each photo "
        "alone by `sca.estimate_batch` (same budget). Coverage among the reliable dives is "
        "tested **two-sided** (the world is drawn from the budget's own priors, so the "
        "intervals must hold the truth 95 % of the time, no less and no more; every quantity "
        "shown is tested, K_d(490) is not published). Half-width (hi - lo) / 2 / truth. Seed "
        f"{s['seed']}, {s['workers']} worker processes, {s['seconds']:.0f} s; a joint fit took "
        f"{s['joint_s_median']:.1f} s (median).",
        "",
        "| quantity | value |",
        "|---|---|",
        f"| one-water dives called reliable | {s['reliable']} / {s['dives']} |",
        f"| reliable with C or a_CDOM outside its interval | {s['reliable_wrong']} / "
        f"{s['reliable']} (two 95 % intervals: about 5-10 % expected) |",
        f"| joint C interval narrower than the median photo's | {s['narrower']} / "
        f"{s['compared']} dives (median width ratio {_num(s['width_ratio_median'])}) |",
        f"| one-water dives the heterogeneity test rejects (false alarms, 1 % level) | "
        f"{s['false_alarms']} / {s['dives']} |",
        f"| mixed dives found not one water | {s['mixed_found']} / {s['mixed_dives']} |",
        f"| mixed dives whose odd photo is named (alone) | {s['mixed_named']} / "
        f"{s['mixed_dives']} |",
        f"| mixed dives called reliable | {s['mixed_reliable']} / {s['mixed_dives']} |",
        "",
    ] + _coverage_table(s["coverage"]) + [
        "",
        "Acceptance (`honest`): every tested quantity's reliable joint intervals hold the truth "
        f"at the nominal 95 % (two-sided binomial p >= {CONSISTENCY_P}), they are narrower than "
        "the median photo's in most dives, and no mixed dive is called reliable: "
        f"**{'holds' if honest(s) else 'FAILS'}**.",
        "",
    ]
    return lines


def _num(x, fmt="{:.2f}"):
    return "-" if x is None else fmt.format(x)


def _ci(ci) -> str:
    return f"[{ci[0]:.3g}, {ci[1]:.3g}]"


def _clean_section(c: dict) -> list[str]:
    waters = "; ".join(f"{w}: C {v[0]:g} mg m^-3, a_CDOM(440) {v[1]:g} m^-1"
                       for w, v in CLEAN_WATERS.items())
    now, before = c["rules"]["now"], c["rules"]["before"]
    lines = [
        "## 2. Clean dives, camera calibrated in air: never confidently wrong (issue 37)",
        "",
        f"{c['per_water']} dives per water ({waters}), the nominal slopes, the clean world's "
        "tolerances (chart 0.5 %, curves 0.5 nm, gains 0.5 %, drawn once per dive), a "
        "single-scattering veil, 8 photos per dive with their depths and distances told "
        "exactly: the first dive of each water with the issue's geometry (depths "
        f"{', '.join(f'{d:g}' for d in ISSUE_DEPTHS)} m x distances "
        f"{', '.join(f'{d:g}' for d in ISSUE_DISTANCES)} m), the others at random in 2-15 m x "
        "1-3 m. The camera was calibrated from the renderer's photo of the same chart in air "
        "(`measure.calibrate`; its per-patch term, median "
        f"{100 * c['calibration_patch_median']:.2g} %) and every dive fitted by "
        "`sca.joint.estimate_joint` with the budget `measure` gives a calibrated camera "
        "(`measure.budget_for`), under two rules: **before** (issue 37's state: the "
        "calibration's in-air per-patch term taken as the underwater one, all of it shared by "
        "the photos) and **now** (measure's default: the calibration's term as it is, its "
        "chart part shared by the photos and the rest each photo's own: decisions "
        "0053-patch-floor and 0054-patch-correlation). Each photo "
        "alone by `sca.estimate_batch` (the rule now). Coverage is tested two-sided but is not "
        "the criterion: this world is cleaner than the budget, so over-coverage is expected. "
        f"Seed {c['seed']}, {c['workers']} worker processes, {c['seconds']:.0f} s.",
        "",
        "| rule | reliable | **reliable with the truth outside** | joint C narrower than the "
        "median photo's | median width ratio |",
        "|---|---|---|---|---|",
    ]
    for rule in RULES:
        r = c["rules"][rule]
        lines.append(f"| {rule} | {r['reliable']} / {r['dives']} | {r['reliable_wrong']} | "
                     f"{r['narrower']} / {r['compared']} | {_num(r['width_ratio_median'])} |")
    lines += ["", "Reliable with the truth outside, by water (before -> now): " + "; ".join(
        f"{w} {before['by_water'][w]['reliable_wrong']} -> {now['by_water'][w]['reliable_wrong']}"
        f" of {now['by_water'][w]['dives']}" for w in CLEAN_WATERS) + ".", ""]
    for rule in RULES:
        lines += [f"Coverage and median joint half-widths, rule **{rule}**:", ""]
        lines += _coverage_table(c["rules"][rule]["coverage"]) + [""]
    lines += ["The issue's geometry, per water (C, a_CDOM(440) [95 %]; the calibration's "
              "per-patch term; the fitted CDOM slope, prior 0.014 ± 0.0025 nm^-1):", "",
              "| water | truth | rule | patch term (shared fraction) | C | a_CDOM | reliable | "
              "chi2 / dof | fitted S_CDOM |", "|---|---|---|---|---|---|---|---|---|"]
    for d in c["issue_dives"]:
        for rule in RULES:
            r = d[rule]
            lines.append(
                f"| {d['water']} | {d['truth']['chl']:g}, {d['truth']['cdom']:g} | {rule} | "
                f"{100 * r['patch']:.2g} % ({r['patch_correlation']:.2g}) | {r['chl']:.3g} "
                f"{_ci(r['chl_ci'])} | {r['cdom']:.3g} {_ci(r['cdom_ci'])} | {r['reliable']} | "
                f"{r['chi2']:.0f} / {r['dof']} | {_num(r['cdom_slope'], '{:.4f}')} |")
    lines += ["", "Acceptance (`clean_acceptance`): with the rule now no clean dive is reliable "
              "with the truth outside, and the joint C interval is narrower than the median "
              f"photo's in most dives: **{'holds' if clean_acceptance(c) else 'FAILS'}**.", ""]
    return lines


def report(s: dict, command: str, clean: dict | None = None) -> str:
    """DIVE.md's text: the budget-prior dives and (``clean``) the clean dives."""
    lines = [
        "# DIVE — one water from many photos, on a world we did not make",
        "",
        f"Generated by `{command}` (`experiments/dive_honesty.py`); do not edit by hand.",
        "",
        "Every photo below was rendered by the independent renderer "
        "(`experiments/independent_world.py`, no code shared with `forward`). Which coverage "
        "test applies where: dives drawn from the budget's own priors (section 1) are tested "
        "two-sided; the clean dives (section 2) are inside the budget and cleaner than it, so "
        "their criterion is that none is reliable with the truth outside; the dives with the "
        "reference shot (section 3) are drawn from the reference budget's priors and tested "
        "two-sided.",
        "",
    ] + _prior_section(s, command)
    if clean is not None:
        lines += _clean_section(clean)
    return "\n".join(lines)


def _write(path: Path, content: str):
    path.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(path, content)



# --------------------------------------------------------------------------- dives with the reference shot
#: Photos per dive (issue 47: a dive of six photos).
REF_PHOTOS = 6
#: Dives in the full run (about 17 s of CPU each: 8 dives ~70 s on 2 cores) and with
#: ``--quick``.
REF_DIVES_FULL, REF_DIVES_QUICK = 8, 4
#: The bands of the criterion and its target: joint 95 % relative half-width of c (issue 47).
REF_C_BANDS = ("c_443", "c_490", "c_555")
REF_C_TARGET = 0.05
#: The reference shot's exposure (the chart in air, not clipped).
REF_AIR_EXPOSURE = 0.7
#: The fits (labels): with the reference shot and the default budget on the same photos.
REF_WITH_REF, REF_DEFAULT = "with the reference", "default budget"
REF_LABELS = (REF_WITH_REF, REF_DEFAULT)
#: The bound's ablations: the reference budget with one term removed (label -> change).
REF_ABLATIONS = {"as stated": {}, "no sky change": {"sky": 0.0}, "no per-patch term": {"patch": 0.0},
             "depth and distance exact": {"depth": 0.0, "distance": 0.0}}


def draw_reference_dive(rng: np.random.Generator, photos: int = REF_PHOTOS) -> dict:
    """One dive's truth (:func:`draw_dive`, ``photos`` photos) with 'surface_mired' (the
    light of the reference shot), the photos' light changed within the sky's stated sd, and
    each photo's own per-patch factors scaled to the reference budget's own part."""
    from sca.budget import DEFAULT_UNCERTAIN
    from sca.reference import REFERENCE_MINUTES, REFERENCE_PATCH, sky_sd

    dive = draw_dive(rng, n=photos)
    surface = dive["options"]["daylight_mired"]
    change = _sky_change(rng, np.array([surface]), sky_sd(REFERENCE_MINUTES))[0]
    scale = REFERENCE_PATCH / float(DEFAULT_UNCERTAIN["patch"])
    return {**dive, "surface_mired": surface,
            "options": {**dive["options"], "daylight_mired": float(surface + change)},
            "photo_factors": 1 + (dive["photo_factors"] - 1) * scale}


def render_reference_dive(dive: dict, rng: np.random.Generator) -> dict:
    """The photos (:func:`experiments.dive_honesty.render_dive`) and the reference shot's
    measured light 'light' (:class:`sca.reference.Light`)."""
    from sca.reference import measure_light

    photos_rng, air_rng = rng.spawn(2)
    out = render_dive(dive, photos_rng)
    air = iw.render_calibration(rng=air_rng, **{**dive["options"], "exposure": REF_AIR_EXPOSURE,
                                                "daylight_mired": dive["surface_mired"]})
    out["light"] = measure_light(np.maximum(air["rgb"], 0.0), air["sigma"])
    return out


def fit_reference_dive(dive: dict, rendered: dict, full: bool = True) -> dict:
    """The joint fit with the reference and (``full``) with the default budget (plain numbers
    of :func:`experiments.dive_honesty.fit_dive`'s kind) and the bounds (:func:`reference_bounds`)."""
    from sca.reference import with_reference

    light = rendered["light"]
    out = {"truth": rendered["truth"], "light": light.to_dict(),
           "surface_mired": dive["surface_mired"],
           "photo_mired": dive["options"]["daylight_mired"], "fits": {}}
    for label, uncertain in ((REF_WITH_REF, with_reference(None, light)), (REF_DEFAULT, None))[
            :len(REF_LABELS) if full else 1]:
        out["fits"][label] = joint_fit(dive, rendered, uncertain)
    if full:
        out["bounds"] = reference_bounds(dive, rendered, with_reference(None, light))
    return out


def _ref_gains(dive, rendered, setup) -> np.ndarray:
    """Each photo's exposure gain: the rendered values over the model's at the truth
    (least squares)."""
    from sca.model import ChartModel

    mdl = ChartModel(setup)
    out = []
    for i, M in enumerate(rendered["rgb"]):
        G = mdl.predict({"chl": dive["chl"], "cdom": dive["cdom"], "depth": dive["depth"][i],
                         "distance": dive["distance"][i]}, jacobian=False).values
        out.append(float(np.dot(M.reshape(-1), G) / np.dot(G, G)))
    return np.array(out)


def _ref_ablated(uncertain: dict, change: dict) -> dict:
    """The reference budget with a term removed: 'sky' the daylight's sd down to the shot's
    own fit, the others to 0."""
    out = dict(uncertain)
    for k, v in change.items():
        if k == "sky":
            out["daylight"] = {**out["daylight"], "sd": out["daylight"]["sd_fit"]}
        else:
            out[k] = v
    return out


def reference_bounds(dive: dict, rendered: dict, uncertain: dict) -> dict:
    """ablation label -> band -> the Cramér-Rao bound's 95 % relative half-width of c
    (1.96 sd / c, :func:`sca.joint.dive_precision` at the true water and geometry, the photos'
    noise and gains) under the reference budget with one term removed (:data:`REF_ABLATIONS`)."""
    import forward
    from forward.imaging import resolve_setup
    from sca.joint import dive_precision

    setup = resolve_setup(None, forward.DEFAULT_CAMERA, None, None, None)
    gain = _ref_gains(dive, rendered, setup)
    out = {}
    for label, change in REF_ABLATIONS.items():
        p = dive_precision(dive["chl"], dive["cdom"], depth=dive["depth"],
                           distance=dive["distance"], sigma=rendered["sigma"], setup=setup,
                           gain=gain, uncertain=_ref_ablated(uncertain, change))
        out[label] = {b: 1.96 * p["quantity_sd"][b] / p["quantities"][b] for b in REF_C_BANDS}
    return out


def one_reference_dive(args) -> dict:
    """(dive, seed, full) -> the dive rendered and fitted (:func:`fit_reference_dive`; a worker's task), its
    time 'dive_s'."""
    dive, seed, full = args
    t0 = time.perf_counter()
    out = fit_reference_dive(dive, render_reference_dive(dive, np.random.default_rng(seed)), full)
    return {**out, "dive_s": time.perf_counter() - t0}


def run_reference(dives: int = REF_DIVES_FULL, seed: int = 0, workers: int | None = None,
        photos: int = REF_PHOTOS, full: bool = True) -> dict:
    """Draw, render and fit ``dives`` dives of ``photos`` photos with a reference shot
    (``workers`` processes; ``full``: the default budget's fit and the bounds too)."""
    import os

    rng = np.random.default_rng([seed, 47, 60])
    truth = [draw_reference_dive(rng, photos) for _ in range(dives)]
    seeds = rng.integers(0, 2 ** 31, dives)
    workers = workers or min(2, os.cpu_count() or 1)
    t0 = time.perf_counter()
    fits = _pool_map([(t, int(s), full) for t, s in zip(truth, seeds)], workers, one_reference_dive)
    return {"fits": fits, "seconds": time.perf_counter() - t0, "dives": dives, "seed": seed,
            "workers": workers, "photos": photos}


def _ref_half_widths(fits, label) -> dict:
    """band -> the median joint 95 % relative half-width among the reliable fits, and the
    fraction within :data:`REF_C_TARGET`."""
    out = {}
    for b in REF_C_BANDS:
        h = [(f["fits"][label]["intervals"][b][1] - f["fits"][label]["intervals"][b][0]) / 2
             / f["truth"][b] for f in fits
             if f["fits"][label]["reliable"] and f["fits"][label]["intervals"].get(b)]
        out[b] = {"median": float(np.median(h)) if h else None,
                  "within": int(sum(x <= REF_C_TARGET for x in h)), "n": len(h)}
    return out


def summarise_reference(out: dict) -> dict:
    """Per fit: reliable, coverage (two-sided, as the budget-prior dives') and
    the c bands' half-widths against :data:`REF_C_TARGET`; the bounds' medians per ablation; the
    lights' errors; time per dive (the fits and bounds :func:`run_reference` made)."""
    fits = out["fits"]
    per = {}
    for label in [lab for lab in REF_LABELS if lab in fits[0]["fits"]]:
        rel = [(f["truth"], f["fits"][label]) for f in fits if f["fits"][label]["reliable"]]
        per[label] = {"reliable": len(rel), "coverage": _coverage(rel, "two-sided"),
                      "c_half_widths": _ref_half_widths(fits, label)}
    bound = {a: {b: float(np.median([f["bounds"][a][b] for f in fits])) for b in REF_C_BANDS}
             for a in REF_ABLATIONS} if "bounds" in fits[0] else None
    return {"dives": len(fits), "photos": out["photos"], "fits": per, "bounds": bound,
            "light_error_median": float(np.median([abs(f["light"]["centre_mired"]
                                                       - f["surface_mired"]) for f in fits])),
            "sky_change_median": float(np.median([abs(f["photo_mired"] - f["surface_mired"])
                                                  for f in fits])),
            "dive_s_median": float(np.median([f["dive_s"] for f in fits])),
            "seconds": out["seconds"], "workers": out["workers"], "seed": out["seed"]}


def reference_target_met(s: dict) -> bool:
    """Issue 47's dive criterion: with the reference, every c band's median half-width within
    :data:`REF_C_TARGET`."""
    hw = s["fits"][REF_WITH_REF]["c_half_widths"]
    return all(hw[b]["median"] is not None and hw[b]["median"] <= REF_C_TARGET for b in REF_C_BANDS)


def reference_covered(s: dict) -> bool:
    """The reference fits' coverage holds two-sided for every tested quantity
    (as the budget-prior dives')."""
    return _tested_ok(s["fits"][REF_WITH_REF]["coverage"])


def _ref_band_row(label, hw) -> str:
    return f"| {label} | " + " | ".join(
        f"±{_pct(hw[b]['median'], 1)} ({hw[b]['within']} / {hw[b]['n']} within)"
        for b in REF_C_BANDS) + " |"


def reference_section(s: dict) -> list[str]:
    """DIVE.md's section 3: coverage with and without the reference, the c bands' half-widths
    against :data:`REF_C_TARGET` and the bound that limits them."""
    from sca.reference import REFERENCE_MINUTES, REFERENCE_PATCH, sky_sd

    ref = s["fits"][REF_WITH_REF]
    head = "| fit | " + " | ".join(f"{b.replace('_', '(')}) half-width" for b in REF_C_BANDS) + " |"
    lines = [
        f"## 3. Dives of {s['photos']} photos with the reference shot (issue 47)",
        "",
        f"{s['dives']} budget-prior dives of {s['photos']} photos (as section 1, the daylight "
        "drawn from the 30-mired prior), each with a reference shot: the same chart and camera "
        "photographed in air under the surface light by the independent renderer and the light "
        "measured (`sca.reference.measure_light`, with the chart's response; median error "
        f"{s['light_error_median']:.2g} mired); the sky then changed within its stated sd "
        f"({sky_sd(REFERENCE_MINUTES):.2g} mired at {REFERENCE_MINUTES:g} min; median change "
        f"{s['sky_change_median']:.2g} mired) and every photo rendered under the changed light. "
        "Each photo's own part of the per-patch error is the reference budget's (sd "
        f"sqrt(1 - rho) x {100 * REFERENCE_PATCH:g} %: what the shot cannot see). Each dive "
        "fitted by `sca.joint.estimate_joint` with `uncertain=with_reference(None, light)` and, "
        "on the same photos, with the default budget. Coverage two-sided. Seed "
        f"{s['seed']}, {s['workers']} worker processes, {s['seconds']:.0f} s; a dive (render, "
        f"shot, both fits, bounds) took {s['dive_s_median']:.0f} s (median).",
        "",
    ]
    for label in REF_LABELS:
        f = s["fits"][label]
        lines += [f"**{label}**: {f['reliable']} / {s['dives']} reliable.", ""]
        lines += _coverage_table(f["coverage"]) + [""]
    lines += [f"Issue 47's target: c(443/490/555) within ±{100 * REF_C_TARGET:g} % (joint 95 % "
              "relative half-width, median of the reliable dives):", "", head,
              "|---|" + "---|" * len(REF_C_BANDS)]
    lines += [_ref_band_row(label, s["fits"][label]["c_half_widths"]) for label in REF_LABELS]
    lines += ["", "The bound (`sca.joint.dive_precision` at each dive's true water and geometry, "
              "its photos' noise, the reference budget; median of the dives' 1.96 sd / c), as "
              "stated and with one term removed:", "", "| budget | " + " | ".join(
                  b.replace("_", "(") + ")" for b in REF_C_BANDS) + " |",
              "|---|" + "---|" * len(REF_C_BANDS)]
    lines += [f"| {a} | " + " | ".join(f"±{_pct(v[b], 1)}" for b in REF_C_BANDS) + " |"
              for a, v in s["bounds"].items()]
    met, ok = reference_target_met(s), reference_covered(s)
    lines += ["", f"Coverage with the reference (two-sided, every quantity): "
              f"**{'holds' if ok else 'FAILS'}**. The ±{100 * REF_C_TARGET:g} % target: "
              f"**{'met' if met else 'not met'}** (median half-width over the bound as stated: "
              + ", ".join(f"{b.replace('_', '(')}) {_ref_ratio(ref, s, b)}" for b in REF_C_BANDS)
              + f"; the bound's largest term: removing it, \"{_ref_largest(s)}\", narrows it most"
              ").", ""]
    return lines


def _ref_largest(s) -> str:
    """The ablation of :data:`REF_ABLATIONS` whose bound at 443-555 nm is the smallest."""
    cut = {a: sum(v.values()) for a, v in s["bounds"].items() if a != "as stated"}
    return min(cut, key=cut.get)


def _ref_ratio(ref, s, band) -> str:
    m = ref["c_half_widths"][band]["median"]
    return "-" if m is None else f"{m / s['bounds']['as stated'][band]:.1f} x"


def main(argv=None) -> int:
    """Run the experiment and write DIVE.md and benchmarks/dive.json (whole or not at all)."""
    ap = argparse.ArgumentParser(prog="python -m experiments.dive_honesty", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dives", type=int, default=None,
                    help=f"one-water budget-prior dives (default {DIVES_FULL})")
    ap.add_argument("--clean", type=int, default=None,
                    help=f"clean dives per water (default {CLEAN_DIVES_FULL})")
    ap.add_argument("--reference", type=int, default=None,
                    help="dives with the reference shot (default "
                    "REF_DIVES_FULL)")
    ap.add_argument("--quick", action="store_true",
                    help=f"{DIVES_QUICK} dives, {CLEAN_DIVES_QUICK} clean dives per water, "
                    "REF_DIVES_QUICK with the reference shot")
    ap.add_argument("--seed", type=int, default=SEED)
    ap.add_argument("--out", default=str(ROOT / "DIVE.md"))
    ap.add_argument("--json", default=str(ROOT / "benchmarks" / "dive.json"))
    ap.add_argument("--strict", action="store_true", help="exit 1 when the acceptance fails")
    ap.add_argument("--no-photos", action="store_true",
                    help="skip the acceptance dive of whole photographs (experiments.dive_acceptance)")
    args = ap.parse_args(argv)
    dives = args.dives or (DIVES_QUICK if args.quick else DIVES_FULL)
    per_water = args.clean or (CLEAN_DIVES_QUICK if args.quick else CLEAN_DIVES_FULL)
    with_ref = args.reference or (REF_DIVES_QUICK if args.quick else REF_DIVES_FULL)
    if dives < 1 or per_water < 1 or with_ref < 1:
        print("--dives, --clean, --reference: must be >= 1", file=sys.stderr)
        return 2
    s = summarise(run(dives, args.seed))
    c = summarise_clean(run_clean(per_water, args.seed))
    r = summarise_reference(run_reference(with_ref, args.seed))
    command = "python -m experiments.dive_honesty" + "".join(
        f" --{k} {v}" for k, v in (("dives", args.dives), ("clean", args.clean),
                                   ("reference", args.reference)) if v) + (
        " --quick" if args.quick else "")
    text = report(s, command, c) + "\n".join(reference_section(r))
    ok = honest(s) and clean_acceptance(c) and reference_covered(r)
    s["clean"], s["reference"] = c, r
    if not args.no_photos:
        from . import dive_acceptance

        acc = dive_acceptance.run(seed=args.seed)
        text += "\n" + dive_acceptance.report(acc, command)
        s["acceptance_dive"] = {k: [bool(v[0]), v[1]] for k, v in
                                dive_acceptance.checks(acc).items()}
        ok = ok and all(v[0] for v in s["acceptance_dive"].values())
    _write(Path(args.json), json.dumps(s, indent=1, default=_plain) + "\n")
    _write(Path(args.out), text)
    print(text)
    return 1 if args.strict and not ok else 0


def _plain(x):
    """JSON of numpy values."""
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, np.generic):
        return x.item()
    raise TypeError(f"not JSON: {type(x).__name__}")


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
