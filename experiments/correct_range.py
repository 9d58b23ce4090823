"""Per-pixel range correction against today's single-distance correction and grey-world, on
scenes the independent renderer made: ``CORRECTION.md``.

    python -m experiments.correct_range [--out CORRECTION.md] [--figure docs/...jpg] [--seeds N]
    python -m experiments.correct_range --figure-only   # the README's picture alone

Each scene (:func:`experiments.independent_world.render_range_scene`, no code shared with
``forward``): a seafloor receding from 0.8 to 9 m at the camera's depth, open water above it,
a measured ColorChecker at 1 m and held-out charts at 1.5-8 m, photon and read noise, written
as a 16-bit linear TIFF. The camera is calibrated on the chart's values in air (the same
renderer), the near chart is measured with :func:`measure.measure` (corners given), and the
frame is corrected every way:

- matrix: :func:`measure.correct_image` with the scene's range map (the colour matrix per
  range, the default; the cap and the unknown ranges at their defaults); its training set is
  asserted disjoint from the scored chart (:func:`check_held_out`);
- diagonal: the same, ``method="diagonal"`` (the per-channel division alone);
- both again with the true water (controls);
- single distance: the paper's :func:`measure.correction` (von Kries gains at the chart's
  distance, its veiling light subtracted), the same for every pixel;
- white patch: each channel divided by the measured chart's white patch, mapped to the
  camera's white in air (:func:`white_patch`);
- grey-world: each channel divided by its mean over the frame, mapped to the camera's white in
  air (:func:`grey_world`, :func:`camera_white`).

Each result is scaled by one number so that the measured chart's white patch has its luminance
in air (exposure is not what is compared), mapped to CIELAB through the calibrated camera's
XYZ matrix (:func:`forward.camera_to_xyz_matrix`), and each held-out chart's 24 patches (their
central halves) are compared with their appearance in air (the renderer's own camera values in
air): the median CIEDE2000 (scikit-image) per chart, and the same with each patch's L* set to
the truth's (lightness-matched); over ``--seeds`` draws (default :data:`N_SEEDS`), the median
with its bootstrap 95 % interval. A last table runs the matrix correction with other caps
(``max_gain``, first seed): the evidence for :data:`measure.correct.MAX_GAIN`.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from forward.spectra import WHITE_PATCH

from . import independent_world as iw
from .scene import write_tiff

__all__ = ["BASELINES", "CHARTS", "CAPS", "N_SEEDS", "SCENES", "camera_white", "check_held_out",
           "evaluate_scene", "figure_only", "grey_world", "main", "report", "run",
           "white_patch"]

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
#: Seeds per scene of the report (bootstrap intervals of the medians over them)
N_SEEDS = 10
#: The white patch of the chart (ColorChecker patch 19)
WHITE = WHITE_PATCH


def _lab(setup, J):
    from skimage.color import xyz2lab

    import forward

    xyz = np.asarray(J, float) @ forward.camera_to_xyz_matrix(setup).T
    return xyz2lab(np.atleast_2d(xyz), illuminant="D65", observer="2", channel_axis=-1)


def _exposure(img, setup, near) -> float:
    """The one number that gives the measured chart's white patch its luminance in air."""
    import forward

    y_row = forward.camera_to_xyz_matrix(setup)[1]
    return float(y_row @ near["air"][:, WHITE]) / float(y_row @ _patches(img, near["boxes"])[WHITE])


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


def camera_white(setup) -> np.ndarray:
    """The camera's white in air (3,): P^T i of the camera's curves under the light, model
    units (1 in the most sensitive channel; about 0.58, 1, 0.85 for the Nikon 5100)."""
    return np.asarray(setup.white_response, float)


def grey_world(img, white) -> np.ndarray:
    """Grey-world: each channel divided by its mean over the frame and mapped to the camera's
    white in air (a frame whose mean is neutral comes out with the white's colour)."""
    flat = np.asarray(img, float).reshape(-1, 3)
    return np.asarray(img, float) / np.nanmean(flat, axis=0) * np.asarray(white, float)


def white_patch(img, patch_raw, white) -> np.ndarray:
    """White-patch: each channel divided by the measured chart's white patch (raw, veil
    included) and mapped to the camera's white in air."""
    return np.asarray(img, float) / np.asarray(patch_raw, float) * np.asarray(white, float)


def check_held_out(setup) -> None:
    """Assert that the scored chart (the renderer's) is not in the colour matrix's training
    set (:func:`measure.correct_matrix.check_held_out` raises otherwise)."""
    from measure.correct_matrix import check_held_out as check, training_reflectances

    wl = np.asarray(setup.wavelengths, float)
    chart = iw.chart_reflectances(iw.WorldOptions().chart, wl)
    check(chart, training_reflectances(wl)[1], "chart")


