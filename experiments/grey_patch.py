"""A real camera's grey patch against depth (the reference-shot protocol): GREYPATCH.md.

    python -m experiments.grey_patch [--report GREYPATCH.md] [--out figures/grey_patch]

Data (read, never copied: ``../shared/realdata/grey_patch_vs_depth/grayPatch22_per_image.csv``,
from ``pietbro/Underwater-colorimetry``): a ColorChecker grey patch's linear camera RGB on a
research cruise at 0.7-14.9 m, each image divided by a surface reference shot, 253 images.
Camera, distance and exposure were not recorded and the camera auto-exposed, so only the
channel ratios carry the water: ln(R/G) and ln(B/G) of each image's ratios.

Model (validation, never tuning): the package's chart model (:class:`sca.model.ChartModel`,
eq 15 with eqs 4-12, the paper's water and path) with the default camera
(:data:`forward.DEFAULT_CAMERA`: the real camera is unknown) and D65, for ColorChecker patch 22
(neutral 5), at the image's depth and a distance of :data:`DISTANCE_M` (the unknown distance's
stated range :data:`DISTANCES_M`), divided by the same patch in air. Each ratio gets one constant
(:func:`fit_water`: the reference shot's own water and light, the unknown camera balance and
distance); the constants carry no depth dependence, so only the slopes and curvature against
depth test the model. Backscatter (veiling light) is the model's default, zero.

(a) The water retrieved from these data: C and a_CDOM(440) and the two constants fitted to the
per-image ln(R/G) and ln(B/G) (equal weights) by a bounded least-squares on the model function
(``scipy.optimize.least_squares``; the package's estimators need a whole chart), with a 95 %
percentile bootstrap interval over images (:data:`N_BOOT_FIT` refits). (b) Plausible waters:
C in :data:`PLAUSIBLE_CHL`, a_CDOM(440) in :data:`PLAUSIBLE_CDOM` and the paper's Fanning Island
and Monterey Bay waters (:data:`PAPER_WATERS`), over :data:`DISTANCES_M`.

Metric (chosen and written here before the fit was looked at):

- the observed slope: the least-squares slope of the per-image ln(R/G) against depth (m^-1),
  with its 95 % percentile bootstrap interval (images resampled with replacement,
  :data:`N_BOOT` resamples, seed :data:`SEED`); the same for ln(B/G);
- the model's slope: the same least-squares slope of the model's ln(R/G) at the images' depths;
- agreement: the model's slope with the retrieved water (at :data:`DISTANCE_M`) lies inside
  the observed slope's interval; its own interval is the slope over the bootstrap refits. For the
  plausible waters: whether the observed interval overlaps the range of their slopes.
- the residuals (data minus the fitted model) against depth: their RMS and, per depth bin of
  :data:`BIN_M`, their mean (the figure).

(c) Added after the fit was seen (the metric above unchanged): the unknown camera. The same
retrieval and model slope with each of the 49 measured cameras of
``../shared/realdata/camera_sensitivities/ground-truths`` (:func:`camera_check`): how far the
camera alone moves the model's slopes. No camera is chosen; the default stays the package's.

What it cannot show: the camera's curves, the distance and the exposure are unknown, and so is
the cruise's water (no in-situ chlorophyll or CDOM): a retrieved water that reproduces the ratios
is consistent with the model, not a measurement of C or a_CDOM.
"""

from __future__ import annotations

import argparse
import csv
import os
import sys
import time
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from scipy.optimize import least_squares

import forward
from sca.model import ChartModel, upper_cap

from .common import save_figure, style, write_csv
from .realwater.nomad_data import realdata_dir
from .realwater.report import write_report

__all__ = ["BIN_M", "CAMERAS_DIR", "DATA_FILE", "DISTANCE_M", "DISTANCES_M", "GREY_PATCH", "N_BOOT",
           "N_BOOT_FIT", "PAPER_WATERS", "PLAUSIBLE_CDOM", "PLAUSIBLE_CHL", "SEED", "bootstrap_slopes",
           "camera_check", "fit_water", "grey_model", "load_grey_patch", "log_ratios", "main", "model_log_ratios",
           "plausible_slopes", "run", "slope"]

