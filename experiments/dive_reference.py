"""Dives with the surface reference shot (DIVE.md section 3; issue 47's dive criterion).

Each dive is a budget-prior dive (:func:`experiments.dive_worlds.draw_dive`, :data:`PHOTOS`
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

Criterion (issue 47): c(443/490/555) within ±5 % (joint 95 % half-width, :data:`C_TARGET`)
with the truth inside at the nominal rate (two-sided). Where the widths miss the target,
:func:`bounds` gives the Cramér-Rao bound of each dive (:func:`sca.joint.dive_precision` at the
truth, with the reference budget) as stated and with one term at a time removed
(:data:`ABLATIONS`): what limits it.
"""

from __future__ import annotations

import time

import numpy as np

from . import independent_world as iw
from .dive_honesty import (_coverage, _coverage_table, _pct, _pool_map, _tested_ok, joint_fit,
                           render_dive)
from .dive_worlds import draw_dive
from .honesty import _sky_change

__all__ = ["ABLATIONS", "AIR_EXPOSURE", "C_BANDS", "C_TARGET", "DIVES_FULL", "DIVES_QUICK",
           "LABELS", "PHOTOS", "bounds", "covered", "draw", "fit", "one", "render", "run",
           "section", "summarise", "target_met"]

#: Photos per dive (issue 47: a dive of six photos).
PHOTOS = 6
#: Dives in the full run (about 17 s of CPU each: 8 dives ~70 s on 2 cores) and with
#: ``--quick``.
DIVES_FULL, DIVES_QUICK = 8, 4
#: The bands of the criterion and its target: joint 95 % relative half-width of c (issue 47).
C_BANDS = ("c_443", "c_490", "c_555")
C_TARGET = 0.05
#: The reference shot's exposure (the chart in air, not clipped).
AIR_EXPOSURE = 0.7
#: The fits (labels): with the reference shot and the default budget on the same photos.
WITH_REF, DEFAULT = "with the reference", "default budget"
LABELS = (WITH_REF, DEFAULT)
#: The bound's ablations: the reference budget with one term removed (label -> change).
ABLATIONS = {"as stated": {}, "no sky change": {"sky": 0.0}, "no per-patch term": {"patch": 0.0},
             "depth and distance exact": {"depth": 0.0, "distance": 0.0}}


def draw(rng: np.random.Generator, photos: int = PHOTOS) -> dict:
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


def render(dive: dict, rng: np.random.Generator) -> dict:
    """The photos (:func:`experiments.dive_honesty.render_dive`) and the reference shot's
    measured light 'light' (:class:`sca.reference.Light`)."""
    from sca.reference import measure_light

    photos_rng, air_rng = rng.spawn(2)
    out = render_dive(dive, photos_rng)
    air = iw.render_calibration(rng=air_rng, **{**dive["options"], "exposure": AIR_EXPOSURE,
                                                "daylight_mired": dive["surface_mired"]})
    out["light"] = measure_light(np.maximum(air["rgb"], 0.0), air["sigma"])
    return out


def fit(dive: dict, rendered: dict, full: bool = True) -> dict:
    """The joint fit with the reference and (``full``) with the default budget (plain numbers
    of :func:`experiments.dive_honesty.fit_dive`'s kind) and the bounds (:func:`bounds`)."""
    from sca.reference import with_reference

    light = rendered["light"]
    out = {"truth": rendered["truth"], "light": light.to_dict(),
           "surface_mired": dive["surface_mired"],
           "photo_mired": dive["options"]["daylight_mired"], "fits": {}}
    for label, uncertain in ((WITH_REF, with_reference(None, light)), (DEFAULT, None))[
            :len(LABELS) if full else 1]:
        out["fits"][label] = joint_fit(dive, rendered, uncertain)
    if full:
        out["bounds"] = bounds(dive, rendered, with_reference(None, light))
    return out


def _gains(dive, rendered, setup) -> np.ndarray:
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


