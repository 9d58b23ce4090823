"""REALWATER.md's held-out stations held out (issue 50, item 2): the cruise-blocked split, the
cruise-clustered bootstrap, the one scoring rule (C = 0 counted), Morel given the same training
and the Case-1 relations passed as a user's own (experiments/realwater/split.py, empirical.py,
estimators.py; sca.biooptical)."""

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import forward
from sca.auxiliary import auxiliary_observations
from sca.biooptical import Relation, read_case1

REALDATA = Path(__file__).resolve().parents[1].parent / "shared" / "realdata"
needs_data = pytest.mark.skipif(not (REALDATA / "nomad").is_dir(),
                                reason=f"real data absent ({REALDATA}): the NOMAD split needs it")
BANDS = np.array([411.0, 443.0, 489.0, 510.0, 555.0, 670.0])


def test_cruise_split_keeps_each_cruise_on_one_side_and_is_fixed():
    from experiments.realwater.split import cruise_split

    cruise = np.repeat([f"c{k:02d}" for k in range(11)], [3, 1, 4, 2, 5, 1, 1, 2, 6, 3, 2])
    train = cruise_split(cruise)
    for name in np.unique(cruise):
        assert len(set(train[cruise == name])) == 1  # a cruise is wholly train or wholly test
    assert len(np.unique(cruise[train])) == 5  # floor(11 / 2) cruises train
    np.testing.assert_array_equal(cruise_split(cruise), train)  # the fixed seed
    assert not np.array_equal(cruise_split(cruise, seed=1), train)
    with pytest.raises(ValueError, match="cruise"):
        cruise_split(["only"] * 4)


def test_bootstrap_resamples_whole_cruises():
    """Every resample takes a cruise with all its stations (each member the same number of
    times), and with stations alike within a cruise the interval is wider than a station
    bootstrap's."""
    from experiments.realwater.split import cluster_bootstrap

    cruise = np.repeat(np.arange(8).astype(str), 10)
    seen = []

    def stat(idx):
        seen.append(idx)
        return float(np.mean(values[idx]))
    values = np.repeat(np.arange(8.0), 10)  # a cruise's stations share their value
    lo, hi = cluster_bootstrap(stat, cruise, n_resamples=200)
    for idx in seen:
        counts = np.bincount(idx, minlength=80).reshape(8, 10)
        assert np.all(counts == counts[:, :1])
    station = cluster_bootstrap(lambda i: float(np.mean(values[i])), np.arange(80),
                                n_resamples=200)
    assert hi - lo > 2 * (station[1] - station[0])


def test_the_one_scoring_rule_counts_c_zero_in_the_inverse_table():
    """nomad.inverse_stats scores an estimate of 0 as CHL_FLOOR and counts it (the table that
    dropped the stations fitted at C = 0 now counts them)."""
    from experiments.realwater.estimators import CHL_FLOOR
    from experiments.realwater.nomad import inverse_stats

    n = 6
    chl_true = np.full(n, 1.0)
    est = np.array([1.0, 1.1, 0.0, 0.0, 0.0, 0.9])
    fit = SimpleNamespace(chl=est, chl_ci=np.c_[est * 0.5, est * 2 + 0.1], cdom=np.full(n, 0.1),
                          cdom_ci=np.c_[np.full(n, 0.05), np.full(n, 0.2)],
                          reliable=np.ones(n, bool), nuisance={}, p_value=np.ones(n))
    st = SimpleNamespace(chl=chl_true, ag443=np.full(n, np.nan), cruise=np.array(list("aabbcc")))
    stats = inverse_stats(st, fit, np.array([1, 1, 1, 0, 0, 0], bool))
    s = stats["chl"]
    assert s["n"] == n and s["n_zero"] == 3
    assert s["factor_error"] == pytest.approx(np.exp(np.median(np.abs(np.log(
        np.maximum(est, CHL_FLOOR))))))
    assert s["factor_error"] > 10  # half the stations at C = 0: scored, not dropped
    lo, hi = s["factor_error_ci"]
    assert lo <= s["factor_error"] <= hi


def test_morel_given_the_training_recovers_a_law():
    from experiments.realwater.estimators import fit_morel, morel_coefficients, train_morel

    kw, chi, e = morel_coefficients(BANDS)
    chl = np.geomspace(0.03, 20, 30)
    kd = kw + 2.0 * chi * chl[:, None] ** (0.8 * e)  # another water than Table 2's
    k2, chi2, e2 = train_morel(kd, BANDS, chl)
    np.testing.assert_allclose(k2, kw)
    np.testing.assert_allclose(chi2, 2.0 * chi, rtol=1e-8)
    np.testing.assert_allclose(e2, 0.8 * e, rtol=1e-8)
    fit = fit_morel(kd[::7], BANDS, coefficients=(k2, chi2, e2))
    np.testing.assert_allclose(fit.chl, chl[::7], rtol=1e-4)


