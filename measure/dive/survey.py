"""survey.nc: the dive as a CF-1.8 NetCDF file, one record per photo (:func:`survey_dataset`)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .files import atomic
from .summary import exit_code, to_float

__all__ = ["CDOM_WAVELENGTH_NM", "CF_CDOM", "CF_CHL", "netcdf_engine", "survey_dataset",
           "write_survey"]

#: CF standard name and canonical units of C (Chl-a concentration; mg m-3 = 1e-6 kg m-3)
CF_CHL = ("mass_concentration_of_chlorophyll_a_in_sea_water", "mg m-3")
#: CF standard name and units of a_CDOM(440)
CF_CDOM = (("volume_absorption_coefficient_of_radiative_flux_in_sea_water_due_to_"
            "dissolved_organic_matter"), "m-1")
#: The wavelength a_CDOM refers to, nm (Blasinski & Farrell eq 6)
CDOM_WAVELENGTH_NM = 440.0


def survey_dataset(rows, records, attrs=None):
    """The survey as an xarray Dataset (CF-1.8): one record per photo.

    Parameters
    ----------
    rows : list of dict
        The summary rows (:data:`SUMMARY_COLUMNS`), photos only.
    records : dict
        image -> measurement.json content, for the photos measured.
    attrs : dict, optional
        More global attributes (``history``, ``command``, ``uw3p_version``).

    Returns
    -------
    xarray.Dataset
        Dimension ``photo`` (coordinate ``image``), ``wavelength`` (nm) and ``nv`` (2, the
        interval ends): ``chl`` (mg m-3) and ``cdom`` (m-1 at 440 nm) with CF standard names
        and ``chl_bounds``/``cdom_bounds`` (95 % intervals), ``attenuation`` (photo,
        wavelength), ``depth``, ``distance`` and their sds (m), ``time`` (EXIF, NaT where
        absent), ``reliable``, ``flags``, ``status``, ``error`` and the input sources.
    """
    import xarray as xr

    from sca.budget import parse_sd

    n = len(rows)
    wl = next((np.asarray(r["estimate"]["wavelengths"], float) for r in records.values()),
              np.array([], float))
    k = np.full((n, wl.size), np.nan)
    for i, row in enumerate(rows):
        rec = records.get(row["image"])
        if rec is not None and np.array_equal(rec["estimate"]["wavelengths"], wl):
            k[i] = np.asarray(rec["estimate"]["attenuation"], float)

    def col(name):
        return np.array([to_float(r.get(name)) for r in rows], float)

    def sd(name):  # m; a percentage ("5%") of the length it refers to
        return np.array([math.nan if r.get(f"{name}_sd") in (None, "") else float(
            parse_sd(name, r[f"{name}_sd"], to_float(r.get(f"{name}_m")))) for r in rows], float)

    def text(name):
        return np.array([str(r.get(name) or "") for r in rows], dtype=object)

    times = np.array([np.datetime64(r["time"]) if r.get("time") else np.datetime64("NaT")
                      for r in rows], dtype="datetime64[ns]")
    photo = ("photo",)
    ds = xr.Dataset(
        {"chl": (photo, col("chl"), {"standard_name": CF_CHL[0], "units": CF_CHL[1],
                                     "long_name": "chlorophyll concentration C",
                                     "bounds": "chl_bounds"}),
         "chl_bounds": (("photo", "nv"), np.column_stack([col("chl_lo"), col("chl_hi")]),
                        {"long_name": "95 % interval of chl", "units": CF_CHL[1]}),
         "cdom": (photo, col("cdom"), {"standard_name": CF_CDOM[0], "units": CF_CDOM[1],
                                       "long_name": "CDOM absorption a_CDOM at 440 nm",
                                       "bounds": "cdom_bounds",
                                       "coordinates": "cdom_wavelength"}),
         "cdom_bounds": (("photo", "nv"), np.column_stack([col("cdom_lo"), col("cdom_hi")]),
                         {"long_name": "95 % interval of cdom", "units": CF_CDOM[1]}),
         "attenuation": (("photo", "wavelength"), k,
                         {"long_name": "path attenuation k = exp(-(depth + distance) c)",
                          "units": "1"}),
         "depth": (photo, col("depth_m"), {"standard_name": "depth", "units": "m",
                                           "positive": "down", "long_name": "chart depth"}),
         "depth_sd": (photo, sd("depth"), {"long_name": "standard deviation of depth",
                                               "units": "m"}),
         "distance": (photo, col("distance_m"), {"long_name": "camera-to-chart distance",
                                                 "units": "m"}),
         "distance_sd": (photo, sd("distance"),
                         {"long_name": "standard deviation of distance", "units": "m"}),
         "time": (photo, times, {"standard_name": "time",
                                 "long_name": "EXIF DateTimeOriginal (camera local time)"}),
         "gain": (photo, col("gain"), {"long_name": "exposure gain",
                                       "units": "raw units per model unit"}),
         "chi2_dof": (photo, col("chi2_dof"), {"long_name": "chi-square per degree of freedom",
                                               "units": "1"}),
         "reliable": (photo, np.array([exit_code(r) == 0 for r in rows], np.int8),
                      {"long_name": "estimate reliable (no blocking flag)",
                       "flag_values": np.array([0, 1], np.int8),
                       "flag_meanings": "not_reliable reliable"}),
         **{name: (photo, text(name), {"long_name": name.replace("_", " ")})
            for name in ("flags", "status", "error", "depth_source", "distance_source",
                         "corners_source", "corners", "out")}},
        coords={"image": (photo, text("image"), {"long_name": "photo file"}),
                "wavelength": ("wavelength", wl, {"standard_name": "radiation_wavelength",
                                                  "units": "nm"}),
                "cdom_wavelength": ((), CDOM_WAVELENGTH_NM,
                                    {"standard_name": "radiation_wavelength", "units": "nm"})},
        attrs={"Conventions": "CF-1.8", "title": "uw3p dive survey: one record per photo",
               "source": "uw3p measure (Blasinski & Farrell three-parameter model)",
               "references": "H. Blasinski and J. Farrell, A Three Parameter Underwater Image "
                             "Formation Model, IS&T Electronic Imaging 2016"} | (attrs or {}))
    return ds


def netcdf_engine() -> str:
    """The xarray engine survey.nc is written with: 'h5netcdf' (netCDF-4) when its HDF5
    back end h5py is installed, else 'scipy' (netCDF-3 64-bit offset; the same variables,
    names and attributes, strings as character arrays).

    Returns
    -------
    str
    """
    try:
        import h5py  # noqa: F401
    except ImportError:
        return "scipy"
    return "h5netcdf"


def write_survey(ds, path: Path) -> Path:
    with atomic(path) as tmp:
        ds.to_netcdf(tmp, engine=netcdf_engine())
    return path
