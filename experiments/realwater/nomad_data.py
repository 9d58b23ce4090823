"""NOMAD v2 (Werdell & Bailey 2005) as the real-water studies read it: the stations with
measured K_d spectra and in-situ chlorophyll, and a_CDOM(443) taken to 440 nm.

The studies (:mod:`experiments.realwater.nomad`, :mod:`experiments.realwater.biooptical`,
:mod:`experiments.realwater.empirical`) import the data from here.

References
----------
P. J. Werdell and S. W. Bailey, "An improved in-situ bio-optical data set for ocean color
algorithm development and satellite data product validation", Remote Sens. Environ. 98 (2005)
122-140.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

import forward

__all__ = ["CHL_CLASSES", "MIN_KD_BANDS", "MISSING", "NOMAD_FILE", "REALDATA", "NomadStations",
           "cdom_440", "load_nomad", "realdata_dir"]

#: The real-data folder beside the repository (``../shared/realdata``).
REALDATA = Path(__file__).resolve().parents[2].parent / "shared" / "realdata"
#: The NOMAD v2 file inside it.
NOMAD_FILE = Path("nomad") / "nomad_seabass_v2.a_2008200.txt.gz"
#: A station is used when it has at least this many K_d bands and in-situ chlorophyll.
MIN_KD_BANDS = 5
#: Chlorophyll classes of the water-type comparison, mg m^-3 (lower inclusive).
CHL_CLASSES = ((0.0, 0.1), (0.1, 1.0), (1.0, 10.0), (10.0, np.inf))
#: NOMAD's missing-value code.
MISSING = -999.0
#: A grid around 443 nm (forward's grids need >= 3 wavelengths; index 1 is 443 nm).
_GRID_443 = np.array([440.0, 443.0, 446.0])


def realdata_dir() -> Path:
    """``../shared/realdata`` beside the repository (may not exist)."""
    return REALDATA


@dataclass
class NomadStations:
    """NOMAD stations with >= :data:`MIN_KD_BANDS` K_d bands and in-situ chlorophyll.

    Attributes
    ----------
    station : ndarray of int, (N,)
        Row of the station in the file (0-based, data rows only): NOMAD's ``id`` is not unique.
    nomad_id : ndarray of int, (N,)
        NOMAD's ``id``.
    wavelengths : ndarray, (q,)
        The K_d bands, nm.
    kd : ndarray, (N, q)
        K_d, m^-1; NaN where not measured.
    chl : ndarray, (N,)
        In-situ C, mg m^-3: HPLC ``chl_a`` where present, else fluorometric ``chl``.
    hplc : ndarray of bool, (N,)
        ``chl`` is HPLC.
    ag443 : ndarray, (N,)
        a_CDOM(443), m^-1; NaN where not measured.
    aph443, ad443 : ndarray, (N,)
        Phytoplankton (``ap443 - ad443``) and non-algal (``ad443``) absorption at 443 nm,
        m^-1; NaN where not measured.
    bb555 : ndarray, (N,)
        Total backscattering at 555 nm, m^-1; NaN where not measured.
    cruise : ndarray of str, (N,)
        NOMAD's ``cruise`` (the unit of a cruise-blocked split: stations of one cruise share
        their water, :mod:`experiments.realwater.split`).
    """

    station: np.ndarray
    nomad_id: np.ndarray
    wavelengths: np.ndarray
    kd: np.ndarray
    chl: np.ndarray
    hplc: np.ndarray
    ag443: np.ndarray
    aph443: np.ndarray
    ad443: np.ndarray
    bb555: np.ndarray
    cruise: np.ndarray

    def __len__(self) -> int:
        return self.station.size

    def subset(self, idx) -> NomadStations:
        """The stations ``idx`` (index array or boolean mask)."""
        return NomadStations(self.station[idx], self.nomad_id[idx], self.wavelengths,
                             self.kd[idx], self.chl[idx], self.hplc[idx], self.ag443[idx],
                             self.aph443[idx], self.ad443[idx], self.bb555[idx],
                             self.cruise[idx])


def load_nomad(path=None) -> NomadStations:
    """Read NOMAD v2 and keep the stations with >= 5 K_d bands and in-situ chlorophyll.

    Parameters
    ----------
    path : str or os.PathLike, optional
        The ``.txt.gz`` file (default: :data:`REALDATA` / :data:`NOMAD_FILE`).

    Returns
    -------
    NomadStations

    Raises
    ------
    FileNotFoundError
        If the file does not exist.

    References
    ----------
    Werdell & Bailey 2005 (NOMAD); SeaBASS file format (``!`` comment lines, -999 missing).
    """
    import pandas as pd

    path = Path(path) if path is not None else REALDATA / NOMAD_FILE
    if not path.is_file():
        raise FileNotFoundError(f"path: NOMAD file not found: {path}")
    df = pd.read_csv(path, comment="!")
    df = df.replace(MISSING, np.nan)
    kd_cols = [c for c in df.columns if c.startswith("kd") and c[2:].isdigit()]
    wl = np.array([float(c[2:]) for c in kd_cols])
    kd = df[kd_cols].to_numpy(float)
    kd = np.where(kd > 0, kd, np.nan)
    hplc_v = df["chl_a"].to_numpy(float)
    fluor = df["chl"].to_numpy(float)
    hplc = hplc_v > 0
    chl = np.where(hplc, hplc_v, np.where(fluor > 0, fluor, np.nan))
    keep = (np.sum(~np.isnan(kd), axis=1) >= MIN_KD_BANDS) & (chl > 0)
    def positive(col):
        v = col.to_numpy(float)
        return np.where(v > 0, v, np.nan)

    ag = positive(df["ag443"])
    ad = positive(df["ad443"])
    aph = positive(df["ap443"] - df["ad443"])
    bb = positive(df["bb555"])
    rows = np.flatnonzero(keep)
    return NomadStations(rows, df["id"].to_numpy()[rows].astype(int), wl, kd[rows], chl[rows],
                         hplc[rows], ag[rows], aph[rows], ad[rows], bb[rows],
                         df["cruise"].astype(str).to_numpy()[rows])


def cdom_440(ag443, water=None) -> np.ndarray:
    """a_CDOM(440) from a measured a_CDOM(443) through eq 6 with the water's slope, m^-1."""
    shape = forward.cdom_absorption(_GRID_443, 1.0, water=water)[1]
    return np.asarray(ag443, float) / shape