#: The per-image table inside ``../shared/realdata`` (R, G, B, depth_m).
DATA_FILE = Path("grey_patch_vs_depth") / "grayPatch22_per_image.csv"
#: Measured RGB curves of 49 cameras inside ``../shared/realdata`` (wavelength, red, green,
#: blue; Jiang et al. 2013, Kawakami et al. 2013, Tominaga et al. 2021 and others).
CAMERAS_DIR = Path("camera_sensitivities") / "ground-truths"
#: ColorChecker patch 22 (neutral 5), 0-based in the chart's reading order.
GREY_PATCH = 21
#: The distance of the retrieval, m (not recorded: a hand-held chart in front of the camera).
DISTANCE_M = 1.0
#: The stated range of the unknown distance, m.
DISTANCES_M = (0.5, 2.0)
#: Plausible waters: C (mg m^-3) and a_CDOM(440) (m^-1) grids.
PLAUSIBLE_CHL = (0.1, 0.3, 1.0, 3.0)
PLAUSIBLE_CDOM = (0.0, 0.1, 0.3)
#: The paper's waters of Figs 5 and 6: name -> (C, a_CDOM(440)).
PAPER_WATERS = {"Fanning Island (Fig 5)": (1.0, 0.05), "Monterey Bay (Fig 6)": (5.0, 0.1)}
#: Bootstrap resamples of the slopes and of the fit; the random seed; the interval level.
N_BOOT = 2000
N_BOOT_FIT = 200
SEED = 0
LEVEL = 0.95
#: A retrieved C at or below this (mg m^-3) is reported as its lower bound, 0.
CHL_AT_BOUND = 1e-6
#: Depth bins of the residual figure, m.
BIN_M = 1.0
#: The two ratios, in the order of every (..., 2) array.
RATIOS = ("ln(R/G)", "ln(B/G)")
COMMAND = "OPENBLAS_NUM_THREADS=1 .venv/bin/python -m experiments.grey_patch"
ROOT = Path(__file__).resolve().parents[1]


def load_grey_patch(path=None) -> tuple[np.ndarray, np.ndarray]:
    """The per-image depths (n,), m, and ratios to the reference shot (n, 3), R G B.

    Raises
    ------
    FileNotFoundError
        If the file does not exist.
    """
    path = Path(path) if path is not None else realdata_dir() / DATA_FILE
    if not path.is_file():
        raise FileNotFoundError(f"path: grey-patch table not found: {path}")
    with open(path, newline="", encoding="utf-8") as f:
        rows = np.array([[float(r[k]) for k in ("R", "G", "B", "depth_m")]
                         for r in csv.DictReader(f)])
    return rows[:, 3], rows[:, :3]


def log_ratios(rgb) -> np.ndarray:
    """ln(R/G) and ln(B/G) of camera values (..., 3) -> (..., 2)."""
    ln = np.log(np.asarray(rgb, float))
    return np.stack([ln[..., 0] - ln[..., 1], ln[..., 2] - ln[..., 1]], axis=-1)


def grey_model(camera=forward.DEFAULT_CAMERA, water=None) -> ChartModel:
    """The chart model of the grey patch alone (``camera``: as for
    :func:`forward.chart_setup`; D65)."""
    grey = forward.chart_reflectances()[:, [GREY_PATCH]]
    return ChartModel(forward.chart_setup(camera, reflectances=grey), water=water)


def model_log_ratios(model: ChartModel, chl, cdom, depth, distance) -> np.ndarray:
    """The model's ln(R/G), ln(B/G) of the grey patch at (depth, distance) over the same in air.

    Parameters broadcast together (shape S); returns (S + (2,)).
    """
    def values(**p):
        return model.predict(p, jacobian=False).values

    under = values(chl=chl, cdom=cdom, depth=depth, distance=distance)
    air = values(chl=0.0, depth=0.0, distance=0.0)  # path length 0: the patch in air
    return log_ratios(under) - log_ratios(air)


def slope(depth, y) -> np.ndarray:
    """Least-squares slopes of ``y`` (..., n, k) against ``depth`` (broadcast to (..., n)):
    (..., k), one per column (ratio)."""
    d = np.asarray(depth, float)[..., None]
    dc = d - d.mean(axis=-2, keepdims=True)
    yc = np.asarray(y, float) - np.mean(y, axis=-2, keepdims=True)
    return np.sum(dc * yc, axis=-2) / np.sum(dc * dc, axis=-2)


