"""Figs 5 and 6 (simulated half): clear Fanning Island vs murky Monterey Bay water.

Fig 5: C = 1 mg m^-3, a_CDOM(440) = 0.05 m^-1; Fig 6: C = 5 mg m^-3, a_CDOM(440) = 0.1 m^-1.
The paper does not give depth and distance for these photographs; we use 5 m depth and 1 m
distance (a diver's typical chart shot), see decision 0023-appearance-figures. The captured
photographs are not
reproducible here.
"""

from .appearance import render_conditions

__all__ = ["SITES", "main"]

SITES = [
    dict(chl=1.0, cdom=0.05, depth=5.0, distance=1.0,
         label="Fig 5: Fanning Island\nC = 1 mg m$^{-3}$, a$_{CDOM}$ = 0.05 m$^{-1}$"),
    dict(chl=5.0, cdom=0.1, depth=5.0, distance=1.0,
         label="Fig 6: Monterey Bay\nC = 5 mg m$^{-3}$, a$_{CDOM}$ = 0.1 m$^{-1}$"),
]


def main(outdir=None, setting=None):
    return render_conditions(SITES, "fig05_06_sites", "Simulated chart, depth 5 m, distance 1 m",
                             outdir, setting_name=setting)


if __name__ == "__main__":
    main()
