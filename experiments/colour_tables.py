"""Write ``data/colour_science_spectra_1nm.csv`` and ``data/colour_science_srgb.csv``: colour-science's default spectra on the 1 nm grid, and its sRGB for 8-bit images.

    python -m experiments.colour_tables [--out data/colour_science_spectra_1nm.csv]
                                        [--srgb-out data/colour_science_srgb.csv]

The table :data:`forward.spectra.COLOUR_CACHE` is what :mod:`forward.spectra` reads instead of
importing colour-science (seconds) for the default camera, illuminant, chart and the CIE 1931
observer, and the training reflectances of the colour matrix (:mod:`measure.correct_matrix`).
Every column is :func:`forward.spectra.colour_spectrum` -- colour-science's own data,
resampled as the package resamples it -- written with every digit (``repr``), so the cache
gives the same numbers bit for bit; ``tests/test_wait.py`` compares it with the installed
colour-science. The sRGB table (:data:`forward.spectra.SRGB_CACHE`, read by
:func:`forward.spectra.srgb_8bit`) holds colour-science's XYZ -> linear sRGB matrix and the
linear levels where the 8-bit code of its sRGB encoding steps up.
"""

from __future__ import annotations

import argparse
import sys
from importlib import metadata
from pathlib import Path

import numpy as np

from forward.files import write_atomic
from forward.spectra import (
    COLOUR_CACHE,
    COLOUR_CACHE_COLUMNS,
    SRGB_CACHE,
    SRGB_REFERENCE_CHART,
    colour_spectrum,
    wavelength_grid,
)

__all__ = ["DAYLIGHT_TABLE", "GRID_NM", "main", "reference_chart_from_colour", "srgb_rows",
           "table_columns", "write_daylight_table", "write_srgb_table", "write_table"]

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


def srgb_rows() -> list:
    """The rows of the sRGB table, from colour-science: (quantity, index, value).

    Returns
    -------
    list of tuple
        ``('xyz_to_srgb', i, m)`` for the 9 entries of
        ``colour.RGB_COLOURSPACES['sRGB'].matrix_XYZ_to_RGB`` (row-major), then
        ``('encoding_8bit_level', k, colour.cctf_decoding((k - 0.5) / 255, 'sRGB'))`` for
        k = 1..255: the linear value from which the rounded 8-bit code of the encoding is k.
    """
    import colour

    matrix = np.asarray(colour.RGB_COLOURSPACES["sRGB"].matrix_XYZ_to_RGB, float).ravel()
    codes = np.arange(1, 256)
    levels = np.asarray(colour.cctf_decoding((codes - 0.5) / 255.0, function="sRGB"), float)
    chart = reference_chart_from_colour().ravel()
    return ([("xyz_to_srgb", i, float(v)) for i, v in enumerate(matrix)]
            + [("encoding_8bit_level", int(k), float(v)) for k, v in zip(codes, levels)]
            + [("reference_chart_linear_srgb", i, float(v)) for i, v in enumerate(chart)])


def reference_chart_from_colour() -> np.ndarray:
    """Linear sRGB of :data:`forward.spectra.SRGB_REFERENCE_CHART`, computed by colour-science
    (what the table caches).

    Returns
    -------
    numpy.ndarray, (24, 3)
        Patches in reading order.
    """
    import colour

    cc = colour.CCS_COLOURCHECKERS[SRGB_REFERENCE_CHART]
    xyY = np.array(list(cc.data.values()), float)
    return np.asarray(colour.XYZ_to_RGB(colour.xyY_to_XYZ(xyY), "sRGB", cc.illuminant,
                                        apply_cctf_encoding=False), float)


def _write_whole(path, lines) -> str:
    """``lines`` into ``path`` through a temporary file beside it (whole or not at all)."""
    return str(write_atomic(path, "\n".join(lines) + "\n"))


