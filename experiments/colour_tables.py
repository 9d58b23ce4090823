"""Write ``data/colour_science_spectra_1nm.csv``: colour-science's default spectra on the 1 nm grid.

    python -m experiments.colour_tables [--out data/colour_science_spectra_1nm.csv]

The table :data:`forward.spectra.COLOUR_CACHE` is what :mod:`forward.spectra` reads instead of
importing colour-science (seconds) for the default camera, illuminant, chart and the CIE 1931
observer. Every column is :func:`forward.spectra.colour_spectrum` -- colour-science's own data,
resampled as the package resamples it -- written with every digit (``repr``), so the cache
gives the same numbers bit for bit; ``tests/test_wait.py`` compares it with the installed
colour-science.
"""

from __future__ import annotations

import argparse
import os
import sys
from importlib import metadata
from pathlib import Path

import numpy as np

from forward.spectra import (
    COLOUR_CACHE,
    COLOUR_CACHE_COLUMNS,
    colour_spectrum,
    wavelength_grid,
)

__all__ = ["GRID_NM", "main", "table_columns", "write_table"]

#: The cache's grid: 400-700 nm at 1 nm (the package's default; 301 rows)
GRID_NM = (400, 700, 1)


def table_columns() -> dict:
    """Every column of the cache, from colour-science: name -> values on :data:`GRID_NM`.

    Returns
    -------
    dict
        ``wavelength_nm`` first, then the columns of
        :data:`forward.spectra.COLOUR_CACHE_COLUMNS` in order.
    """
    lo, hi, step = GRID_NM
    wl = wavelength_grid(np.arange(lo, hi + step, step, dtype=float))
    out = {"wavelength_nm": wl}
    for (database, name), columns in COLOUR_CACHE_COLUMNS.items():
        vals = np.asarray(colour_spectrum(database, name, wl), float).reshape(wl.size, -1)
        out.update({c: vals[:, j] for j, c in enumerate(columns)})
    return out


def write_table(path) -> str:
    """Write the cache CSV (its ``#`` header names source, units and grid), whole or not at all.

    Parameters
    ----------
    path : str or os.PathLike
        The CSV to write.

    Returns
    -------
    str
        The path written.
    """
    cols = table_columns()
    version = metadata.version("colour-science")
    lo, hi, step = GRID_NM
    header = [
        "# colour-science's default spectra resampled onto the model grid (a cache: importing",
        "#   colour-science takes seconds; forward/spectra.py reads this table instead)",
        f"# Source: colour-science {version} (https://www.colour-science.org), datasets",
        "#   MSDS_CAMERA_SENSITIVITIES['Nikon 5100 (NPL)'] (NPL measurements),",
        "#   SDS_ILLUMINANTS['D65'] (CIE standard illuminant D65, CIE 015:2018),",
        "#   SDS_COLOURCHECKERS['BabelColor Average'] (BabelColor ColorChecker average, patches",
        "#   1-24 in reading order) and MSDS_CMFS['CIE 1931 2 Degree Standard Observer'];",
        "#   resampled by forward.spectra.colour_spectrum (linear between the source's nodes;",
        "#   written by python -m experiments.colour_tables)",
        "# Units: wavelength_nm in nm; camera sensitivities relative (as tabulated, not",
        "#   normalised); D65 relative spectral power; reflectance factors 0-1; CMFs as tabulated",
        f"# Grid: {lo}-{hi} nm, {step} nm steps ({cols['wavelength_nm'].size} rows)",
        ",".join(cols),
    ]
    rows = [",".join(f"{float(v)!r}" if name != "wavelength_nm" else f"{v:g}"
                     for name, v in zip(cols, vals)) for vals in zip(*cols.values())]
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text("\n".join(header + rows) + "\n", encoding="utf-8")
    os.replace(tmp, path)
    return str(path)


def main(argv=None) -> int:
    """``python -m experiments.colour_tables``: write the cache CSV."""
    ap = argparse.ArgumentParser(prog="python -m experiments.colour_tables",
                                 description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "data"
                                         / COLOUR_CACHE))
    print(write_table(ap.parse_args(argv).out))
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