def _interval(samples) -> list:
    tail = 50.0 * (1.0 - LEVEL)
    return np.percentile(samples, [tail, 100.0 - tail], axis=0).T.tolist()


def bootstrap_slopes(depth, y, n_boot: int = N_BOOT, seed: int = SEED) -> np.ndarray:
    """Slopes of the ratios (n, 2) against depth over ``n_boot`` resamples of the images:
    (n_boot, 2)."""
    idx = np.random.default_rng(seed).integers(0, depth.size, (n_boot, depth.size))
    return slope(depth[idx], y[idx])


def fit_water(depth, y, model: ChartModel, distance: float = DISTANCE_M) -> dict:
    """C, a_CDOM(440) and a constant per ratio fitted to the ratios (n, 2): least squares
    (the constants, linear, profiled out: the mean of the data minus the model).

    Returns
    -------
    dict
        'chl' (mg m^-3), 'cdom' (m^-1), 'offsets' (2,), 'fitted' (n, 2) and 'rms' (2,).
    """
    def misfit(theta):
        r = y - model_log_ratios(model, theta[0], theta[1], depth, distance)
        return r - r.mean(axis=0)

    caps = [upper_cap("chl", model.water), upper_cap("cdom", model.water)]
    res = least_squares(lambda t: misfit(t).ravel(), [1.0, 0.1], bounds=([0.0, 0.0], caps),
                        x_scale=[1.0, 0.1])
    gap = y - model_log_ratios(model, res.x[0], res.x[1], depth, distance)
    r = gap - gap.mean(axis=0)
    return {"chl": float(res.x[0]), "cdom": float(res.x[1]),
            "offsets": gap.mean(axis=0).tolist(), "fitted": y - r,
            "rms": np.sqrt(np.mean(r ** 2, axis=0)).tolist()}


def _fit_interval(depth, y, model, n_boot: int, seed: int) -> dict:
    """The retrieval over ``n_boot`` resamples of the images: its C, a_CDOM and the model's
    slopes at the data's depths."""
    rng = np.random.default_rng(seed + 1)
    chl, cdom, slopes = [], [], []
    for _ in range(n_boot):
        i = rng.integers(0, depth.size, depth.size)
        f = fit_water(depth[i], y[i], model)
        chl.append(f["chl"])
        cdom.append(f["cdom"])
        slopes.append(slope(depth, model_log_ratios(model, f["chl"], f["cdom"], depth,
                                                    DISTANCE_M)))
    return {"chl": _interval(chl), "cdom": _interval(cdom), "slope": _interval(slopes)}


def camera_check(depth, y, interval, folder=None) -> dict:
    """The unknown camera: the retrieval and its model slopes with each measured camera.

    Parameters
    ----------
    depth, y : ndarray
        The images' depths (n,) and ratios (n, 2).
    interval : array_like, (2, 2)
        The observed slopes' intervals ([lo, hi] per ratio).
    folder : path, optional
        Folder of camera curves as CSV (default :data:`CAMERAS_DIR` in ``../shared/realdata``).

    Returns
    -------
    dict
        'cameras': name -> {'chl', 'cdom', 'rms', 'model_slope', 'inside'} (inside: both
        slopes inside the observed intervals); 'range': min and max of each slope ((2, 2));
        'n_inside': how many cameras have both inside.
    """
    folder = Path(folder) if folder is not None else realdata_dir() / CAMERAS_DIR
    lo, hi = np.asarray(interval, float).T
    cameras = {}
    for path in sorted(folder.glob("*.csv")):
        model = grey_model(str(path))
        f = fit_water(depth, y, model)
        s = slope(depth, model_log_ratios(model, f["chl"], f["cdom"], depth, DISTANCE_M))
        cameras[path.stem] = {"chl": f["chl"], "cdom": f["cdom"], "rms": f["rms"],
                              "model_slope": s.tolist(),
                              "inside": bool(np.all((lo <= s) & (s <= hi)))}
    s = np.array([c["model_slope"] for c in cameras.values()])
    return {"cameras": cameras, "range": [s.min(axis=0).tolist(), s.max(axis=0).tolist()],
            "n_inside": sum(c["inside"] for c in cameras.values())}


