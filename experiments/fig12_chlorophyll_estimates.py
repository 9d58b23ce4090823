"""Fig 12: estimated vs true C at distance 1 m, depths 5, 10, 20 m; points coloured by CDOM."""

from .fig12_13_common import make

__all__ = ["main"]


def main(outdir=None, grid_name=None, cache_dir=None, workers=None, setting=None):
    return make("chl", "fig12_chlorophyll", "cdom", outdir, grid_name, cache_dir, workers,
                setting)


if __name__ == "__main__":
    main()
