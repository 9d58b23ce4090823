"""Is the joint estimate of a dive honest on a world we did not make?  (DIVE.md)

    python -m experiments.dive_honesty [--dives 40] [--quick] [--out DIVE.md]

Dives of ``PHOTOS`` photographs are rendered by the independent renderer
(:mod:`experiments.independent_world`, no code shared with ``forward``): one water per dive
(C and a_CDOM log-uniform), one chart and one camera per dive (reflectance factors, channel
gains and curve shifts drawn once and used in every photo, as a real chart and camera are),
CDOM and NAP slopes drawn from the default budget's priors, a single-scattering veiling light,
per photo its own depth (4-12 m), distance (1-2.5 m) and exposure, the depth and distance told
with the default budget's errors. Each dive is fitted by :func:`sca.joint.estimate_joint` with
the default budget, and each photo alone by :func:`sca.estimate_batch` (the same budget), and
the report gives: the fraction reliable, the coverage of the truth by the joint 95 % intervals
among the reliable (with a one-sided binomial test against the nominal rate), the joint
interval's width against the median single photo's, and the heterogeneity test's false-alarm
rate. Mixed dives (one photo from another water, C x ``MIXED_FACTOR``) check that the test
finds them and names the photo.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
from scipy import stats

from . import independent_world as iw
from .honesty import CDOM_RANGE, CHL_RANGE, CLEAN_OPTIONS, EXPOSURE_RANGE

__all__ = [
    "DIVES_FULL",
    "DIVES_QUICK",
    "MIXED_FACTOR",
    "PHOTOS",
    "SEED",
    "draw_dive",
    "fit_dive",
    "main",
    "render_dive",
    "report",
    "run",
]

ROOT = Path(__file__).resolve().parents[1]
#: Photos per dive.
PHOTOS = 4
#: Dives in the full run and with ``--quick`` (one-water dives; as many mixed ones / 4).
DIVES_FULL, DIVES_QUICK = 40, 8
#: C of the odd photo of a mixed dive, times the dive's.
MIXED_FACTOR = 5.0
#: Depth and distance ranges of a dive's photos (uniform), m.
DIVE_DEPTHS, DIVE_DISTANCES = (4.0, 12.0), (1.0, 2.5)
#: Seed of every draw.
SEED = 20261122
#: Nominal coverage of one 95 % interval, and the binomial p below which misses are too many.
NOMINAL, CONSISTENCY_P = 0.95, 0.01


def _log_uniform(rng, lo_hi):
    return float(np.exp(rng.uniform(np.log(lo_hi[0]), np.log(lo_hi[1]))))


def draw_dive(rng: np.random.Generator, n: int = PHOTOS, mixed: bool = False) -> dict:
    """The truth of one dive: its water, chart, camera, slopes and photos.

    Parameters
    ----------
    rng : numpy.random.Generator
    n : int
        Photos.
    mixed : bool
        The last photo's C is ``MIXED_FACTOR`` times the others'.

    Returns
    -------
    dict
        'chl', 'cdom' (the water), 'chl_photo' (n,), 'options' (renderer options shared by
        the photos), 'depth', 'distance', 'exposure' (n,) true, 'depth_told',
        'distance_told' (n,).
    """
    from sca.budget import DEFAULT_UNCERTAIN

    chl, cdom = _log_uniform(rng, CHL_RANGE), _log_uniform(rng, CDOM_RANGE)
    opts = {**CLEAN_OPTIONS,
            "reflectance_factors": tuple(1 + rng.normal(0, CLEAN_OPTIONS["reflectance_sd"], 24)),
            "camera_gains": tuple(1 + rng.normal(0, CLEAN_OPTIONS["camera_gain_sd"], 3)),
            "camera_shift_nm": tuple(rng.normal(0, CLEAN_OPTIONS["camera_shift_nm_sd"], 3)),
            "cdom_slope": float(rng.normal(iw.CDOM_SLOPE_PER_NM, DEFAULT_UNCERTAIN["cdom_slope"])),
            "nap_slope": float(rng.normal(iw.NAP_SLOPE_PER_NM, DEFAULT_UNCERTAIN["nap_slope"]))}
    depth = rng.uniform(*DIVE_DEPTHS, n)
    distance = rng.uniform(*DIVE_DISTANCES, n)
    chl_photo = np.full(n, chl)
    if mixed:
        chl_photo[-1] *= MIXED_FACTOR
    rel = float(DEFAULT_UNCERTAIN["distance"].rstrip("%")) / 100
    return {"chl": chl, "cdom": cdom, "chl_photo": chl_photo, "options": opts, "depth": depth,
            "distance": distance, "exposure": rng.uniform(*EXPOSURE_RANGE, n),
            "depth_told": depth + rng.normal(0, DEFAULT_UNCERTAIN["depth"], n),
            "distance_told": distance * (1 + rng.normal(0, rel, n)), "mixed": mixed}


def render_dive(dive: dict, rng: np.random.Generator) -> dict:
    """Render every photo's chart: 'rgb', 'sigma' (n, 3, 24)."""
    rgb, sig = [], []
    for i, stream in enumerate(rng.spawn(dive["depth"].size)):
        out = iw.render_chart(dive["chl_photo"][i], dive["cdom"], dive["depth"][i],
                              dive["distance"][i], rng=stream,
                              **{**dive["options"], "exposure": float(dive["exposure"][i])})
        rgb.append(np.maximum(out["rgb"], 0.0))
        sig.append(out["sigma"])
    return {"rgb": np.array(rgb), "sigma": np.array(sig)}


