"""The spectral K_d model (sca.spectral) and the real-water experiments (NOMAD, casts)."""

import csv
from pathlib import Path

import numpy as np
import pytest

from forward import Water
from forward.spectra import read_spectral_table
from sca.spectral import KD_PARAMS, KdModel, fit_spectrum

REALDATA = Path(__file__).resolve().parents[1].parent / "shared" / "realdata"
needs_data = pytest.mark.skipif(not (REALDATA / "nomad").is_dir(),
                                reason=f"real data absent ({REALDATA}): make real-data needs it")

BANDS = np.array([411.0, 443.0, 489.0, 510.0, 555.0, 670.0])


# ------------------------------------------------------------------ the data table
@pytest.mark.parametrize("wl,kw,chi,e", [(400, 0.0209, 0.1100, 0.668), (440, 0.0168, 0.1041, 0.707),
                                         (490, 0.0217, 0.0690, 0.702), (700, 0.6500, 0.0300, 0.600)])
def test_morel_1988_table_published_values(wl, kw, chi, e):
    grid, vals = read_spectral_table("diffuse_attenuation_morel_1988.csv")
    assert grid.size == 61 and grid[0] == 400 and grid[-1] == 700
    np.testing.assert_allclose(vals[grid == wl][0], [kw, chi, e], rtol=1e-12)


def test_morel_1988_table_header_and_readme():
    from forward import spectra

    text = (spectra._data_dir() / "diffuse_attenuation_morel_1988.csv").read_text()
    header = "\n".join(l for l in text.splitlines() if l.startswith("#"))
    for word in ("Source:", "Units:", "Grid:"):
        assert word in header
    assert "diffuse_attenuation_morel_1988.csv" in (spectra._data_dir() / "README.md").read_text()


# ------------------------------------------------------------------ the model
def test_kd_is_split_down_leg():
    """K_d is the 'split' path model's depth coefficient: tau(depth=1, distance=0)."""
    w = Water(path_model="split")
    m = KdModel(BANDS, water=w)
    kd, _ = m.kd({"chl": 0.7, "cdom": 0.05})
    tau, _ = w.on_grid(BANDS).optical_depth(0.7, 0.05, 1.0, 0.0)
    np.testing.assert_allclose(kd, tau, rtol=1e-12)
    # mu_d halves -> K_d doubles
    kd2, _ = m.kd({"chl": 0.7, "cdom": 0.05, "downwelling_cosine": 0.375})
    np.testing.assert_allclose(kd2, 2 * kd, rtol=1e-12)


@pytest.mark.parametrize("name", KD_PARAMS)
def test_kd_jacobian_matches_finite_differences(name):
    m = KdModel(BANDS)
    base = {"chl": 0.8, "cdom": 0.04, "downwelling_cosine": 0.8, name: None}
    base[name] = 0.8 if name == "chl" else 0.04 if name == "cdom" else \
        0.8 if name == "downwelling_cosine" else float(getattr(m.water, name))
    _, d = m.kd(base, (name,))
    h = 1e-6 * max(abs(base[name]), 1e-3)
    up, dn = dict(base), dict(base)
    up[name] += h
    dn[name] -= h
    fd = (m.kd(up)[0] - m.kd(dn)[0]) / (2 * h)
    np.testing.assert_allclose(d[name], fd, rtol=1e-5, atol=1e-9 * np.abs(fd).max() + 1e-14)
    assert np.any(np.abs(d[name]) > 0), f"K_d does not depend on {name}"


def test_kd_rejects_unknown_names():
    with pytest.raises(ValueError, match="params"):
        KdModel(BANDS).kd({"chl": 1.0, "depth": 2.0})
    with pytest.raises(ValueError, match="kd"):
        fit_spectrum(np.array([0.1, -0.2, 0.1, 0.1, 0.1, 0.5]), BANDS)
    with pytest.raises(ValueError, match="uncertain"):
        fit_spectrum(np.ones(6) * 0.1, BANDS, uncertain={"depth": 0.2})