def _ablated(uncertain: dict, change: dict) -> dict:
    """The reference budget with a term removed: 'sky' the daylight's sd down to the shot's
    own fit, the others to 0."""
    out = dict(uncertain)
    for k, v in change.items():
        if k == "sky":
            out["daylight"] = {**out["daylight"], "sd": out["daylight"]["sd_fit"]}
        else:
            out[k] = v
    return out


def bounds(dive: dict, rendered: dict, uncertain: dict) -> dict:
    """ablation label -> band -> the Cramér-Rao bound's 95 % relative half-width of c
    (1.96 sd / c, :func:`sca.joint.dive_precision` at the true water and geometry, the photos'
    noise and gains) under the reference budget with one term removed (:data:`ABLATIONS`)."""
    import forward
    from forward.imaging import resolve_setup
    from sca.joint import dive_precision

    setup = resolve_setup(None, forward.DEFAULT_CAMERA, None, None, None)
    gain = _gains(dive, rendered, setup)
    out = {}
    for label, change in ABLATIONS.items():
        p = dive_precision(dive["chl"], dive["cdom"], depth=dive["depth"],
                           distance=dive["distance"], sigma=rendered["sigma"], setup=setup,
                           gain=gain, uncertain=_ablated(uncertain, change))
        out[label] = {b: 1.96 * p["quantity_sd"][b] / p["quantities"][b] for b in C_BANDS}
    return out


def one(args) -> dict:
    """(dive, seed, full) -> the dive rendered and fitted (:func:`fit`; a worker's task), its
    time 'dive_s'."""
    dive, seed, full = args
    t0 = time.perf_counter()
    out = fit(dive, render(dive, np.random.default_rng(seed)), full)
    return {**out, "dive_s": time.perf_counter() - t0}


def run(dives: int = DIVES_FULL, seed: int = 0, workers: int | None = None,
        photos: int = PHOTOS, full: bool = True) -> dict:
    """Draw, render and fit ``dives`` dives of ``photos`` photos with a reference shot
    (``workers`` processes; ``full``: the default budget's fit and the bounds too)."""
    import os

    rng = np.random.default_rng([seed, 47, 60])
    truth = [draw(rng, photos) for _ in range(dives)]
    seeds = rng.integers(0, 2 ** 31, dives)
    workers = workers or min(2, os.cpu_count() or 1)
    t0 = time.perf_counter()
    fits = _pool_map([(t, int(s), full) for t, s in zip(truth, seeds)], workers, one)
    return {"fits": fits, "seconds": time.perf_counter() - t0, "dives": dives, "seed": seed,
            "workers": workers, "photos": photos}


def _half_widths(fits, label) -> dict:
    """band -> the median joint 95 % relative half-width among the reliable fits, and the
    fraction within :data:`C_TARGET`."""
    out = {}
    for b in C_BANDS:
        h = [(f["fits"][label]["intervals"][b][1] - f["fits"][label]["intervals"][b][0]) / 2
             / f["truth"][b] for f in fits
             if f["fits"][label]["reliable"] and f["fits"][label]["intervals"].get(b)]
        out[b] = {"median": float(np.median(h)) if h else None,
                  "within": int(sum(x <= C_TARGET for x in h)), "n": len(h)}
    return out


def summarise(out: dict) -> dict:
    """Per fit: reliable, coverage (two-sided, as the budget-prior dives') and
    the c bands' half-widths against :data:`C_TARGET`; the bounds' medians per ablation; the
    lights' errors; time per dive (the fits and bounds :func:`run` made)."""
    fits = out["fits"]
    per = {}
    for label in [lab for lab in LABELS if lab in fits[0]["fits"]]:
        rel = [(f["truth"], f["fits"][label]) for f in fits if f["fits"][label]["reliable"]]
        per[label] = {"reliable": len(rel), "coverage": _coverage(rel, "two-sided"),
                      "c_half_widths": _half_widths(fits, label)}
    bound = {a: {b: float(np.median([f["bounds"][a][b] for f in fits])) for b in C_BANDS}
             for a in ABLATIONS} if "bounds" in fits[0] else None
    return {"dives": len(fits), "photos": out["photos"], "fits": per, "bounds": bound,
            "light_error_median": float(np.median([abs(f["light"]["centre_mired"]
                                                       - f["surface_mired"]) for f in fits])),
            "sky_change_median": float(np.median([abs(f["photo_mired"] - f["surface_mired"])
                                                  for f in fits])),
            "dive_s_median": float(np.median([f["dive_s"] for f in fits])),
            "seconds": out["seconds"], "workers": out["workers"], "seed": out["seed"]}