def fit_dive(dive: dict, rendered: dict) -> dict:
    """The joint fit and every photo's own fit (default budget); plain numbers."""
    import forward
    import sca
    from forward.imaging import resolve_setup
    from sca.joint import estimate_joint

    t0 = time.perf_counter()
    setup = resolve_setup(None, forward.DEFAULT_CAMERA, None, None, None)
    names = [f"photo {i + 1}" for i in range(dive["depth"].size)]
    j = estimate_joint(rendered["rgb"], depth=dive["depth_told"], distance=dive["distance_told"],
                       sigma=rendered["sigma"], setup=setup, names=names)
    joint_s = time.perf_counter() - t0
    b = sca.estimate_batch(rendered["rgb"], depth=dive["depth_told"],
                           distance=dive["distance_told"], sigma=rendered["sigma"], gain="free")
    return {"chl": j.chl, "chl_ci": list(j.chl_ci), "cdom": j.cdom, "cdom_ci": list(j.cdom_ci),
            "reliable": j.reliable, "flags": list(j.flags), "one_water": j.heterogeneity["one_water"],
            "disagree": j.heterogeneity["disagree"], "joint_s": joint_s,
            "single_chl_ci": b.chl_ci.tolist(), "single_cdom_ci": b.cdom_ci.tolist(),
            "single_reliable": b.reliable.tolist()}


def _one(args):
    dive, seed = args
    rng = np.random.default_rng(seed)
    return fit_dive(dive, render_dive(dive, rng))