def test_case1_takes_ones_own_relations():
    w = forward.resolve_water(None)
    own = {"cdom": Relation("cdom", 0.1, 0.5, 0.3, 1e-4, 1e-3, 10)}
    obs = auxiliary_observations({"case1": own}, w)
    assert [o.name for o in obs] == ["case1_cdom"] and obs[0].sd == 0.3
    params = {"chl": np.array([1.0]), "cdom": np.array([0.1])}
    assert obs[0].function(params, ())[0][0] == pytest.approx(np.log(0.1 + 1e-4) - np.log(0.1)
                                                       - 0.5 * np.log(1.001))
    table = auxiliary_observations({"case1": ["cdom"]}, w)[0]
    assert table.sd == read_case1()["cdom"].sd != obs[0].sd
    with pytest.raises(ValueError, match="case1"):
        auxiliary_observations({"case1": {"cdom": 0.1}}, w)


@needs_data
def test_no_test_cruise_is_among_the_training_stations():
    from experiments.realwater.nomad_data import load_nomad
    from experiments.realwater.split import cruise_split

    st = load_nomad()
    train = cruise_split(st.cruise)
    assert not set(st.cruise[train]) & set(st.cruise[~train])
    assert 0.25 < train.mean() < 0.75 and len(np.unique(st.cruise)) == 320


@needs_data
def test_comparison_learns_on_the_training_cruises_only(tmp_path):
    """The constant, the relations and the real-water choice's mu_d come from the training
    cruises: scrambling the test cruises' measurements leaves them unchanged; the section
    names the split and writes the CSV with it."""
    from experiments.realwater import empirical, nomad

    st = nomad.load_nomad().subset(np.arange(60))
    res = empirical.compare(st)
    train = res["train"]
    assert not set(st.cruise[train]) & set(st.cruise[~train])
    assert res["median_train"] == pytest.approx(np.median(st.chl[train]))
    scrambled = st.subset(np.arange(len(st)))
    scrambled.ag443[~train] = 5.0
    scrambled.chl[~train] = 50.0
    tr = scrambled.subset(np.flatnonzero(train))
    kwargs, learned = empirical.real_water_choice(tr)
    assert learned["common_factor"] == res["learned"]["common_factor"]
    assert learned["relations"] == res["relations"]
    for half in ("train", "test"):
        assert set(res["halves"][half]) == set(empirical.ESTIMATORS)
    md, numbers = empirical.section(st, tmp_path, res=res)
    assert numbers["cruises_shared"] == 0 and "The criterion" in "\n".join(md)
    lines = (tmp_path / "nomad_empirical.csv").read_text().splitlines()
    assert lines[[i for i, x in enumerate(lines) if not x.startswith("#")][0]].startswith(
        "split,station,cruise")
    assert "On the held-out cruises" in empirical.headline(numbers)


def test_headline_says_where_the_package_loses_to_a_constant():
    """REALWATER.md's first paragraph names every package estimator whose factor error on the
    test cruises exceeds the constant's, and the criterion's verdict with what failed."""
    from experiments.realwater.empirical import criterion, headline

    def s(fe, cov=np.nan, closed=np.nan, **kw):
        return {"factor_error": fe, "factor_error_ci": (fe - 0.1, fe + 0.1), "coverage": cov,
                "closed": closed, "measured": 0.0, "width_factor": 20.0, **kw}
    test = {"median": s(4.0), "morel": s(2.2, 0.3, 0.9), "morel_trained": s(1.6, 0.3, 0.9),
            "package": s(5.4, 0.7, 0.2), "case1": s(2.7, 0.7, 0.9),
            "real_water": s(2.5, 0.8, 0.9, coverage_reliable=0.8)}
    numbers = {"scores": {"test": test}, "n_test": 10, "cruises_test": 3,
               "criterion": criterion(test)}
    text = headline(numbers)
    assert "**the package's defaults lose to a constant**: 5.40 [5.30–5.50]" in text
    assert "Case-1 prior lose" not in text and "**not met** (factor error, coverage failed)" in text
    test["package"] = s(3.0, 0.7, 0.2)
    assert "no package estimator loses to a constant" in headline(numbers)
