"""Does a design keep its promise on a world we did not make?  (DESIGN.md)

    python -m experiments.design_check [--dives 50] [--quick] [--out DESIGN.md]

Designs are taken from :func:`sca.design` (what ``uw3p design`` runs; the equivalent command is
in the report): "C to +-30 %" for a coastal water, and for a clear one (where the design finds
none, the precision it does promise there, "C to +-60 %"), each with the auxiliary measurement
the design asks for. Each design's dive is rendered :data:`DIVES_FULL` times by the independent
renderer (:mod:`experiments.independent_world`, no code shared with ``forward``), in a world
drawn from the default budget's own priors: one chart and one camera per dive (each patch's
reflectance off by N(0, 1 %), each channel's gain by N(0, 1 %) and its curve shifted by
N(0, 1 nm), the same in every photo), the CDOM and NAP slopes drawn from their priors, a
single-scattering veiling light, each photo its own unknown exposure, photon and read noise,
the depths and distances told with the budget's errors (0.2 m, 5 %). The surface light is D65
in every dive (the renderer takes named illuminants only: the budget's 30 mired of daylight
colour is not drawn). The water sample's a_CDOM(440) is the truth plus N(0, its sd). Each
dive is fitted by :func:`sca.joint.estimate_joint` (default budget, the sample fused), and the
report gives per design: the median realised 95 % half-width of C (and of the attenuation
coefficient c, its worst standard band) against the designed one (the ratio; the issue asks
for 0.75-1.33), the coverage of the truth by the joint intervals among the reliable dives with
a two-sided binomial test against the nominal 95 %, and whether C's half-width meets the
target. Two more rows follow the coastal design into water it did not guess (C and a_CDOM
0.6x and 1.5x the guess): what a diver who guessed wrong gets, reported without a criterion
(the design promises its precision for the water guessed).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
from scipy import stats

from forward.files import write_atomic
from . import independent_world as iw
from .dive_honesty import render_dive
from .honesty import CLEAN_OPTIONS, EXPOSURE_RANGE

__all__ = ["CONSISTENCY_P", "DESIGNS", "DIVES_FULL", "DIVES_QUICK", "NOMINAL", "RATIO_RANGE",
           "SEED", "check", "command", "design_of", "draw_dive", "fit_dive", "main", "report",
           "run", "summarise", "truth_of"]

ROOT = Path(__file__).resolve().parents[1]
#: Dives per design in the full run and with ``--quick``.
DIVES_FULL, DIVES_QUICK = 40, 6
#: Seed of every draw.
SEED = 20261126
#: Nominal coverage of one 95 % interval; a two-sided binomial p below CONSISTENCY_P fails.
NOMINAL, CONSISTENCY_P = 0.95, 0.01
#: The range the realised half-width may lie in, times the designed one (issue 37).
RATIO_RANGE = (0.75, 1.33)
#: The designs checked: a name, the water guessed, the dive's depths and distances (m), the
#: targets (relative 95 % half-widths) and the water sample's sd (m^-1; None: the default);
#: 'truth', where given, the water the dives are rendered in (C, a_CDOM(440)) when it is not
#: the water guessed (informational rows: no criterion).
#: The coastal designs' sample is a precise one (0.0025 m^-1, underway long-path
#: spectrophotometry; DESIGN.md was made with it): with the default 0.015 m^-1 no protocol
#: reaches C +-30 % there (decision 0075-design-reference-shot). The clear water's sample is a
#: long-path cell's (0.001 m^-1, a tenth of its a_CDOM): with 0.0025 m^-1 no protocol reaches
#: even +-60 % there.
DESIGNS = (
    {"name": "coastal, C to ±30 %", "chl": 1.0, "cdom": 0.1, "depth": (2.0, 15.0),
     "distance": (1.0, 3.0), "targets": {"chl": 0.30}, "sample_sd": 0.0025},
    {"name": "clear, C to ±30 %", "chl": 0.1, "cdom": 0.01, "depth": (2.0, 15.0),
     "distance": (1.0, 3.0), "targets": {"chl": 0.30}, "sample_sd": 0.001},
    {"name": "clear, C to ±60 %", "chl": 0.1, "cdom": 0.01, "depth": (2.0, 15.0),
     "distance": (1.0, 3.0), "targets": {"chl": 0.60}, "sample_sd": 0.001},
    {"name": "coastal, C to ±30 %, the water 0.6× the guess", "chl": 1.0, "cdom": 0.1,
     "depth": (2.0, 15.0), "distance": (1.0, 3.0), "targets": {"chl": 0.30}, "sample_sd": 0.0025,
     "truth": (0.6, 0.06)},
    {"name": "coastal, C to ±30 %, the water 1.5× the guess", "chl": 1.0, "cdom": 0.1,
     "depth": (2.0, 15.0), "distance": (1.0, 3.0), "targets": {"chl": 0.30}, "sample_sd": 0.0025,
     "truth": (1.5, 0.15)},
)
#: The world's draws: the default budget's own sds (sca.budget.DEFAULT_UNCERTAIN): per-patch
#: reflectance ('patch'), channel gains ('balance'), curve shifts ('camera_shift', nm).
WORLD = {"reflectance_sd": 0.01, "camera_gain_sd": 0.01, "camera_shift_nm_sd": 1.0}
#: Bands of the attenuation coefficient reported (sca.derived.BANDS_NM).
C_BANDS = ("c_443", "c_490", "c_555", "c_670")


def command(spec: dict) -> str:
    """The ``uw3p design`` command equivalent to a design of :data:`DESIGNS`."""
    def nums(v):
        return " ".join(f"{x:g}" for x in np.atleast_1d(v))

    names = {"chl": "C", "cdom": "a_CDOM", "c": "c"}
    out = (f"uw3p design --chl {spec['chl']:g} --cdom {spec['cdom']:g} --depth "
           f"{nums(spec['depth'])} --distance {nums(spec['distance'])}")
    out += "".join(f" --target {names.get(k, k)}={100 * v:g}%" for k, v in spec["targets"].items())
    if spec["sample_sd"] is not None:
        out += f" --sample-sd {spec['sample_sd']:g}"
    return out


def truth_of(spec: dict) -> tuple:
    """The water the dives of ``spec`` are rendered in: (C, a_CDOM(440)), the guess unless
    ``spec`` has 'truth'."""
    return tuple(spec.get("truth", (spec["chl"], spec["cdom"])))


def design_of(spec: dict):
    """The design of ``spec`` (:func:`sca.design`, as ``uw3p design`` runs it)."""
    import sca
    from sca.protocols import SAMPLE_SD

    return sca.design(spec["chl"], spec["cdom"], depth=spec["depth"], distance=spec["distance"],
                      targets=spec["targets"],
                      sample_sd=SAMPLE_SD if spec["sample_sd"] is None else spec["sample_sd"])


def draw_dive(rng: np.random.Generator, spec: dict, protocol, sample_sd: float) -> dict:
    """The truth of one dive of ``protocol`` in the water of ``spec`` (:func:`truth_of`): its
    chart, camera, slopes, exposures, the told geometry and the water sample's reading.

    Parameters
    ----------
    rng : numpy.random.Generator
    spec : dict
        A design of :data:`DESIGNS`.
    protocol : sca.protocols.Protocol
        The design's protocol.
    sample_sd : float
        The water sample's sd, m^-1 (its reading is drawn only where the protocol takes one).

    Returns
    -------
    dict
        As :func:`experiments.dive_honesty.draw_dive` ('chl', 'cdom', 'chl_photo', 'options',
        'depth', 'distance', 'exposure', 'depth_told', 'distance_told') and 'auxiliary' (the
        fit's ``auxiliary=``).
    """
    from sca.budget import DEFAULT_UNCERTAIN

    depth, distance = (np.array(x, float) for x in zip(*protocol.photos))
    n = depth.size
    opts = {**CLEAN_OPTIONS, **WORLD,
            "reflectance_factors": tuple(1 + rng.normal(0, WORLD["reflectance_sd"], 24)),
            "camera_gains": tuple(1 + rng.normal(0, WORLD["camera_gain_sd"], 3)),
            "camera_shift_nm": tuple(rng.normal(0, WORLD["camera_shift_nm_sd"], 3)),
            "cdom_slope": float(rng.normal(iw.CDOM_SLOPE_PER_NM, DEFAULT_UNCERTAIN["cdom_slope"])),
            "nap_slope": float(rng.normal(iw.NAP_SLOPE_PER_NM, DEFAULT_UNCERTAIN["nap_slope"]))}
    rel = float(DEFAULT_UNCERTAIN["distance"].rstrip("%")) / 100
    chl, cdom = truth_of(spec)
    aux = None
    if "sample" in protocol.auxiliary:
        reading = cdom + rng.normal(0, sample_sd)
        while reading <= 0:  # a reading is positive
            reading = cdom + rng.normal(0, sample_sd)
        aux = {"cdom": (float(reading), sample_sd)}
    return {"chl": chl, "cdom": cdom, "chl_photo": np.full(n, chl),
            "options": opts, "depth": depth, "distance": distance,
            "exposure": rng.uniform(*EXPOSURE_RANGE, n),
            "depth_told": np.maximum(depth + rng.normal(0, DEFAULT_UNCERTAIN["depth"], n), 0.0),
            "distance_told": distance * (1 + rng.normal(0, rel, n)), "auxiliary": aux}


def fit_dive(dive: dict, rendered: dict) -> dict:
    """The joint fit of one dive (default budget, the auxiliary measurement fused); plain
    numbers."""
    import forward
    from forward.imaging import resolve_setup
    from sca.joint import estimate_joint

    t0 = time.perf_counter()
    setup = resolve_setup(None, forward.DEFAULT_CAMERA, None, None, None)
    j = estimate_joint(rendered["rgb"], depth=dive["depth_told"], distance=dive["distance_told"],
                       sigma=rendered["sigma"], setup=setup, auxiliary=dive["auxiliary"])
    return {"chl": j.chl, "chl_ci": list(j.chl_ci), "cdom": j.cdom, "cdom_ci": list(j.cdom_ci),
            "quantity_intervals": {k: list(v) for k, v in j.quantity_intervals.items()},
            "reliable": j.reliable, "flags": list(j.flags), "path_model": j.path_model,
            "photo_scatter": j.photo_scatter, "seconds": time.perf_counter() - t0}


def _one(args):
    dive, seed = args
    return fit_dive(dive, render_dive(dive, np.random.default_rng(seed)))


def run(dives: int = DIVES_FULL, seed: int = SEED, workers: int | None = None,
        specs=DESIGNS) -> list:
    """Design, draw, render and fit ``dives`` dives of each design that has a protocol.

    Returns
    -------
    list of dict
        Per design: 'spec', 'design' (:class:`sca.Design`), 'truth' and 'fits' (lists; empty
        where no protocol meets the targets), 'seconds'.
    """
    from sca.protocols import SAMPLE_SD

    rng = np.random.default_rng(seed)
    out, designs = [], {}
    workers = workers or min(2, os.cpu_count() or 1)
    for spec in specs:
        t0 = time.perf_counter()
        key = command(spec)  # the same command, the same design
        d = designs[key] = designs.get(key) or design_of(spec)
        truth = []
        if d.meets:
            sd = SAMPLE_SD if spec["sample_sd"] is None else spec["sample_sd"]
            truth = [draw_dive(rng, spec, d.protocol.protocol, sd) for _ in range(dives)]
        seeds = rng.integers(0, 2 ** 31, len(truth)).tolist()
        with ProcessPoolExecutor(workers) as pool:
            fits = list(pool.map(_one, zip(truth, seeds)))
        out.append({"spec": spec, "design": d, "truth": truth, "fits": fits,
                    "seconds": time.perf_counter() - t0, "workers": workers})
    return out


def _half(ci, truth):
    lo, hi = ci
    return (hi - lo) / 2 / truth if np.isfinite(hi) else np.inf


def _binom_two_sided(misses, n):
    """Two-sided binomial p of ``misses`` misses in n at the nominal miss rate."""
    return float(stats.binomtest(misses, n, 1 - NOMINAL).pvalue) if n else float("nan")


def summarise(res: dict) -> dict:
    """One design's numbers for the report."""
    d, fits, truth = res["design"], res["fits"], res["truth"]
    spec = res["spec"]
    out = {"name": spec["name"], "command": command(spec), "meets": d.meets,
           "dives": len(fits), "seconds": res["seconds"], "truth": truth_of(spec),
           "informational": "truth" in spec}
    shown = d.protocol if d.meets else d.best
    out.update(protocol=shown.protocol.describe(), designed_chl=shown.rel95["chl"],
               bound_chl=shown.bound_rel95["chl"], designed_c=shown.rel95["c"],
               span=" and ".join(shown.span), limiting=d.limiting,
               target_chl=res["spec"]["targets"].get("chl", float("nan")))
    if not fits:
        return out
    rel = [(t, f) for t, f in zip(truth, fits) if f["reliable"]]
    chl_half = np.array([_half(f["chl_ci"], t["chl"]) for t, f in rel])
    c_half = np.array([max(_half(f["quantity_intervals"][b], _c_truth(t, b)) for b in C_BANDS)
                       for t, f in rel]) if rel else np.array([])
    miss = {k: sum(not f[f"{k}_ci"][0] <= t[k] <= f[f"{k}_ci"][1] for t, f in rel)
            for k in ("chl", "cdom")}
    for b in C_BANDS:
        miss[b] = sum(not f["quantity_intervals"][b][0] <= _c_truth(t, b)
                      <= f["quantity_intervals"][b][1] for t, f in rel)
    worst_band = max(C_BANDS, key=lambda b: miss[b])
    spanned = [(t, f) for t, f in rel if "path-model-span" in f["flags"]]
    alone = [(t, f) for t, f in rel if "path-model-span" not in f["flags"]]
    n = len(rel)
    med = float(np.median(chl_half)) if n else float("nan")
    out.update(
        reliable=n, confident_wrong=sum(
            not (f["chl_ci"][0] <= t["chl"] <= f["chl_ci"][1]
                 and f["cdom_ci"][0] <= t["cdom"] <= f["cdom_ci"][1]) for t, f in rel),
        realised_chl=med, ratio_chl=med / shown.rel95["chl"],
        ratio_bound=med / shown.bound_rel95["chl"],
        realised_chl_q=(float(np.quantile(chl_half, 0.25)), float(np.quantile(chl_half, 0.75)))
        if n else (np.nan, np.nan),
        within_target=int(np.sum(chl_half <= out["target_chl"])) if n else 0,
        worst_band=worst_band, not_reliable=sorted({fl for f in fits if not f["reliable"]
                                                    for fl in f["flags"]}),
        realised_c=float(np.median(c_half)) if n else float("nan"),
        ratio_c=float(np.median(c_half)) / shown.rel95["c"] if n else float("nan"),
        spanned=len(spanned),
        realised_chl_spanned=float(np.median([_half(f["chl_ci"], t["chl"])
                                              for t, f in spanned])) if spanned else float("nan"),
        realised_chl_alone=float(np.median([_half(f["chl_ci"], t["chl"]) for t, f in alone]))
        if alone else float("nan"),
        **{f"miss_{k}": v for k, v in miss.items()},
        **{f"p_{k}": _binom_two_sided(v, n) for k, v in miss.items()},
        fit_s=float(np.median([f["seconds"] for f in fits])))
    return out


def _c_truth(dive: dict, band: str) -> float:
    """The world's attenuation coefficient c = a + b at ``band`` (its own optics, its slopes)."""
    wl = float(band.split("_")[1])
    optics = iw.water_optics(np.array([wl - 0.5, wl, wl + 0.5]), dive["chl"], dive["cdom"],
                             cdom_slope=dive["options"]["cdom_slope"],
                             nap_slope=dive["options"]["nap_slope"])
    return float(optics["c"][1])


def check(s: dict) -> dict:
    """The issue's criteria for one checked design: name -> (holds, detail); none for a design
    that promised nothing (no dives) or a water it did not guess (informational)."""
    if not s["dives"] or s.get("informational"):
        return {}
    lo, hi = RATIO_RANGE
    return {
        "realised / designed C half-width in 0.75-1.33": (
            lo <= s["ratio_chl"] <= hi, f"{s['ratio_chl']:.2f}"),
        "C covered at the nominal rate (two-sided binomial p >= 0.01)": (
            s["p_chl"] >= CONSISTENCY_P, f"{s['miss_chl']} misses in {s['reliable']}, "
            f"p = {s['p_chl']:.2f}"),
        "median C half-width within the target": (
            s["realised_chl"] <= s["target_chl"],
            f"±{100 * s['realised_chl']:.0f} % (target ±{100 * s['target_chl']:.0f} %)"),
    }


def _pct(x):
    return "–" if not np.isfinite(x) else f"±{100 * x:.0f} %"


def report(summaries: list, cmd: str) -> str:
    """DESIGN.md's text."""
    L = ["# DESIGN — does a design keep its promise on a world we did not make?", "",
         f"Generated by `{cmd}` (`experiments/design_check.py`); do not edit by hand.", "",
         "Each design is `sca.design`'s (what `uw3p design` runs; its command below). Its dive "
         "was rendered by the independent renderer (`experiments/independent_world.py`, no code "
         "shared with `forward`) in a world drawn from the default budget's own priors: one "
         "chart and one camera per dive (each patch's reflectance off by N(0, 1 %), each "
         "channel's gain by N(0, 1 %), its curve shifted by N(0, 1 nm), the same in every "
         "photo), the CDOM and NAP slopes drawn from their priors, a single-scattering veiling "
         "light, each photo its own unknown exposure, photon and read noise, depths and "
         "distances told with the budget's errors (0.2 m, 5 %); the surface light D65 in every "
         "dive (the budget's 30 mired of daylight colour not drawn). The water sample's "
         "a_CDOM(440) reading is the truth plus N(0, its sd). Each dive was fitted by "
         "`sca.joint.estimate_joint` with the default budget and the sample. The designed "
         "half-width is the design's prediction: the Cramér-Rao bound of the joint estimate, "
         "widened where the estimator's interval spans path models the data cannot tell apart "
         "(`sca.protocols`); \"bound alone\" is the bound without that span. Half-widths are "
         "(hi − lo) / 2 relative to the truth, medians over the reliable dives; c is the path's "
         "attenuation coefficient at its worst standard band (443, 490, 555, 670 nm).", ""]
    for s in summaries:
        L += [f"## {s['name']}", "", f"`{s['command']}`", ""]
        if s.get("informational"):
            L += [f"The dives are rendered in water the design did not guess: C "
                  f"{s['truth'][0]:g} mg m⁻³, a_CDOM(440) {s['truth'][1]:g} m⁻¹. What a diver "
                  "who guessed wrong gets; no criterion (the design promises its precision for "
                  "the water guessed).", ""]
        if not s["meets"]:
            L += [f"No protocol of the space meets the target. The best, {s['protocol']}, is "
                  f"designed to give C {_pct(s['designed_chl'])} (the bound alone "
                  f"{_pct(s['bound_chl'])}; its interval spans the path models {s['span']}); "
                  f"what limits it: {s['limiting']}. Not rendered: the design makes no promise "
                  "to check.", ""]
            continue
        L += [f"Designed: {s['protocol']}; C {_pct(s['designed_chl'])} (bound alone "
              f"{_pct(s['bound_chl'])}; span: {s['span']}), c {_pct(s['designed_c'])}. "
              f"{s['dives']} dives, {s['seconds']:.0f} s on 2 processes (a joint fit "
              f"{s['fit_s']:.1f} s, median).", "",
              "| quantity | value |", "|---|---|",
              f"| dives called reliable | {s['reliable']} / {s['dives']}"
              + (f" (the others flagged {', '.join(s['not_reliable'])})"
                 if s["not_reliable"] else "") + " |",
              f"| C: realised 95 % half-width, median (quartiles) | {_pct(s['realised_chl'])} "
              f"({_pct(s['realised_chl_q'][0])}–{_pct(s['realised_chl_q'][1])}) |",
              f"| C: realised / designed | {s['ratio_chl']:.2f} (against the bound alone: "
              f"{s['ratio_bound']:.2f}) |",
              f"| C: dives whose interval spans path models | {s['spanned']} / {s['reliable']} "
              f"(median half-width {_pct(s['realised_chl_spanned'])}; the others "
              f"{_pct(s['realised_chl_alone'])}) |",
              f"| C: half-width within the target (±{100 * s['target_chl']:.0f} %) | "
              f"{s['within_target']} / {s['reliable']} dives |",
              f"| C: 95 % interval holds the truth | {s['reliable'] - s['miss_chl']} / "
              f"{s['reliable']} (two-sided binomial p = {s['p_chl']:.2f}) |",
              f"| a_CDOM(440): interval holds the truth | {s['reliable'] - s['miss_cdom']} / "
              f"{s['reliable']} (p = {s['p_cdom']:.2f}) |",
              "| c: each band's interval holds the truth | " + ", ".join(
                  f"{b[2:]} nm {s['reliable'] - s['miss_' + b]}" for b in C_BANDS)
              + f" of {s['reliable']} (the worst, {s['worst_band'][2:]} nm: p = "
              f"{s['p_' + s['worst_band']]:.2f}) |",
              f"| c: realised half-width (worst band), median; realised / designed | "
              f"{_pct(s['realised_c'])}; {s['ratio_c']:.2f} |",
              f"| reliable with C or a_CDOM outside its interval | {s['confident_wrong']} / "
              f"{s['reliable']} |", ""]
        crit = check(s)
        if crit:
            L += ["| criterion (issue 37) | holds | detail |", "|---|---|---|"]
            L += [f"| {k} | {'yes' if ok else '**no**'} | {detail} |"
                  for k, (ok, detail) in crit.items()]
            L.append("")
    return "\n".join(L)


def main(argv=None) -> int:
    """Run the check and write DESIGN.md (whole or not at all)."""
    ap = argparse.ArgumentParser(prog="python -m experiments.design_check", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dives", type=int, default=None,
                    help=f"dives per design (default {DIVES_FULL})")
    ap.add_argument("--quick", action="store_true", help=f"{DIVES_QUICK} dives per design")
    ap.add_argument("--seed", type=int, default=SEED)
    ap.add_argument("--workers", type=int, default=None, help="processes (default 2)")
    ap.add_argument("--out", default=str(ROOT / "DESIGN.md"))
    ap.add_argument("--strict", action="store_true", help="exit 1 when a criterion fails")
    args = ap.parse_args(argv)
    dives = args.dives or (DIVES_QUICK if args.quick else DIVES_FULL)
    if dives < 1:
        print("--dives: must be >= 1", file=sys.stderr)
        return 2
    summaries = [summarise(r) for r in run(dives, args.seed, args.workers)]
    cmd = "python -m experiments.design_check" + (f" --dives {dives}" if args.dives else
                                                  " --quick" if args.quick else "")
    if args.seed != SEED:
        cmd += f" --seed {args.seed}"
    text = report(summaries, cmd)
    path = Path(args.out)
    write_atomic(path, text)
    print(text)
    ok = all(v[0] for s in summaries for v in check(s).values())
    return 1 if args.strict and not ok else 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