def _plausible_grid() -> tuple:
    """C, a_CDOM and distance of every plausible water, each (N, 1) (broadcast over depths)."""
    mesh = np.meshgrid(PLAUSIBLE_CHL, PLAUSIBLE_CDOM, DISTANCES_M, indexing="ij")
    return tuple(a.reshape(-1, 1) for a in mesh)


def plausible_slopes(depth, model: ChartModel) -> dict:
    """The model's slopes at the data's depths for the plausible waters over the distances.

    Returns
    -------
    dict
        'grid': min and max of each ratio's slope over :data:`PLAUSIBLE_CHL` x
        :data:`PLAUSIBLE_CDOM` x :data:`DISTANCES_M` ((2, 2) list); one entry per
        :data:`PAPER_WATERS` name: its slopes at each end of :data:`DISTANCES_M` ((2, 2) list).
    """
    chl, cdom, dist = _plausible_grid()
    s = slope(depth, model_log_ratios(model, chl, cdom, depth, dist)).reshape(-1, 2)
    out = {"grid": [s.min(axis=0).tolist(), s.max(axis=0).tolist()]}
    for name, (c, a) in PAPER_WATERS.items():
        z = np.array(DISTANCES_M)[:, None]
        out[name] = slope(depth, model_log_ratios(model, c, a, depth, z)).tolist()
    return out


def run(outdir, *, n_boot: int = N_BOOT, n_boot_fit: int = N_BOOT_FIT,
        seed: int = SEED) -> dict:
    """Every number of GREYPATCH.md, the figure and the residual CSV.

    Parameters
    ----------
    outdir : path
        Folder of ``grey_patch.png`` / ``.pdf`` and ``grey_patch_residuals.csv``.
    n_boot, n_boot_fit : int
        Bootstrap resamples of the slopes and of the retrieval.
    seed : int
        The bootstrap's seed.

    Returns
    -------
    dict
        JSON-ready numbers ('observed', 'retrieved', 'by_distance', 'plausible', 'agrees').

    Raises
    ------
    FileNotFoundError
        When ``../shared/realdata`` (its grey-patch table) is absent.
    """
    depth, rgb = load_grey_patch()
    y = log_ratios(rgb)
    model = grey_model()
    boot = bootstrap_slopes(depth, y, n_boot, seed)
    fit = fit_water(depth, y, model)
    model_slope = slope(depth, model_log_ratios(model, fit["chl"], fit["cdom"], depth,
                                                DISTANCE_M))
    observed = {"slope": slope(depth, y).tolist(), "interval": _interval(boot),
                "n_images": int(depth.size), "depth_m": [float(depth.min()), float(depth.max())],
                "r": [float(np.corrcoef(depth, y[:, k])[0, 1]) for k in range(2)]}
    retrieved = {k: fit[k] for k in ("chl", "cdom", "offsets", "rms")}
    retrieved |= {"model_slope": model_slope.tolist(),
                  "interval": _fit_interval(depth, y, model, n_boot_fit, seed)}
    by_distance = {}
    for z in DISTANCES_M:
        f = fit_water(depth, y, model, z)
        by_distance[f"{z:g}"] = {"chl": f["chl"], "cdom": f["cdom"], "rms": f["rms"],
                                 "model_slope": slope(depth, model_log_ratios(
                                     model, f["chl"], f["cdom"], depth, z)).tolist()}
    plausible = plausible_slopes(depth, model)
    lo, hi = np.array(observed["interval"]).T
    grid = np.array(plausible["grid"])
    numbers = {"observed": observed, "retrieved": retrieved, "by_distance": by_distance,
               "plausible": plausible,
               "agrees": {"retrieved": ((lo <= model_slope) & (model_slope <= hi)).tolist(),
                          "plausible_overlap": ((grid[0] <= hi) & (lo <= grid[1])).tolist()}}
    numbers["cameras"] = camera_check(depth, y, observed["interval"])
    numbers["figures"] = [str(p) for p in _figure(depth, y, fit, model, plausible, outdir)]
    numbers["csv"] = str(_residual_csv(depth, y, fit, outdir))
    return numbers


