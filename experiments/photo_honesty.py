"""Photographs the estimator did not make, through ``measure.measure`` (its default engine).

    python -m experiments.photo_honesty [--n 30] [--mode lm] [--cases clean,...]

Each photo: the independent renderer's patch values (:mod:`experiments.independent_world`, no
code shared with ``forward``; reflectances and camera gains drawn with sd 1 %, camera curves
shifted with sd 0.5 nm, a single-scattering veil) drawn by :mod:`experiments.scene` on a reef
(blue cast, 2 glints, lens blur, photon and read noise) as a 900 x 1350 Bayer DNG; the camera
calibrated from the same chart rendered in air (``measure.calibrate``); measured with the true
grid corners (or shifted ones). C is log-uniform 0.1-5 mg m^-3, a_CDOM 0.01-0.5 m^-1, depth
2-10 m, distance 0.8-2.5 m. Printed per case: photos, reliable, and reliable with the truth
outside either 95 % interval ("confident wrong"; about 10 % of the reliable ones expected),
with the one-sided binomial p-value of that count at 10 %, and the flags of the unreliable ones.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from .honesty import NOMINAL_JOINT, miss_p

__all__ = ["BASE", "CASES", "SEED", "SIZE", "main", "run_case"]

#: Frame (height, width), pixels
SIZE = (900, 1350)
#: Random seed of the conditions and renders
SEED = 20261123
#: The renderer's options of every case (its tolerances)
BASE = {"backscatter": "single_scatter", "reflectance_sd": 0.01, "camera_gain_sd": 0.01,
        "camera_shift_nm_sd": 0.5}
#: Case -> (renderer options, depth told minus true depth (m), corners shifted by this many
#: patch pitches along the chart's rows)
CASES = {
    "clean": ({}, 0.0, 0.0),
    "cdom_slope_0.019": ({"cdom_slope": 0.019}, 0.0, 0.0),
    "nap_slope_0.006": ({"nap_slope": 0.006}, 0.0, 0.0),
    "yellowing_0.03": ({"yellowing": 0.03}, 0.0, 0.0),
    "depth_told_+0.3m": ({}, 0.3, 0.0),
    "corners_shift_0.5": ({}, 0.0, 0.5),
}


def run_case(name, n, rng, folder, mode="lm") -> dict:
    """Render and measure ``n`` photos of case ``name``; the counts (see the module)."""
    import measure

    from . import independent_world as iw
    from . import scene

    opts, depth_err, shift = CASES[name]
    opts = {**BASE, **opts}
    reliable = wrong = 0
    flags = {}
    for i in range(n):
        seed = int(rng.integers(2 ** 31))
        chl = float(10 ** rng.uniform(np.log10(0.1), np.log10(5)))
        cdom = float(10 ** rng.uniform(-2, np.log10(0.5)))
        depth, dist = float(rng.uniform(2, 10)), float(rng.uniform(0.8, 2.5))
        out = iw.render_chart(chl, cdom, depth, dist, rng=seed, **opts, noise=False)
        cal = iw.render_calibration(rng=seed, **opts, noise=False)
        corners = scene.card_corners(SIZE, width_fraction=0.4,
                                     rotation_deg=float(rng.uniform(-20, 20)))
        img = scene.render_scene(out["expected"], corners, size=SIZE, seed=seed, glints=2,
                                 cast="blue", exposure=float(rng.uniform(0.4, 0.7)))
        air = scene.render_scene(cal["expected"], corners, size=SIZE, seed=seed + 1,
                                 background="flat", cast=(1.0, 1.0, 1.0), exposure=0.7,
                                 vignetting=0.0)
        p_uw = scene.write_dng(Path(folder) / f"{name}_{i}.dng", img["image"])
        p_air = scene.write_dng(Path(folder) / f"{name}_{i}_air.dng", air["image"])
        prof = measure.calibrate(measure.sample_patches(measure.read_image(p_air),
                                                        air["grid_corners"]), image=p_air)
        grid = np.array(img["grid_corners"], float)
        grid = grid + shift * (grid[1] - grid[0]) / 6.0  # 6 patches along a row
        m = measure.measure(p_uw, corners=grid, depth=depth + depth_err, distance=dist,
                            profile=prof, mode=mode)
        e = m.estimate
        if m.reliable:
            reliable += 1
            wrong += not (e.chl_ci[0] <= chl <= e.chl_ci[1]
                          and e.cdom_ci[0] <= cdom <= e.cdom_ci[1])
        else:
            for f in m.flags:
                flags[f] = flags.get(f, 0) + 1
    p = miss_p(wrong, reliable, NOMINAL_JOINT) if reliable else float("nan")
    return {"n": n, "reliable": reliable, "confident_wrong": wrong, "p_value": p,
            "flags": dict(sorted(flags.items(), key=lambda kv: -kv[1])[:4])}


def main(argv=None) -> int:
    """Run the cases and print one line each."""
    ap = argparse.ArgumentParser(prog="python -m experiments.photo_honesty",
                                 description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=30, help="photos per case (default 30)")
    ap.add_argument("--mode", default="lm", help="measure.measure's engine (default lm)")
    ap.add_argument("--cases", default=",".join(CASES), help="comma-separated case names")
    args = ap.parse_args(argv)
    names = args.cases.split(",")
    unknown = set(names) - set(CASES)
    if unknown:
        ap.error(f"--cases: unknown {sorted(unknown)}; choose from {list(CASES)}")
    rng = np.random.default_rng(SEED)
    with tempfile.TemporaryDirectory(prefix="uw3p_photo_honesty_") as tmp:
        for name in names:
            r = run_case(name, args.n, rng, tmp, args.mode)
            print(f"{name}: {r['reliable']}/{r['n']} reliable, {r['confident_wrong']} confident "
                  f"wrong (binomial p at 10 %: {r['p_value']:.2g}); unreliable flags "
                  f"{r['flags']}", flush=True)
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