def write_srgb_table(path) -> str:
    """Write the sRGB CSV (its ``#`` header names source, units and grid), whole or not at all.

    Parameters
    ----------
    path : str or os.PathLike
        The CSV to write.

    Returns
    -------
    str
        The path written.
    """
    version = metadata.version("colour-science")
    header = [
        "# colour-science's sRGB for 8-bit images (a cache: importing colour-science takes about",
        "#   1 s; the previews of uw3p measure read this table, forward.spectra.srgb_8bit)",
        f"# Source: colour-science {version} (https://www.colour-science.org):",
        "#   RGB_COLOURSPACES['sRGB'].matrix_XYZ_to_RGB (IEC 61966-2-1:1999, D65) and",
        "#   cctf_decoding((k - 0.5) / 255, function='sRGB'), the linear value from which the",
        "#   rounded 8-bit code of the sRGB encoding is k; and XYZ_to_RGB(xyY_to_XYZ(xyY),",
        f"#   'sRGB', illuminant, apply_cctf_encoding=False) of CCS_COLOURCHECKERS['{SRGB_REFERENCE_CHART}']",
        "#   (the chart detection's reference colours) (written by python -m",
        "#   experiments.colour_tables)",
        "# Units: xyz_to_srgb dimensionless, index = 3 row + column (rows R, G, B; columns X, Y,",
        "#   Z); encoding_8bit_level in linear light 0-1, index = the 8-bit code k;",
        "#   reference_chart_linear_srgb linear sRGB 0-1, index = 3 patch + channel (patches",
        "#   0-23 in reading order; channels R, G, B)",
        "# Grid: none (9 matrix entries; codes 1-255; 24 x 3 chart values)",
        "quantity,index,value",
    ]
    return _write_whole(path, header + [f"{q},{i},{v!r}" for q, i, v in srgb_rows()])


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
        "#   1-24 in reading order), MSDS_CMFS['CIE 1931 2 Degree Standard Observer'] and",
        "#   colour.quality.datasets SDS_TCS['CIE 1995'] (CIE 13.3 test colour samples TCS01-14)",
        "#   and SDS_VS['NIST CQS 9.0'] (VS1-15): the colour matrix's training set;",
        "#   resampled by forward.spectra.colour_spectrum (linear between the source's nodes;",
        "#   written by python -m experiments.colour_tables)",
        "# Units: wavelength_nm in nm; camera sensitivities relative (as tabulated, not",
        "#   normalised); D65 relative spectral power; reflectance factors 0-1; CMFs as tabulated",
        f"# Grid: {lo}-{hi} nm, {step} nm steps ({cols['wavelength_nm'].size} rows)",
        ",".join(cols),
    ]
    rows = [",".join(f"{float(v)!r}" if name != "wavelength_nm" else f"{v:g}"
                     for name, v in zip(cols, vals)) for vals in zip(*cols.values())]
    return _write_whole(path, header + rows)


#: The CIE daylight basis functions' table (:data:`forward.daylight.DAYLIGHT_BASIS_TABLE`)
DAYLIGHT_TABLE = "cie_daylight_basis_5nm.csv"


def write_daylight_table(path) -> str:
    """Write the CIE daylight basis functions S0, S1, S2 (CIE 015:2018, Table T.2) as tabulated,
    300-830 nm at 5 nm, from colour-science's dataset; returns the path."""
    from colour.colorimetry import SDS_BASIS_FUNCTIONS_CIE_ILLUMINANT_D_SERIES as basis

    wl = basis["S0"].wavelengths
    lines = ["# The CIE daylight basis functions S0, S1, S2 of the D series: a daylight of",
             "#   correlated colour temperature T is S0 + M1(T) S1 + M2(T) S2 (forward.daylight)",
             "# Source: CIE 015:2018 Colorimetry, 4th ed., Table T.2 (as in colour-science "
             f"{metadata.version('colour-science')},",
             "#   colour.colorimetry.SDS_BASIS_FUNCTIONS_CIE_ILLUMINANT_D_SERIES; written by",
             "#   python -m experiments.colour_tables)",
             "# Units: wavelength_nm in nm; S0, S1, S2 relative spectral power (S0(560) = 100)",
             "# Grid: 300-830 nm, 5 nm steps (107 rows)",
             "wavelength_nm,s0,s1,s2"]
    for j, w in enumerate(wl):
        vals = [basis[k].values[j] for k in ("S0", "S1", "S2")]
        lines.append(f"{w:g}," + ",".join(f"{float(v):g}" for v in vals))
    Path(path).write_text("\n".join(lines) + "\n", encoding="utf-8")
    return str(path)


def main(argv=None) -> int:
    """``python -m experiments.colour_tables``: write the cache CSVs and the daylight table."""
    ap = argparse.ArgumentParser(prog="python -m experiments.colour_tables",
                                 description=__doc__.splitlines()[0])
    data = Path(__file__).resolve().parents[1] / "data"
    ap.add_argument("--out", default=str(data / COLOUR_CACHE))
    ap.add_argument("--srgb-out", default=str(data / SRGB_CACHE))
    ap.add_argument("--daylight-out", default=str(data / DAYLIGHT_TABLE))
    args = ap.parse_args(argv)
    print(write_table(args.out))
    print(write_srgb_table(args.srgb_out))
    print(write_daylight_table(args.daylight_out))
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