def _binned(depth, v) -> tuple[np.ndarray, np.ndarray]:
    """Mean of ``v`` (n, k) per depth bin of :data:`BIN_M`: (bin centres, means)."""
    b = np.floor(depth / BIN_M).astype(int)
    keys = np.unique(b)
    return (keys + 0.5) * BIN_M, np.array([v[b == k].mean(axis=0) for k in keys])


def _figure(depth, y, fit, model, plausible, outdir) -> list:
    """Data and model against depth (left), residuals (right), one row per ratio."""
    style()
    grid = np.linspace(0.0, depth.max(), 100)
    chl, cdom, dist = _plausible_grid()
    # each plausible water with its own constants (the mean of the data minus it)
    band = model_log_ratios(model, chl, cdom, grid, dist).reshape(-1, grid.size, 2)
    at_data = model_log_ratios(model, chl, cdom, depth, dist).reshape(-1, depth.size, 2)
    band = band + np.mean(y - at_data, axis=1)[:, None, :]
    curve = model_log_ratios(model, fit["chl"], fit["cdom"], grid, DISTANCE_M) + fit["offsets"]
    resid = y - fit["fitted"]
    centres, means = _binned(depth, resid)
    fig, axes = plt.subplots(2, 2, figsize=(7.2, 5.0), constrained_layout=True)
    for k, name in enumerate(RATIOS):
        ax = axes[k, 0]
        ax.fill_between(grid, band[..., k].min(axis=0), band[..., k].max(axis=0), color="0.85",
                        label="plausible waters (shape)")
        ax.plot(depth, y[:, k], ".", ms=3, color="C0", label="images")
        ax.plot(grid, curve[:, k], "-", color="C3",
                label=f"model, retrieved water ({DISTANCE_M:g} m)")
        ax.set_xlabel("depth (m)")
        ax.set_ylabel(name + " over the reference")
        ax = axes[k, 1]
        ax.axhline(0.0, color="0.5", lw=0.8)
        ax.plot(depth, resid[:, k], ".", ms=3, color="C0", label="images")
        ax.plot(centres, means[:, k], "o-", ms=3, color="C1", label=f"{BIN_M:g} m bins")
        ax.set_xlabel("depth (m)")
        ax.set_ylabel(name + " residual")
    axes[0, 0].legend(fontsize=7)
    axes[0, 1].legend(fontsize=7)
    fig.suptitle("A real camera's grey patch against depth: data and the package's model")
    return save_figure(fig, "grey_patch", outdir)


def _residual_csv(depth, y, fit, outdir) -> Path:
    rows = [[f"{d:g}"] + [f"{v:.6g}" for v in (*y[i], *fit["fitted"][i])]
            for i, d in enumerate(depth)]
    return write_csv(Path(outdir) / "grey_patch_residuals.csv",
                     ["depth_m", "ln_rg", "ln_bg", "model_ln_rg", "model_ln_bg"], rows,
                     f"The grey patch's ratios and the model with the retrieved water "
                     f"(Generated by: {COMMAND})")


def _iv(pair, f="{:.4f}") -> str:
    return f"[{f.format(pair[0])}, {f.format(pair[1])}]"


def _verdict(inside: bool) -> str:
    return "**inside**" if inside else "**outside**"