def test_round_trip_recovers_chl_and_cdom_within_intervals():
    rng = np.random.default_rng(3)
    chl = np.array([0.05, 0.3, 1.0, 3.0, 10.0])
    cdom = np.array([0.005, 0.02, 0.05, 0.2, 0.5])
    m = KdModel(BANDS)
    kd = m.kd({"chl": chl, "cdom": cdom})[0]
    exact = fit_spectrum(kd, BANDS)
    np.testing.assert_allclose(exact.chl, chl, rtol=1e-4)
    np.testing.assert_allclose(exact.cdom, cdom, rtol=1e-3, atol=1e-5)
    noisy = fit_spectrum(kd * np.exp(0.05 * rng.standard_normal(kd.shape)), BANDS)
    assert np.all((noisy.chl_ci[:, 0] <= chl) & (chl <= noisy.chl_ci[:, 1]))
    assert np.all((noisy.cdom_ci[:, 0] <= cdom) & (cdom <= noisy.cdom_ci[:, 1]))
    assert np.all(noisy.reliable)


def test_missing_bands_are_weight_zero():
    m = KdModel(BANDS)
    kd = m.kd({"chl": np.array([0.5, 0.5]), "cdom": np.array([0.03, 0.03])})[0]
    kd[1, 2] = np.nan
    fit = fit_spectrum(kd, BANDS, intervals=False)
    assert list(fit.dof) == [4, 3]
    np.testing.assert_allclose(fit.chl, 0.5, rtol=1e-4)


def test_misfit_is_not_reliable():
    m = KdModel(BANDS)
    kd = m.kd({"chl": 1.0, "cdom": 0.05})[0]
    kd = kd * np.array([1.0, 3.0, 0.3, 3.0, 0.3, 1.0])  # no water looks like this
    fit = fit_spectrum(kd, BANDS)
    assert fit.p_value[0] < 0.01 and not fit.reliable[0]


# ------------------------------------------------------------------ real data
@needs_data
def test_nomad_counts_match_readme():
    from experiments.realwater import nomad

    st = nomad.load_nomad()
    assert len(st) == 2027
    assert int(np.sum(~np.isnan(st.ag443))) == 601
    assert np.all(np.sum(~np.isnan(st.kd), axis=1) >= 5)
    assert 0.011 < st.chl.min() and st.chl.max() < 70


@needs_data
def test_nomad_twenty_stations_inverse_csv(tmp_path):
    from experiments.realwater import nomad

    st = nomad.load_nomad().subset(np.arange(20))
    fit = nomad.fit_stations(st)
    train = np.arange(20) < 12
    path = nomad.write_inverse_csv(tmp_path / "nomad_inverse.csv", st, fit, train)
    with open(path, newline="") as f:
        rows = list(csv.DictReader(l for l in f if not l.startswith("#")))
    assert len(rows) == 20
    for col in ("station", "cruise", "split", "chl_insitu", "chl", "chl_lo", "chl_hi",
                "reliable", "cdom_insitu", "cdom", "cdom_lo", "cdom_hi"):
        assert col in rows[0]
    assert [r["split"] for r in rows] == ["train"] * 12 + ["test"] * 8
    assert [r["cruise"] for r in rows] == list(st.cruise)
    for r in rows:
        assert float(r["chl"]) >= 0 and float(r["chl_lo"]) <= float(r["chl"]) <= float(r["chl_hi"])
        assert r["reliable"] in ("0", "1")
    stats = nomad.inverse_stats(st, fit, train)
    assert 0.0 <= stats["chl"]["coverage"] <= 1.0
    assert stats["chl"]["n_reliable"] == int(np.sum(fit.reliable))
    assert stats["chl_train"]["n"] == 12 and stats["chl_test"]["n"] == 8
    assert np.isfinite(stats["chl"]["factor_error"])


