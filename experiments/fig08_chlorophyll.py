"""Fig 8: chart appearance for C from 0.01 to 100 mg m^-3 at 10 m depth, 1 m distance, CDOM 0.1."""

from .appearance import render_conditions

CHL_MG_M3 = (0.01, 0.1, 1.0, 10.0, 100.0)


def conditions():
    return [dict(chl=c, cdom=0.1, depth=10.0, distance=1.0, label=f"C = {c:g} mg m^-3")
            for c in CHL_MG_M3]


def main(outdir=None):
    return render_conditions(conditions(), "fig08_chlorophyll",
                             "depth 10 m, distance 1 m, a_CDOM(440) = 0.1 m^-1", outdir)


if __name__ == "__main__":
    main()