def report(n: dict, seconds: float) -> str:
    """GREYPATCH.md from :func:`run`'s numbers."""
    o, r, p, c = n["observed"], n["retrieved"], n["plausible"], n["cameras"]
    ri, ag = r["interval"], n["agrees"]
    grid = np.array(p["grid"])
    lines = [
        "# GREYPATCH — a real camera's grey patch against depth",
        "",
        f"Generated by `{COMMAND}` (`experiments/grey_patch.py`, {seconds:.0f} s; part of "
        "`make reproduce-figures` where `../shared/realdata` exists). **Validation, never "
        "tuning**: nothing of the package was chosen to fit these data; only the water (C, "
        "a_CDOM(440)) and one constant per ratio are fitted, as stated. Figure "
        "`figures/grey_patch/grey_patch.png`, the residuals `grey_patch_residuals.csv`, every "
        "number `grey_patch.json`.",
        "",
        f"**Data** (`../shared/realdata/{DATA_FILE.as_posix()}`, `pietbro/Underwater-colorimetry`): "
        f"a ColorChecker grey patch's linear camera RGB in {o['n_images']} images at "
        f"{o['depth_m'][0]:g}–{o['depth_m'][1]:g} m on a research cruise, each divided by a "
        "surface reference shot. Camera, distance and exposure were not recorded (auto-exposure):"
        " only ln(R/G) and ln(B/G) carry the water.",
        "",
        "**Model**: `sca.model.ChartModel` (eq 15, the paper's water and 'beam' path) with the "
        f"default camera ({forward.DEFAULT_CAMERA}; the real camera is unknown) and D65, "
        f"ColorChecker patch {GREY_PATCH + 1} at the image's depth and {DISTANCE_M:g} m (the "
        f"unknown distance's stated range {DISTANCES_M[0]:g}–{DISTANCES_M[1]:g} m), over the "
        "same patch in air, plus one constant per ratio (the reference shot's water and light, "
        "the camera's balance, the distance). Backscatter: the model's default, none.",
        "",
        "**Metric** (chosen before the fit was seen; module docstring): the least-squares slope "
        "of the per-image ratio against depth, its 95 % bootstrap interval over images "
        f"({N_BOOT} resamples); the model agrees when its slope at the images' depths, with the "
        "retrieved water, lies inside that interval.",
        "",
        "## Slopes against depth (m⁻¹)",
        "",
        "| | ln(R/G) | ln(B/G) |",
        "|---|---|---|",
        "| observed (95 % bootstrap) | " + " | ".join(
            f"{o['slope'][k]:.4f} {_iv(o['interval'][k])}" for k in range(2)) + " |",
        f"| model, retrieved water, {DISTANCE_M:g} m ({N_BOOT_FIT} refits) | " + " | ".join(
            f"{r['model_slope'][k]:.4f} {_iv(ri['slope'][k])}: {_verdict(ag['retrieved'][k])}"
            for k in range(2)) + " |"]
    for z, b in n["by_distance"].items():
        lines.append(f"| model, water retrieved at {z} m | " + " | ".join(
            f"{b['model_slope'][k]:.4f}" for k in range(2)) + " |")
    lines.append("| plausible waters (range; overlap with observed) | " + " | ".join(
        f"{_iv(grid[:, k])}: {'overlaps' if ag['plausible_overlap'][k] else '**no overlap**'}"
        for k in range(2)) + " |")
    for name in PAPER_WATERS:
        lines.append(f"| {name}, {DISTANCES_M[0]:g} / {DISTANCES_M[1]:g} m | " + " | ".join(
            f"{p[name][0][k]:.4f} / {p[name][1][k]:.4f}" for k in range(2)) + " |")
    lines.append(f"| {len(c['cameras'])} measured cameras, each its retrieved water (range) | " + " | ".join(
        _iv(np.array(c["range"])[:, k]) for k in range(2)) + " |")
    lines += [
        "",
        f"Plausible waters: C {', '.join(f'{v:g}' for v in PLAUSIBLE_CHL)} mg m⁻³ × a_CDOM(440) "
        f"{', '.join(f'{v:g}' for v in PLAUSIBLE_CDOM)} m⁻¹ × {DISTANCES_M[0]:g} and "
        f"{DISTANCES_M[1]:g} m; the paper's Fanning Island and Monterey Bay waters (Figs 5–6).",
        "",
        "## The retrieved water",
        "",
        ("C = 0 mg m⁻³ (its lower bound) in every bootstrap refit"
         if ri["chl"][1] <= CHL_AT_BOUND else
         f"C = {_chl(r['chl'])} mg m⁻³ [{_chl(ri['chl'][0])}, {_chl(ri['chl'][1])}]") + f", a_CDOM(440) = {r['cdom']:.3g} "
        f"m⁻¹ {_iv(ri['cdom'], '{:.3g}')} (95 % bootstrap over images) with the default camera "
        f"at {DISTANCE_M:g} m; at " + ", ".join(
            f"{z} m: C = {_chl(b['chl'])}, a_CDOM = {b['cdom']:.3g}"
            for z, b in n["by_distance"].items()) + ". Residual RMS (data − model): "
        f"ln(R/G) {r['rms'][0]:.3f}, ln(B/G) {r['rms'][1]:.3f}; their means per 1 m of depth are "
        "in the figure's right column.",
        "",
        "## What it shows",
        "",
        _shows(n),
        "",
        "What it cannot show: the camera's curves, the distance and the exposure are unknown, "
        "and so is the cruise's water (no chlorophyll or CDOM was measured), so the retrieved "
        "water is what the model needs, not a measurement; the reference shot's own water and "
        "light hide in the constants; backscatter is left out. Images taken at one depth are "
        "resampled as independent, so the intervals may be too narrow. A camera whose slopes "
        "agree does not make it the cruise's camera.",
        "",
        "The figure, `figures/grey_patch/grey_patch.png`, is drawn by the same command (the "
        "figures are generated, not kept in the repository).",
        ""]
    return "\n".join(lines)