def target_met(s: dict) -> bool:
    """Issue 47's dive criterion: with the reference, every c band's median half-width within
    :data:`C_TARGET`."""
    hw = s["fits"][WITH_REF]["c_half_widths"]
    return all(hw[b]["median"] is not None and hw[b]["median"] <= C_TARGET for b in C_BANDS)


def covered(s: dict) -> bool:
    """The reference fits' coverage holds two-sided for every tested quantity
    (as the budget-prior dives')."""
    return _tested_ok(s["fits"][WITH_REF]["coverage"])


def _band_row(label, hw) -> str:
    return f"| {label} | " + " | ".join(
        f"±{_pct(hw[b]['median'], 1)} ({hw[b]['within']} / {hw[b]['n']} within)"
        for b in C_BANDS) + " |"


def section(s: dict) -> list[str]:
    """DIVE.md's section 3: coverage with and without the reference, the c bands' half-widths
    against :data:`C_TARGET` and the bound that limits them."""
    from sca.reference import REFERENCE_MINUTES, REFERENCE_PATCH, sky_sd

    ref = s["fits"][WITH_REF]
    head = "| fit | " + " | ".join(f"{b.replace('_', '(')}) half-width" for b in C_BANDS) + " |"
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
    for label in LABELS:
        f = s["fits"][label]
        lines += [f"**{label}**: {f['reliable']} / {s['dives']} reliable.", ""]
        lines += _coverage_table(f["coverage"]) + [""]
    lines += [f"Issue 47's target: c(443/490/555) within ±{100 * C_TARGET:g} % (joint 95 % "
              "relative half-width, median of the reliable dives):", "", head,
              "|---|" + "---|" * len(C_BANDS)]
    lines += [_band_row(label, s["fits"][label]["c_half_widths"]) for label in LABELS]
    lines += ["", "The bound (`sca.joint.dive_precision` at each dive's true water and geometry, "
              "its photos' noise, the reference budget; median of the dives' 1.96 sd / c), as "
              "stated and with one term removed:", "", "| budget | " + " | ".join(
                  b.replace("_", "(") + ")" for b in C_BANDS) + " |",
              "|---|" + "---|" * len(C_BANDS)]
    lines += [f"| {a} | " + " | ".join(f"±{_pct(v[b], 1)}" for b in C_BANDS) + " |"
              for a, v in s["bounds"].items()]
    met, ok = target_met(s), covered(s)
    lines += ["", f"Coverage with the reference (two-sided, every quantity): "
              f"**{'holds' if ok else 'FAILS'}**. The ±{100 * C_TARGET:g} % target: "
              f"**{'met' if met else 'not met'}** (median half-width over the bound as stated: "
              + ", ".join(f"{b.replace('_', '(')}) {_ratio(ref, s, b)}" for b in C_BANDS)
              + f"; the bound's largest term: removing it, \"{_largest(s)}\", narrows it most"
              ").", ""]
    return lines


def _largest(s) -> str:
    """The ablation of :data:`ABLATIONS` whose bound at 443-555 nm is the smallest."""
    cut = {a: sum(v.values()) for a, v in s["bounds"].items() if a != "as stated"}
    return min(cut, key=cut.get)


def _ratio(ref, s, band) -> str:
    m = ref["c_half_widths"][band]["median"]
    return "-" if m is None else f"{m / s['bounds']['as stated'][band]:.1f} x"
