"""HONESTY.md's reference-shot worlds: the light measured in air at the site, then the dive.

Issue 47, item 6. Each chart of a world (clear and coastal water,
:data:`experiments.honesty.C_WATERS`; depths 1-15 m, distances 0.5-3 m, the exposure unknown;
the other nuisances of the default budget drawn from their priors as in the ``priors`` world):

1. the surface daylight is drawn from the default budget's 30-mired prior;
2. the reference shot: the same chart and camera (its drawn channel gains, curve shifts and
   per-patch reflectances) photographed in air under that light by the independent renderer
   (:func:`experiments.independent_world.render_calibration`, with its noise), and the light
   fitted by :func:`sca.reference.measure_light`;
3. the sky changes between the shot and the dive: ``reference`` by a draw within the stated sd
   (:func:`sca.reference.sky_sd` at :data:`sca.reference.REFERENCE_MINUTES`), ``sky-beyond`` by
   :data:`BEYOND_SD` times the stated sd (sqrt(sd_fit^2 + sd_sky^2)), either sign;
4. the chart underwater rendered under the changed light and fitted with
   ``uncertain=with_reference(None, lights)`` (one batch, each chart its own measured prior) and, on
   the very same photos, with the default budget (``reference`` only).

:func:`run_reference` renders and fits; :func:`reference_text` is HONESTY.md's section.
Each world's coverage test is :func:`experiments.honesty.test_of` of its name (``reference``:
two-sided, inside its stated budget; ``sky-beyond``: one-sided, outside it); for
``sky-beyond`` honest means each chart flagged (not reliable) or covered, and the report says
how many are neither.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from sca.reference import REFERENCE_MINUTES, measure_light, sky_sd, with_reference

from . import honesty as h
from . import independent_world as iw

__all__ = ["BEYOND_SD", "DTAU_BANDS", "DTAU_TARGET", "ILLUMINANT_SHOTS", "REFERENCE_LABELS",
           "dtau_half_widths", "illuminant_check", "reference_text", "run_reference"]

#: The sky's change of the ``sky-beyond`` world, in units of the stated sd (uniform).
BEYOND_SD = (3.0, 4.0)
#: The bands of the optical depth's criterion and its target: the 95 % half-width of
#: tau = c (depth + distance) at most 0.10 (issue 47).
DTAU_BANDS = ("443", "490", "555")
DTAU_TARGET = 0.10
#: Reference shots per light of :func:`illuminant_check` (each a render and a fit: ~0.5 s)
ILLUMINANT_SHOTS = 20
#: The fits of the reference worlds (row labels): the light and the chart's response measured
#: in air, the light alone (decision 0069-reference-shot) and the default budget.
WITH_REF, LIGHT_ONLY, DEFAULT = "with the reference", "the light only", "default budget"
REFERENCE_LABELS = (WITH_REF, LIGHT_ONLY, DEFAULT)
#: The renderer's per-chart draws the reference shot shares with the photo underwater.
SHARED_DRAWS = ("camera_shift_nm", "camera_gains", "reflectance_factors")


def _world():
    """The ``priors`` world (the budget's own priors) with the daylight of the conditions."""
    priors = {w.name: w for w in h.worlds()}["priors"]
    return dataclasses.replace(priors, name="reference", group="reference",
                               draw_daylight=True)


def _in_range(mired) -> np.ndarray:
    """Inside the daylight series (4000-25 000 K) as a shift from D65."""
    lo, hi = 1e6 / 25000.0 - 1e6 / iw.D65_CCT, 1e6 / 4000.0 - 1e6 / iw.D65_CCT
    return (mired > lo) & (mired < hi)


def _sky_change(rng, surface, sd) -> np.ndarray:
    """N(0, sd) changes of ``surface`` (mired), redrawn where the light would leave the
    daylight series."""
    out = rng.normal(0.0, sd, surface.size)
    while not (bad := ~_in_range(surface + out)).all() and bad.any():
        out[bad] = rng.normal(0.0, sd, int(bad.sum()))
    return out


def _beyond(rng, surface, stated) -> np.ndarray:
    """Changes of :data:`BEYOND_SD` x ``stated`` sd, either sign (the other where the first
    would leave the daylight series)."""
    size = rng.uniform(*BEYOND_SD, surface.size) * stated
    sign = rng.choice([-1.0, 1.0], surface.size)
    return np.where(_in_range(surface + sign * size), sign, -sign) * size


def _air_shots(world, cond, drawn, rng) -> list:
    """The reference shot of every chart: in air, under the surface light, the same camera and
    chart as the photo underwater; the light fitted by :func:`sca.reference.measure_light`."""
    lights = []
    for i, stream in enumerate(rng.spawn(cond["chl"].size)):
        opts = {**h.CLEAN_OPTIONS, **world.options, "exposure": float(cond["exposure"][i]),
                "daylight_mired": float(cond["surface_mired"][i])}
        opts.update({k: tuple(np.atleast_1d(drawn[i][k])) for k in SHARED_DRAWS})
        air = iw.render_calibration(rng=stream, **opts)
        lights.append(measure_light(np.maximum(air["rgb"], 0.0), air["sigma"]))
    return lights


def illuminant_check(n: int = ILLUMINANT_SHOTS, seed: int = h.SEED) -> dict:
    """What a reference shot says of the ``wrong_illuminant`` world's light.

    ``n`` charts photographed in air by the independent renderer (the clean world's tolerances,
    exposure 0.2-0.9) under :data:`experiments.honesty.WRONG_ILLUMINANT` and, for contrast,
    under D65, each light fitted by :func:`sca.reference.measure_light` and judged by
    :func:`sca.reference.check_daylight` (``uw3p measure --reference`` refuses a light it
    rejects).

    Returns
    -------
    dict
        light name -> {'n', 'refused' (count), 'cct_median' (K), 'chi2_dof_median'}.
    """
    from sca.reference import check_daylight

    from forward.errors import InputError

    rng = np.random.default_rng([seed, 50, 5])
    out = {}
    for light in (h.WRONG_ILLUMINANT, "D65"):
        refused, cct, chi2 = 0, [], []
        for stream in rng.spawn(n):
            opts = {**h.CLEAN_OPTIONS, "illuminant": light,
                    "exposure": float(stream.uniform(*h.EXPOSURE_RANGE))}
            air = iw.render_calibration(rng=stream, **opts)
            lt = measure_light(np.maximum(air["rgb"], 0.0), air["sigma"])
            cct.append(lt.cct)
            chi2.append(lt.chi2_dof)
            try:
                check_daylight(lt)
            except InputError:
                refused += 1
        out[light] = {"n": n, "refused": refused, "cct_median": float(np.median(cct)),
                      "chi2_dof_median": float(np.median(chi2))}
    return out


def dtau_half_widths(est, rendered) -> dict:
    """band -> (N,) 95 % half-width of the optical depth tau at the band: the estimate's
    'tau_<band>' interval where :func:`sca.derived.quantity_names` has it, else c's interval
    times the told depth + distance; and 'source' saying which."""
    qi = est.quantity_intervals
    told = np.asarray(rendered["depth"], float) + np.asarray(rendered["distance"], float)
    own = all(f"tau_{b}" in qi for b in DTAU_BANDS)
    out = {"source": "tau's interval" if own else "c's interval x (told depth + distance)"}
    for b in DTAU_BANDS:
        ci = np.asarray(qi[f"tau_{b}"] if own else qi[f"c_{b}"], float)
        out[b] = (ci[:, 1] - ci[:, 0]) / 2.0 * (1.0 if own else told)
    return out


def _flagged_or_covered(est, truth) -> dict:
    """Per quantity: charts covered (reliable, truth inside), flagged (not reliable) and
    neither (reliable and missed: confidently wrong)."""
    rel = np.asarray(est.reliable, bool)
    out = {}
    for k, (ci, t) in h._estimates(est, truth).items():
        inside = h._inside(ci, t)
        out[k] = {"covered": int((inside & rel).sum()), "flagged": int((~rel).sum()),
                  "neither": int((~inside & rel).sum())}
    return out


def _summary(est, cond, rendered, test) -> dict:
    s = h.summarise(est, cond, rendered["depth"] + rendered["distance"], rendered["truth"],
                    test)
    dtau = dtau_half_widths(est, rendered)
    rel = np.asarray(est.reliable, bool)
    s["dtau_source"] = dtau.pop("source")
    s["median_dtau95"] = {b: h._median(v[rel]) for b, v in dtau.items()}
    s["flagged_or_covered"] = _flagged_or_covered(est, rendered["truth"])
    return s


def _fresh(seq) -> np.random.Generator:
    """A generator of ``seq``'s own state (its children the same every time)."""
    return np.random.default_rng(np.random.SeedSequence(seq.entropy, spawn_key=seq.spawn_key))


def _render(world, cond, rng):
    """:func:`experiments.honesty.render_set` keeping each chart's shared draws."""
    return h.render_set(world, cond, rng, keep=SHARED_DRAWS)


def _draw_set(water, n, rng):
    """One water type's charts: (world, conditions, the photos underwater, the reference
    shots' lights (with the chart's response), seconds spent in air, the seeds of sky-beyond
    and of the photos)."""
    world = _world()
    cond_seq, air_seq, sky_seq, beyond_seq, uw_seq = rng.bit_generator.seed_seq.spawn(5)
    cond = h._water_conditions(np.random.default_rng(cond_seq), n, water)
    cond["surface_mired"] = cond["daylight_mired"]
    cond["daylight_mired"] = cond["surface_mired"] + _sky_change(
        np.random.default_rng(sky_seq), cond["surface_mired"], sky_sd(REFERENCE_MINUTES))
    rendered = _render(world, cond, _fresh(uw_seq))
    t0 = time.perf_counter()
    lights = _air_shots(world, cond, rendered["drawn"], np.random.default_rng(air_seq))
    return world, cond, rendered, lights, time.perf_counter() - t0, (beyond_seq, uw_seq)


def _light_only(lights) -> list:
    """The lights without the chart's response (the plain-light reference, decision
    0069-reference-shot)."""
    return [dataclasses.replace(lt, factors=None, factors_sd=None) for lt in lights]


def _water_set(water, n, rng, log, beyond=True):
    """Render and fit one water type's charts in both worlds (``beyond``: and sky-beyond)."""
    world, cond, rendered, lights, air_s, (beyond_seq, uw_seq) = _draw_set(water, n, rng)
    budgets = with_reference(None, lights, REFERENCE_MINUTES)
    test = h.test_of("reference")
    out = {"reference": {
        label: _summary(h.fit_set(rendered, budget), cond, rendered, test)
        for label, budget in ((WITH_REF, budgets), (LIGHT_ONLY, with_reference(
            None, _light_only(lights), REFERENCE_MINUTES)), (DEFAULT, None))}}
    stated = budgets["daylight"]["sd"]
    out["lights"] = {"sd_fit_median": float(np.median([lt.sd for lt in lights])),
                     "error_median_abs": float(np.median(np.abs(
                         [lt.centre for lt in lights] - cond["surface_mired"]))),
                     "sd_stated_median": float(np.median(stated)),
                     "sky_change_sd": sky_sd(REFERENCE_MINUTES)}
    out["render_s"] = rendered["render_s"] + air_s  # sky-beyond's renders: in 'elapsed_s'

    if beyond:
        out["sky-beyond"] = _sky_beyond(world, cond, budgets, beyond_seq, uw_seq)
    if log:
        log(f"reference/{water}: " + "; ".join(
            f"{w} {lab} reliable {s['reliable']}/{s['n']} fit {s['fit_s']:.1f} s"
            for w in ("reference", "sky-beyond") for lab, s in out.get(w, {}).items()))
    return out


def _sky_beyond(world, cond, budgets, beyond_seq, uw_seq) -> dict:
    """The same charts (camera draws and noise: the same streams) under a sky changed by
    :data:`BEYOND_SD` x each chart's stated sd, fitted with its reference."""
    stated = budgets["daylight"]["sd"]
    far = {**cond, "daylight_mired": cond["surface_mired"] + _beyond(
        np.random.default_rng(beyond_seq), cond["surface_mired"], stated)}
    beyond = _render(world, far, _fresh(uw_seq))
    return {WITH_REF: _summary(h.fit_set(beyond, budgets), far, beyond,
                                  h.test_of("sky-beyond"))}


def run_reference(n: int = h.C_CHARTS_FULL, seed: int = h.SEED, log=None, *, waters=None,
                  beyond: bool = True) -> dict:
    """The reference-shot worlds on clear and coastal water (:data:`experiments.honesty.C_WATERS`).

    Parameters
    ----------
    n : int
        Charts per water type.
    seed : int
        Seed of the conditions and renders (its own streams).
    log : callable, optional
        Called with one progress line per water type.
    waters : sequence of str, optional
        The water types to run (default all of :data:`experiments.honesty.C_WATERS`).
    beyond : bool, optional
        Run the ``sky-beyond`` world too (default True).

    Returns
    -------
    dict
        'waters': water -> {'reference': {label: summary}, 'sky-beyond': {label: summary},
        'lights', 'render_s'}; 'pooled': world -> label -> summary of both water types
        together; 'n', 'seed', 'minutes', 'elapsed_s'.
    """
    t0 = time.perf_counter()
    streams = np.random.default_rng([seed, 47, 6]).spawn(len(h.C_WATERS))
    waters = {w: _water_set(w, n, rng, log, beyond) for w, rng in zip(h.C_WATERS, streams)
              if waters is None or w in waters}
    return {"waters": waters, "pooled": _pooled(waters), "n": n, "seed": seed,
            "minutes": REFERENCE_MINUTES, "elapsed_s": time.perf_counter() - t0}


def _pooled(waters) -> dict:
    """world -> label -> both water types' counts added (:func:`_pool`)."""
    out = {}
    for world in ("reference", "sky-beyond"):
        if world not in next(iter(waters.values())):
            continue
        out[world] = {}
        for label in next(iter(waters.values()))[world]:
            parts = [w[world][label] for w in waters.values()]
            out[world][label] = _pool(parts)
    return out


def _pool(parts) -> dict:
    """Counts of ``parts`` (summaries) added and their coverages retested."""
    test = parts[0]["test"]
    n_rel = sum(p["reliable"] for p in parts)
    cov = {k: h._coverage(sum(p["coverage"][k]["covered"] for p in parts), n_rel,
                          h.NOMINAL_SINGLE, test)
           for k in parts[0]["coverage"] if k != "joint"}
    foc = {k: {f: sum(p["flagged_or_covered"][k][f] for p in parts) for f in v}
           for k, v in parts[0]["flagged_or_covered"].items()}
    return {"n": sum(p["n"] for p in parts), "reliable": n_rel, "test": test, "coverage": cov,
            "flagged_or_covered": foc}


# --------------------------------------------------------------------------- the report
def _quantities(summary):
    return [(k, label) for k, label in h.reported_quantities() if k in summary["coverage"]]


def _cell(s, key) -> str:
    cov = s["coverage"][key]
    text = (f"{h._pct(cov['fraction'])} · ±{h._pct(s['median_rel_halfwidth'].get(key))} "
            f"(p {h._p(cov['p'])})")
    return f"**{text}**" if cov["p"] is not None and cov["p"] < h.CONSISTENCY_P else text


def _dtau_cells(s) -> str:
    return " | ".join(h._num(s["median_dtau95"][b]) + (
        "" if s["median_dtau95"][b] is None or s["median_dtau95"][b] <= DTAU_TARGET else " ✗")
        for b in DTAU_BANDS)


def _table(ref) -> list:
    first = next(iter(ref["waters"].values()))["reference"][WITH_REF]
    qs = _quantities(first)
    lines = ["| world | water | fit | test | reliable | " + " | ".join(lab for _, lab in qs) +
             " | " + " | ".join(f"Δτ({b})" for b in DTAU_BANDS) + " |",
             "|" + "---|" * (5 + len(qs) + len(DTAU_BANDS))]
    for world in ("reference", "sky-beyond"):
        for water, e in ref["waters"].items():
            for label, s in e.get(world, {}).items():
                lines.append(f"| {world} | {water} | {label} | {s['test']} | "
                             f"{s['reliable']}/{s['n']} | " +
                             " | ".join(_cell(s, k) for k, _ in qs) + " | " +
                             _dtau_cells(s) + " |")
    return lines


def _beyond_text(ref) -> list:
    """Flagged or covered, per quantity, pooled: said plainly."""
    if "sky-beyond" not in ref["pooled"]:
        return []
    s = ref["pooled"]["sky-beyond"][WITH_REF]
    worst = {k: v["neither"] for k, v in s["flagged_or_covered"].items()}
    lines = [f"`sky-beyond` (pooled, {s['n']} charts, {s['reliable']} reliable): " + ", ".join(
        f"{lab} {v['covered']} covered, {v['flagged']} flagged, {v['neither']} neither"
        for k, lab in h.reported_quantities() if (v := s["flagged_or_covered"].get(k)))
        + "."]
    bad = [k for k in worst if s["coverage"][k]["p"] is not None
           and s["coverage"][k]["p"] < h.CONSISTENCY_P]
    if not bad:
        lines.append("Honest: the misses among the reliable charts are no more than the "
                     f"nominal 5 % ({s['test']} binomial test); the rest are flagged.")
    else:
        names = ", ".join(dict(h.reported_quantities()).get(k, k) for k in bad)
        lines.append(f"**Not honest** for {names}: a sky changed by {BEYOND_SD[0]:g}-"
                     f"{BEYOND_SD[1]:g} sd is neither flagged nor covered on more charts than "
                     f"the nominal 5 % ({s['test']} p < "
                     f"{h.CONSISTENCY_P}): the photo underwater hardly sees the light's colour. "
                     "The reference shot is honest only within its stated sky sd (decision "
                     "0069-reference-shot): give the time between the shot and the dive, and "
                     "shoot it under the same sun or shade.")
    return lines


def _reference_verdict(ref) -> list:
    pooled = ref["pooled"]["reference"]
    out = []
    for label, s in pooled.items():
        fails = [dict(h.reported_quantities()).get(k, k) for k, v in s["coverage"].items()
                 if v["p"] is not None and v["p"] < h.CONSISTENCY_P]
        out.append(f"`reference` {label} (pooled, {s['reliable']} reliable of {s['n']}): "
                   + (f"every quantity covered at the nominal rate ({s['test']})." if not fails
                      else f"**coverage fails** ({s['test']} p < "
                      f"{h.CONSISTENCY_P}) for " + ", ".join(fails) + "."))
    return out


def reference_text(ref) -> list:
    """HONESTY.md's section on the reference shot (lines); [] without it."""
    if not ref:
        return []
    first = next(iter(ref["waters"].values()))
    lights = ", ".join(
        f"{w}: median sd of the light measured {e['lights']['sd_fit_median']:.1f} mired, "
        f"median |error| {e['lights']['error_median_abs']:.1f} mired, stated sd "
        f"{e['lights']['sd_stated_median']:.1f} mired" for w, e in ref["waters"].items())
    src = first["reference"][WITH_REF]["dtau_source"]
    return ["", "## The surface reference shot (issue 47, item 6)", "",
            f"{ref['n']} charts per water type (seed {ref['seed']}, its own draws), the "
            "attenuation criterion's waters, depth 1-15 m, distance 0.5-3 m, exposure unknown, "
            "the other nuisances of the default budget drawn from their priors (the `priors` "
            "world). The surface daylight is drawn from the budget's 30-mired prior; the "
            "reference shot is the same chart and camera in air under it (the independent "
            "renderer, its noise), its light fitted by `sca.reference.measure_light`; the sky "
            "then changes by N(0, sky_sd) mired (`sca.reference.sky_sd` at "
            f"{ref['minutes']:g} min: {first['lights']['sky_change_sd']:.1f} mired) and the "
            "chart underwater is rendered under the changed light and fitted with "
            "`uncertain=with_reference(None, lights)` (one batch, each chart its own measured "
            "prior), and on the same photos with the default budget. `sky-beyond`: the same "
            f"charts, the sky changed by {BEYOND_SD[0]:g}-{BEYOND_SD[1]:g} x the stated sd "
            "(either sign); honest there means flagged or covered. " + lights + ". "
            f"Each cell: coverage · ±median half-width (binomial p; bold below "
            f"{h.CONSISTENCY_P}). Δτ(λ): the median 95 % half-width of the optical depth "
            f"tau = c (d + L) among the reliable charts ({src}), against the issue's target "
            f"<= {DTAU_TARGET:.2f} (✗: above it). Run time {ref['elapsed_s']:.0f} s.", ""] + \
        _table(ref) + [""] + [f"- {t}" for t in _reference_verdict(ref)] + \
        [f"- {t}" for t in _beyond_text(ref)]


def holds(ref) -> dict:
    """The reference world's criterion per fit with the reference: covered at the nominal
    rate (its test, :func:`experiments.honesty.test_of`), pooled over both water types."""
    s = ref["pooled"]["reference"][WITH_REF]
    return {f"reference: {dict(h.reported_quantities()).get(k, k)}":
            bool(v["p"] is None or v["p"] >= h.CONSISTENCY_P) for k, v in s["coverage"].items()}


# --------------------------------------------------------------------------- the residual term
#: The per-patch terms tried by :func:`residual_patch` (relative).
RESIDUAL_GRID = (0.0015, 0.003, 0.006, 0.01, 0.015)


def residual_patch(n: int = 10, seed: int = h.SEED, grid=RESIDUAL_GRID) -> dict:
    """The per-patch term the chart's response measured in air leaves (decision
    0079-reference-patch-response): the reference world's charts (clear and coastal) fitted
    with their lights and responses at each per-patch term of ``grid``, the pooled chi^2/dof
    of each, and the term at which it is 1 (method of moments, interpolated in log-log:
    chi^2 falls as the term grows), with the light alone for comparison.

    Returns
    -------
    dict
        'grid', 'chi2_dof' {label: [pooled chi^2/dof per term]}, 'patch' {label: the term at
        chi^2/dof = 1 (NaN outside the grid)}, 'n', 'seed'.
    """
    streams = np.random.default_rng([seed, 47, 2]).spawn(len(h.C_WATERS))
    sets = [_draw_set(w, n, rng) for w, rng in zip(h.C_WATERS, streams)]
    chi2 = {}
    for label, strip in ((WITH_REF, False), (LIGHT_ONLY, True)):
        chi2[label] = []
        for p in grid:
            num = den = 0.0
            for _, _, rendered, lights, _, _ in sets:
                budget = with_reference(None, _light_only(lights) if strip else lights)
                est = h.fit_set(rendered, budget | {"patch": p})
                num += float(np.nansum(est.chi2_dof * est.dof))
                den += float(np.sum(est.dof))
            chi2[label].append(num / den)
    x = np.log(np.asarray(grid, float))
    patch = {k: float(np.exp(np.interp(0.0, -np.log(v), x, left=np.nan, right=np.nan)))
             for k, v in chi2.items()}
    return {"grid": list(grid), "chi2_dof": chi2, "patch": patch, "n": n, "seed": seed}
