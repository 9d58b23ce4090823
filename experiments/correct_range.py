"""Per-pixel range correction against today's single-distance correction and grey-world, on
scenes the independent renderer made: ``CORRECTION.md``.

    python -m experiments.correct_range [--out CORRECTION.md] [--figure docs/...jpg]

Each scene (:func:`experiments.independent_world.render_range_scene`, no code shared with
``forward``): a seafloor receding from 0.8 to 9 m at the camera's depth, open water above it,
a measured ColorChecker at 1 m and held-out charts at 1.5-8 m, photon and read noise, written
as a 16-bit linear TIFF. The camera is calibrated on the chart's values in air (the same
renderer), the near chart is measured with :func:`measure.measure` (corners given), and the
frame is corrected three ways:

- per-pixel: :func:`measure.correct_image` with the scene's range map (the cap and the
  unknown ranges at their defaults);
- single distance: today's :func:`measure.correction` (von Kries gains at the chart's distance,
  its veiling light subtracted), the same for every pixel;
- grey-world: each channel divided by its mean over the frame.

Each result is scaled by one number so that the measured chart's white patch has its luminance
in air (exposure is not what is compared), mapped to CIELAB through the calibrated camera's
XYZ matrix (:func:`forward.camera_to_xyz_matrix`), and each held-out chart's 24 patches (their
central halves) are compared with their appearance in air (the renderer's own camera values in
air): the median CIEDE2000 (scikit-image) per chart. A second table runs the per-pixel
correction with other caps (``max_gain``): the evidence for :data:`measure.correct.MAX_GAIN`.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from . import independent_world as iw
from .scene import write_tiff

__all__ = ["CHARTS", "CAPS", "SCENES", "evaluate_scene", "main", "report", "run"]

#: The scenes: (name, C mg m^-3, a_CDOM(440) m^-1, depth m, renderer options)
SCENES = (
    ("clear, 6 m", 0.3, 0.03, 6.0, {}),
    ("coastal, 8 m", 2.0, 0.1, 8.0, {}),
    ("CDOM-rich, 4 m, split path", 1.0, 0.3, 4.0, {"path": "split"}),
)
#: The charts: (range m, x position, width px); the first is measured
CHARTS = ((1.0, 0.5, 150), (1.5, 0.14, None), (2.0, 0.86, None), (3.0, 0.2, None),
          (4.5, 0.8, None), (6.0, 0.3, None), (8.0, 0.7, None))
#: The caps compared (max_gain; inf: none)
CAPS = (4.0, 8.0, 16.0, 32.0, np.inf)
#: Frame size (height, width), pixels
SIZE = (300, 480)
#: Seed of the scenes
SEED = 38


def _lab(setup, J):
    from skimage.color import xyz2lab

    import forward

    xyz = np.asarray(J, float) @ forward.camera_to_xyz_matrix(setup).T
    return xyz2lab(np.atleast_2d(xyz), illuminant="D65", observer="2", channel_axis=-1)


def _patches(img, boxes):
    """Mean of each patch's central half, (24, 3)."""
    out = []
    for x0, y0, x1, y1 in boxes:
        out.append(img[int(round(y0)):int(round(y1)), int(round(x0)):int(round(x1))]
                   .reshape(-1, 3).mean(axis=0))
    return np.array(out)


def _profile(scene, gain=20000.0):
    """A camera profile from the chart's values in air (as a calibration photo gives them)."""
    import measure
    from measure.chart import PatchSample

    air = scene["charts"][0]["air"] * gain
    sample = PatchSample(rgb=air, sigma=np.sqrt(air) / 30 + 1.0, n_pixels=np.full((3, 24), 900),
                         clipped=np.zeros((3, 24)), boxes=np.zeros((24, 4, 2)))
    return measure.calibrate(sample)


