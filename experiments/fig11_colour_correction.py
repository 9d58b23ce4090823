"""Fig 11: von Kries colour correction with the *estimated* attenuation, distance 5 m, two depths.

For each depth: the captured chart (camera values -> XYZ with the camera's 3x3 matrix), and the
corrected chart: estimated backscatter s_hat removed, then a von Kries adaptation
(colour-science, 'Von Kries' cone space) from the effective illuminant i * k_hat to the surface
illuminant i (whites as the camera sees them). Both images are normalised so that the white
patch has the luminance of the reference (the paper normalises its images too). The number:
mean CIEDE2000 of the 24 patches against the chart under the surface illuminant (CIE 1931 XYZ
of R under D65), before and after; the camera-in-air value is the floor set by the 3x3 matrix.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

import forward

from . import sweep
from .common import figures_dir, save_figure, write_csv
from .grids import FIG11

WHITE = 18  # index of the white patch of the ColorChecker


def _normalise(xyz, ref):
    return xyz * (ref[WHITE, 1] / xyz[WHITE, 1])


def delta_e(xyz, ref, white_xyz):
    import colour

    xy = colour.XYZ_to_xy(white_xyz)
    return colour.delta_E(colour.XYZ_to_Lab(xyz, xy), colour.XYZ_to_Lab(ref, xy), method="CIE 2000")


def correct(rgb, k_hat, s_hat, setup):
    """Corrected XYZ (n, 3): remove s_hat, then von Kries from i * k_hat to i."""
    import colour

    M = forward.camera_to_xyz_matrix(setup)
    xyz = (M @ (np.asarray(rgb) - np.asarray(s_hat)[:, None])).T
    white_eff = M @ (setup.sensitivities.T @ (setup.illuminant * np.asarray(k_hat)))
    white_ref = M @ (setup.sensitivities.T @ setup.illuminant)
    return colour.adaptation.chromatic_adaptation_VonKries(xyz, white_eff, white_ref,
                                                          transform="Von Kries")


def main(outdir=None, grid_name=None, cache_dir=None, workers=None):
    import colour

    setup = forward.chart_setup()
    M = forward.camera_to_xyz_matrix(setup)
    ref = forward.chart_xyz(setup)
    white = ref[WHITE] / ref[WHITE, 1]
    air = _normalise((M @ (setup.sensitivities.T @ (setup.illuminant[:, None] * setup.reflectances))).T, ref)
    floor = float(np.mean(delta_e(air, ref, white)))
    conds = [sweep.condition(FIG11["chl"], FIG11["cdom"], d, FIG11["distance"], 0)
             for d in FIG11["depths"]]
    results, _ = sweep.run(conds, cache_dir=cache_dir, workers=1, progress=False, desc="fig11")
    fig, axes = plt.subplots(len(conds), 2, figsize=(6, 2.3 * len(conds)), squeeze=False)
    rows = []
    for (ax0, ax1), res in zip(axes, results):
        rgb = np.array(res["rgb"])
        before = _normalise((M @ rgb).T, ref)
        after = _normalise(correct(rgb, res["attenuation_hat"], res["backscatter_hat"], setup), ref)
        de_before = float(np.mean(delta_e(before, ref, white)))
        de_after = float(np.mean(delta_e(after, ref, white)))
        rows.append([res["depth"], res["distance"], f"{de_before:.3f}", f"{de_after:.3f}",
                     f"{floor:.3f}", res["seed"], res["converged"]])
        for ax, xyz, title in ((ax0, before, "captured"), (ax1, after, "corrected")):
            srgb = np.clip(colour.XYZ_to_sRGB(xyz), 0, 1)
            ax.imshow(forward.patches_image(srgb))
            de = de_before if title == "captured" else de_after
            ax.set_title(f"depth {res['depth']:g} m, {title}: mean dE00 {de:.1f}", fontsize=8)
            ax.set_axis_off()
    fig.suptitle("von Kries correction with the estimated attenuation (distance 5 m)", fontsize=9)
    save_figure(fig, "fig11_colour_correction", outdir)
    plt.close(fig)
    write_csv(figures_dir(outdir) / "fig11_colour_correction.csv",
              ["depth_m", "distance_m", "mean_de2000_captured", "mean_de2000_corrected",
               "mean_de2000_camera_in_air", "seed", "converged"], rows,
              comment="Fig 11: mean CIEDE2000 of the 24 patches vs the chart under D65 (CIE 1931)")
    return rows


if __name__ == "__main__":
    main()