def _corrections(photo, meas, scene, chl, cdom, caps) -> tuple:
    """The frame corrected every way: {method: J (H, W, 3)} and {cap: J} (matrix)."""
    import measure
    from measure.correct import MAX_GAIN
    from measure.correctwater import correction_water

    raw = photo.data
    white = camera_white(meas.setup)

    def per_pixel(water, **kw):
        return measure.correct_image(photo, water, scene["range"], float_output=True,
                                     linear=False, srgb=False, **kw).values
    per_cap = {cap: per_pixel(meas, max_gain=cap) for cap in caps}
    methods = {
        "matrix": per_cap[MAX_GAIN] if MAX_GAIN in per_cap else per_pixel(meas),
        "diagonal": per_pixel(meas, method="diagonal"),
        "matrix, true water": per_pixel(correction_water(meas).with_water(chl, cdom)),
        "diagonal, true water": per_pixel(correction_water(meas).with_water(chl, cdom),
                                          method="diagonal"),
        "single distance": (raw - meas.offset.astype(np.float32)) * meas.gains.astype(np.float32),
        "white patch": white_patch(raw, _patches(raw, scene["charts"][0]["boxes"])[WHITE],
                                   white),
        "grey-world": grey_world(raw, white)}
    return methods, per_cap


def evaluate_scene(name, chl, cdom, depth, options, folder: Path, seed: int,
                   figure: Path | None = None, caps=CAPS) -> dict:
    """Render, measure, correct every way, compare; the numbers of one scene and seed."""
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
    check_held_out(setup)
    methods, per_cap = _corrections(photo, meas, scene, chl, cdom, caps)

    def scores(img):
        """Per held-out chart: median ΔE00, and with each patch's L* set to the truth's."""
        k = _exposure(img, setup, near)
        de, de_l = [], []
        for ch in scene["charts"][1:]:
            got = _lab(setup, k * _patches(img, ch["boxes"]))
            want = _lab(setup, ch["air"].T)
            de.append(_median_de(got, want))
            de_l.append(_median_de(np.column_stack([want[:, 0], got[:, 1:]]), want))
        return de, de_l
    scored = {m: scores(img) for m, img in methods.items()}
    if figure is not None:  # as shot (the camera's daylight balance) and the default correction
        shown = {"as shot, daylight white balance": photo.data,
                 "uw3p correct": methods["matrix"]}
        _figure(figure, setup, near, shown, {k: scores(v)[0] for k, v in shown.items()},
                [c["range"] for c in scene["charts"][1:]])
    e = meas.estimate
    return {"name": name, "chl": chl, "cdom": cdom, "depth": depth, "ranges":
            [c["range"] for c in scene["charts"][1:]],
            "results": {m: v[0] for m, v in scored.items()},
            "lightness_matched": {m: v[1] for m, v in scored.items()},
            "by_cap": {cap: scores(img)[0] for cap, img in per_cap.items()},
            "estimate": {"chl": e.chl, "chl_ci": e.chl_ci, "cdom": e.cdom, "cdom_ci": e.cdom_ci,
                         "reliable": meas.reliable, "flags": meas.flags},
            "spread": meas.correction_uncertainty, "measure_s": t_measure,
            "cap_m": measure.correction_table(meas).cap}


def _median_de(a, b) -> float:
    from skimage.color import deltaE_ciede2000

    return float(np.median(deltaE_ciede2000(a, b, channel_axis=-1)))


def _figure(path: Path, setup, near, images: dict, de: dict, ranges) -> None:
    """Before / after, side by side, and under each its held-out charts' median ΔE00: the
    frame as the camera saw it, in the calibrated camera's colours (white-balanced for
    daylight in air), and corrected per pixel (:func:`measure.correct_image`, the default
    matrix, as ``uw3p correct``), both scaled by one number so that the measured chart's white
    patch has its luminance in air (as the scores are), sRGB."""
    from matplotlib import font_manager
    from PIL import Image, ImageDraw, ImageFont

    from measure.output import srgb_preview

    white = camera_white(setup) * 1.05
    tiles = [srgb_preview(_exposure(img, setup, near) * np.asarray(img, float), setup,
                          white=white) for img in images.values()]
    gap = np.full((tiles[0].shape[0], 8, 3), 255, np.uint8)
    picture = Image.fromarray(np.hstack([tiles[0], gap, tiles[1]]))
    canvas = Image.new("RGB", (picture.width, picture.height + 44), "white")
    canvas.paste(picture)
    font = ImageFont.truetype(font_manager.findfont("DejaVu Sans"), 13)  # it has the Δ
    draw = ImageDraw.Draw(canvas)
    at = f"{min(ranges):g}-{max(ranges):g} m"
    for i, (label, values) in enumerate(de.items()):
        x = i * (tiles[0].shape[1] + gap.shape[1]) + 6
        draw.text((x, picture.height + 4), label, fill="black", font=font)
        draw.text((x, picture.height + 23), f"median ΔE00 per chart at {at}: "
                  + "  ".join(f"{v:.1f}" for v in values), fill="black", font=font)
    canvas.save(path, quality=90)