def evaluate_scene(name, chl, cdom, depth, options, folder: Path, seed: int,
                   figure: Path | None = None) -> dict:
    """Render, measure, correct three ways, compare; the numbers of one scene."""
    from skimage.color import deltaE_ciede2000

    import measure

    scene = iw.render_range_scene(chl, cdom, depth, size=SIZE, charts=CHARTS, rng=seed,
                                  **options)
    path = write_tiff(folder / f"scene_{seed}.tif", scene["image"])
    photo = measure.read_image(path)
    near = scene["charts"][0]
    t0 = time.perf_counter()
    meas = measure.measure(photo, corners=near["grid"], depth=depth, distance=near["range"],
                           profile=_profile(scene))
    t_measure = time.perf_counter() - t0
    setup = meas.setup
    raw = photo.data
    methods = {"single distance": (raw - meas.offset.astype(np.float32)) * meas.gains.astype(np.float32),
               "grey-world": raw / raw.reshape(-1, 3).mean(axis=0)}
    per_cap = {}
    for cap in CAPS:
        per_cap[cap] = measure.correct_image(photo, meas, scene["range"], max_gain=cap,
                                             float_output=True, linear=False, srgb=False).values
    from measure.correct import MAX_GAIN

    methods = {"per-pixel": per_cap[MAX_GAIN]} | methods
    white = 18  # patch 19, the white
    truth_near = near["air"][:, white]
    import forward

    y_row = forward.camera_to_xyz_matrix(setup)[1]
    results, by_cap = {}, {}

    def scores(img):
        near_white = _patches(img, near["boxes"])[white]
        k = float(y_row @ truth_near) / float(y_row @ near_white)
        out = []
        for ch in scene["charts"][1:]:
            got = _lab(setup, k * _patches(img, ch["boxes"]))
            want = _lab(setup, ch["air"].T)
            out.append(float(np.median(deltaE_ciede2000(got, want, channel_axis=-1))))
        return out
    for m, img in methods.items():
        results[m] = scores(img)
    for cap, img in per_cap.items():
        by_cap[cap] = scores(img)
    if figure is not None:
        _figure(figure, photo, meas, scene, name)
    e = meas.estimate
    return {"name": name, "chl": chl, "cdom": cdom, "depth": depth, "ranges":
            [c["range"] for c in scene["charts"][1:]], "results": results, "by_cap": by_cap,
            "estimate": {"chl": e.chl, "chl_ci": e.chl_ci, "cdom": e.cdom, "cdom_ci": e.cdom_ci,
                         "reliable": meas.reliable, "flags": meas.flags},
            "spread": meas.correction_uncertainty, "measure_s": t_measure,
            "cap_m": measure.correction_table(meas).cap}


def _figure(path: Path, photo, meas, scene, name):
    """Before / after: the frame as the camera saw it (white-balanced on the near chart's
    white, as a photographer would) and corrected per pixel, both sRGB."""
    from PIL import Image

    import measure
    from measure.imagefiles import to_8bit
    from measure.output import srgb_preview

    wb = photo.data / _patches(photo.data, scene["charts"][0]["boxes"])[18]
    before = srgb_preview(wb, meas.setup, white=np.ones(3) * 1.05)
    after = measure.correct_image(photo, meas, scene["range"], linear=False).srgb
    after8 = to_8bit(after)
    gap = np.full((before.shape[0], 8, 3), 255, np.uint8)
    Image.fromarray(np.hstack([before, gap, after8])).save(path, quality=90)


def run(seed: int = SEED, figure: Path | None = None) -> list:
    """Every scene's numbers."""
    with tempfile.TemporaryDirectory(prefix="uw3p-correct-") as tmp:
        return [evaluate_scene(name, c, a, d, opt, Path(tmp), seed + i,
                               figure if i == 1 else None)
                for i, (name, c, a, d, opt) in enumerate(SCENES)]


def _checks(out) -> list:
    """(scene, range, holds) of the criterion: per-pixel below both others at every range
    beyond the measured chart's."""
    rows = []
    for s in out:
        for j, r in enumerate(s["ranges"]):
            res = s["results"]
            rows.append((s["name"], r, res["per-pixel"][j] < min(res["single distance"][j],
                                                                  res["grey-world"][j])))
    return rows