def run(dives: int = DIVES_FULL, seed: int = SEED, workers: int | None = None) -> dict:
    """Draw, render and fit ``dives`` one-water dives and ``dives // 4`` mixed ones."""
    rng = np.random.default_rng(seed)
    truth = [draw_dive(rng) for _ in range(dives)] + [draw_dive(rng, mixed=True)
                                                      for _ in range(max(dives // 4, 1))]
    seeds = rng.integers(0, 2 ** 31, len(truth))
    workers = workers or min(2, os.cpu_count() or 1)
    t0 = time.perf_counter()
    with ProcessPoolExecutor(workers) as pool:
        fits = list(pool.map(_one, zip(truth, seeds.tolist())))
    return {"truth": truth, "fits": fits, "seconds": time.perf_counter() - t0,
            "dives": dives, "seed": seed, "workers": workers}


def _inside(ci, x):
    return ci[0] <= x <= ci[1]


def _binom_p(miss, n):
    """P(at least ``miss`` misses in n) at the nominal miss rate."""
    return float(stats.binom.sf(miss - 1, n, 1 - NOMINAL)) if n else float("nan")


def summarise(out: dict) -> dict:
    """The report's numbers."""
    one = [(t, f) for t, f in zip(out["truth"], out["fits"]) if not t["mixed"]]
    mixed = [(t, f) for t, f in zip(out["truth"], out["fits"]) if t["mixed"]]
    rel = [(t, f) for t, f in one if f["reliable"]]
    miss = {k: sum(not _inside(f[f"{k}_ci"], t[k]) for t, f in rel) for k in ("chl", "cdom")}
    ratio = []
    for t, f in one:
        w = np.array(f["single_chl_ci"], float)
        width = w[:, 1] - w[:, 0]
        width = width[np.isfinite(width)]
        jw = f["chl_ci"][1] - f["chl_ci"][0]
        if width.size and np.isfinite(jw):
            ratio.append(jw / np.median(width))
    single_cov = [all(_inside(ci, t["chl"]) for ci, ok in zip(f["single_chl_ci"], f["single_reliable"])
                      if ok) for t, f in one]
    return {
        "dives": len(one), "mixed_dives": len(mixed), "photos": PHOTOS,
        "reliable": len(rel), "miss_chl": miss["chl"], "miss_cdom": miss["cdom"],
        "coverage_chl": 1 - miss["chl"] / len(rel) if rel else float("nan"),
        "coverage_cdom": 1 - miss["cdom"] / len(rel) if rel else float("nan"),
        "p_chl": _binom_p(miss["chl"], len(rel)), "p_cdom": _binom_p(miss["cdom"], len(rel)),
        "width_ratio_median": float(np.median(ratio)) if ratio else float("nan"),
        "narrower": int(sum(r < 1 for r in ratio)), "compared": len(ratio),
        "false_alarms": sum(not f["one_water"] for _, f in one),
        "mixed_found": sum(not f["one_water"] for _, f in mixed),
        "mixed_named": sum(f["disagree"] == [f"photo {PHOTOS}"] for _, f in mixed),
        "mixed_reliable": sum(f["reliable"] for _, f in mixed),
        "joint_s_median": float(np.median([f["joint_s"] for f in out["fits"]])),
        "single_all_inside": int(sum(single_cov)),
        "seconds": out["seconds"], "workers": out["workers"], "seed": out["seed"],
    }


def honest(s: dict) -> bool:
    """The acceptance: the reliable joint intervals miss no more than the nominal rate allows
    (binomial p >= CONSISTENCY_P for C and for a_CDOM), they are narrower than the median
    photo's in most dives, and every mixed dive is refused (not reliable)."""
    return (s["p_chl"] >= CONSISTENCY_P and s["p_cdom"] >= CONSISTENCY_P
            and s["narrower"] > s["compared"] / 2 and s["mixed_reliable"] == 0)


def report(s: dict, command: str) -> str:
    """DIVE.md's text."""
    pct = lambda x: f"{100 * x:.0f} %"
    lines = [
        "# DIVE — one water from many photos, on a world we did not make",
        "",
        f"Generated by `{command}` (`experiments/dive_honesty.py`); do not edit by hand.",
        "",
        f"{s['dives']} one-water dives of {s['photos']} photos each and {s['mixed_dives']} mixed "
        "dives (the last photo from water with C x "
        f"{MIXED_FACTOR:g}) were rendered by the independent renderer "
        "(`experiments/independent_world.py`, no code shared with `forward`): one chart, "
        "camera and pair of slopes per dive (drawn once, the same in every photo), each photo "
        "its own depth (4-12 m), distance (1-2.5 m), exposure and single-scattering veil, depth "
        "and distance told with the default budget's errors. Each dive was fitted by "
        "`sca.joint.estimate_joint` (default budget: the chart's, camera's and water's terms "
        "shared by the photos) and each photo alone by `sca.estimate_batch` (same budget). "
        f"Seed {s['seed']}, {s['workers']} worker processes, {s['seconds']:.0f} s in all; a "
        f"joint fit took {s['joint_s_median']:.1f} s (median).",
        "",
        "| quantity | value |",
        "|---|---|",
        f"| one-water dives called reliable | {s['reliable']} / {s['dives']} |",
        f"| joint 95 % interval of C holds the truth (reliable dives) | "
        f"{pct(s['coverage_chl'])} ({s['miss_chl']} misses; binomial p = {s['p_chl']:.2f}) |",
        f"| joint 95 % interval of a_CDOM holds the truth (reliable dives) | "
        f"{pct(s['coverage_cdom'])} ({s['miss_cdom']} misses; binomial p = {s['p_cdom']:.2f}) |",
        f"| joint C interval narrower than the median photo's | {s['narrower']} / "
        f"{s['compared']} dives (median width ratio {s['width_ratio_median']:.2f}) |",
        f"| one-water dives the heterogeneity test rejects (false alarms, 1 % level) | "
        f"{s['false_alarms']} / {s['dives']} |",
        f"| mixed dives found not one water | {s['mixed_found']} / {s['mixed_dives']} |",
        f"| mixed dives whose odd photo is named (alone) | {s['mixed_named']} / "
        f"{s['mixed_dives']} |",
        f"| mixed dives called reliable | {s['mixed_reliable']} / {s['mixed_dives']} |",
        "",
        "Acceptance (`honest`): the reliable joint intervals miss no more often than the "
        f"nominal 5 % allows (one-sided binomial p >= {CONSISTENCY_P}), they are narrower than "
        "the median photo's in most dives, and no mixed dive is called reliable: "
        f"**{'holds' if honest(s) else 'FAILS'}**.",
        "",
    ]
    return "\n".join(lines)


def main(argv=None) -> int:
    """Run the experiment and write DIVE.md and benchmarks/dive.json (whole or not at all)."""
    ap = argparse.ArgumentParser(prog="python -m experiments.dive_honesty", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dives", type=int, default=None, help=f"one-water dives (default {DIVES_FULL})")
    ap.add_argument("--quick", action="store_true", help=f"{DIVES_QUICK} dives")
    ap.add_argument("--seed", type=int, default=SEED)
    ap.add_argument("--out", default=str(ROOT / "DIVE.md"))
    ap.add_argument("--json", default=str(ROOT / "benchmarks" / "dive.json"))
    ap.add_argument("--strict", action="store_true", help="exit 1 when the acceptance fails")
    ap.add_argument("--no-photos", action="store_true",
                    help="skip the acceptance dive of whole photographs (experiments.dive_acceptance)")
    args = ap.parse_args(argv)
    dives = args.dives or (DIVES_QUICK if args.quick else DIVES_FULL)
    if dives < 1:
        print("--dives: must be >= 1", file=sys.stderr)
        return 2
    out = run(dives, args.seed)
    s = summarise(out)
    command = "python -m experiments.dive_honesty" + (f" --dives {dives}" if args.dives else
                                                       " --quick" if args.quick else "")
    text = report(s, command)
    ok = honest(s)
    if not args.no_photos:
        from . import dive_acceptance

        acc = dive_acceptance.run(seed=args.seed)
        text += "\n" + dive_acceptance.report(acc, command)
        s["acceptance_dive"] = {k: [bool(v[0]), v[1]] for k, v in
                                dive_acceptance.checks(acc).items()}
        ok = ok and all(v[0] for v in s["acceptance_dive"].values())
    for path, content in ((Path(args.json), json.dumps(s, indent=1) + "\n"), (Path(args.out), text)):
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(path.name + ".tmp")
        tmp.write_text(content, encoding="utf-8")
        os.replace(tmp, path)
    print(text)
    return 1 if args.strict and not ok else 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
