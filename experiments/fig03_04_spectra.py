"""Figs 3 and 4: the spectral shapes of the constituents' absorption (Fig 3) and scattering
(Fig 4), from the same :class:`forward.Water` the simulator and the estimators use.

The paper: "Individual components are not shown to scale, y-axis represents arbitrary units."
So each curve is drawn divided by its maximum over 400-700 nm, and the CSVs give the values in
m^-1 at stated concentrations beside the normalised shapes:

* Fig 3 (eq 5): pure sea water a_w (Smith & Baker 1981), phytoplankton a_phi (the basis t_1 of
  eq 9, scaled by eq 10), CDOM (eq 6, slope 0.014 nm^-1), NAP (eqs 7-8, slope 0.011 nm^-1);
* Fig 4 (eq 11): pure sea water b_w (Morel 1974) and the particles b_p of eq 12 (Table 1),
  with its three terms: pico- and nanoparticles, microparticles, the background b_k.

The shapes do not depend on the sensor, so the two figures are made once (``figures/``).
"""

from __future__ import annotations

import matplotlib.pyplot as plt

import forward

from .common import figures_dir, save_figure, style, write_csv

__all__ = ["main", "absorption_shapes", "scattering_shapes", "CHL", "CDOM"]

#: The concentrations of the CSVs' absolute values (the figures are normalised)
CHL = 1.0
CDOM = 0.1


def absorption_shapes(water=None) -> dict:
    """name: a(lambda) in m^-1 at C = CHL, a_CDOM(440) = CDOM on the 1 nm grid (eq 5)."""
    wl = forward.wavelength_grid()
    w = forward.water.resolve_water(water)
    return {
        "pure sea water a$_w$": forward.water.pure_water_absorption(wl, water=w),
        "phytoplankton a$_\\Phi$": forward.water.phytoplankton_absorption(wl, CHL, water=w),
        "CDOM a$_{CDOM}$": forward.water.cdom_absorption(wl, CDOM, water=w),
        "non-algal particles a$_{NAP}$": forward.water.nap_absorption(wl, CHL, water=w),
    }


def scattering_shapes(water=None) -> dict:
    """name: b(lambda) in m^-1 at C = CHL on the 1 nm grid (eqs 11-12)."""
    wl = forward.wavelength_grid()
    w = forward.water.resolve_water(water)
    small, large, background = forward.water.particle_scattering_terms(wl, water=w)
    w12, w3 = forward.water.particle_scattering_weights(CHL, water=w)
    return {
        "pure sea water b$_w$": forward.water.pure_water_scattering(wl, water=w),
        "particles b$_p$ (eq 12)": forward.water.particle_scattering(wl, CHL, water=w),
        "  pico- and nanoparticles": float(w12) * small,
        "  microparticles": float(w3) * large,
        "  background b$_k$": background,
    }


def _plain(name):
    return (name.strip().replace("$_w$", "_w").replace("$_\\Phi$", "_phi").replace("$_{CDOM}$", "_CDOM")
            .replace("$_{NAP}$", "_NAP").replace("$_p$", "_p").replace("$_k$", "_k"))


def _draw(ax, shapes, title):
    wl = forward.wavelength_grid()
    for name, v in shapes.items():
        ls = ":" if name.startswith("  ") else "-"
        ax.plot(wl, v / v.max(), ls, lw=1.6 if ls == "-" else 1.2, label=name.strip())
    ax.set(xlim=(400, 700), ylim=(0, 1.08), xlabel="wavelength (nm)",
           ylabel="shape (each curve / its maximum; arbitrary units)")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.2), ncol=2)


def _csv(path, shapes, comment):
    wl = forward.wavelength_grid()
    names = list(shapes)
    header = ["wavelength_nm"] + [_plain(n) + "_per_m" for n in names] + \
        [_plain(n) + "_shape" for n in names]
    rows = [[f"{w:g}"] + [f"{shapes[n][i]:.6g}" for n in names]
            + [f"{shapes[n][i] / shapes[n].max():.6g}" for n in names] for i, w in enumerate(wl)]
    write_csv(path, header, rows, comment=comment)


def main(outdir=None, grid_name=None, cache_dir=None, workers=None):
    style()
    out = figures_dir(outdir)
    a = absorption_shapes()
    b = scattering_shapes()
    for shapes, name, title, what in (
            (a, "fig03_absorption_shapes", "Fig 3: absorption of the constituents (eq 5), not to "
             "scale", f"absorption (m^-1) at C = {CHL:g} mg m^-3, a_CDOM(440) = {CDOM:g} m^-1"),
            (b, "fig04_scattering_shapes", "Fig 4: scattering (eqs 11, 12), not to scale",
             f"scattering (m^-1) at C = {CHL:g} mg m^-3 (eq 12 with Table 1 as printed)")):
        fig, ax = plt.subplots(figsize=(4.8, 4.2), constrained_layout=True)
        _draw(ax, shapes, title)
        save_figure(fig, name, out)
        plt.close(fig)
        _csv(out / f"{name}.csv", shapes,
             f"{title}: {what} (_per_m) and each divided by its maximum over 400-700 nm (_shape); "
             "forward.Water() defaults (the paper's), 1 nm grid")
    return a, b


if __name__ == "__main__":
    main()