@needs_data
def test_nomad_forward_ratio_table():
    from experiments.realwater import nomad

    st = nomad.load_nomad().subset(np.arange(200))
    pred = nomad.forward_predictions(st)
    rows = nomad.ratio_table(st, pred, nomad.water_groups(st))
    assert {r[1] for r in rows} == {"kd_model", "beam", "morel1988"}
    assert all(r[5] <= r[4] <= r[6] and r[3] > 0 for r in rows)
    # the paper's c = a + b_w + b_p with eq 12 (really b_bp, small) is mu_d (a + b_b) / mu_d
    # plus half of b_w: c / K_d lies between mu_d = 0.75 and, where b_w matters, a little above
    ratio = pred["beam"] / pred["kd_model"]
    assert np.all(ratio >= 0.75 * (1 - 1e-12)) and np.all(ratio < 0.9)


@needs_data
def test_casts_load():
    from experiments.realwater import casts

    names, wl, kd = casts.load_casts()
    assert len(names) == 6 and wl.min() >= 400 and wl.max() <= 700
    assert np.nanmax(kd) < 5 and np.nanmin(kd) > 0


@needs_data
def test_nomad_iop_checks_and_held_out_priors():
    from experiments.realwater import nomad

    st = nomad.load_nomad()
    checks = nomad.iop_checks(st)
    for name in ("aph443", "ad443", "bb555"):
        v = checks[name]
        assert v["n"] > 100 and v["median_ratio"] > 0 and v["log_sd_even"] > 0
    # eq 12 is a backscattering: measured b_b(555) is of its size, not ~100x smaller
    assert 0.3 < checks["bb555"]["median_ratio"] < 3
    pri = nomad.bio_optical_uncertain(checks)
    assert pri["phyto_scale"] == pytest.approx(checks["aph443"]["log_sd_even"] * 0.0378)
    assert set(pri) >= {"cdom_slope", "nap_slope", "downwelling_cosine", "nap_scale"}


@needs_data
def test_synthetic_worlds_cover_at_about_the_nominal_rate():
    """On spectra the model made (with the fit's own error model) the intervals are honest."""
    from experiments.realwater import nomad

    st = nomad.load_nomad()
    sub = st.subset(np.flatnonzero(np.isfinite(st.ag443))[:120])
    cov = nomad.synthetic_coverage(sub, seed=1)
    assert cov["n"] == 120
    # binomial(120, 0.95): P(coverage < 0.85) ~ 1e-4
    assert cov["coverage_chl"] >= 0.85 and cov["coverage_cdom"] >= 0.85


def test_real_data_command_exits_2_without_data(monkeypatch, tmp_path):
    import experiments.realwater.__main__ as main

    monkeypatch.setattr(main, "realdata_dir", lambda: tmp_path / "absent")
    report = tmp_path / "REALWATER.md"
    assert main.main(["--out", str(tmp_path / "out"), "--report", str(report)]) == 2
    assert not report.exists()


@needs_data
def test_real_water_budget_terms_are_the_even_stations_scatter():
    """REAL_WATER_UNCERTAIN's phyto_scale and nap_scale are the scatter of real water's
    chlorophyll-specific absorption about eqs 10 and 8, measured on the even NOMAD stations
    (REALWATER.md): the constants follow the data they cite."""
    import forward
    from experiments.realwater import nomad
    from sca.budget import REAL_WATER_UNCERTAIN as DEFAULT_UNCERTAIN

    checks = nomad.iop_checks(nomad.load_nomad())
    water = forward.resolve_water(None)
    assert DEFAULT_UNCERTAIN["phyto_scale"] == pytest.approx(
        checks["aph443"]["log_sd_even"] * water.phyto_scale, rel=0.02)
    assert DEFAULT_UNCERTAIN["nap_scale"] == pytest.approx(
        checks["ad443"]["log_sd_even"] * water.nap_scale, rel=0.02)