def report(out, command: str, seconds: float, figure: str | None) -> str:
    """CORRECTION.md."""
    from measure.correct import MAX_GAIN

    ok = all(h for *_, h in _checks(out))
    lines = [
        "# Correcting every pixel at its own range",
        "",
        f"Generated by `{command}` (`experiments/correct_range.py`, {seconds:.0f} s; part of "
        "`make reproduce-figures`). Scenes of the independent renderer "
        "(`experiments/independent_world.py: render_range_scene`, no code shared with "
        f"`forward`): a {SIZE[1]}x{SIZE[0]} px frame of a seafloor receding from 0.8 to 9 m at "
        "the camera's depth, open water above it, a ColorChecker at 1 m that is measured "
        "(`measure.measure`, corners given, the camera calibrated on the chart in air) and "
        "held-out charts at 1.5-8 m; photon and read noise; the renderer's veiling light "
        "(Petzold's particle backscatter ratio, not the package's). Each frame corrected by "
        "`measure.correct_image` with the range map (cap `max_gain` = "
        f"{MAX_GAIN:g}), by today's single-distance correction (`measure.correction`) and by "
        "grey-world; each scaled once so the measured chart's white has its luminance in air. "
        "Numbers: each held-out chart's median CIEDE2000 over its 24 patches against their "
        "appearance in air (the renderer's camera values in air, through the calibrated "
        "camera's XYZ matrix).",
        "",
        f"**Criterion** (the per-pixel correction closer than both others at every range beyond "
        f"the measured chart's, in every scene): **{'holds' if ok else 'fails'}**"
        + ("." if ok else " at " + ", ".join(f"{r:g} m ({n})" for n, r, h in _checks(out)
                                             if not h) + "."),
        ""]
    for s in out:
        e = s["estimate"]
        lines += [f"## {s['name']}: C = {s['chl']:g} mg m^-3, a_CDOM(440) = {s['cdom']:g} m^-1, "
                  f"depth {s['depth']:g} m",
                  "",
                  f"Measured on the 1 m chart: C = {e['chl']:.3g} [{e['chl_ci'][0]:.3g}, "
                  f"{e['chl_ci'][1]:.3g}], a_CDOM(440) = {e['cdom']:.3g} [{e['cdom_ci'][0]:.3g}, "
                  f"{e['cdom_ci'][1]:.3g}], reliable {e['reliable']}; the cap at "
                  f"{s['cap_m']:.2f} m.",
                  "",
                  "| range (m) | per-pixel | single distance | grey-world |",
                  "|---|---|---|---|"]
        for j, r in enumerate(s["ranges"]):
            res = s["results"]
            lines.append(f"| {r:g} | {res['per-pixel'][j]:.1f} | {res['single distance'][j]:.1f} "
                         f"| {res['grey-world'][j]:.1f} |")
        sp = s["spread"] or {}
        if sp.get("chart_de00"):
            greys = ", ".join(f"{g['range_m']:g} m {g['de00']:.1f}" for g in sp["grey_de00"])
            lines += ["", f"The correction's own uncertainty (over the water's 95 % intervals, "
                          f"measurement.json): the chart's ΔE00 spread median "
                          f"{sp['chart_de00']['median']:.1f} (max {sp['chart_de00']['max']:.1f}); "
                          f"an 18 % grey's by range: {greys}."]
        lines.append("")
    lines += ["## The cap (evidence for `MAX_GAIN`)", "",
              "Median ΔE00 of the held-out charts by range with other caps (`max_gain`: the "
              "largest amplification of a channel's direct signal by the range).", "",
              "| scene | range (m) | " + " | ".join(f"max_gain {c:g}" for c in CAPS) + " |",
              "|---|---|" + "---|" * len(CAPS)]
    for s in out:
        for j, r in enumerate(s["ranges"]):
            lines.append(f"| {s['name']} | {r:g} | " + " | ".join(
                f"{s['by_cap'][c][j]:.1f}" for c in CAPS) + " |")
    if figure:
        lines += ["", "## Before and after", "",
                  f"![before / after]({figure})", "",
                  "The coastal scene: left, the frame white-balanced on the near chart's white "
                  "(what a photographer's white balance does); right, corrected per pixel "
                  "(`corrected_srgb.tif`). The open water above the floor has no range and is "
                  "corrected at the chart's distance."]
    lines.append("")
    return "\n".join(lines)


def main(argv=None) -> int:
    """Run the scenes and write CORRECTION.md (with ``--strict``, exit 1 when the criterion
    fails)."""
    ap = argparse.ArgumentParser(prog="python -m experiments.correct_range", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="CORRECTION.md")
    ap.add_argument("--figure", default="docs/correction_before_after.jpg")
    ap.add_argument("--seed", type=int, default=SEED)
    ap.add_argument("--strict", action="store_true", help="exit 1 when the criterion fails")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    fig = Path(args.figure) if args.figure else None
    if fig is not None:
        fig.parent.mkdir(parents=True, exist_ok=True)
    out = run(args.seed, fig)
    text = report(out, "python -m experiments.correct_range", time.perf_counter() - t0,
                  args.figure or None)
    Path(args.out).write_text(text, encoding="utf-8")
    print(text)
    return 1 if args.strict and not all(h for *_, h in _checks(out)) else 0


if __name__ == "__main__":  # pragma: no cover
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    sys.exit(main())
