"""Fig 7: chart appearance over a depth x distance grid at C = 1 mg m^-3, a_CDOM(440) = 0.1 m^-1."""

from .appearance import render_conditions

__all__ = ["DEPTHS_M", "DISTANCES_M", "conditions", "main"]

DEPTHS_M = (1.0, 5.0, 10.0, 20.0)
DISTANCES_M = (0.5, 1.0, 5.0, 10.0)


def conditions():
    return [dict(chl=1.0, cdom=0.1, depth=d, distance=r, label=f"depth {d:g} m, distance {r:g} m")
            for d in DEPTHS_M for r in DISTANCES_M]


def main(outdir=None, setting=None):
    return render_conditions(conditions(), "fig07_depth_distance",
                             "C = 1 mg m$^{-3}$, a$_{CDOM}$(440) = 0.1 m$^{-1}$ "
                             "(rows: depth, columns: distance)",
                             outdir, ncols=len(DISTANCES_M), setting_name=setting)


if __name__ == "__main__":
    main()
