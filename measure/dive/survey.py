"""survey.nc: the dive as a CF-1.8 NetCDF file, one record per photo (:func:`survey_dataset`)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .files import atomic
from .summary import exit_code, to_float

__all__ = ["CDOM_WAVELENGTH_NM", "CF_CDOM", "CF_CHL", "netcdf_engine", "path_standard_name",
           "survey_dataset", "write_survey"]

#: CF standard name and canonical units of C (Chl-a concentration; mg m-3 = 1e-6 kg m-3)
CF_CHL = ("mass_concentration_of_chlorophyll_a_in_sea_water", "mg m-3")
#: CF standard name and units of a_CDOM(440)
CF_CDOM = (("volume_absorption_coefficient_of_radiative_flux_in_sea_water_due_to_"
            "dissolved_organic_matter"), "m-1")
#: The wavelength a_CDOM refers to, nm (Blasinski & Farrell eq 6)
CDOM_WAVELENGTH_NM = 440.0


def path_standard_name(path_models) -> str:
    """The CF standard name of the path's attenuation coefficient of results whose supported
    path models are ``path_models`` (:data:`sca.derived.PATH_CF`): the name where every one
    is the same model with a CF name, else '' (the coefficient is then the path's, by path
    model: the beam attenuation c under 'beam', the absorption a under 'absorption').

    Parameters
    ----------
    path_models : iterable of str

    Returns
    -------
    str
    """
    from sca.derived import PATH_CF

    models = set(path_models)
    return PATH_CF.get(models.pop(), "") if len(models) == 1 else ""


def _verdict_words() -> str:
    """The verdicts of :data:`sca.derived.VERDICTS` in words ('measured, ... or not
    constrained')."""
    from sca.derived import VERDICTS

    return ", ".join(VERDICTS[:-1]) + " or " + VERDICTS[-1]


def _quantity_attrs(name, standard_name):
    """Attributes of one derived quantity's variable (:data:`sca.derived.QUANTITIES`)."""
    from sca.derived import QUANTITIES

    terms, band, text, units, cf = QUANTITIES[name]
    cf = standard_name if terms is None else cf
    return ({"standard_name": cf} if cf else {}) | {
        "long_name": f"{text} (95 % interval in {name}_bounds)", "units": units,
        "coordinates": f"{name}_wavelength"}


def _spectrum_attrs(standard_name, models):
    return ({"standard_name": standard_name} if standard_name else {}) | {
        "long_name": "attenuation coefficient of the light's path, tau / (depth + distance)",
        "units": "m-1", "comment": "the beam attenuation c = a + b under path model 'beam', the "
        "absorption a under 'absorption', the path-weighted mean of K_d and c under 'split'; "
        "path models of these results: " + (", ".join(sorted(models)) or "none")}


def _joint_variables(joint, wl):
    """The joint estimate of the dive as variables of their own (joint.json's content)."""
    from sca.derived import QUANTITIES

    nv = ("nv",)
    span = "path-model-span" in (joint.get("flags") or [])
    models = list(joint.get("path_models") or {}) if span else [joint.get("path_model", "")]
    cf = path_standard_name(models)
    where = " of the dive (all photos fitted as one water)"
    out = {"joint_chl": ((), to_float(joint["chl"]),
                         {"standard_name": CF_CHL[0], "units": CF_CHL[1],
                          "long_name": "chlorophyll concentration C" + where,
                          "bounds": "joint_chl_bounds"}),
           "joint_chl_bounds": (nv, [to_float(v) for v in joint["chl_ci"]],
                                {"units": CF_CHL[1], "long_name": "95 % interval of joint_chl"}),
           "joint_cdom": ((), to_float(joint["cdom"]),
                          {"standard_name": CF_CDOM[0], "units": CF_CDOM[1],
                           "long_name": "CDOM absorption a_CDOM at 440 nm" + where,
                           "bounds": "joint_cdom_bounds", "coordinates": "cdom_wavelength"}),
           "joint_cdom_bounds": (nv, [to_float(v) for v in joint["cdom_ci"]],
                                 {"units": CF_CDOM[1],
                                  "long_name": "95 % interval of joint_cdom"}),
           "joint_reliable": ((), np.int8(bool(joint.get("reliable"))),
                              {"long_name": "joint estimate reliable (no blocking flag)",
                               "flag_values": np.array([0, 1], np.int8),
                               "flag_meanings": "not_reliable reliable"})}
    quantities, intervals = joint.get("quantities") or {}, joint.get("quantity_intervals") or {}
    for q in QUANTITIES:
        if q in quantities:
            attrs = _quantity_attrs(q, cf)
            attrs["long_name"] = attrs["long_name"].replace(f"{q}_bounds", f"joint_{q}_bounds")
            out[f"joint_{q}"] = ((), to_float(quantities[q]),
                                 attrs | {"bounds": f"joint_{q}_bounds"} | {
                                     "comment": "at the photos' median depth and distance"})
            out[f"joint_{q}_bounds"] = (nv, [to_float(v) for v in intervals[q]],
                                        {"units": attrs["units"],
                                         "long_name": f"95 % interval of joint_{q}"})
    c = np.asarray(joint.get("beam_attenuation") or [], float)
    if c.size and c.size == wl.size and np.allclose(joint.get("wavelengths"), wl):
        ci = np.asarray([[to_float(v) for v in pair] for pair in joint["beam_attenuation_ci"]])
        out["joint_attenuation_coefficient"] = (
            ("wavelength",), c, _spectrum_attrs(cf, models) | {
                "bounds": "joint_attenuation_coefficient_bounds",
                "long_name": "attenuation coefficient of the light's path" + where})
        out["joint_attenuation_coefficient_bounds"] = (
            ("wavelength", "nv"), ci,
            {"units": "m-1", "long_name": "95 % interval of joint_attenuation_coefficient"})
    for name, verdict in (joint.get("verdicts") or {}).items():
        out[f"joint_{name}_verdict"] = ((), str(verdict), {
            "long_name": f"what the dive says of {name}: {_verdict_words()}"})
    return out


def survey_dataset(rows, records, attrs=None, joint=None):
    """The survey as an xarray Dataset (CF-1.8): one record per photo, and the dive's joint
    estimate as variables of its own.

    Parameters
    ----------
    rows : list of dict
        The summary rows (:data:`SUMMARY_COLUMNS`), photos only.
    records : dict
        image -> measurement.json content, for the photos measured.
    attrs : dict, optional
        More global attributes (``history``, ``command``, ``uw3p_version``).
    joint : dict, optional
        joint.json's content (:meth:`sca.joint.JointEstimate.to_dict`).

    Returns
    -------
    xarray.Dataset
        Dimension ``photo`` (coordinate ``image``), ``wavelength`` (nm) and ``nv`` (2, the
        interval ends): ``chl`` (mg m-3) and ``cdom`` (m-1 at 440 nm) with CF standard names
        and ``chl_bounds``/``cdom_bounds`` (95 % intervals); what each photo measures
        (:mod:`sca.derived`, each with ``<name>_bounds`` and ``<name>_verdict``): ``c_443``
        ... ``c_670`` and ``a_nw_440`` (m-1), the optical depth ``tau_443`` ... ``tau_670``
        (units "1"; no CF standard name), and the spectrum ``attenuation_coefficient``
        (photo, wavelength) with ``attenuation_coefficient_bounds`` (photo, wavelength, nv) --
        the CF name of the beam attenuation or the absorption coefficient where every photo's
        path model says which (:func:`path_standard_name`); ``transmittance`` (photo,
        wavelength; k = exp(-(depth + distance) c), dimensionless); ``chl_verdict``,
        ``cdom_verdict``, ``path_model``; ``depth``, ``distance`` and their sds (m), ``time``
        (EXIF, NaT where absent), ``reliable``, ``flags``, ``status``, ``error`` and the input
        sources; with ``joint``: ``joint_chl``, ``joint_cdom``, ``joint_<quantity>``, their
        ``_bounds``, ``joint_attenuation_coefficient`` (wavelength) with its bounds,
        ``joint_reliable`` and the verdicts.
    """
    import xarray as xr

    from sca.budget import parse_sd
    from sca.derived import QUANTITIES

    n = len(rows)
    wl = next((np.asarray(r["estimate"]["wavelengths"], float) for r in records.values()),
              np.asarray((joint or {}).get("wavelengths") or [], float))
    k = np.full((n, wl.size), np.nan)
    c = np.full((n, wl.size), np.nan)
    c_ci = np.full((n, wl.size, 2), np.nan)
    q = {name: np.full(n, np.nan) for name in QUANTITIES}
    q_ci = {name: np.full((n, 2), np.nan) for name in QUANTITIES}
    verdicts = {name: [""] * n for name in ("chl", "cdom", *QUANTITIES)}
    path_model = [""] * n
    models = set()
    for i, row in enumerate(rows):
        rec = records.get(row["image"])
        if rec is None or not np.array_equal(rec["estimate"]["wavelengths"], wl):
            continue
        e = rec["estimate"]
        k[i] = np.asarray(e["transmittance"], float)
        c[i] = np.asarray(e["beam_attenuation"], float)
        c_ci[i] = np.asarray([[to_float(v) for v in pair] for pair in e["beam_attenuation_ci"]])
        for name in QUANTITIES:  # a record of an earlier version may lack one (tau): NaN
            q[name][i] = to_float(e["quantities"].get(name))
            q_ci[name][i] = [to_float(v) for v in e["quantity_intervals"].get(name, (None,) * 2)]
        for name, v in e["verdicts"].items():
            if name in verdicts:
                verdicts[name][i] = str(v)
        path_model[i] = e["path_model"]
        models.update(e.get("path_models") or [e["path_model"]])
    cf = path_standard_name(models)

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
    quantity_vars = {}
    for name in QUANTITIES:
        quantity_vars[name] = (photo, q[name], _quantity_attrs(name, cf)
                               | {"bounds": f"{name}_bounds"})
        quantity_vars[f"{name}_bounds"] = (("photo", "nv"), q_ci[name], {
            "long_name": f"95 % interval of {name}", "units": QUANTITIES[name][3]})
    verdict_vars = {f"{name}_verdict": (photo, np.array(v, dtype=object), {
        "long_name": f"what the photo says of {name}: {_verdict_words()}"})
        for name, v in verdicts.items()}
    band_coords = {f"{name}_wavelength": ((), float(QUANTITIES[name][1]), {
        "standard_name": "radiation_wavelength", "units": "nm"}) for name in QUANTITIES}
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
         **quantity_vars,
         "attenuation_coefficient": (("photo", "wavelength"), c, _spectrum_attrs(cf, models)
                                     | {"bounds": "attenuation_coefficient_bounds"}),
         "attenuation_coefficient_bounds": (("photo", "wavelength", "nv"), c_ci, {
             "long_name": "95 % interval of attenuation_coefficient", "units": "m-1"}),
         "transmittance": (("photo", "wavelength"), k,
                           {"long_name": "transmittance of the light's path k = exp(-(depth + "
                                         "distance) c)", "units": "1"}),
         **verdict_vars,
         "path_model": (photo, np.array(path_model, dtype=object),
                        {"long_name": "the best-fitting path model of the photo's fit"}),
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
                         "corners_source", "corners", "out")},
         **(_joint_variables(joint, wl) if joint else {})},
        coords={"image": (photo, text("image"), {"long_name": "photo file"}),
                "wavelength": ("wavelength", wl, {"standard_name": "radiation_wavelength",
                                                  "units": "nm"}),
                "cdom_wavelength": ((), CDOM_WAVELENGTH_NM,
                                    {"standard_name": "radiation_wavelength", "units": "nm"}),
                **band_coords},
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
