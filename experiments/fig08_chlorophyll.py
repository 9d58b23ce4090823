"""Fig 8: chart appearance for C from 0.01 to 100 mg m^-3 at 10 m depth, 1 m distance, CDOM 0.1.

The first row is what the camera records (exposure capped at 1/30 s): at C = 100 mg m^-3 the
chart receives a few per mille of the surface light at 10 m and is nearly black -- a real
effect, not a rendering fault. The second row scales each chart to its brightest patch, which
shows the hue moving from blue to green as the paper describes.
"""

from .appearance import render_conditions

__all__ = ["CHL_MG_M3", "conditions", "main"]

CHL_MG_M3 = (0.01, 0.1, 1.0, 10.0, 100.0)


def conditions():
    return [dict(chl=c, cdom=0.1, depth=10.0, distance=1.0, label=f"C = {c:g} mg m$^{{-3}}$")
            for c in CHL_MG_M3]


def main(outdir=None, setting=None):
    return render_conditions(conditions(), "fig08_chlorophyll",
                             "depth 10 m, distance 1 m, a$_{CDOM}$(440) = 0.1 m$^{-1}$; top: as "
                             "recorded, bottom: each chart scaled to its brightest patch", outdir,
                             setting_name=setting, normalised_row=True)


if __name__ == "__main__":
    main()
