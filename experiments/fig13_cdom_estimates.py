"""Fig 13: estimated vs true a_CDOM(440) at distance 1 m, depths 5, 10, 20 m; coloured by C."""

from .fig12_13_common import make

__all__ = ["main"]


def main(outdir=None, grid_name=None, cache_dir=None, workers=None, setting=None):
    return make("cdom", "fig13_cdom", "chl", outdir, grid_name, cache_dir, workers,
                setting)


if __name__ == "__main__":
    main()
