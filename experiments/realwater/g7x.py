"""The paper's own real photographs: 17 Canon G7X underwater ColorCheckers (Blasinski & Farrell).

Data (read, never copied: ``../shared/realdata/g7x/``, README there): ``realRGB_Depth.mat``,
17 charts of RAW patch means (linear, black subtracted, unit white balance), each image divided
by its own maximum (the exposure gain is unknown), depth and distance not recorded (a few
metres to ~20 m); ``CanonG7x.mat``, the camera's measured quantal responsivities 400:5:700 nm
with their measured R:G:B balance; ``simulatedRGB_Depth.mat``, the authors' PBRT + ISET
simulation of a chart in pure water, D65, 1 m, Canon 1D Mark III, depths 0-20 m.

What is done (:func:`run`), each number with the command that produced it:

* **Fit of every chart** with the model (:func:`sca.estimate`, free exposure gain, the paper's
  exact model ``uncertain={}``), depth and distance unknown within bounds: the χ² is profiled
  on a grid, depth :data:`DEPTHS_M` (1-25 m: the README's "a few metres to ~20 m" with room on
  both sides), distance :data:`DISTANCES_M` (0.5-3 m: a diver holding or facing a chart; for
  'beam' and 'absorption' only depth + distance counts, so distance is held at
  :data:`DISTANCE_M`). Noise: :func:`photon_sigma` (stated assumptions) plus the package's
  per-patch systematic term (:data:`sca.budget.DEFAULT_UNCERTAIN` ``patch``) in the weights.
* **Residuals** against photon noise (the per-patch systematic error the residuals show beyond
  it, :func:`measure.camera.patch_systematic`) and against two baselines that know no water:
  diagonal (one gain per channel on the in-air chart rendering, 3 parameters) and affine
  (3 x 3 + offset, 12 parameters); the model has 6 (C, a_CDOM, gain, 3 veiling lights) plus
  the profiled geometry.
* **Path models** 'beam' (the paper), 'absorption' and 'split' (diffuse K_d down, beam c
  across): χ² of each per chart (likelihood ratio at equal parameter count).
* **Grey correction**: the model's von Kries correction (:func:`measure.correction`) of the
  real greys against grey-world and white-patch, as the angle of the corrected grey patches
  from the white of air, before and after the fix of ``measure.camera_setup`` (it threw away
  the curves' measured channel balance).
* **Captured vs model** panels (the paper's Figs 5-6 layout), sRGB through the camera's 3 x 3.
* **Forward model vs PBRT/ISET** on the authors' simulated series at known depth.

For REPRODUCTION.md's real-camera rows (issue 39, :mod:`experiments.realcamera`), each judged on
data the fit did not see:

* **Cross-validation** (:func:`cross_validate`): every patch predicted by fits that did not see
  it (:data:`FOLDS`: one chart column per fold; a held-out value's weight ~0 in every fit), by
  the model (the paper's; with measure's light field; with each optional physics of
  :mod:`forward.chart_physics`, :data:`PHYSICS`) and by the affine and diagonal baselines.
* **Held-out greys** (:func:`held_out_greys`): the correction of greys no method saw.
* **The user's own path** (:func:`measure_path`): each chart drawn as a DNG with flat patches
  (:func:`write_chart_dng`) and measured by the ``uw3p measure`` command
  (:func:`measure_command`: the G7X curves, the default budget, depth told 9 +- 6 m, distance
  1 +- 0.5 m).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import scipy.io

import forward
import sca
from forward.spectra import WHITE_PATCH
from measure.camera import camera_setup, patch_systematic
from measure.lightfield import fit_light_field
from measure.correct import correction

from ..common import save_figure, style

__all__ = [
    "CLIP_LEVEL",
    "DNG_FILL",
    "DNG_SIZE",
    "FOLDS",
    "HELD_GREYS",
    "HELD_OUT_SIGMA",
    "PHYSICS",
    "TILTS_DEG",
    "TOLD_DEPTH_M",
    "TOLD_DEPTH_SD_M",
    "TOLD_DISTANCE_M",
    "TOLD_DISTANCE_SD_M",
    "cross_validate",
    "cv_baselines",
    "cv_fits",
    "held_out_greys",
    "measure_command",
    "measure_path",
    "write_chart_dng",
    "write_curves_csv",
    "COMMAND",
    "DEPTHS_M",
    "DISTANCES_M",
    "DISTANCE_M",
    "FULL_WELL_E",
    "GREYS",
    "PATH_MODELS",
    "PIXELS_PER_PATCH",
    "REALDATA",
    "baselines",
    "fit_chart",
    "grey_angles",
    "load_charts",
    "load_curves",
    "photon_sigma",
    "run",
    "simulated_check",
]

#: ``../shared/realdata`` beside the repository (absent in an installed package).
REALDATA = Path(__file__).resolve().parents[2].parent / "shared" / "realdata"
#: Depth grid of the profile, m: the series spans "a few metres to ~20 m" (README), unrecorded
#: per file; 1-25 m leaves room on both sides.
DEPTHS_M = (1.0, 2.0, 3.0, 5.0, 7.0, 10.0, 13.0, 16.0, 20.0, 25.0)
#: Camera-to-chart distances of the 'split' profile, m (a chart held or faced by a diver).
DISTANCES_M = (0.5, 1.0, 2.0, 3.0)
#: Distance for 'beam' and 'absorption', m: k depends on depth + distance only, so the depth
#: grid is a grid of the path length and the distance is a label.
DISTANCE_M = 1.0
#: Assumed full-well capacity of a G7X pixel, electrons (a 1-inch 20 MP sensor, 2.4 um pixels:
#: ~10^4 e-; an assumption, not a measurement), and the image maximum taken as full scale.
FULL_WELL_E = 1.0e4
#: Assumed pixels per channel averaged in a patch mean (a lower bound: a chart patch at 1 m on
#: a 20 MP frame covers ~10^4 pixels, a quarter of them red or blue); fewer pixels = more noise,
#: so this bounds the photon noise from above and the chi^2 from below.
PIXELS_PER_PATCH = 1.0e3
#: Grey patches of the angle (0-based: white, neutral 8, 6.5, 5); neutral 3.5 and black are
#: reported apart: at 1-4 % of the white their colour is the veiling light's estimate.
GREYS = (18, 19, 20, 21)
#: Path models compared.
PATH_MODELS = ("beam", "absorption", "split")
#: The authors' ISET simulation saturates at 0.949 of its scale: values above this are left out.
CLIP_LEVEL = 0.94
#: The command that produces every number here.
COMMAND = ("OPENBLAS_NUM_THREADS=1 .venv/bin/python -c \"from pathlib import Path; "
           "from experiments.realwater import g7x; "
           "print(g7x.run(Path('figures/realwater'))[0])\"")


def _folder() -> Path:
    folder = REALDATA / "g7x"
    if not folder.is_dir():
        raise FileNotFoundError(f"realdata: {folder} is absent (../shared/realdata beside the "
                                "repository)")
    return folder


def load_charts():
    """The 17 real G7X charts in ColorChecker reading order.

    Returns
    -------
    names : list of str
        The image names (IMG_xxxx).
    rgb : numpy.ndarray, (17, 3, 24)
        Patch means, each image's maximum = 1 (R, G, B by patch 1-24). The files hold the
        chart upside down (README): reading order is ``a[::-1].reshape(24, 3).T``.

    Raises
    ------
    FileNotFoundError
        When ``../shared/realdata/g7x`` is absent.
    """
    mat = scipy.io.loadmat(_folder() / "realRGB_Depth.mat")
    names = [str(n.ravel()[0]) if n.size else "" for n in mat["imageNames"].ravel()]
    rgb = np.stack([np.asarray(a, float)[::-1].reshape(24, 3).T for a in mat["measuredRGB"].ravel()])
    return names, rgb


def load_curves():
    """The G7X's measured responsivities.

    Returns
    -------
    wavelengths : numpy.ndarray, (61,)
        400-700 nm at 5 nm.
    curves : numpy.ndarray, (61, 3)
        Quantal responsivities (act on photons), R, G, B, with their measured balance.
    """
    mat = scipy.io.loadmat(_folder() / "CanonG7x.mat")
    return mat["wavelength"].ravel().astype(float), np.asarray(mat["data"], float)


def photon_sigma(rgb) -> np.ndarray:
    """Photon-noise standard error of patch means in units of the image maximum.

    sigma = sqrt(v / (FULL_WELL_E PIXELS_PER_PATCH)) for a value v (fraction of the maximum,
    taken as full scale): Poisson electrons v FULL_WELL_E per pixel, averaged over
    PIXELS_PER_PATCH pixels; read noise (a few e-) is negligible against it for v > 10^-3.

    Parameters
    ----------
    rgb : array_like
        Patch means, fraction of the image maximum.

    Returns
    -------
    numpy.ndarray
        Standard errors, same shape and unit (a floor of one electron's worth).
    """
    v = np.maximum(np.asarray(rgb, float), 1.0 / FULL_WELL_E)
    return np.sqrt(v / (FULL_WELL_E * PIXELS_PER_PATCH))


def _model_values(est, setup) -> np.ndarray:
    G = forward.camera_response(setup.sensitivities, setup.illuminant, est.attenuation,
                                setup.reflectances)
    return est.gain * G + np.asarray(est.backscatter, float)[:, None]


def fit_chart(rgb, sigma, setup, path_model: str = "beam") -> dict:
    """The model's best fit of one chart, depth (and for 'split' distance) profiled on a grid.

    Parameters
    ----------
    rgb, sigma : array_like, (3, 24)
        Patch means and their standard errors (same unit).
    setup : forward.ChartSetup
        The camera set-up (:func:`measure.camera_setup`).
    path_model : {'beam', 'absorption', 'split'}
        The path model.

    Returns
    -------
    dict
        ``depth``, ``distance`` (m), ``chi2`` (weighted by ``sigma``), ``estimate``
        (:class:`sca.Estimate`), ``fitted`` (3, 24) model values, ``profile`` {(depth,
        distance): chi2}.
    """
    water = forward.Water(path_model=path_model)
    dists = DISTANCES_M if path_model == "split" else (DISTANCE_M,)
    best, profile = None, {}
    for depth in DEPTHS_M:
        for dist in dists:
            est = sca.estimate(rgb, depth=depth, distance=dist, sigma=sigma, gain="free",
                               setup=setup, water=water, uncertain={})
            fitted = _model_values(est, setup)
            chi2 = float(np.sum(((rgb - fitted) / sigma) ** 2))
            profile[(depth, dist)] = chi2
            if best is None or chi2 < best["chi2"]:
                best = {"depth": depth, "distance": dist, "chi2": chi2, "estimate": est,
                        "fitted": fitted}
    best["profile"] = profile
    return best


def baselines(rgb, sigma, air) -> dict:
    """Weighted least-squares fits that know no water: diagonal and affine.

    Parameters
    ----------
    rgb, sigma : array_like, (3, n)
        Patch means and standard errors.
    air : array_like, (3, n)
        The chart rendered in air (P^T diag(i) R).

    Returns
    -------
    dict
        name -> {'chi2', 'parameters', 'fitted' (3, n)}: 'diagonal' (M_c = g_c A_c, 3
        parameters), 'affine' (M_c = a_c . A + b_c, 12 parameters).
    """
    rgb, sigma, air = (np.asarray(a, float) for a in (rgb, sigma, air))
    out = {}
    for name, design in (("diagonal", None), ("affine", np.vstack([air, np.ones(air.shape[1])]))):
        fitted = np.empty_like(rgb)
        for c in range(rgb.shape[0]):
            X = air[c:c + 1] if design is None else design
            w = 1.0 / sigma[c]
            coef, *_ = np.linalg.lstsq((X * w).T, rgb[c] * w, rcond=None)
            fitted[c] = coef @ X
        out[name] = {"chi2": float(np.sum(((rgb - fitted) / sigma) ** 2)),
                     "parameters": 3 if design is None else 12, "fitted": fitted}
    return out


def _angle(rgb, white) -> np.ndarray:
    """Angle (degrees) of each column of ``rgb`` from the direction ``white``."""
    u = np.asarray(white, float) / np.linalg.norm(white)
    v = np.asarray(rgb, float)
    cos = np.clip(u @ v / np.linalg.norm(v, axis=0), -1.0, 1.0)
    return np.degrees(np.arccos(cos))


def grey_angles(rgb, est, setup, target_setup) -> dict:
    """Angles of the corrected grey patches from the white of air, per method.

    Parameters
    ----------
    rgb : array_like, (3, 24)
        Captured patch means.
    est : sca.Estimate
        The model's fit (attenuation, veiling light) with ``setup``.
    setup : forward.ChartSetup
        The set-up of the fit (its correction :func:`measure.correction`).
    target_setup : forward.ChartSetup
        The camera with its true balance: its white of air (P^T i) is the target of every
        correction, and its chart in air the reference of grey-world and white-patch.

    Returns
    -------
    dict
        method -> angles (degrees, one per patch of :data:`GREYS` then neutral 3.5, black):
        'model', 'grey-world', 'white-patch'.
    """
    rgb = np.asarray(rgb, float)
    gains, offset = correction(est, setup, rgb[:, WHITE_PATCH])
    air = target_setup.sensitivities.T @ (target_setup.illuminant[:, None] * target_setup.reflectances)
    corrected = {
        "model": gains[:, None] * (rgb - offset[:, None]),
        "grey-world": (air.mean(axis=1) / rgb.mean(axis=1))[:, None] * rgb,
        "white-patch": (air[:, WHITE_PATCH] / rgb[:, WHITE_PATCH])[:, None] * rgb,
    }
    cols = list(GREYS) + [22, 23]
    return {k: _angle(v[:, cols], target_setup.white_response) for k, v in corrected.items()}


def _srgb(xyz_matrix, rgb, scale) -> np.ndarray:
    import colour

    xyz = (xyz_matrix @ np.asarray(rgb, float)).T * scale
    return np.clip(colour.XYZ_to_sRGB(xyz), 0.0, 1.0)


def _panels(names, charts, fits, setup, outdir) -> list:
    """Captured (top) and model best fit (bottom) per chart, sRGB through the camera's 3 x 3,
    each pair scaled so that the captured white has Y = 0.8."""
    M = forward.camera_to_xyz_matrix(setup)
    cols = 6
    rows = int(np.ceil(len(names) / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(7.2, 1.75 * rows), constrained_layout=True,
                             squeeze=False)
    for ax in axes.ravel():
        ax.set_axis_off()
    for ax, name, rgb, fit in zip(axes.ravel(), names, charts, fits):
        scale = 0.8 / max(float((M @ rgb[:, WHITE_PATCH])[1]), 1e-12)
        top = forward.patches_image(_srgb(M, rgb, scale), patch_px=10, gap_px=2)
        bottom = forward.patches_image(_srgb(M, fit["fitted"], scale), patch_px=10, gap_px=2)
        gap = np.ones((4,) + top.shape[1:])
        ax.imshow(np.concatenate([top, gap, bottom]))
        ax.set_title(f"{name}\n{fit['depth']:g} m + {fit['distance']:g} m", fontsize=7)
    fig.suptitle("Real G7X charts: captured (top) and the model's best fit (bottom), beam path",
                 fontsize=8)
    return save_figure(fig, "g7x_captured_vs_model", outdir)


def simulated_check(wavelengths) -> dict:
    """The forward model against the authors' PBRT + ISET series (pure water, D65, 1 m).

    Per depth: the forward model's chart (C = a_CDOM = 0, the depth, 1 m, the Canon 1D Mark
    III curves of Jiang et al. 2013 from ``camera_sensitivities/ground-truths``) is fitted to
    ISET's chart with one gain per channel (ISET's own filters and auto-exposure differ by a
    per-channel factor); values above :data:`CLIP_LEVEL` are left out. If both describe the
    same water, those gains do not drift with depth: the slope of ln(g_R / g_G) and
    ln(g_B / g_G) against depth is the model's error in c_R - c_G and c_B - c_G (m^-1).

    Parameters
    ----------
    wavelengths : array_like
        The grid, nm.

    Returns
    -------
    dict
        'depth_m', 'rms_rel' (per depth, relative RMS residual of the per-channel fit),
        'ln_rg', 'ln_bg' (per depth), 'slope_rg', 'slope_bg' (m^-1).
    """
    mat = scipy.io.loadmat(_folder() / "simulatedRGB_Depth.mat")
    depths = mat["depth_m"].ravel().astype(float)
    sims = [np.asarray(a, float)[::-1].reshape(24, 3).T for a in mat["simulatedRGB"].ravel()]
    curves = REALDATA / "camera_sensitivities" / "ground-truths" / "Canon_1D-Mk-III_Jiang-et-al-2013.csv"
    setup = forward.chart_setup(str(curves), None, None, wavelengths)
    water = forward.Water()
    rms, lrg, lbg = [], [], []
    for d, sim in zip(depths, sims):
        k = forward.attenuation(setup.wavelengths, 0.0, 0.0, d, 1.0, water=water)
        G = forward.camera_response(setup.sensitivities, setup.illuminant, k, setup.reflectances)
        ok = sim < CLIP_LEVEL
        g = np.array([np.sum(sim[c, ok[c]] * G[c, ok[c]]) / np.sum(G[c, ok[c]] ** 2)
                      for c in range(3)])
        r = np.where(ok, sim - g[:, None] * G, 0.0)
        rms.append(float(np.linalg.norm(r) / np.linalg.norm(np.where(ok, sim, 0.0))))
        lrg.append(float(np.log(g[0] / g[1])))
        lbg.append(float(np.log(g[2] / g[1])))
    return {"depth_m": depths.tolist(), "rms_rel": rms, "ln_rg": lrg, "ln_bg": lbg,
            "slope_rg": float(np.polyfit(depths, lrg, 1)[0]),
            "slope_bg": float(np.polyfit(depths, lbg, 1)[0])}


def _old_setup(curves, wavelengths):
    """The set-up as ``measure.camera_setup(curves, quantal=True)`` built it before the fix:
    the quantal curves times lambda, every channel renormalised to peak 1 (balance lost)."""
    return forward.chart_setup(np.asarray(curves) * np.asarray(wavelengths)[:, None], None, None,
                               wavelengths)


def run(outdir: Path) -> tuple[str, dict]:
    """Every G7X result: fits, residuals, path models, grey correction, PBRT/ISET check.

    Parameters
    ----------
    outdir : pathlib.Path
        Folder of the figures (``g7x_*.png`` / ``.pdf``).

    Returns
    -------
    markdown : str
        The section for REALWATER.md.
    numbers : dict
        Every number of the section (JSON-ready).

    Raises
    ------
    FileNotFoundError
        When ``../shared/realdata/g7x`` is absent.
    """
    style()
    outdir = Path(outdir)
    names, charts = load_charts()
    wl, curves = load_curves()
    setup = camera_setup(curves, quantal=True, wavelengths=wl)
    old = _old_setup(curves, wl)
    patch = float(sca.budget.DEFAULT_UNCERTAIN["patch"])
    air = setup.sensitivities.T @ (setup.illuminant[:, None] * setup.reflectances)
    per_chart, fits = [], []
    for name, rgb in zip(names, charts):
        sig_ph = photon_sigma(rgb)
        sig = np.sqrt(sig_ph ** 2 + (patch * rgb) ** 2)
        beam = fit_chart(rgb, sig, setup, "beam")  # the paper's model, as in measure
        fits.append(beam)
        lf = fit_light_field(rgb, sig, setup, beam["depth"], beam["distance"], forward.Water())
        models = {pm: fit_chart(rgb, sig, lf["setup"], pm) for pm in PATH_MODELS}
        base = baselines(rgb, sig, air)
        before = fit_chart(rgb, sig, old, "beam")
        ang_new = grey_angles(rgb, beam["estimate"], setup, setup)
        ang_old = grey_angles(rgb, before["estimate"], old, setup)
        ng = len(GREYS)
        row = {"name": name,
               "depth_m": beam["depth"], "distance_m": beam["distance"],
               "chl": float(beam["estimate"].chl), "cdom": float(beam["estimate"].cdom),
               "chi2": {pm: models[pm]["chi2"] for pm in PATH_MODELS}
               | {b: base[b]["chi2"] for b in base} | {"beam, no field": beam["chi2"]},
               "light_field": {"model": lf["model"], "coefficients": lf["coefficients"],
                               "range": [float(lf["field"].min()), float(lf["field"].max())]},
               "split_geometry": [models["split"]["depth"], models["split"]["distance"]],
               "best_path": min(PATH_MODELS, key=lambda pm: models[pm]["chi2"]),
               "systematic": {k: patch_systematic(rgb - v, sig_ph, rgb, dof) for k, v, dof in (
                   ("beam, no field", beam["fitted"], 72 - 7),
                   ("beam", models["beam"]["fitted"], 72 - 7 - len(lf["coefficients"])),
                   ("diagonal", base["diagonal"]["fitted"], 72 - 3),
                   ("affine", base["affine"]["fitted"], 72 - 12))},
               "rms_rel": float(np.linalg.norm(rgb - beam["fitted"]) / np.linalg.norm(rgb)),
               "grey_deg": {"model (fixed)": float(np.mean(ang_new["model"][:ng])),
                            "model (before fix)": float(np.mean(ang_old["model"][:ng])),
                            "grey-world": float(np.mean(ang_new["grey-world"][:ng])),
                            "white-patch": float(np.mean(ang_new["white-patch"][:ng]))},
               "dark_deg": {k: v[ng:].tolist() for k, v in ang_new.items()},
               "dark_deg_before": ang_old["model"][ng:].tolist()}
        per_chart.append(row)
    figures = _panels(names, charts, fits, setup, outdir)
    figures += _grey_figure(per_chart, outdir)
    sim = simulated_check(wl)
    numbers = _summary(per_chart, sim, setup, old)
    numbers["figures"] = [str(p) for p in figures]
    return _markdown(numbers), numbers


def _grey_figure(rows, outdir) -> list:
    methods = ("model (before fix)", "model (fixed)", "grey-world", "white-patch")
    fig, ax = plt.subplots(figsize=(7.2, 2.6), constrained_layout=True)
    x = np.arange(len(rows))
    for j, m in enumerate(methods):
        ax.bar(x + (j - 1.5) * 0.2, [r["grey_deg"][m] for r in rows], 0.2, label=m)
    ax.set_xticks(x, [r["name"].replace("IMG_", "") for r in rows], rotation=90, fontsize=7)
    ax.set_ylabel("greys from white of air (°)")
    ax.set_title("Real G7X greys (patches 19-22) after correction")
    top = max(max(r["grey_deg"].values()) for r in rows)
    ax.set_ylim(0.0, 1.3 * top)  # room for the legend above the bars
    ax.legend(fontsize=7, ncol=4, loc="upper center")
    return save_figure(fig, "g7x_grey_correction", outdir)


def _stats(values) -> dict:
    v = np.asarray(values, float)
    return {"median": float(np.median(v)), "min": float(v.min()), "max": float(v.max())}


def _summary(rows, sim, setup, old) -> dict:
    keys = ["beam, no field"] + list(PATH_MODELS) + ["diagonal", "affine"]
    fields = [r["light_field"]["model"] for r in rows]
    wins = {pm: sum(r["best_path"] == pm for r in rows) for pm in PATH_MODELS}
    d_abs = [r["chi2"]["absorption"] - r["chi2"]["beam"] for r in rows]
    d_split = [r["chi2"]["split"] - r["chi2"]["beam"] for r in rows]
    # the same differences in units of the beam fit's residual variance (chi^2/dof): the
    # likelihood ratio if the systematic misfit, not the photon noise, is the noise
    scale = [r["chi2"]["beam"] / (72 - 7 - len(r["light_field"]["coefficients"])) for r in rows]
    return {
        "charts": rows,
        "n_charts": len(rows),
        "noise": {"full_well_e": FULL_WELL_E, "pixels_per_patch": PIXELS_PER_PATCH,
                  "patch_term": float(sca.budget.DEFAULT_UNCERTAIN["patch"])},
        "chi2_dof": {k: _stats([r["chi2"][k] / (72 - p - (len(r["light_field"]["coefficients"])
                                                                 if k in PATH_MODELS else 0))
                                for r in rows])
                     for k, p in zip(keys, (7, 7, 7, 8, 3, 12))},
        "systematic": {k: _stats([r["systematic"][k] for r in rows])
                       for k in ("beam, no field", "beam", "diagonal", "affine")},
        "light_fields": {f: fields.count(f) for f in sorted(set(fields))},
        "rms_rel_beam": _stats([r["rms_rel"] for r in rows]),
        "depth_beam_m": _stats([r["depth_m"] for r in rows]),
        "path_wins": wins,
        "delta_chi2_absorption_minus_beam": _stats(d_abs),
        "delta_chi2_split_minus_beam": _stats(d_split),
        "delta_scaled_absorption_minus_beam": _stats(np.divide(d_abs, scale)),
        "delta_scaled_split_minus_beam": _stats(np.divide(d_split, scale)),
        "grey_deg": {m: _stats([r["grey_deg"][m] for r in rows]) for m in rows[0]["grey_deg"]},
        "balance": (setup.white_response / setup.white_response.max()).tolist(),
        "white_of_air_angle_old_vs_true": float(_angle(old.white_response[:, None],
                                                       setup.white_response)[0]),
        "simulated": sim,
    }


def _fmt(s, f="{:.3g}") -> str:
    return f"{f.format(s['median'])} ({f.format(s['min'])}–{f.format(s['max'])})"


def _markdown(n) -> str:
    c = n["chi2_dof"]
    sy = n["systematic"]
    g = n["grey_deg"]
    sim = n["simulated"]
    lines = [
        "## The paper's real Canon G7X charts (17 photographs)",
        "",
        (f"Command: `{COMMAND}` (figures `g7x_captured_vs_model.png`, "
        "`g7x_grey_correction.png`). Median (min–max) over the 17 charts."),
        "",
        ("**Fit.** Free exposure gain, the paper's exact model (`uncertain={}`), depth profiled "
        f"over {DEPTHS_M[0]:g}–{DEPTHS_M[-1]:g} m, distance {DISTANCE_M:g} m ('split': "
        f"{DISTANCES_M[0]:g}–{DISTANCES_M[-1]:g} m). Noise assumed for a patch mean: photon "
        f"noise of {FULL_WELL_E:.0e} e⁻ full well over {PIXELS_PER_PATCH:.0e} pixels "
        "(relative sd ≈ 0.1 % at 10 % of the maximum), plus the package's per-patch term "
        f"{n['noise']['patch_term']:.0%} in the weights. Best-fit depth (beam): "
        f"{_fmt(n['depth_beam_m'])} m."),
        "",
        "The path models are compared with the light field that `measure` would model "
        "(`measure.lightfield.fit_light_field` at the beam fit's geometry, chosen by its "
        "likelihood-ratio test: " + ", ".join(f"{k} {v}" for k, v in n["light_fields"].items())
        + " charts).",
        "",
        "In-sample fits (each fitted to all 24 patches; REPRODUCTION.md gives the same error on "
        "patches the fit did not see):",
        "",
        "| fit | parameters | χ²/dof (photon + per-patch noise) | systematic error beyond photon noise |",
        "|---|---|---|---|",
        (f"| model, beam, no light field (the paper's) | 6 + depth | {_fmt(c['beam, no field'])} | "
        f"{_fmt(sy['beam, no field'], '{:.1%}')} |"),
        (f"| model, beam + light field | 6 + depth + field | {_fmt(c['beam'])} | "
        f"{_fmt(sy['beam'], '{:.1%}')} |"),
        f"| model, absorption + light field | 6 + depth + field | {_fmt(c['absorption'])} | |",
        f"| model, split + light field | 6 + depth, distance + field | {_fmt(c['split'])} | |",
        (f"| diagonal (gain per channel on the chart in air) | 3 | {_fmt(c['diagonal'])} | "
        f"{_fmt(sy['diagonal'], '{:.1%}')} |"),
        f"| affine (3×3 + offset) | 12 | {_fmt(c['affine'])} | {_fmt(sy['affine'], '{:.1%}')} |",
        "",
        f"Relative RMS residual of the beam fit: {_fmt(n['rms_rel_beam'], '{:.1%}')}.",
        "",
        (f"**Path models.** Lowest χ² per chart: beam {n['path_wins']['beam']}, absorption "
        f"{n['path_wins']['absorption']}, split {n['path_wins']['split']} of {n['n_charts']}. "
        f"χ²(absorption) − χ²(beam): {_fmt(n['delta_chi2_absorption_minus_beam'])}; "
        f"χ²(split) − χ²(beam): {_fmt(n['delta_chi2_split_minus_beam'])} (equal parameter "
        "count for beam and absorption; split has distance besides). The residuals are "
        "systematic, not photon noise (χ²/dof ≫ 1 for every fit, the affine baseline "
        "included), so the honest likelihood ratio divides Δχ² by the beam fit's χ²/dof: "
        f"absorption − beam {_fmt(n['delta_scaled_absorption_minus_beam'])}, split − beam "
        f"{_fmt(n['delta_scaled_split_minus_beam'])}. A difference below ~4 (χ²₁ at 95 %) "
        "does not distinguish the path models."),
        "",
        ("**Grey correction** (mean angle of patches 19–22 from the camera's white of air "
        "under D65, the target of every correction; 0° = perfectly neutral after the camera's "
        "D65 white balance). In-sample: the greys are judged on the chart that was fitted. "
        "REPRODUCTION.md's real-camera rows judge them on held-out greys, give the model's "
        "cross-validated residual against the baselines and measure the charts through "
        "`uw3p measure` (`experiments/realcamera.py`):"),
        "",
        "| method | angle (°) |",
        "|---|---|",
    ]
    lines += [f"| {m} | {_fmt(s, '{:.2f}')} |" for m, s in g.items()]
    lines += [
        "",
        ("Cause of the tint before the fix: `measure.camera_setup` scaled every channel of the "
        "G7X's measured curves to peak 1, discarding their measured balance "
        f"({', '.join(f'{b:.3f}' for b in n['balance'])} of the white in air after the fix); "
        "the fit then attributes the balance error to the water, and the von Kries correction "
        "maps the white to the wrong white of air "
        f"({n['white_of_air_angle_old_vs_true']:.1f}° from the true one). Fixed: the curves' "
        "own balance is kept (`measure.camera.own_balance`)."),
        "",
        ("**Forward model vs the authors' PBRT + ISET** (pure water, D65, 1 m, Canon 1D Mark III "
        "curves of Jiang et al. 2013; one gain per channel per depth): relative RMS residual "
        f"{np.median(sim['rms_rel']):.1%} (median over {len(sim['depth_m'])} depths, "
        f"{min(sim['rms_rel']):.1%}–{max(sim['rms_rel']):.1%}); drift of the channel gains "
        f"with depth: d ln(g_R/g_G)/dz = {sim['slope_rg']:+.4f} m⁻¹, d ln(g_B/g_G)/dz = "
        f"{sim['slope_bg']:+.4f} m⁻¹ (0 if both describe the same pure water)."),
    ]
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------- the user's own path
#: The depth and distance told to ``uw3p measure`` for every G7X chart, m, with their standard
#: deviations (issue 39): the series spans "a few metres to ~20 m" (README), so 9 +- 6 m; a chart
#: held or faced by a diver, 1 +- 0.5 m.
TOLD_DEPTH_M, TOLD_DEPTH_SD_M = 9.0, 6.0
TOLD_DISTANCE_M, TOLD_DISTANCE_SD_M = 1.0, 0.5
#: The DNG of a G7X chart: frame size (pixels), the white's fraction of the raw range, and the
#: photon noise of :func:`photon_sigma`'s assumptions (FULL_WELL_E electrons at the image maximum)
DNG_SIZE = (400, 600)
DNG_FILL = 0.9


def write_curves_csv(path) -> Path:
    """Write the G7X's measured quantal curves as the CSV ``uw3p --camera`` reads.

    Parameters
    ----------
    path : str or Path
        The file to write (a temporary folder: the data are not copied into the project).

    Returns
    -------
    Path
        ``path``.
    """
    wl, curves = load_curves()
    lines = ["wavelength,red,green,blue"] + [f"{w:g},{r:.8g},{g:.8g},{b:.8g}"
                                            for w, (r, g, b) in zip(wl, curves)]
    Path(path).write_text("\n".join(lines) + "\n")
    return Path(path)


def write_chart_dng(rgb, path, seed: int = 0):
    """A real chart's patch means as a RAW photograph: flat patches in a DNG.

    Each patch is drawn flat with its measured mean (the frame and the water around the card
    with the black patch's), exposed so that the image maximum reaches :data:`DNG_FILL` of the
    14-bit range above the black level, with the photon noise that :func:`photon_sigma` assumes
    (:data:`FULL_WELL_E` electrons at the maximum) and 2 DN of read noise
    (:func:`measure.synthetic_photo.mosaic_from_values`, ``write_dng``).

    Parameters
    ----------
    rgb : array_like, (3, 24)
        Patch means, fraction of the image maximum.
    path : str or Path
        The DNG to write.
    seed : int, optional
        The noise's seed.

    Returns
    -------
    path : str
        The file written.
    corners : numpy.ndarray, (4, 2)
        The patch grid's corners (pixels), as ``uw3p measure --corners`` takes them.
    """
    from measure.synthetic_photo import (BLACK_LEVELS_DN, WHITE_LEVEL_DN, Scene, default_corners,
                                   mosaic_from_values, write_dng)

    rgb = np.asarray(rgb, float)
    h, w = DNG_SIZE
    span = WHITE_LEVEL_DN - max(BLACK_LEVELS_DN)
    gain = DNG_FILL * span / float(rgb.max())
    scene = Scene(width=w, height=h, gain=gain, electrons_per_dn=FULL_WELL_E / (gain * float(rgb.max())),
                  read_noise_dn=2.0, seed=seed)
    corners = default_corners(w, h)
    black = rgb[:, 23]
    mosaic = mosaic_from_values(scene, corners, rgb, black, np.zeros(3))
    return write_dng(mosaic, path), corners


def measure_command(dng, corners, curves_csv, out) -> list:
    """The ``uw3p measure`` command line of one G7X chart (issue 39: the user's own path).

    Parameters
    ----------
    dng : str
        The chart's DNG (:func:`write_chart_dng`).
    corners : array_like, (4, 2)
        Its patch grid's corners, pixels.
    curves_csv : str or Path
        The G7X curves (:func:`write_curves_csv`; quantal).
    out : str or Path
        The output folder.

    Returns
    -------
    list of str
        The arguments after ``uw3p``: the G7X curves (``--quantal``), the default budget, depth
        told :data:`TOLD_DEPTH_M` +- :data:`TOLD_DEPTH_SD_M` m and distance
        :data:`TOLD_DISTANCE_M` +- :data:`TOLD_DISTANCE_SD_M` m, no camera profile (none exists
        for the authors' camera), no corrected TIFF.
    """
    c = " ".join(f"{x:.3f},{y:.3f}" for x, y in np.asarray(corners, float))
    return ["measure", str(dng), "--camera", str(curves_csv), "--quantal",
            "--depth", f"{TOLD_DEPTH_M:g}", "--depth-sd", f"{TOLD_DEPTH_SD_M:g}",
            "--distance", f"{TOLD_DISTANCE_M:g}", "--distance-sd", f"{TOLD_DISTANCE_SD_M:g}",
            "--corners", c, "--out", str(out), "--tiff", "none", "--overwrite"]


def _measure_one(args):
    """Render chart ``i`` as a DNG in ``folder`` and measure it with ``uw3p measure`` (the
    command, in its own process); the numbers of its measurement.json that the row needs."""
    import json
    import os
    import subprocess
    import sys

    i, rgb, folder, curves_csv = args
    folder = Path(folder)
    dng, corners = write_chart_dng(rgb, folder / f"chart{i:02d}.dng", seed=i)
    out = folder / f"chart{i:02d}"
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
    done = subprocess.run([sys.executable, "-m", "uw3p", *measure_command(dng, corners, curves_csv, out)],
                          capture_output=True, text=True, env=env, check=False)
    if not (out / "measurement.json").exists():
        raise RuntimeError(f"uw3p measure of chart {i} wrote nothing (exit {done.returncode}): "
                           f"{done.stderr.strip()[-500:]}")
    j = json.loads((out / "measurement.json").read_text())
    e = j["estimate"]
    return {"exit": done.returncode, "reliable": bool(e["reliable"]), "flags": list(e["flags"]),
            "chl": e["chl"], "cdom": e["cdom"], "chi2_dof": e["chi2_dof"],
            "nuisance": e.get("nuisance", {}), "rgb": j["patches"]["rgb"],
            "gains": j["correction"]["gains"], "offset": j["correction"]["offset"]}


def measure_path(charts, folder, workers: int = 2) -> list:
    """Every chart through the user's own path: a DNG with flat patches, ``uw3p measure``.

    Parameters
    ----------
    charts : array_like, (N, 3, 24)
        The real charts' patch means.
    folder : str or Path
        A scratch folder (DNGs, the curves' CSV and measure's outputs; a temporary folder: the
        data are not copied into the project).
    workers : int, optional
        Commands run at once (default 2).

    Returns
    -------
    list of dict
        Per chart: ``exit`` (the command's status), ``reliable``, ``flags``, ``chl``, ``cdom``,
        ``chi2_dof``, ``nuisance``, the sampled ``rgb`` (3, 24) and the correction's ``gains``
        and ``offset`` (3,).
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    curves_csv = write_curves_csv(folder / "canon_g7x_quantal.csv")
    jobs = [(i, np.asarray(rgb, float), str(folder), str(curves_csv)) for i, rgb in enumerate(charts)]
    if workers > 1:  # each measurement is its own process: threads only wait for them
        from concurrent.futures import ThreadPoolExecutor

        with ThreadPoolExecutor(max_workers=workers) as pool:
            return list(pool.map(_measure_one, jobs))
    return [_measure_one(job) for job in jobs]


# --------------------------------------------------------------------------- cross-validation
#: Leave-patches-out folds: fold f holds out the chart's column f (patches f, f + 6, f + 12,
#: f + 18: one patch of each row, one grey among them), so every patch is predicted once by a
#: fit that did not see it
FOLDS = tuple(tuple(range(f, 24, 6)) for f in range(6))
#: A held-out value's standard error, times the largest value: its weight in every fit is ~0
HELD_OUT_SIGMA = 1e6
#: The greys the held-out grey correction is judged on (0-based: neutral 8, 6.5, 5); the fits
#: behind it see every other patch, the white among them (white-patch uses it too)
HELD_GREYS = (19, 20, 21)
#: The physics options judged (:mod:`forward.chart_physics`), each with its literature values
PHYSICS = ("in-water reflectance", "forward scattering", "tilted chart")
#: The chart tilts (degrees from horizontal, towards the sun) among which a fold's training
#: patches choose for the tilted-chart option (the photographs' tilts are not recorded)
TILTS_DEG = (0.0, 30.0, 60.0, 90.0)


def _held_sigma(sigma, held):
    s = np.array(sigma, float, copy=True)
    s[:, list(held)] = HELD_OUT_SIGMA * float(np.max(sigma))
    return s


def _batch_profile(rgb, sigmas, setup, depths=DEPTHS_M) -> list:
    """The free-gain exact-model fits of one chart under several weightings (one per fold) at
    every depth, in one batch (:func:`sca.estimate_batch`): per weighting the best depth by
    chi^2 (held-out patches weigh nothing).

    Returns
    -------
    list of dict
        Per weighting: ``chi2``, ``depth``, ``predicted`` (3, 24), ``chl``, ``cdom``.
    """
    rgb = np.asarray(rgb, float)
    nd, nf = len(depths), len(sigmas)
    sig = np.repeat(np.asarray(sigmas, float), nd, axis=0)
    b = sca.estimate_batch(np.repeat(rgb[None], nd * nf, axis=0),
                           depth=np.tile(np.asarray(depths, float), nf),
                           distance=np.full(nd * nf, DISTANCE_M), sigma=sig, setup=setup,
                           gain="free", intervals=False, uncertain={}, path_models=("beam",))
    G = np.einsum("lc,nl,lj->ncj", setup.sensitivities, setup.illuminant[None] * b.attenuation,
                  setup.reflectances)
    pred = b.gain[:, None, None] * G + np.asarray(b.backscatter, float)[:, :, None]
    chi2 = np.sum(((rgb[None] - pred) / sig) ** 2, axis=(1, 2)).reshape(nf, nd)
    out = []
    for f in range(nf):
        j = f * nd + int(np.argmin(chi2[f]))
        out.append({"chi2": float(chi2.ravel()[j]), "depth": float(np.tile(depths, nf)[j]),
                    "predicted": pred[j], "chl": float(b.chl[j]), "cdom": float(b.cdom[j]),
                    "setup": setup})
    return out


def _physics_setups(option, setup, chl, cdom, depth):
    """The set-ups of one physics option at a fitted water (C, a_CDOM, depth): the chart's
    reflectance under water; its patch means blurred by forward scattering at the fitted C; the
    light on a chart tilted by each of :data:`TILTS_DEG` at the fitted water and depth."""
    import dataclasses

    from forward import chart_physics as cp

    if option == "in-water reflectance":
        return [dataclasses.replace(setup, reflectances=cp.in_water_reflectance(setup.reflectances))]
    wl = setup.wavelengths
    if option == "forward scattering":
        phi = cp.forward_scatter_fraction(forward.water.particle_scattering(wl, max(chl, 0.0)),
                                          DISTANCE_M)
        return [dataclasses.replace(setup, reflectances=cp.forward_scatter_reflectance(
            setup.reflectances, phi, DISTANCE_M))]
    if option == "tilted chart":
        c = forward.Water().on_grid(wl).beam_coefficient(max(chl, 0.0), max(cdom, 0.0))
        return [dataclasses.replace(setup, illuminant=setup.illuminant
                                    * cp.tilted_chart_light(wl, c, depth, t)) for t in TILTS_DEG]
    raise ValueError(f"option: must be one of {PHYSICS}, got {option!r}")


def cv_fits(rgb, sigma, setup, folds=FOLDS, *, option=None, light_field=False) -> list:
    """The model's fits of one chart with each fold's patches held out.

    The paper's exact model with a free gain (:func:`sca.estimate_batch`), the depth profiled
    over :data:`DEPTHS_M` on the training patches. With a physics ``option`` (:data:`PHYSICS`)
    the fit is repeated once at the option's set-up for the water the plain fit found (the blur
    and the tilted light depend on the water; for the tilt, the best of :data:`TILTS_DEG` by the
    training chi^2). With ``light_field``, measure's light field
    (:func:`measure.lightfield.fit_light_field`, the smallest the training patches support) at
    the best geometry, then the depth profiled again with it.

    Parameters
    ----------
    rgb, sigma : array_like, (3, 24)
        Patch means and the fits' standard errors.
    setup : forward.ChartSetup
        The camera's set-up.
    folds : sequence of sequences of int, optional
        The held-out patches of each fit (default :data:`FOLDS`).
    option : str, optional
        One of :data:`PHYSICS`.
    light_field : bool, optional
        Model the light field.

    Returns
    -------
    list of dict
        Per fold: ``predicted`` (3, 24) model values (the held-out ones are predictions),
        ``depth``, ``chl``, ``cdom``, ``setup`` (the fit's), ``chi2`` (training).
    """
    rgb = np.asarray(rgb, float)
    sigs = [_held_sigma(sigma, held) for held in folds]
    fits = _batch_profile(rgb, sigs, setup)
    if option is not None:
        new = []
        for f, fit in enumerate(fits):
            cands = [_batch_profile(rgb, [sigs[f]], s)[0]
                     for s in _physics_setups(option, setup, fit["chl"], fit["cdom"], fit["depth"])]
            new.append(min(cands, key=lambda x: x["chi2"]))
        fits = new
    if light_field:
        for f, fit in enumerate(fits):
            lf = fit_light_field(rgb, sigs[f], fit["setup"], fit["depth"], DISTANCE_M,
                                 forward.Water())
            if lf["model"] != "none":
                fits[f] = _batch_profile(rgb, [sigs[f]], lf["setup"])[0]
    return fits


def cv_baselines(rgb, sigma, air, held) -> dict:
    """The affine and diagonal baselines' predictions of the held-out patches (fitted on the
    others, :func:`baselines`)."""
    base = baselines(rgb, _held_sigma(sigma, held), air)
    return {k: v["fitted"] for k, v in base.items()}


def cross_validate(rgb, setup, *, options=(None,) + PHYSICS, light_field=True) -> dict:
    """Leave-patches-out cross-validation of one chart: every patch predicted by fits that did
    not see it (:data:`FOLDS`), by the model (with each physics option, without and with the
    light field) and by the baselines.

    Parameters
    ----------
    rgb : array_like, (3, 24)
        A chart's patch means (fraction of the image maximum).
    setup : forward.ChartSetup
        The G7X's set-up.
    options : sequence, optional
        Physics options (None: the paper's model).
    light_field : bool, optional
        Also the paper's model with the light field (the options are judged without it).

    Returns
    -------
    dict
        name -> {'predicted' (3, 24), 'systematic' (the per-patch relative error beyond photon
        noise of the held-out residuals, :func:`measure.camera.patch_systematic` with dof 72),
        'rms' (relative RMS of the held-out residuals)}; names: 'model', 'model + light field',
        'model + <option>', 'affine', 'diagonal'.
    """
    rgb = np.asarray(rgb, float)
    sig_ph = photon_sigma(rgb)
    patch = float(sca.budget.DEFAULT_UNCERTAIN["patch"])
    sig = np.sqrt(sig_ph ** 2 + (patch * rgb) ** 2)
    air = setup.sensitivities.T @ (setup.illuminant[:, None] * setup.reflectances)
    variants = [(opt, lf) for opt in options for lf in ((False, True) if light_field and opt is None
                                                      else (False,))]
    preds = {}
    for opt, lf in variants:
        name = "model" + (f" + {opt}" if opt else "") + (" + light field" if lf else "")
        p = np.zeros_like(rgb)
        for held, fit in zip(FOLDS, cv_fits(rgb, sig, setup, option=opt, light_field=lf)):
            p[:, list(held)] = fit["predicted"][:, list(held)]
        preds[name] = p
    for held in FOLDS:
        for name, p in cv_baselines(rgb, sig, air, held).items():
            preds.setdefault(name, np.zeros_like(rgb))[:, list(held)] = p[:, list(held)]
    return {k: {"predicted": v, "systematic": patch_systematic(rgb - v, sig_ph, rgb, rgb.size),
                "rms": float(np.linalg.norm(rgb - v) / np.linalg.norm(rgb))}
            for k, v in preds.items()}


def held_out_greys(rgb, setup) -> dict:
    """The grey correction judged on greys no method saw (:data:`HELD_GREYS`).

    The model (the paper's, with the light field as measure models it) is fitted to the other
    21 patches; its von Kries correction (:func:`measure.correction`) is applied to the held-out
    greys. White-patch takes its gains from the white (seen by every method); grey-world from
    the mean of the same 21 patches against their mean in air.

    Parameters
    ----------
    rgb : array_like, (3, 24)
        A chart's patch means.
    setup : forward.ChartSetup
        The G7X's set-up.

    Returns
    -------
    dict
        method -> the mean angle (degrees) of the held-out greys from the white of air:
        'model', 'grey-world', 'white-patch'.
    """
    rgb = np.asarray(rgb, float)
    sig_ph = photon_sigma(rgb)
    sig = np.sqrt(sig_ph ** 2 + (float(sca.budget.DEFAULT_UNCERTAIN["patch"]) * rgb) ** 2)
    fit = cv_fits(rgb, sig, setup, [HELD_GREYS], light_field=True)[0]
    train = [j for j in range(24) if j not in HELD_GREYS]
    est = sca.estimate(rgb, depth=fit["depth"], distance=DISTANCE_M,
                       sigma=_held_sigma(sig, HELD_GREYS), gain="free", setup=fit["setup"],
                       uncertain={}, mode="lm")
    gains, offset = correction(est, setup, rgb[:, WHITE_PATCH])
    air = setup.sensitivities.T @ (setup.illuminant[:, None] * setup.reflectances)
    corrected = {
        "model": gains[:, None] * (rgb - offset[:, None]),
        "grey-world": (air[:, train].mean(axis=1) / rgb[:, train].mean(axis=1))[:, None] * rgb,
        "white-patch": (air[:, WHITE_PATCH] / rgb[:, WHITE_PATCH])[:, None] * rgb,
    }
    return {k: float(np.mean(_angle(v[:, list(HELD_GREYS)], setup.white_response)))
            for k, v in corrected.items()}