def _shows(n: dict) -> str:
    o, r, c, ag = n["observed"], n["retrieved"], n["cameras"], n["agrees"]
    best = min(c["cameras"].items(), key=lambda kv: sum(kv[1]["rms"]))
    both = all(ag["retrieved"])
    text = [f"The observed ln(R/G) changes at {o['slope'][0]:+.4f} m⁻¹ (its interval "
            f"{'excludes' if not o['interval'][0][0] <= 0 <= o['interval'][0][1] else 'holds'}"
            f" 0) and ln(B/G) at {o['slope'][1]:+.4f} m⁻¹. With the default camera the model "
            f"{'reproduces both' if both else 'does not reproduce them'}: its slopes with the "
            f"retrieved water are {r['model_slope'][0]:+.4f} and {r['model_slope'][1]:+.4f} "
            f"m⁻¹, and the plausible waters' ln(R/G) slopes "
            f"{'overlap' if ag['plausible_overlap'][0] else 'do not reach'} the observed one."]
    if r["chl"] <= CHL_AT_BOUND:
        text.append("The fit takes C at its lower bound, 0: the clearest water the model may "
                    "take" + (", still short of the observed ln(R/G) slope."
                              if not ag["retrieved"][0] else "."))
    text.append(f"The camera alone moves the model's ln(R/G) slope over "
                f"{_iv(np.array(c['range'])[:, 0])} m⁻¹ across the {len(c['cameras'])} measured "
                f"cameras; with {c['n_inside']} of them both slopes fall inside the observed "
                f"intervals (lowest residual: {best[0]}, RMS {best[1]['rms'][0]:.3f} / "
                f"{best[1]['rms'][1]:.3f})" + "".join(
                    f"{'; inside: ' if j == 0 else ', '}{name} (C = {_chl(v['chl'])}, "
                    f"a_CDOM(440) = {v['cdom']:.3g})" for j, (name, v) in enumerate(
                        (k, v) for k, v in c["cameras"].items() if v["inside"])) + ".")
    if not both and c["n_inside"]:
        text.append("So the disagreement is within what the unknown camera can do: these data "
                    "neither confirm nor refute the model's water physics; the camera's curves "
                    "must be known before a grey patch's colour against depth measures water.")
    elif not both:
        text.append("No measured camera explains the disagreement either: the model's physics "
                    "(or the protocol's assumptions) miss these data.")
    return " ".join(text)


def _chl(value: float) -> str:
    return "0 (bound)" if value <= CHL_AT_BOUND else f"{value:.3g}"


def main(argv=None) -> int:
    """Run the study; write GREYPATCH.md, the figure, CSV and JSON (each whole). Exit 2 when
    ``../shared/realdata`` is absent."""
    ap = argparse.ArgumentParser(prog="python -m experiments.grey_patch", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default=str(ROOT / "figures" / "grey_patch"),
                    help="folder of the figure, CSV and JSON (default figures/grey_patch)")
    ap.add_argument("--report", default=str(ROOT / "GREYPATCH.md"), help="report file")
    args = ap.parse_args(argv)
    if not (realdata_dir() / DATA_FILE).is_file():
        print(f"real data absent: {realdata_dir() / DATA_FILE} does not exist", file=sys.stderr)
        return 2
    t0 = time.perf_counter()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    numbers = run(out)
    text = report(numbers, time.perf_counter() - t0)
    write_report(Path(args.report), [text], numbers, out / "grey_patch.json", header="")
    print(f"wrote {args.report}", file=sys.stderr)
    return 0


if __name__ == "__main__":  # pragma: no cover
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    sys.exit(main())