def figure_only(path: Path, seed: int = SEED) -> None:
    """The README's picture alone: the coastal scene of the report's first seed
    (:func:`run`'s figure), without the report."""
    name, c, a, d, opt = SCENES[1]
    with tempfile.TemporaryDirectory(prefix="uw3p-correct-") as tmp:
        evaluate_scene(name, c, a, d, opt, Path(tmp), seed + 1, path, ())


def run(seeds: int = N_SEEDS, seed: int = SEED, figure: Path | None = None) -> list:
    """Every scene's numbers over ``seeds`` noise and floor draws: per scene, the per-seed
    results (the cap table on the first seed only) and the seconds per seed."""
    out = []
    with tempfile.TemporaryDirectory(prefix="uw3p-correct-") as tmp:
        for i, (name, c, a, d, opt) in enumerate(SCENES):
            t0 = time.perf_counter()
            runs = [evaluate_scene(name, c, a, d, opt, Path(tmp), seed + i + 100 * j,
                                   figure if (i == 1 and j == 0) else None,
                                   CAPS if j == 0 else ())
                    for j in range(seeds)]
            out.append(runs[0] | {"runs": runs, "seeds": seeds,
                                  "seconds_per_seed": (time.perf_counter() - t0) / seeds,
                                  "results": _pool(runs, "results"),
                                  "lightness_matched": _pool(runs, "lightness_matched")})
    return out


def _pool(runs, key) -> dict:
    """{method: [(median over seeds, lo, hi) per range]}: the median of the per-seed chart
    medians and its bootstrap 95 % interval (scipy.stats.bootstrap, percentile; None for one
    seed)."""
    from scipy.stats import bootstrap

    pooled = {}
    for m in runs[0][key]:
        vals = np.array([r[key][m] for r in runs])  # (seeds, ranges)
        rows = []
        for v in vals.T:
            if v.size < 2 or np.ptp(v) == 0:
                rows.append((float(np.median(v)), None, None))
                continue
            ci = bootstrap((v,), np.median, confidence_level=0.95, n_resamples=2000,
                           method="percentile", random_state=np.random.default_rng(0)
                           ).confidence_interval
            rows.append((float(np.median(v)), float(ci.low), float(ci.high)))
        pooled[m] = rows
    return pooled


#: The methods the matrix must beat at every held-out range (the criterion)
BASELINES = ("diagonal", "single distance", "white patch", "grey-world")


def _checks(out) -> list:
    """(scene, range, holds) of the criterion: the matrix method's median below every
    baseline's at every range beyond the measured chart's."""
    rows = []
    for s in out:
        res = s["results"]
        for j, r in enumerate(s["ranges"]):
            rows.append((s["name"], r, res["matrix"][j][0] < min(res[b][j][0]
                                                                 for b in BASELINES)))
    return rows


def _cell(v) -> str:
    med, lo, hi = v
    return f"{med:.1f}" if lo is None else f"{med:.1f} [{lo:.1f}, {hi:.1f}]"


def _table(s, key) -> list:
    methods = list(s[key])
    lines = ["| range (m) | " + " | ".join(methods) + " |", "|---|" + "---|" * len(methods)]
    for j, r in enumerate(s["ranges"]):
        lines.append(f"| {r:g} | " + " | ".join(_cell(s[key][m][j]) for m in methods) + " |")
    return lines


def _training_count() -> int:
    """How many reflectances train the colour matrix (:mod:`measure.correct_matrix`)."""
    from measure.correct_matrix import training_reflectances

    return len(training_reflectances(np.arange(400.0, 701.0, 10.0))[0])


