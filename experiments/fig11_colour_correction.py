"""Fig 11: von Kries colour correction with the *estimated* attenuation, distance 5 m, depths
10 m (the chart of Fig 9, the paper's "top left image") and 20 m, against two honest baselines.

For each depth: the captured chart (camera values -> XYZ with the camera's 3x3 matrix); the
paper's correction: estimated backscatter s_hat removed, then a von Kries adaptation
(colour-science, 'Von Kries' cone space) from the effective illuminant i * k_hat to the surface
illuminant i; and two corrections that need no model: grey-world (channel gains that give the
chart's mean the colour of the chart's mean in air) and white-patch (gains that make the white
patch the white of air), both on the captured values. All images are normalised so that the
white patch has the luminance of the reference (the paper normalises its images too). The
number: mean CIEDE2000 of the 24 patches against the chart under the surface illuminant (CIE
1931 XYZ of R under D65); the camera-in-air value is the floor set by the 3x3 matrix.

The control (issue 39): the same von Kries correction with the *true* attenuation and veiling
light (the world's k, sampled on the estimator's grid, and s): the limit of a diagonal
correction, so that the estimator's share of the error (estimated minus true) is separated
from the correction's own.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

import forward
from forward.spectra import WHITE_PATCH

from . import sweep
from .common import figures_dir, save_figure, style, write_csv
from .estimation import condition_kw
from .grids import FIG11
from .grids import setting as get_setting

__all__ = ["main", "correct", "baseline", "delta_e", "METHODS"]

METHODS = ("captured", "von Kries (estimated k)", "von Kries (true k)", "grey-world",
           "white-patch")


def _normalise(xyz, ref):
    return xyz * (ref[WHITE_PATCH, 1] / xyz[WHITE_PATCH, 1])


def delta_e(xyz, ref, white_xyz):
    import colour

    xy = colour.XYZ_to_xy(white_xyz)
    return colour.delta_E(colour.XYZ_to_Lab(xyz, xy), colour.XYZ_to_Lab(ref, xy), method="CIE 2000")


def correct(rgb, k_hat, s_hat, setup, setup_k=None):
    """Corrected XYZ (n, 3): remove s_hat, then von Kries from i * k_hat to i. ``setup_k`` is
    the estimator's setup when k_hat is on another grid than ``setup`` (the white points are
    computed on k_hat's grid; the camera-to-XYZ matrix is the camera's, from ``setup``)."""
    import colour

    M = forward.camera_to_xyz_matrix(setup)
    sk = setup if setup_k is None else setup_k
    xyz = (M @ (np.asarray(rgb) - np.asarray(s_hat)[:, None])).T
    white_eff = M @ (sk.sensitivities.T @ (sk.illuminant * np.asarray(k_hat)))
    white_ref = M @ (sk.sensitivities.T @ sk.illuminant)
    return colour.adaptation.chromatic_adaptation_VonKries(xyz, white_eff, white_ref,
                                                          transform="Von Kries")


def baseline(rgb, setup, method):
    """XYZ (n, 3) of the captured camera values with grey-world or white-patch channel gains."""
    rgb = np.asarray(rgb)
    air = setup.sensitivities.T @ (setup.illuminant[:, None] * setup.reflectances)
    if method == "grey-world":
        gains = air.mean(axis=1) / rgb.mean(axis=1)
    else:
        gains = air[:, WHITE_PATCH] / rgb[:, WHITE_PATCH]
    return (forward.camera_to_xyz_matrix(setup) @ (gains[:, None] * rgb)).T


def main(outdir=None, grid_name=None, cache_dir=None, workers=None, setting=None):
    import colour

    s = get_setting(setting)
    style()
    setup = forward.chart_setup()
    M = forward.camera_to_xyz_matrix(setup)
    ref = forward.chart_xyz(setup)
    white = ref[WHITE_PATCH] / ref[WHITE_PATCH, 1]
    air = _normalise((M @ (setup.sensitivities.T @ (setup.illuminant[:, None] * setup.reflectances))).T, ref)
    floor = float(np.mean(delta_e(air, ref, white)))
    step = s["estimation_step_nm"]
    wl_hat = sweep.estimation_grid(step)
    setup_k = None if wl_hat is None else forward.chart_setup(wavelengths=wl_hat)
    conds = [sweep.condition(FIG11["chl"], FIG11["cdom"], d, FIG11["distance"], 0,
                             **condition_kw(s))
             for d in FIG11["depths"]]
    grid_k = (setup if setup_k is None else setup_k).wavelengths
    results, _ = sweep.run(conds, cache_dir=cache_dir, workers=1, progress=False, desc="fig11")
    fig, axes = plt.subplots(len(conds), len(METHODS), figsize=(7.5, 1.7 * len(conds) + 0.4),
                             squeeze=False, constrained_layout=True)
    rows = []
    for axrow, res in zip(axes, results):
        rgb = np.array(res["rgb"])
        images = {
            "captured": _normalise((M @ rgb).T, ref),
            "von Kries (estimated k)": _normalise(correct(rgb, res["attenuation_hat"],
                                                          res["backscatter_hat"], setup, setup_k),
                                                  ref),
            "von Kries (true k)": _normalise(correct(
                rgb, np.interp(grid_k, res["wavelengths"], res["attenuation"]),
                res["backscatter"], setup, setup_k), ref),
            "grey-world": _normalise(baseline(rgb, setup, "grey-world"), ref),
            "white-patch": _normalise(baseline(rgb, setup, "white-patch"), ref),
        }
        de = {k: float(np.mean(delta_e(v, ref, white))) for k, v in images.items()}
        rows.append([res["depth"], res["distance"]] + [f"{de[k]:.3f}" for k in METHODS]
                    + [f"{floor:.3f}", res["seed"], res["converged"]])
        for ax, method in zip(axrow, METHODS):
            srgb = np.clip(colour.XYZ_to_sRGB(images[method]), 0, 1)
            ax.imshow(forward.patches_image(srgb))
            ax.set_title(f"{method}\n{res['depth']:g} m: mean ΔE$_{{00}}$ {de[method]:.1f}",
                         fontsize=8)
            ax.set_axis_off()
    fig.suptitle(f"Colour correction, distance 5 m ({s['illuminance_lux']:g} lx; estimator on a "
                 f"{step:g} nm grid)")
    save_figure(fig, "fig11_colour_correction", outdir)
    plt.close(fig)
    write_csv(figures_dir(outdir) / "fig11_colour_correction.csv",
              ["depth_m", "distance_m", "mean_de2000_captured", "mean_de2000_von_kries",
               "mean_de2000_von_kries_true_k", "mean_de2000_grey_world",
               "mean_de2000_white_patch", "mean_de2000_camera_in_air", "seed", "converged"], rows,
              comment="Fig 11: mean CIEDE2000 of the 24 patches vs the chart under D65 (CIE 1931); "
                      "von Kries with the estimated attenuation (the paper's method), with the "
                      "true attenuation and veiling light (the control: a diagonal correction's "
                      "limit), and two model-free baselines on the same captured values")
    return rows


if __name__ == "__main__":
    main()
