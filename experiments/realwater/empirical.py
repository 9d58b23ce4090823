"""Real water against the empirical law (issue 37 item 6, issue 50 item 2): C from NOMAD's K_d
spectra by the package, by Morel's (1988) law and by a constant, on training and on held-out
cruises.

**The split is by cruise** (:func:`experiments.realwater.split.cruise_split`: random halves of
the cruises, fixed seed; decision 0081-cruise-blocked-realwater): no test station's cruise has
a training station. Everything an estimator learns from NOMAD (the constant's median, the
Case-1 relations, the mean cosine, Morel's trained coefficients) is learned on the training
cruises only; every score carries a cruise-clustered bootstrap 95 % interval. The estimators
(:data:`ESTIMATORS`):

* 'median': the training cruises' median C, predicted everywhere;
* 'morel': C alone fitted to the bands by Morel's K_w + chi C^e as published
  (:func:`experiments.realwater.estimators.fit_morel`);
* 'morel_trained': the same law given the same training: chi and e of each band refitted on the
  training cruises (:func:`experiments.realwater.estimators.train_morel`);
* 'package': :func:`sca.spectral.fit_spectrum` as it is (its defaults);
* 'case1': the package with the Case-1 relation prior (``auxiliary={'case1': relations}``,
  ``CASE1_UNCERTAIN``), the relations relearned on the training cruises;
* 'real_water': **the documented real-water choice** (:func:`real_water_choice`, an explicit
  option, never a default): Pope & Fry's (1997) pure water (:func:`pope_fry_water`), the mean
  cosine mu_d learned on the training cruises (:func:`kd_common_factor`) and the Case-1
  relations learned there.

Scores: :func:`experiments.realwater.estimators.score`, the one rule of every table (an estimate
of 0 scored as :data:`experiments.realwater.estimators.CHL_FLOOR` and counted).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

import forward
from sca.biooptical import CASE1_UNCERTAIN, read_case1
from sca.spectral import KD_UNCERTAIN, KdModel, fit_spectrum

from ..common import save_figure, style, write_csv
from .biooptical import COMMAND, agrees, fit_relations, learn_relations, measured_440, tested_on
from .estimators import CHL_FLOOR, fit_morel, score, train_morel
from .nomad_data import CHL_CLASSES, REALDATA, NomadStations
from .split import BOOTSTRAP_RESAMPLES, SPLIT_SEED, cruise_split

__all__ = ["CHOICE", "CRITERION", "ESTIMATORS", "OBPG_FILE", "by_class", "compare", "criterion",
           "headline", "kd_common_factor", "pope_fry_water", "real_water_choice", "section"]

#: The estimators, in the report's order: key -> label.
ESTIMATORS = {
    "median": "constant: the training cruises' median C",
    "morel": "Morel (1988) K_w + χ C^e as published, C alone",
    "morel_trained": "Morel's law given the same training (χ, e per band refitted)",
    "package": "package: `fit_spectrum` defaults",
    "case1": "package + Case-1 relation prior (relearned on the training cruises)",
    "real_water": "**the real-water choice**: Pope & Fry water + trained μ̄_d + Case-1 relations",
}
#: The package's estimators as the headline names them.
SHORT = {"package": "the package's defaults", "case1": "the package with the Case-1 prior",
         "real_water": "the real-water choice"}
#: The documented real-water choice's key (the criterion's and ``nomad_inverse.csv``'s).
CHOICE = "real_water"
#: The issue's criterion on the test cruises: the choice's median factor error below Morel's
#: (as published), coverage among reliable stations within 0.92-0.98 and at least half of the
#: intervals closed.
CRITERION = {"coverage": (0.92, 0.98), "closed": 0.5}
#: NASA OBPG's pure-water table inside ``../shared/realdata`` (column 2: absorption, m^-1,
#: equal to Pope & Fry 1997 at 440, 500, 560 and 680 nm; README there).
OBPG_FILE = Path("ocean_optics_tables") / "nasa_obpg_optics_coef.txt"


def pope_fry_water(water=None):
    """``water`` with Pope & Fry's (1997) pure-water absorption (NASA OBPG's table, 380-720 nm,
    read from ``../shared/realdata``; never copied into the project).

    Returns
    -------
    forward.Water

    Raises
    ------
    FileNotFoundError
        Without the real-data folder.
    """
    path = REALDATA / OBPG_FILE
    if not path.is_file():
        raise FileNotFoundError(f"path: {path} not found")
    t = np.loadtxt(path)
    keep = (t[:, 0] >= 380.0) & (t[:, 0] <= 720.0)
    return dataclasses.replace(forward.resolve_water(water),
                               pure_water_absorption_table=(t[keep, 0], t[keep, 1]))


def kd_common_factor(train: NomadStations, water=None) -> dict:
    """The model's K_d against the measured one where every input was measured, on ``train``.

    At the training stations with ag443, ad443 and ap443 measured, the model's K_d
    (:class:`sca.spectral.KdModel`) at the in-situ C and a_CDOM(440), with eq 8's and eq 10's
    scales set to give the measured a_NAP(440) and a_phi(440); the common factor of a station
    is the mean over its bands of ln(model / measured).

    Returns
    -------
    dict
        'n'; 'median' and 'scatter' (half the 16-84 % range) of the common factor;
        'band_sd' (sd of the per-band residual about it); 'mu_d' (the water's mu_d times
        exp(median): the mu_d that would centre it) and 'mu_d_sd' (scatter x mu_d).
    """
    water = forward.resolve_water(water)
    meas = measured_440(train, water)
    ok = np.isfinite(meas["cdom"]) & np.isfinite(meas["nap"]) & np.isfinite(meas["phyto"])
    s = train.subset(np.flatnonzero(ok))
    vals = {q: v[ok] for q, v in meas.items()}
    kd = KdModel(s.wavelengths, water=water).kd({
        "chl": s.chl, "cdom": vals["cdom"],
        "nap_scale": vals["nap"] / s.chl ** water.nap_exponent,
        "phyto_scale": vals["phyto"] / s.chl ** water.phyto_exponent})[0]
    lr = np.log(kd / s.kd)
    common = np.nanmean(lr, axis=1)
    lo, med, hi = np.percentile(common, [16, 50, 84])
    scatter = float((hi - lo) / 2)
    mu = float(water.downwelling_cosine * np.exp(med))
    return {"n": int(ok.sum()), "median": float(med), "scatter": scatter,
            "band_sd": float(np.nanstd(lr - common[:, None])), "mu_d": mu,
            "mu_d_sd": scatter * mu}


def real_water_choice(train: NomadStations, water=None) -> tuple[dict, dict]:
    """The documented real-water choice (decision 0081-cruise-blocked-realwater), learned on the
    stations ``train`` only: an explicit option of the K_d fit, never a default.

    * pure water: Pope & Fry (1997) (:func:`pope_fry_water`, in place of Smith & Baker 1981);
    * mu_d: centred where ``train``'s K_d at in-situ inputs put it with that water
      (:func:`kd_common_factor`), its prior sd the stations' scatter;
    * the Case-1 relations (:func:`experiments.realwater.biooptical.fit_relations` on
      ``train``) as priors, with eq 8's and eq 10's scales freed (``CASE1_UNCERTAIN``).

    Returns
    -------
    kwargs : dict
        For :func:`sca.spectral.fit_spectrum` ('water', 'uncertain', 'auxiliary').
    learned : dict
        'common_factor' (:func:`kd_common_factor` with Pope & Fry water) and 'relations'.
    """
    pure = pope_fry_water(water)
    cf = kd_common_factor(train, pure)
    relations = fit_relations(train, water)
    kwargs = {"water": dataclasses.replace(pure, downwelling_cosine=cf["mu_d"]),
              "uncertain": {**KD_UNCERTAIN, **CASE1_UNCERTAIN,
                            "downwelling_cosine": cf["mu_d_sd"]},
              "auxiliary": {"case1": relations}}
    return kwargs, {"common_factor": cf, "relations": relations}


def _scored(st, mask, est, fit) -> dict:
    """:func:`score` of the stations ``mask`` (cruise-clustered intervals), and for a package
    fit the coverage among its reliable stations."""
    c, lo, hi = est
    pick = (lambda a: None if a is None else a[mask])
    out = score(c[mask], st.chl[mask], pick(lo), pick(hi), clusters=st.cruise[mask])
    if fit is not None and hasattr(fit, "reliable"):
        r = mask & fit.reliable
        rel = score(c[r], st.chl[r], lo[r], hi[r], clusters=st.cruise[r]) if r.any() else {}
        out.update(n_reliable=int(r.sum()), coverage_reliable=rel.get("coverage", np.nan),
                   coverage_reliable_ci=rel.get("coverage_ci", (np.nan, np.nan)))
    return out


def compare(st: NomadStations, water=None, *, train=None) -> dict:
    """Every estimator on the training and on the test cruises.

    Parameters
    ----------
    st : NomadStations
        The stations (both halves).
    water : forward.Water, optional
        The package's water (default: the paper's).
    train : array_like of bool, (N,), optional
        The training stations (default :func:`~experiments.realwater.split.cruise_split` of
        ``st.cruise``).

    Returns
    -------
    dict
        'train' (the mask); 'halves': {'train', 'test'} -> {estimator: score}; 'estimates':
        {estimator: (C, lo, hi)} over all stations; 'fits' (the package fits and Morel's);
        'learned' (the real-water choice's, when ``../shared/realdata`` has the OBPG table);
        'median_train'; 'relations' (learned on the training cruises).
    """
    water = forward.resolve_water(water)
    train = cruise_split(st.cruise) if train is None else np.asarray(train, bool)
    tr = st.subset(np.flatnonzero(train))
    median = float(np.median(tr.chl))
    relations = fit_relations(tr, water)
    runs = {"package": {"water": water},
            "case1": {"water": water, "auxiliary": {"case1": relations},
                      "uncertain": {**KD_UNCERTAIN, **CASE1_UNCERTAIN}}}
    learned = {}
    if (REALDATA / OBPG_FILE).is_file():
        runs[CHOICE], learned = real_water_choice(tr, water)
    fits = {"morel": fit_morel(st.kd, st.wavelengths),
            "morel_trained": fit_morel(st.kd, st.wavelengths,
                                       coefficients=train_morel(tr.kd, st.wavelengths, tr.chl))}
    fits.update({k: fit_spectrum(st.kd, st.wavelengths, **kw) for k, kw in runs.items()})
    est = {"median": (np.full(len(st), median), None, None),
           **{k: (f.chl, f.chl_ci[:, 0], f.chl_ci[:, 1]) for k, f in fits.items()}}
    halves = {half: {k: _scored(st, m, e, fits.get(k)) for k, e in est.items()}
              for half, m in (("train", train), ("test", ~train))}
    return {"train": train, "halves": halves, "estimates": est, "fits": fits,
            "learned": learned, "median_train": median, "relations": relations}


def criterion(test: dict, choice: str = CHOICE) -> dict:
    """The issue's criterion on the test cruises (:data:`CRITERION`).

    Parameters
    ----------
    test : dict
        estimator -> score on the test cruises (:func:`compare`'s ``halves['test']``).
    choice : str, optional
        The documented choice's key.

    Returns
    -------
    dict
        'factor_error', 'coverage', 'closed' (each True when met), 'met' (all three) and the
        margins: 'factor_error_margin' (Morel's minus the choice's), 'coverage_margin' (how far
        outside 92-98 %; 0 inside), 'closed_margin' (share minus 0.5). The coverage is among
        the choice's reliable stations ('coverage_reliable'; 'coverage' if it has none).
    """
    c, m = test[choice], test["morel"]
    lo, hi = CRITERION["coverage"]
    cov = c.get("coverage_reliable", c["coverage"])
    out = {"factor_error": c["factor_error"] < m["factor_error"],
           "coverage": lo <= cov <= hi, "closed": c["closed"] >= CRITERION["closed"],
           "factor_error_margin": m["factor_error"] - c["factor_error"],
           "coverage_margin": float(min(cov - lo, 0.0) + max(cov - hi, 0.0)),
           "closed_margin": c["closed"] - CRITERION["closed"], "coverage_value": cov}
    out["met"] = bool(out["factor_error"] and out["coverage"] and out["closed"])
    return out


def by_class(st: NomadStations, res: dict, keys=("morel", CHOICE)) -> list:
    """Factor error and bias of ``keys`` per chlorophyll class (:data:`~experiments.realwater.
    nomad_data.CHL_CLASSES`) on each half: rows (class label, half, n, {key: score})."""
    rows = []
    keys = [k for k in keys if k in res["estimates"]]
    for lo, hi in CHL_CLASSES:
        for half, hm in (("train", res["train"]), ("test", ~res["train"])):
            m = hm & (st.chl >= lo) & (st.chl < hi)
            if m.any():
                rows.append((f"{lo:g}–{hi:g}", half, int(m.sum()),
                             {k: score(res["estimates"][k][0][m], st.chl[m],
                                       clusters=st.cruise[m]) for k in keys}))
    return rows


def _pc(x):
    return "–" if x is None or not np.isfinite(x) else f"{100 * x:.0f} %"


def _f(x, nd=2):
    return "–" if x is None or not np.isfinite(x) else f"{x:.{nd}f}"


def _ci(pair, pct=False):
    """' [lo–hi]' of a bootstrap interval ('' when it has none)."""
    if pair is None or not np.all(np.isfinite(pair)):
        return ""
    return f" [{_pc(pair[0])}–{_pc(pair[1])}]" if pct else f" [{_f(pair[0])}–{_f(pair[1])}]"


def _fe(s: dict) -> str:
    """A score's factor error with its cruise-clustered interval."""
    return f"{s['factor_error']:.2f}{_ci(s.get('factor_error_ci'))}"


def headline(numbers: dict) -> str:
    """REALWATER.md's first paragraph: where the package's estimators lose to a constant on the
    test cruises, and whether the real-water choice met the criterion (numbers of
    :func:`section`)."""
    test = numbers["scores"]["test"]
    const = _fe(test["median"])
    losers = [k for k in SHORT if k in test
              and test[k]["factor_error"] > test["median"]["factor_error"]]
    text = (f"**On the held-out cruises** (NOMAD, {numbers['n_test']} stations of "
            f"{numbers['cruises_test']} cruises none of which has a training station; median "
            "factor error of C with its cruise-clustered bootstrap 95 % interval, an estimate "
            f"of 0 scored as {CHL_FLOOR:g} mg m⁻³): ")
    text += (" and ".join(f"**{SHORT[k]} lose to a constant**: {_fe(test[k])}" for k in losers)
             + f" against the training cruises' median C's {const}. " if losers else
             f"no package estimator loses to a constant ({const}). ")
    text += (f"Morel (1988) as published: {_fe(test['morel'])}; given the same training: "
             f"{_fe(test['morel_trained'])}. ")
    crit = numbers.get("criterion")
    return text + ("" if crit is None else _choice_text(test, crit)) + "\n"


def _choice_text(test: dict, crit: dict) -> str:
    """The headline's sentences on the real-water choice and the criterion."""
    c = test[CHOICE]
    failed = [n for n, k in (("factor error", "factor_error"), ("coverage", "coverage"),
                             ("closed", "closed")) if not crit[k]]
    return (f"The real-water choice (Pope & Fry water, μ̄_d and the Case-1 relations learned on "
            f"the training cruises): factor error {_fe(c)}, coverage among reliable "
            f"{_pc(crit['coverage_value'])}{_ci(c.get('coverage_reliable_ci'), True)}, closed "
            f"{_pc(c['closed'])}: the criterion (factor error below Morel's, coverage 92–98 %, "
            f"half closed) is {'**met**' if crit['met'] else '**not met**'}"
            + (f" ({', '.join(failed)} failed)" if failed else "") + ". "
            + _versus_trained(test))


def _versus_trained(test: dict) -> str:
    """Where Morel's law given the same training stands against the real-water choice, and how
    wide the choice's intervals are (words follow the numbers)."""
    c, t = test[CHOICE], test["morel_trained"]
    better = t["factor_error"] < c["factor_error"]
    return (f"Morel's law given the same training has {'the lower' if better else 'a higher'} "
            f"factor error ({t['factor_error']:.2f} against {c['factor_error']:.2f}) with "
            f"coverage {_pc(t['coverage'])}; the choice's intervals are wide (median hi/lo "
            f"{_f(c['width_factor'], 1)}, {_pc(c['measured'])} 'measured').")


def _figure(st, res, outdir):
    import matplotlib.pyplot as plt

    style()
    test = ~res["train"]
    keys = [k for k in ("morel", CHOICE) if k in res["estimates"]]
    fig, axes = plt.subplots(1, len(keys), figsize=(7.5, 3.6), layout="constrained", sharey=True)
    for ax, key in zip(np.atleast_1d(axes), keys):
        c, lo, hi = (a[test] for a in res["estimates"][key])
        e = np.maximum(c, CHL_FLOOR)
        ax.errorbar(st.chl[test], e, yerr=[np.clip(e - np.maximum(lo, CHL_FLOOR), 0, None),
                                           np.clip(np.nan_to_num(hi, posinf=1e4) - e, 0, None)],
                    fmt="none", lw=0.3, ecolor="0.6", alpha=0.25)
        ax.plot(st.chl[test], e, "o", ms=2, alpha=0.6)
        ax.plot([1e-3, 1e2], [1e-3, 1e2], "k-", lw=0.8)
        s = res["halves"]["test"][key]
        ax.set_title(f"{'Morel 1988, C alone' if key == 'morel' else 'the real-water choice'}\n"
                     f"factor error {s['factor_error']:.2f}, coverage {100 * s['coverage']:.0f} %")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlim(5e-3, 1e2)
        ax.set_ylim(2e-3, 1e3)
        ax.set_xlabel("in-situ C (mg m$^{-3}$)")
    np.atleast_1d(axes)[0].set_ylabel(
        f"C from K_d, 95 % interval (mg m$^{{-3}}$; floored at {CHL_FLOOR:g})")
    fig.suptitle("NOMAD stations of the held-out (test) cruises")
    paths = save_figure(fig, "nomad_empirical", outdir)
    plt.close(fig)
    return paths


def _write_csv(st, res, path):
    keys = list(res["estimates"])
    rows = []
    for i in range(len(st)):
        row = ["train" if res["train"][i] else "test", int(st.station[i]), st.cruise[i],
               f"{st.chl[i]:.6g}"]
        for k in keys:
            c, lo, hi = res["estimates"][k]
            row += [f"{c[i]:.6g}", "" if lo is None else f"{lo[i]:.6g}",
                    "" if hi is None else f"{hi[i]:.6g}"]
        rows.append(row)
    header = ["split", "station", "cruise", "chl_insitu"] + [f"{k}_{x}" for k in keys
                                                            for x in ("chl", "lo", "hi")]
    return write_csv(path, header, rows,
                     "NOMAD v2: C (mg m^-3) from each station's K_d by every estimator of "
                     "REALWATER.md's 'Real water against the empirical law'\n(split: the "
                     f"cruise-blocked split, seed {SPLIT_SEED}; lo, hi: 95 % interval; empty: "
                     "none). Generated by: make real-data")


def _limits(paper: dict, learned: dict) -> str:
    """The paragraph on the K_d model's own error at in-situ inputs on the training cruises,
    with the paper's water and with the choice's (words follow the numbers)."""
    factor = float(np.exp(paper["median"]))
    text = ("**The K_d model at in-situ inputs** (the training cruises). Where every input was "
            f"measured ({paper['n']} training stations with ag443, ad443 and ap443), the model's "
            f"K_d with the paper's water (Smith & Baker, μ̄_d = 0.75) is ×{factor:.2f} the "
            f"measured one (median over stations of the mean ln ratio over a station's bands; "
            f"scatter ±{paper['scatter']:.2f} in ln between stations, {paper['band_sd']:.2f} per "
            f"band about a station's mean): it attenuates {'too much' if factor > 1 else 'too little'}; "
            "a prior on the other absorbers cannot remove that, and it weighs most in clear "
            "water, where pure water dominates K_d.")
    cf = learned.get("common_factor")
    if cf:
        text += (" With Pope & Fry's (1997) pure water (0.0064 m⁻¹ at 440 nm against Smith & "
                 "Baker's 0.0145; read at run time from the NASA OBPG table in "
                 f"`../shared/realdata`, not shipped) the factor is ×{np.exp(cf['median']):.2f} "
                 f"at μ̄_d = 0.75, so the choice centres μ̄_d at {cf['mu_d']:.2f} ± "
                 f"{cf['mu_d_sd']:.2f} (the stations' scatter as its prior sd). Both change the "
                 "paper's physics (decision 0041-nomad-kd-evidence): an explicit option of the "
                 "fit (`real_water_choice`), never the package's default.")
    return text + "\n"


def _row(label, name, s):
    rel = (f"{_pc(s['coverage_reliable'])}{_ci(s.get('coverage_reliable_ci'), True)} "
           f"({s['n_reliable']})" if "n_reliable" in s else "–")
    return (f"| {label} | {name} | {s['n']} | {s['n_zero']} | {_f(s['factor_error'])}"
            f"{_ci(s.get('factor_error_ci'))} | {s['bias_log']:+.2f} ({s['bias_factor']:.2f}) | "
            f"{_f(s['r2_log'])} | {_pc(s['coverage'])}{_ci(s.get('coverage_ci'), True)} | {rel} | "
            f"{_pc(s['closed'])} | {_pc(s['measured'])} | {_f(s['width_factor'], 1)} |")


def _relation_rows(relations, test):
    names = {"cdom": "a_CDOM(440) (`ag443` → 440 nm by eq 6)",
             "nap": "a_NAP(440) (`ad443` → 440 nm by eq 7)",
             "phyto": "a_φ(440) (`ap443 − ad443` → 440 nm by eq 9's shape)"}
    return [f"| {names[q]} | {r.n} | {r.alpha:.4g} | {r.beta:.3f} | {r.sd:.2f} | "
            f"{test[q]['n']} | {test[q]['median']:+.2f} | {test[q]['sd']:.2f} | "
            f"{_pc(test[q]['within'])} |" for q, r in relations.items()]


def section(st: NomadStations, outdir: Path, water=None, res=None) -> tuple[list, dict]:
    """The REALWATER.md subsection, its figure and CSV, and its numbers.

    Parameters
    ----------
    st : NomadStations
        The stations.
    outdir : pathlib.Path
        Where the figure and ``nomad_empirical.csv`` go.
    water : forward.Water, optional
        The package's water.
    res : dict, optional
        :func:`compare`'s result (computed here when None).

    Returns
    -------
    markdown : list of str
        Lines of the subsection.
    numbers : dict
        The scores, the relations and their held-out test, the criterion.
    """
    res = compare(st, water) if res is None else res
    train = res["train"]
    tr, te = st.subset(np.flatnonzero(train)), st.subset(np.flatnonzero(~train))
    shared = sorted(set(tr.cruise) & set(te.cruise))
    reproduced = agrees(learn_relations(st, water), read_case1())
    test_rel = tested_on(te, res["relations"], water)
    paper = kd_common_factor(tr, water)
    crit = criterion(res["halves"]["test"]) if CHOICE in res["estimates"] else None
    figs = _figure(st, res, outdir)
    _write_csv(st, res, Path(outdir) / "nomad_empirical.csv")
    classes = by_class(st, res)
    n_cr = len(np.unique(st.cruise))
    md = ["", "### Real water against the empirical law (issue 37 item 6, issue 50 item 2)\n",
          (f"**A cruise-blocked split.** The {len(st)} stations come from {n_cr} cruises; "
           "stations of one cruise share their water, so the split is by cruise: random halves "
           f"of the cruises (`experiments.realwater.split.cruise_split`, seed {SPLIT_SEED}, "
           "fixed before any result was seen; decision 0081-cruise-blocked-realwater). "
           f"**Training**: {len(tr)} stations of {len(np.unique(tr.cruise))} cruises; **test**: "
           f"{len(te)} stations of {len(np.unique(te.cruise))} cruises; cruises in both: "
           f"{len(shared)}. Everything an estimator learns from NOMAD (the constant's median, "
           "the Case-1 relations, μ̄_d, Morel's trained χ and e) is learned on the training "
           "cruises only. Every score has a **cruise-clustered bootstrap** 95 % interval "
           f"(whole cruises resampled with replacement, {BOOTSTRAP_RESAMPLES} resamples, "
           "percentile; `split.cluster_bootstrap`).\n"),
          ("**The Case-1 relations** (`sca.biooptical`): ln(a_q(440) + 10⁻⁴) = ln α + β "
           "ln(C + 10⁻³) with log-normal scatter. The package's table "
           f"`data/case1_relations_nomad_even.csv` (learned on the even rows by `{COMMAND}`) "
           f"{'is' if reproduced else '**is not**'} reproduced by this run; its even rows share "
           "cruises with the test half, so the comparison below relearns the relations on the "
           "training cruises (`auxiliary={'case1': relations}`) and tests them on the test "
           "cruises (residual of the measured value about the relation):\n"),
          ("| quantity | training stations | α (m⁻¹) | β | scatter (ln sd) | test stations | "
           "test: median residual | test: ln sd | test: within ±1.96 sd |"),
          "|---|---|---|---|---|---|---|---|---|", *_relation_rows(res["relations"], test_rel),
          "",
          ("**C from the K_d spectrum.** Error model of every fit: per band 5 % ⊕ 15 % (the "
           "same weights for Morel's law). **One scoring rule in every table** "
           "(`experiments.realwater.estimators.score`): factor error exp(median |ln(Ĉ/C)|), "
           "**an estimate of 0 scored as "
           f"{CHL_FLOOR:g} mg m⁻³** (the package's smallest start-grid C) and counted (column "
           "C = 0); bias the median ln(Ĉ/C) (×: its exp); r² of ln Ĉ against ln C; coverage of "
           "the in-situ C by the 95 % interval, over all stations and over the fit's reliable "
           "ones (χ² p ≥ 0.01, converged, C interval closed; their number in brackets); closed: "
           "both ends found, the lower above 0; measured: closed with hi/lo ≤ 3; hi/lo the "
           "median over closed intervals. [a–b]: cruise-clustered bootstrap 95 % interval.\n"),
          ("| estimator | cruises | n | C = 0 | factor error | bias ln (×) | r² (ln) | coverage | "
           "coverage (reliable) | closed | measured | hi/lo |"),
          "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for key, label in ESTIMATORS.items():
        for half, name in (("train", "training"), ("test", "**test**")):
            if key in res["halves"][half]:
                md.append(_row(label, name, res["halves"][half][key]))
    md += ["", _criterion_text(res["halves"]["test"], crit), _limits(paper, res["learned"]),
           ("By in-situ chlorophyll (mg m⁻³; factor error [cruise-clustered 95 %] and bias as a "
            "factor, of Morel's law as published and of the real-water choice):\n"),
           "| C class | cruises | n | Morel: factor error | Morel: bias × | real-water choice: "
           "factor error | real-water choice: bias × |", "|---|---|---|---|---|---|---|",
           *[_class_row(c, h, n, v) for c, h, n, v in classes], "",
           ("Files: " + ", ".join(f"`{p.name}`" for p in figs if p.suffix == ".png")
            + ", `nomad_empirical.csv` (every estimate and interval per station, its split and "
              "cruise).\n")]
    numbers = {"split_seed": SPLIT_SEED, "n_train": len(tr), "n_test": len(te),
               "cruises_train": int(len(np.unique(tr.cruise))),
               "cruises_test": int(len(np.unique(te.cruise))), "cruises_shared": len(shared),
               "relations_training": {q: dataclasses.asdict(r)
                                      for q, r in res["relations"].items()},
               "relations_reproduced": reproduced, "relations_test": test_rel,
               "scores": res["halves"], "criterion": crit, "common_factor_paper": paper,
               "learned": {"common_factor": res["learned"].get("common_factor")},
               "median_train": res["median_train"],
               "by_class": [{"class": c, "half": h, "n": n, **v} for c, h, n, v in classes]}
    return md, numbers


def _class_row(c, h, n, v):
    cells = []
    for k in ("morel", CHOICE):
        s = v.get(k)
        cells += ["–", "–"] if s is None else [
            f"{_f(s['factor_error'])}{_ci(s['factor_error_ci'])}", _f(s["bias_factor"])]
    return f"| {c} | {'training' if h == 'train' else 'test'} | {n} | " + " | ".join(cells) + " |"


def _criterion_text(test, crit) -> str:
    if crit is None:
        return ("**The criterion** could not be judged: the OBPG table of `../shared/realdata` "
                "is absent (the real-water choice needs it).\n")
    c, mo = test[CHOICE], test["morel"]
    parts = [f"median factor error {c['factor_error']:.2f}{_ci(c['factor_error_ci'])} against "
             f"Morel's {mo['factor_error']:.2f}{_ci(mo['factor_error_ci'])} "
             f"({'below' if crit['factor_error'] else 'not below'}; margin "
             f"{crit['factor_error_margin']:+.2f})",
             f"coverage among reliable {100 * crit['coverage_value']:.1f} % "
             f"({'within' if crit['coverage'] else 'outside'} 92–98 %"
             + ("" if crit["coverage"] else
                f", by {100 * abs(crit['coverage_margin']):.1f} points") + ")",
             f"closed {100 * c['closed']:.0f} % ({'at least' if crit['closed'] else 'below'} "
             "half)"]
    return ("**The criterion** (test cruises, the real-water choice against Morel (1988) as "
            f"published): {'**met**' if crit['met'] else '**not met**'}: " + "; ".join(parts)
            + ".\n")