def report(out, command: str, seconds: float, figure: str | None) -> str:
    """CORRECTION.md."""
    from measure.correct import MAX_GAIN

    ok = all(h for *_, h in _checks(out))
    seeds = out[0]["seeds"]
    per_seed = sum(s["seconds_per_seed"] for s in out)
    lines = [
        "# Correcting every pixel at its own range",
        "",
        f"Generated by `{command}` (`experiments/correct_range.py`, {seconds:.0f} s, "
        f"{per_seed:.1f} s per seed of the {len(out)} scenes; part of "
        "`make reproduce-figures`). Scenes of the independent renderer "
        "(`experiments/independent_world.py: render_range_scene`, no code shared with "
        f"`forward`): a {SIZE[1]}x{SIZE[0]} px frame of a seafloor receding from 0.8 to 9 m at "
        "the camera's depth, open water above it, a ColorChecker at 1 m that is measured "
        "(`measure.measure`, corners given, the camera calibrated on the chart in air) and "
        "held-out charts at 1.5-8 m; photon and read noise; the renderer's veiling light "
        "(Petzold's particle backscatter ratio, not the package's). "
        f"{seeds} seed(s) per scene (noise and floor). Each frame corrected by "
        "`measure.correct_image` with the range map (cap `max_gain` = "
        f"{MAX_GAIN:g}) with the colour matrix per range (**matrix**, the default; its "
        f"training set, the {_training_count()} CIE 1995 / NIST CQS 9.0 test colour samples, "
        "asserted disjoint "
        "from the scored chart) and per channel (**diagonal**), both also with the true water "
        "(controls: the measured veil and gain, the true C and a_CDOM); by the paper's "
        "single-distance correction (`measure.correction`); by **white patch** (each channel "
        "divided by the measured chart's white, mapped to the camera's white in air) and by "
        "**grey-world** (each channel divided by its frame mean, mapped to the camera's white "
        "in air, P^T i); each scaled once so the measured chart's white has its luminance in "
        "air. Numbers: each held-out chart's median CIEDE2000 over its 24 patches against their "
        "appearance in air (the renderer's camera values in air, through the calibrated "
        "camera's XYZ matrix); the median over the seeds with its bootstrap 95 % interval. The "
        "second table per scene is the same with each patch's L* set to the truth's "
        "(lightness-matched: no range-free method models the fall-off of brightness).",
        "",
        f"**Criterion** (the matrix correction closer than every baseline ({', '.join(BASELINES)}) "
        f"at every range beyond the measured chart's, in every scene): "
        f"**{'holds' if ok else 'fails'}**"
        + ("." if ok else " at " + ", ".join(f"{r:g} m ({n})" for n, r, h in _checks(out)
                                             if not h) + "."),
        ""]
    for s in out:
        e = s["estimate"]
        lines += [f"## {s['name']}: C = {s['chl']:g} mg m^-3, a_CDOM(440) = {s['cdom']:g} m^-1, "
                  f"depth {s['depth']:g} m",
                  "",
                  f"Measured on the 1 m chart (first seed): C = {e['chl']:.3g} "
                  f"[{e['chl_ci'][0]:.3g}, {e['chl_ci'][1]:.3g}], a_CDOM(440) = {e['cdom']:.3g} "
                  f"[{e['cdom_ci'][0]:.3g}, {e['cdom_ci'][1]:.3g}], reliable {e['reliable']}; "
                  f"the cap at {s['cap_m']:.2f} m; {s['seconds_per_seed']:.1f} s per seed.",
                  "", "Median ΔE00:", ""] + _table(s, "results") + [
                  "", "Lightness-matched median ΔE00:", ""] + _table(s, "lightness_matched")
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
              "largest amplification of a channel's direct signal by the range), the matrix "
              "method, the first seed.", "",
              "| scene | range (m) | " + " | ".join(f"max_gain {c:g}" for c in CAPS) + " |",
              "|---|---|" + "---|" * len(CAPS)]
    for s in out:
        for j, r in enumerate(s["ranges"]):
            lines.append(f"| {s['name']} | {r:g} | " + " | ".join(
                f"{s['by_cap'][c][j]:.1f}" for c in CAPS) + " |")
    if figure:
        lines += ["", "## Before and after", "",
                  f"![before / after]({figure})", "",
                  "The coastal scene: left, the frame as the camera saw it, in the calibrated "
                  "camera's colours (white-balanced for daylight in air); right, corrected per "
                  "pixel (`uw3p correct`, the matrix method); under each, the median ΔE00 of "
                  "each held-out chart (both scaled so that the measured chart's white has its "
                  "luminance in air). The open water above the floor has no range and is "
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
    ap.add_argument("--seeds", type=int, default=N_SEEDS,
                    help=f"noise and floor draws per scene (default {N_SEEDS})")
    ap.add_argument("--strict", action="store_true", help="exit 1 when the criterion fails")
    ap.add_argument("--figure-only", action="store_true",
                    help="write the before/after picture (--figure) alone, not the report")
    args = ap.parse_args(argv)
    if args.figure_only:
        figure_only(Path(args.figure), args.seed)
        return 0
    t0 = time.perf_counter()
    fig = Path(args.figure) if args.figure else None
    if fig is not None:
        fig.parent.mkdir(parents=True, exist_ok=True)
    if args.seeds < 1:
        ap.error("--seeds: at least 1")
    out = run(args.seeds, args.seed, fig)
    text = report(out, "python -m experiments.correct_range", time.perf_counter() - t0,
                  args.figure or None)
    Path(args.out).write_text(text, encoding="utf-8")
    print(text)
    return 1 if args.strict and not all(h for *_, h in _checks(out)) else 0


if __name__ == "__main__":  # pragma: no cover
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    sys.exit(main())
