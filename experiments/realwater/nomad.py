"""NOMAD v2: the paper's water model against 2027 measured K_d spectra with in-situ chlorophyll.

Forward: from in-situ C (HPLC ``chl_a`` where present, else fluorometric ``chl``) and, where
measured, a_CDOM (``ag443``), three predictions of each measured K_d band:

* the model's K_d = (a + b_b) / mu_d (:class:`sca.spectral.KdModel`; mu_d = 0.75, b_bp = eq 12
  as published, ``particle_backscatter_fraction`` 1): the 'split' path model's way down;
* the paper's beam attenuation c = a + b (eq 4): what its 'beam' path model uses on the way
  down;
* an empirical anchor, Morel (1988) Table 2: K_d = K_w + chi C^e (Case 1 waters).

Inverse: C and a_CDOM(440) fitted to each K_d spectrum by :func:`sca.spectral.fit_spectrum`
(95 % profile-likelihood intervals with the nuisance priors and the fixed error model of
:mod:`sca.spectral`), compared with the in-situ values.

Validation, never tuning: nothing here is fitted to NOMAD; every constant is the paper's or
fixed from the literature before the comparison (:mod:`sca.spectral`).

References
----------
P. J. Werdell and S. W. Bailey, "An improved in-situ bio-optical data set for ocean color
algorithm development and satellite data product validation", Remote Sens. Environ. 98 (2005)
122-140. A. Morel, J. Geophys. Res. 93 (1988) 10749-10768, Table 2.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import forward
from sca.spectral import (
    KD_MODEL_ERROR,
    KD_SIGMA_REL,
    KD_UNCERTAIN,
    KdModel,
    fit_spectrum,
)

from ..common import save_figure, style, write_csv
from .estimators import CDOM_FLOOR, CHL_FLOOR, MOREL_TABLE, morel_coefficients, score
from .nomad_data import (_GRID_443, CHL_CLASSES, MIN_KD_BANDS, NomadStations, cdom_440,
                         load_nomad)
from .split import SPLIT_SEED

__all__ = [
    "CHL_CLASSES",
    "MIN_KD_BANDS",
    "MOREL_1988_TABLE",
    "REPORT_BANDS",
    "NomadStations",
    "fit_stations",
    "forward_predictions",
    "inverse_stats",
    "load_nomad",
    "morel_1988_kd",
    "ratio_table",
    "run",
    "write_inverse_csv",
]

#: Bands quoted in the report's tables, nm (the others are in the CSV).
REPORT_BANDS = (411, 443, 489, 510, 555, 670, 683)
#: File of ``data/`` with Morel's (1988) K_w, chi, e.
MOREL_1988_TABLE = MOREL_TABLE
#: The same around 555 nm.
_GRID_555 = np.array([550.0, 555.0, 560.0])
#: The figures show a band only where at least this share of the group's stations have it
#: (the band sets differ between cruises: a median over a few stations is another water).
FIG_BAND_SHARE = 0.3
#: Percentiles of the scatter reported (the 16-84 % range, +-1 sd of a normal).
LOW_PCT, HIGH_PCT = 16, 84


def morel_1988_kd(wavelengths, chl) -> np.ndarray:
    """K_d = K_w + chi C^e of Morel (1988) Table 2, linearly interpolated in wavelength.

    Parameters
    ----------
    wavelengths : array_like, (q,)
        nm, within 400-700.
    chl : array_like, (N,)
        C, mg m^-3.

    Returns
    -------
    ndarray, (N, q)
        K_d, m^-1.

    References
    ----------
    A. Morel (1988), J. Geophys. Res. 93:10749, Table 2 (``data/diffuse_attenuation_morel_1988.csv``).
    """
    kw, chi, e = morel_coefficients(wavelengths)
    c = np.asarray(chl, float)[:, None]
    return kw + chi * c ** e


def forward_predictions(st: NomadStations, *, cdom=None, water=None) -> dict:
    """The three forward predictions of every station's K_d bands, m^-1, each (N, q).

    Parameters
    ----------
    st : NomadStations
        The stations.
    cdom : array_like, (N,), optional
        a_CDOM(440), m^-1 (default: from ``ag443``, 0 where it was not measured).
    water : forward.Water, optional
        The water model (default: the paper's).

    Returns
    -------
    dict
        'kd_model' ((a + b_b) / mu_d), 'beam' (c = a + b), 'morel1988'.
    """
    if cdom is None:
        cdom = np.nan_to_num(cdom_440(st.ag443, water), nan=0.0)
    model = KdModel(st.wavelengths, water=water)
    kd_model = model.kd({"chl": st.chl, "cdom": np.asarray(cdom, float)})[0]
    beam = model.terms.beam_coefficient(st.chl, np.asarray(cdom, float))
    return {"kd_model": kd_model, "beam": beam,
            "morel1988": morel_1988_kd(st.wavelengths, st.chl)}


def _pct(x):
    x = x[np.isfinite(x)]
    if x.size == 0:
        return np.nan, np.nan, np.nan, 0
    lo, med, hi = np.percentile(x, [LOW_PCT, 50, HIGH_PCT])
    return med, lo, hi, x.size


def ratio_table(st: NomadStations, pred: dict, groups: dict) -> list:
    """Median and 16-84 % range of predicted / measured K_d per band, model and group.

    Parameters
    ----------
    st : NomadStations
        The stations.
    pred : dict
        name -> (N, q) predictions (:func:`forward_predictions`).
    groups : dict
        group name -> (N,) boolean mask.

    Returns
    -------
    list of tuple
        (group, model, band nm, n, median, p16, p84) rows.
    """
    rows = []
    for g, mask in groups.items():
        for name, p in pred.items():
            r = p[mask] / st.kd[mask]
            for j, wl in enumerate(st.wavelengths):
                med, lo, hi, n = _pct(r[:, j])
                if n:
                    rows.append((g, name, int(wl), n, med, lo, hi))
    return rows


def water_groups(st: NomadStations, water=None) -> dict:
    """The water types: chlorophyll classes (all stations) and, among stations with ag443,
    Case-1-like (a_CDOM(443) below the model's particle absorption a_phi + a_NAP at 443 nm at
    the in-situ C) against CDOM-rich (above it)."""
    groups = {"all": np.ones(len(st), bool)}
    for lo, hi in CHL_CLASSES:
        groups[f"C {lo:g}-{hi:g}"] = (st.chl >= lo) & (st.chl < hi)
    has = ~np.isnan(st.ag443)
    particles = (forward.phytoplankton_absorption(_GRID_443, st.chl, water=water)[:, 1]
                 + forward.nap_absorption(_GRID_443, st.chl, water=water)[:, 1])
    groups["ag443 measured"] = has
    groups["Case-1-like"] = has & (st.ag443 <= particles)
    groups["CDOM-rich"] = has & (st.ag443 > particles)
    return groups


def model_iops(st: NomadStations, water=None) -> dict:
    """The model's a_phi(443), a_NAP(443) (eqs 8-10) and b_b(555) (0.5 b_w + eq 12) at each
    station's in-situ C, m^-1 (N,) each."""
    b_b = KdModel(_GRID_555, water=water).terms.backscattering(st.chl)[:, 1]
    return {"aph443": forward.phytoplankton_absorption(_GRID_443, st.chl, water=water)[:, 1],
            "ad443": forward.nap_absorption(_GRID_443, st.chl, water=water)[:, 1],
            "bb555": b_b}


def iop_checks(st: NomadStations, water=None) -> dict:
    """Measured / model of a_phi(443), a_NAP(443) and b_b(555) at the in-situ C: the median
    ratio and the scatter of ln(ratio) (half the 16-84 % range), overall and per station half.

    Returns
    -------
    dict
        name -> {'n', 'median_ratio', 'log_sd', 'log_sd_even', 'log_sd_odd'}.
    """
    mod = model_iops(st, water)
    out = {}
    for name, meas in (("aph443", st.aph443), ("ad443", st.ad443), ("bb555", st.bb555)):
        ok = np.isfinite(meas) & (mod[name] > 0)
        r = np.log(meas[ok] / mod[name][ok])
        even = st.station[ok] % 2 == 0

        def half_width(x):
            return float(np.diff(np.percentile(x, [LOW_PCT, HIGH_PCT]))[0] / 2) if x.size > 2 \
                else np.nan
        out[name] = {"n": int(ok.sum()), "median_ratio": float(np.exp(np.median(r))),
                     "log_sd": half_width(r), "log_sd_even": half_width(r[even]),
                     "log_sd_odd": half_width(r[~even])}
    return out


def bio_optical_uncertain(checks: dict, water=None) -> dict:
    """The K_d fit's priors widened by the chlorophyll-specific absorption's scatter, derived
    from the EVEN stations only (:func:`iop_checks`): ``phyto_scale`` and ``nap_scale`` get a
    relative sd equal to the scatter of ln(measured / model) of a_phi(443) and a_NAP(443)
    (centred on the paper's values: the scatter is taken from the data, the model is not)."""
    water = forward.resolve_water(water)
    out = dict(KD_UNCERTAIN)
    out["phyto_scale"] = checks["aph443"]["log_sd_even"] * water.phyto_scale
    out["nap_scale"] = checks["ad443"]["log_sd_even"] * water.nap_scale
    return out


def synthetic_coverage(st: NomadStations, *, seed: int = 0, water=None) -> dict:
    """The intervals on the model's own worlds: each station with ag443 gets a K_d spectrum
    made by :class:`sca.spectral.KdModel` at its in-situ C and a_CDOM(440), its own bands, the
    nuisances drawn from their priors and each band multiplied by 1 + N(0, sigma) (the fit's
    error model). Coverage of the 95 % intervals of C and a_CDOM should then be near 95 %.

    Returns
    -------
    dict
        'n', 'coverage_chl', 'coverage_cdom', 'reliable_fraction'.
    """
    sub = st.subset(np.flatnonzero(np.isfinite(st.ag443)))
    rng = np.random.default_rng(seed)
    water = forward.resolve_water(water)
    n = len(sub)
    params = {"chl": sub.chl, "cdom": cdom_440(sub.ag443, water)}
    for k, sd in KD_UNCERTAIN.items():
        params[k] = float(getattr(water, k)) + sd * rng.standard_normal(n)
    kd = KdModel(sub.wavelengths, water=water).kd(params)[0]
    rel = float(np.hypot(KD_SIGMA_REL, KD_MODEL_ERROR))
    kd = kd * np.maximum(1.0 + rel * rng.standard_normal(kd.shape), 0.05)
    kd = np.where(np.isnan(sub.kd), np.nan, kd)
    fit = fit_spectrum(kd, sub.wavelengths, water=water)
    inside_c = (fit.chl_ci[:, 0] <= params["chl"]) & (params["chl"] <= fit.chl_ci[:, 1])
    inside_g = (fit.cdom_ci[:, 0] <= params["cdom"]) & (params["cdom"] <= fit.cdom_ci[:, 1])
    return {"n": n, "coverage_chl": float(np.mean(inside_c)),
            "coverage_cdom": float(np.mean(inside_g)),
            "coverage_chl_reliable": float(np.mean(inside_c[fit.reliable])),
            "reliable_fraction": float(np.mean(fit.reliable))}


def red_band_subset(st: NomadStations, pred: dict) -> dict:
    """Who has a 670 nm K_d: median C and the 443 nm model / measured ratio of the ag443
    stations with and without that band; and the range of c / K_d(model)."""
    j670 = int(np.flatnonzero(st.wavelengths == 670.0)[0])
    j443 = int(np.flatnonzero(st.wavelengths == 443.0)[0])
    ag = np.isfinite(st.ag443)
    r443 = pred["kd_model"][:, j443] / st.kd[:, j443]
    out = {}
    for key, m in (("with", ag & np.isfinite(st.kd[:, j670])),
                   ("without", ag & np.isnan(st.kd[:, j670]))):
        out[f"chl_{key}"] = float(np.median(st.chl[m])) if m.any() else np.nan
        out[f"ratio443_{key}"] = float(np.nanmedian(r443[m])) if m.any() else np.nan
    c_kd = pred["beam"] / pred["kd_model"]
    out["c_over_kd_min"], out["c_over_kd_max"] = float(c_kd.min()), float(c_kd.max())
    return out


def fit_stations(st: NomadStations, **kw):
    """:func:`sca.spectral.fit_spectrum` of every station (missing bands NaN)."""
    return fit_spectrum(st.kd, st.wavelengths, **kw)


def _scores(est, ref, lo, hi, reliable, clusters, floor) -> dict:
    """:func:`~experiments.realwater.estimators.score` (the one rule: an estimate of 0 scored as
    ``floor`` and counted) with cruise-clustered intervals, and the coverage among the
    reliable stations."""
    out = score(est, ref, lo, hi, floor=floor, clusters=clusters)
    r = reliable
    out.update(n_reliable=int(r.sum()), coverage_reliable=float(np.mean(
        (lo[r] <= ref[r]) & (ref[r] <= hi[r]))) if r.any() else np.nan)
    return out


def inverse_stats(st: NomadStations, fit, train, water=None) -> dict:
    """Scores of the fitted C and a_CDOM(440) against the in-situ values
    (:func:`~experiments.realwater.estimators.score`, the rule of every table: C = 0 counted as
    :data:`~experiments.realwater.estimators.CHL_FLOOR`, a_CDOM = 0 as
    :data:`~experiments.realwater.estimators.CDOM_FLOOR`), for all stations and the training
    and test cruises (``train``: the cruise-blocked split's mask)."""
    ci = fit.chl_ci
    out = {}
    for name, m in (("chl", np.ones(st.chl.size, bool)), ("chl_train", train),
                    ("chl_test", ~train)):
        out[name] = _scores(fit.chl[m], st.chl[m], ci[m, 0], ci[m, 1], fit.reliable[m],
                            st.cruise[m], CHL_FLOOR)
    has = ~np.isnan(st.ag443)
    out["cdom"] = _scores(fit.cdom[has], cdom_440(st.ag443[has], water), fit.cdom_ci[has, 0],
                          fit.cdom_ci[has, 1], fit.reliable[has], st.cruise[has], CDOM_FLOOR)
    mu = fit.nuisance.get("downwelling_cosine")
    if mu is not None and fit.reliable.any():
        out["mu_d_p16"], out["mu_d_median"], out["mu_d_p84"] = (
            float(v) for v in np.percentile(mu[fit.reliable], [LOW_PCT, 50, HIGH_PCT]))
    else:
        out["mu_d_p16"] = out["mu_d_median"] = out["mu_d_p84"] = np.nan
    out["reliable_fraction"] = float(np.mean(fit.reliable))
    out["misfit_fraction"] = float(np.mean(fit.p_value < 0.01))
    return out


def write_inverse_csv(path: Path, st: NomadStations, fit, train, water=None) -> Path:
    """``nomad_inverse.csv``: one row per station (written whole, via a temporary file): its
    cruise, its ``split`` ('train' / 'test': the cruise-blocked split's mask ``train``) and
    ``fit`` (the real-water choice in ``make real-data``)."""
    ref = cdom_440(st.ag443, water)
    rows = []
    for i in range(len(st)):
        has = np.isfinite(ref[i])
        rows.append([int(st.station[i]), int(st.nomad_id[i]), st.cruise[i],
                     "train" if train[i] else "test", f"{st.chl[i]:.6g}",
                     "hplc" if st.hplc[i] else "fluorometric", f"{fit.chl[i]:.6g}",
                     f"{fit.chl_ci[i, 0]:.6g}", f"{fit.chl_ci[i, 1]:.6g}",
                     int(bool(fit.reliable[i])), f"{fit.chi2[i]:.6g}", int(fit.dof[i]),
                     f"{fit.p_value[i]:.4g}",
                     f"{ref[i]:.6g}" if has else "", f"{fit.cdom[i]:.6g}" if has else "",
                     f"{fit.cdom_ci[i, 0]:.6g}" if has else "",
                     f"{fit.cdom_ci[i, 1]:.6g}" if has else ""])
    header = ["station", "nomad_id", "cruise", "split", "chl_insitu", "chl_source", "chl",
              "chl_lo", "chl_hi", "reliable", "chi2", "dof", "p_value", "cdom_insitu", "cdom",
              "cdom_lo", "cdom_hi"]
    comment = ("NOMAD v2 inverse: C (mg m^-3) and a_CDOM(440) (m^-1) fitted to each measured "
               "K_d spectrum\nby sca.spectral.fit_spectrum with the real-water choice "
               "(experiments.realwater.empirical.real_water_choice: Pope & Fry 1997 water,\n"
               "mu_d and the Case-1 relations learned on the training cruises; 95 % "
               f"profile-likelihood intervals; sigma_rel {KD_SIGMA_REL}, model error "
               f"{KD_MODEL_ERROR}).\nstation = data row of the NOMAD file (0-based); split = "
               f"the cruise-blocked split (seed {SPLIT_SEED}): train / test cruises; "
               "cdom_insitu = ag443 taken to 440 nm by eq 6.\nGenerated by: make real-data")
    return write_csv(path, header, rows, comment)


# ------------------------------------------------------------------ figures
def _figure_forward(st, pred, groups, outdir):
    import matplotlib.pyplot as plt

    style()
    fig, axes = plt.subplots(1, 2, figsize=(7.5, 3.2), layout="constrained", sharey=True)
    wl = st.wavelengths
    labels = {"kd_model": "model K_d = (a + b_b)/0.75", "beam": "paper's c = a + b",
              "morel1988": "Morel 1988 K_w + chi C^e"}
    mask = groups["ag443 measured"]
    for name, p in pred.items():
        r = p[mask] / st.kd[mask]
        stats = np.array([_pct(r[:, j])[:3] for j in range(wl.size)])
        good = np.array([_pct(r[:, j])[3] >= FIG_BAND_SHARE * mask.sum() for j in range(wl.size)])
        axes[0].plot(wl[good], stats[good, 0], "o-", ms=3, label=labels[name])
        axes[0].fill_between(wl[good], stats[good, 1], stats[good, 2], alpha=0.15)
    axes[0].set_title(f"stations with a_CDOM measured (n = {int(mask.sum())})")
    fig.suptitle(f"bands measured at >= {100 * FIG_BAND_SHARE:.0f} % of a group's stations "
                 "(CDOM 0 where not measured)")
    for g in [k for k in groups if k.startswith("C ")] + ["CDOM-rich"]:
        m = groups[g]
        r = pred["kd_model"][m] / st.kd[m]
        stats = np.array([_pct(r[:, j]) for j in range(wl.size)])
        good = stats[:, 3] >= FIG_BAND_SHARE * m.sum()
        axes[1].plot(wl[good], stats[good, 0], "o-", ms=3, label=f"{g} (n = {int(m.sum())})")
    axes[1].set_title("model K_d by water type")
    for ax in axes:
        ax.axhline(1.0, color="k", lw=0.8)
        ax.set_yscale("log")
        ax.set_xlabel("wavelength (nm)")
        ax.legend(loc="lower left")
    axes[0].set_ylabel("predicted / measured K_d (median, 16-84 %)")
    paths = save_figure(fig, "nomad_forward_ratio", outdir)
    plt.close(fig)
    return paths


def _figure_inverse(st, fit, outdir):
    import matplotlib.pyplot as plt

    style()
    fig, ax = plt.subplots(figsize=(4.5, 4.2), layout="constrained")
    for rel, colour, lab in ((False, "0.6", "not reliable"), (True, "C0", "reliable")):
        m = fit.reliable == rel
        lo = np.clip(fit.chl[m] - fit.chl_ci[m, 0], 0, None)
        hi = np.clip(np.nan_to_num(fit.chl_ci[m, 1], posinf=1e4) - fit.chl[m], 0, None)
        ax.errorbar(st.chl[m], np.maximum(fit.chl[m], 1e-3), yerr=[lo, hi], fmt="none",
                    lw=0.3, ecolor=colour, alpha=0.12)
        ax.plot(st.chl[m], np.maximum(fit.chl[m], 1e-3), "o", ms=2, color=colour, alpha=0.6,
                label=f"{lab} (n = {int(m.sum())})")
    ax.plot([1e-3, 1e2], [1e-3, 1e2], "k-", lw=0.8)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(5e-3, 1e2)
    ax.set_ylim(1e-3, 1e3)
    ax.set_xlabel("in-situ C (mg m$^{-3}$)")
    ax.set_ylabel("C fitted to K_d, 95 % interval (mg m$^{-3}$; 0 drawn at 10$^{-3}$)")
    ax.set_title("the fit of nomad_inverse.csv")
    ax.legend(loc="upper left")
    paths = save_figure(fig, "nomad_inverse", outdir)
    plt.close(fig)
    return paths


# ------------------------------------------------------------------ the section
#: The inverse table's fits: key of :func:`experiments.realwater.empirical.compare` -> label.
INVERSE_FITS = {"package": "defaults", "real_water": "real-water choice"}


def _inverse_rows(stats: dict) -> list:
    """Markdown rows of :func:`inverse_stats` per fit (:data:`INVERSE_FITS`)."""
    rows = []
    for key, stat in stats.items():
        for label, v in (("C, all", stat["chl"]), ("C, training cruises", stat["chl_train"]),
                         ("C, test cruises", stat["chl_test"]), ("a_CDOM(440)", stat["cdom"])):
            ci = v.get("factor_error_ci", (np.nan, np.nan))
            cc = v.get("coverage_ci", (np.nan, np.nan))
            rows.append(f"| {INVERSE_FITS[key]} | {label} | {v['n']} | {v['n_zero']} | "
                        f"{_fmt(v['bias_factor'])} | {_fmt(v['factor_error'])} "
                        f"[{_fmt(ci[0])}–{_fmt(ci[1])}] | {_fmt(v['r2_log'])} | "
                        f"{_fmt(100 * v['coverage'], 0)} % [{_fmt(100 * cc[0], 0)}–"
                        f"{_fmt(100 * cc[1], 0)}] | {v['n_reliable']} | "
                        f"{_fmt(100 * v['coverage_reliable'], 0)} % |")
    return rows


def _shown(path: Path) -> str:
    """``path`` relative to the repository when inside it (the report's file names)."""
    try:
        return Path(path).resolve().relative_to(Path(__file__).resolve().parents[2]).as_posix()
    except ValueError:
        return Path(path).as_posix()


def _fmt(x, nd=2):
    return "–" if x is None or not np.isfinite(x) else f"{x:.{nd}f}"


def _group_table(table, groups, model, with_n):
    """Markdown rows of the median [16-84 %] ratio of ``model`` per water type and band."""
    rows = ["| group | " + " | ".join(f"{b} nm" for b in REPORT_BANDS) + " |",
            "|---|" + "---|" * len(REPORT_BANDS)]
    for g in groups:
        cells = []
        for b in REPORT_BANDS:
            v = table.get((g, model, b))
            n = f" (n {v[0]})" if v and with_n else ""
            cells.append(f"{_fmt(v[1])} [{_fmt(v[2])}–{_fmt(v[3])}]{n}" if v else "–")
        rows.append(f"| {g} | " + " | ".join(cells) + " |")
    return rows


def run(outdir: Path, *, stations: int | None = None) -> tuple[str, dict]:
    """The NOMAD experiments: figures and CSVs in ``outdir``, and the report's section.

    Parameters
    ----------
    outdir : pathlib.Path
        Output folder (``figures/realwater``).
    stations : int, optional
        Use only the first this many stations (a quick check; default all).

    Returns
    -------
    markdown : str
        The REALWATER.md section.
    numbers : dict
        The headline numbers.

    Raises
    ------
    FileNotFoundError
        If the NOMAD file is absent.
    """
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    st = load_nomad()
    n_all, n_ag = len(st), int(np.sum(~np.isnan(st.ag443)))
    if stations is not None:
        st = st.subset(np.arange(min(stations, len(st))))
    pred = forward_predictions(st)
    groups = water_groups(st)
    rows = ratio_table(st, pred, groups)
    write_csv(outdir / "nomad_forward_ratio.csv",
              ["group", "model", "band_nm", "n", "median_ratio", "p16", "p84"],
              [(g, m, b, n, f"{a:.4g}", f"{lo:.4g}", f"{hi:.4g}") for g, m, b, n, a, lo, hi in rows],
              "predicted / measured K_d per band, NOMAD v2 (Generated by: make real-data)")
    from .empirical import CHOICE, compare
    from .empirical import section as empirical_section

    res = compare(st)
    fits = {k: res["fits"][k] for k in ("package", CHOICE) if k in res["fits"]}
    stats = {k: inverse_stats(st, f, res["train"]) for k, f in fits.items()}
    shown = fits.get(CHOICE, fits["package"])
    write_inverse_csv(outdir / "nomad_inverse.csv", st, shown, res["train"])
    checks = iop_checks(st)
    widened = bio_optical_uncertain(checks)
    synth = synthetic_coverage(st)
    empirical_md, empirical = empirical_section(st, outdir, res=res)
    figs = _figure_forward(st, pred, groups, outdir) + _figure_inverse(st, shown, outdir)
    table = {(g, m, b): (n, a, lo, hi) for g, m, b, n, a, lo, hi in rows}
    red = red_band_subset(st, pred)
    numbers = {"stations": len(st), "stations_with_ag443": int(np.sum(~np.isnan(st.ag443))),
               "hplc_fraction": float(np.mean(st.hplc)), "inverse": stats,
               "iop_checks": checks, "inverse_fit": CHOICE if CHOICE in fits else "package", "widened_priors": widened, "empirical": empirical,
               "synthetic_coverage": synth, "red_band_subset": red,
               "forward": {f"{g}|{m}|{b}": v for (g, m, b), v in table.items()}}
    md = [f"## NOMAD v2: the model against {len(st)} measured K_d spectra\n",
          (f"Data: {n_all} NOMAD stations with ≥ {MIN_KD_BANDS} K_d bands and in-situ chlorophyll "
          f"({n_ag} with a_CDOM(443)); C is HPLC `chl_a` where present "
          f"({100 * np.mean(st.hplc):.0f} % of stations), else fluorometric `chl`. Nothing is "
          "fitted to these data: every constant is the paper's or fixed from the literature "
          "beforehand.\n"),
          ("**K_d approximation.** K_d(λ) = (a(λ) + b_b(λ)) / μ̄_d with μ̄_d = 0.75 (Gordon 1989, "
          "Limnol. Oceanogr. 34:1389; μ̄_d ≈ 0.7–0.9, Kirk 2011 ch. 6), a from eqs 5–10, "
          "b_b = 0.5 b_w + b_bp with b_bp = eq 12 as published (Brewin et al. 2012 fitted eq 12 "
          "to particle *backscattering*; `particle_backscatter_fraction` = 1). "
          "Ratio = predicted / measured.\n"),
          "### Forward: predicted / measured K_d (median [16–84 %])\n",
          ("Stations with a_CDOM measured (the model's inputs all in situ) and all stations "
          "(a_CDOM set to 0 where it was not measured):\n"),
          "| stations | band (nm) | n | model K_d | paper's beam c | Morel 1988 |",
          "|---|---|---|---|---|---|"]
    for g in ("ag443 measured", "all"):
        for b in REPORT_BANDS:
            cells = []
            n = 0
            for m in ("kd_model", "beam", "morel1988"):
                v = table.get((g, m, b))
                if v:
                    n = v[0]
                    cells.append(f"{_fmt(v[1])} [{_fmt(v[2])}–{_fmt(v[3])}]")
                else:
                    cells.append("–")
            md.append(f"| {g} | {b} | {n} | " + " | ".join(cells) + " |")
    md += ["", (f"**Why the red bands look worse.** The stations with a 670 nm K_d are not the "
                f"others: among those with ag443, median C {_fmt(red['chl_with'])} mg m⁻³ with a "
                f"670 nm band against {_fmt(red['chl_without'])} without; at 443 nm the model "
                f"K_d / measured is {_fmt(red['ratio443_with'])} at the former and "
                f"{_fmt(red['ratio443_without'])} at the latter. The low red ratio is a high-C "
                "(coastal) subset, not a failure specific to the red.\n"),
           ("**The paper's c against K_d.** With eq 12 a backscattering (below), the paper's "
            "c = a + b_w + b_bp is a + b_b + b_w/2 ≈ μ̄_d × the model's K_d: c / K_d(model) lies "
            f"between {_fmt(red['c_over_kd_min'], 3)} and {_fmt(red['c_over_kd_max'], 3)} over "
            "all stations and bands. So c / K_d(measured) ≈ 0.75 × K_d(model) / K_d(measured).\n")]
    md += ["", ("Model K_d by water type (chlorophyll classes over all stations, CDOM set to 0 "
           "where not measured; Case-1-like / CDOM-rich: a_CDOM(443) below / above the model's "
           "particle absorption a_φ + a_NAP at 443 nm):\n"),
           *_group_table(table, groups, "kd_model", with_n=True)]
    md += ["", "Morel 1988 by water type, for comparison:\n",
           *_group_table(table, groups, "morel1988", with_n=False)]
    md += ["", "### Inverse: C and a_CDOM fitted to each K_d spectrum\n",
           ("`sca.spectral.fit_spectrum` (the one core: `forward.WaterTerms.path_coefficient` with "
           "`DIFFUSE_TERMS`, `sca.lm` Levenberg–Marquardt, `sca.intervals` 95 % profile "
           f"likelihood). Error model fixed beforehand: per band {100 * KD_SIGMA_REL:.0f} % "
           f"(radiometric K_d) ⊕ {100 * KD_MODEL_ERROR:.0f} % (the K_d approximation's own "
           "error), priors cdom_slope ± 0.0025 nm⁻¹, nap_slope ± 0.0025 nm⁻¹ (the budget's), "
           "μ̄_d 0.75 ± 0.075 (the defaults) or as the real-water choice learns it (next "
           "subsection). Reliable: χ² p ≥ 0.01, converged, C interval closed. Scored by the "
           f"rule of every table: an estimate of 0 counted as {CHL_FLOOR:g} mg m⁻³ (a_CDOM: "
           f"{CDOM_FLOOR:g} m⁻¹); training / test: the cruise-blocked split; [a–b]: "
           "cruise-clustered bootstrap 95 % interval.\n"),
           ("| fit | quantity | n | estimates of 0 | bias (median factor) | median factor error | "
            "r² (ln) | coverage of 95 % interval | reliable | coverage (reliable) |"),
           "|---|---|---|---|---|---|---|---|---|---|",
           *_inverse_rows(stats)]
    d = stats["package"]
    md.append(f"\nDefaults: fitted μ̄_d (nuisance, prior 0.75 ± 0.075), median over "
              f"reliable stations: {_fmt(d['mu_d_median'])} [16–84 %: "
              f"{_fmt(d['mu_d_p16'])}–{_fmt(d['mu_d_p84'])}]; misfits (χ² p < 0.01): "
              f"{_fmt(100 * d['misfit_fraction'], 0)} % of stations.")
    md += ["", ("**The intervals on the model's own worlds** (a check of the machinery, not of "
           f"the water): {synth['n']} K_d spectra made by the model at the ag443 stations' "
           "in-situ C and a_CDOM, their own bands, nuisances drawn from the priors, per-band "
           f"noise of the error model: coverage C {_fmt(100 * synth['coverage_chl'], 0)} %, "
           f"a_CDOM {_fmt(100 * synth['coverage_cdom'], 0)} % (nominal 95 %), reliable "
           f"{_fmt(100 * synth['reliable_fraction'], 0)} %.\n"),
           ("**The chlorophyll-specific optical properties, measured.** NOMAD also has a_φ(443) "
           "(= ap443 − ad443), a_NAP(443) (= ad443) and total b_b(555) at some of these stations. "
           "Measured / model at the in-situ C (median; scatter = half the 16–84 % range of "
           "ln ratio):\n"), "| quantity | n | measured / model | scatter of ln ratio |",
           "|---|---|---|---|"]
    for k, label in (("aph443", "a_φ(443) (eq 10)"), ("ad443", "a_NAP(443) (eq 8)"),
                     ("bb555", "b_b(555) = 0.5 b_w + eq 12 as b_bp")):
        v = checks[k]
        md.append(f"| {label} | {v['n']} | {_fmt(v['median_ratio'])} | {_fmt(v['log_sd'])} |")
    md += ["", "b_b(555) measured / model ≈ " + _fmt(checks["bb555"]["median_ratio"]) +
           ": eq 12 with Table 1 is the particle **back**scattering (were it b_p, b_bp would be "
           "1–2 % of it and the ratio ≈ 0.01–0.02), so `particle_backscatter_fraction` = 1 is "
           "right for b_b, and the paper's c = a + b_w + eq 12 lacks almost all particle "
           "scattering: it is a + b_b + b_w/2, i.e. ≈ μ̄_d K_d, not a beam attenuation.\n",
           ("**The budget's real-water term.** The scatter of a_φ(443) and a_NAP(443) per unit "
            "C, measured on the EVEN stations only (ln sd "
            f"{_fmt(checks['aph443']['log_sd_even'])} and {_fmt(checks['ad443']['log_sd_even'])}"
            "), as priors on `phyto_scale` and `nap_scale` (relative sds, centred on the "
            "paper's values: `sca.budget.REAL_WATER_UNCERTAIN`). The even rows share cruises with "
            "both halves of the cruise-blocked split below, so this term is not compared there "
            "(every estimator there learns on the training cruises only).")]
    md += empirical_md
    md += ["", "Files: " + ", ".join(f"`{p.name}`" for p in figs if p.suffix == ".png")
           + ", `nomad_forward_ratio.csv`, `nomad_inverse.csv` (one row per station) in "
           f"`{_shown(outdir)}`.\n", "Command: `make real-data`.\n"]
    return "\n".join(md), numbers
