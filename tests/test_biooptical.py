"""The Case-1 relation prior (sca.biooptical, auxiliary={'case1': True}), the one-parameter
Morel (1988) inversion and the scores of REALWATER.md's 'Real water against the empirical law'
(experiments/realwater/estimators.py, empirical.py, biooptical.py)."""

from pathlib import Path

import numpy as np
import pytest

import forward
import sca
from sca.auxiliary import auxiliary_observations, planned
from sca.biooptical import (CASE1_QUANTITIES, CASE1_TABLE, CASE1_UNCERTAIN, Relation, binds,
                            case1_observations, fit_relation, read_case1, relation_observation)
from sca.spectral import KD_UNCERTAIN, KdModel, fit_spectrum

REALDATA = Path(__file__).resolve().parents[1].parent / "shared" / "realdata"
needs_data = pytest.mark.skipif(not (REALDATA / "nomad").is_dir(),
                                reason=f"real data absent ({REALDATA}): make real-data needs it")

BANDS = np.array([411.0, 443.0, 489.0, 510.0, 555.0, 670.0])
CASE1 = {"auxiliary": {"case1": True}, "uncertain": {**KD_UNCERTAIN, **CASE1_UNCERTAIN}}


# ------------------------------------------------------------------ the table
@pytest.mark.parametrize("q,alpha,beta,sd,n", [("cdom", 0.05847, 0.6114, 0.8703, 299),
                                               ("nap", 0.0147, 0.9712, 0.891, 321),
                                               ("phyto", 0.05166, 0.7636, 0.4389, 321)])
def test_case1_table_values(q, alpha, beta, sd, n):
    """The constants learned on NOMAD's even rows (`python -m experiments.realwater.biooptical`,
    REALWATER.md): a change of the table is a change of the prior and must show here."""
    r = read_case1()[q]
    assert (r.alpha, r.beta, r.sd, r.n) == (alpha, beta, sd, n)
    assert (r.floor, r.chl_floor) == (1e-4, 1e-3)
    assert set(read_case1()) == set(CASE1_QUANTITIES)


def test_case1_table_header_and_readme():
    from forward import spectra

    text = (spectra._data_dir() / CASE1_TABLE).read_text()
    header = "\n".join(l for l in text.splitlines() if l.startswith("#"))
    for word in ("Source:", "Units:", "Grid:", "EVEN", "python -m experiments.realwater.biooptical"):
        assert word in header
    assert CASE1_TABLE in (spectra._data_dir() / "README.md").read_text()


def test_fit_relation_recovers_a_known_law():
    rng = np.random.default_rng(0)
    chl = np.exp(rng.uniform(-4, 4, 4000))
    a = 0.05 * chl ** 0.6 * np.exp(0.5 * rng.standard_normal(chl.size))
    a[::7] = np.nan  # unpaired: left out
    r = fit_relation("cdom", chl, a, floor=1e-9, chl_floor=1e-9)
    assert r.alpha == pytest.approx(0.05, rel=0.03) and r.beta == pytest.approx(0.6, abs=0.01)
    assert r.sd == pytest.approx(0.5, rel=0.03) and r.n == int(np.isfinite(a).sum())
    with pytest.raises(ValueError, match="value"):
        fit_relation("cdom", [1.0, 2.0], [0.1, 0.2], floor=1e-4, chl_floor=1e-3)
    with pytest.raises(ValueError, match="quantity"):
        Relation("secchi", 1.0, 1.0, 1.0, 1e-4, 1e-3)
    with pytest.raises(ValueError, match="sd"):
        Relation("cdom", 1.0, 1.0, 0.0, 1e-4, 1e-3)


# ------------------------------------------------------------------ the observations
def _params(chl=0.8, cdom=0.03):
    w = forward.resolve_water(None)
    return {"chl": np.array([chl, 2 * chl]), "cdom": np.array([cdom, 3 * cdom]),
            "nap_scale": np.full(2, w.nap_scale * 1.3), "phyto_scale": np.full(2, w.phyto_scale * 0.7),
            "nap_exponent": np.full(2, w.nap_exponent), "nap_slope": np.full(2, w.nap_slope)}


@pytest.mark.parametrize("q", CASE1_QUANTITIES)
def test_relation_derivatives_match_finite_differences(q):
    obs = case1_observations(forward.resolve_water(None), (q,))[0]
    base = _params()
    names = tuple(base)
    _, d = obs.function(base, names)
    for name in names:
        h = 1e-6 * np.abs(base[name]).max()
        up, dn = dict(base), dict(base)
        up[name] = base[name] + h
        dn[name] = base[name] - h
        fd = (obs.function(up, ())[0] - obs.function(dn, ())[0]) / (2 * h)
        np.testing.assert_allclose(d.get(name, 0.0) * np.ones(2), fd, rtol=1e-5, atol=1e-9)
    assert np.all(np.abs(d["chl"]) > 0)  # every relation acts on C


@pytest.mark.parametrize("q", CASE1_QUANTITIES)
def test_relation_is_zero_on_the_law_and_measures_the_model_own_absorber(q):
    """h = 0 where the model's a_q(440) is the relation's; a_q is the model's own (eq 6, 8, 10
    via forward), not a restated formula."""
    w = forward.resolve_water(None)
    r = read_case1()[q]
    chl = np.array([0.1, 1.0, 10.0])
    target = r.predict(chl)
    p = {"chl": chl, "cdom": np.full(3, 0.02), "nap_scale": np.full(3, w.nap_scale),
         "phyto_scale": np.full(3, w.phyto_scale)}
    if q == "cdom":
        p["cdom"] = target
    elif q == "nap":
        p["nap_scale"] = target / forward.nap_absorption_440(chl)[...] * w.nap_scale
    else:
        p["phyto_scale"] = target / forward.phytoplankton_absorption_440(chl) * w.phyto_scale
    h, _ = relation_observation(r, w).function(p, ())
    np.testing.assert_allclose(h, 0.0, atol=1e-10)
    # one sd of scatter away: h = sd
    p2 = dict(p)
    key = {"cdom": "cdom", "nap": "nap_scale", "phyto": "phyto_scale"}[q]
    p2[key] = (target + r.floor) * np.exp(r.sd) - r.floor if q == "cdom" else p[key] * np.exp(r.sd)
    h2, _ = relation_observation(r, w).function(p2, ())
    expected = r.sd if q == "cdom" else np.log((target * np.exp(r.sd) + r.floor)
                                                 / (target + r.floor))
    np.testing.assert_allclose(h2, expected, rtol=1e-9)


@pytest.mark.parametrize("q", ["nap", "phyto"])
def test_particle_relation_is_inert_where_its_scale_is_held(q):
    """With eq 8's / eq 10's scale fixed the relation would act on C alone: it is inert."""
    w = forward.resolve_water(None)
    obs = case1_observations(w, (q,))[0]
    h, d = obs.function({"chl": np.array([0.5]), "cdom": np.array([0.01])}, ("chl", "cdom"))
    assert np.all(h == 0) and d == {}
    scale = {"nap": "nap_scale", "phyto": "phyto_scale"}[q]
    assert not binds(obs, ("chl", "cdom")) and binds(obs, ("chl", "cdom", scale))
    cdom = case1_observations(w, ("cdom",))[0]
    assert binds(cdom, ("chl", "cdom"))
    assert binds(auxiliary_observations({"cdom": (0.1, 0.02)}, w)[0], ("chl",))


def test_auxiliary_case1_choices_and_errors():
    w = forward.resolve_water(None)
    assert [o.name for o in auxiliary_observations({"case1": True}, w)] == \
        ["case1_cdom", "case1_nap", "case1_phyto"]
    assert [o.name for o in auxiliary_observations({"case1": ["cdom"]}, w)] == ["case1_cdom"]
    assert auxiliary_observations({"case1": False}, w) == []
    with pytest.raises(ValueError, match="case1"):
        auxiliary_observations({"case1": "cdom"}, w)
    with pytest.raises(ValueError, match="case1"):
        auxiliary_observations({"case1": ["secchi"]}, w)
    # a design plans the relation as it is (no value to take from the conditions)
    assert planned({"case1": True, "cdom": (0.1, 0.02)}, w,
                   {"chl": np.array([1.0]), "cdom": np.array([0.05])})["case1"] is True


# ------------------------------------------------------------------ in the K_d fit
def test_fit_spectrum_case1_adds_its_terms_and_pulls_cdom_to_the_relation():
    """A spectrum with a_CDOM 10x the relation's: the prior pulls the fit's a_CDOM toward the
    relation; each acting relation adds one degree of freedom; without its scale free a
    particle relation adds nothing."""
    m = KdModel(BANDS)
    kd = m.kd({"chl": 1.0, "cdom": 0.5})[0] * np.exp(0.05 * np.array([1, -1, 0.5, 0, -0.5, 1]))
    plain = fit_spectrum(kd, BANDS)
    cdom_only = fit_spectrum(kd, BANDS, auxiliary={"case1": True})
    full = fit_spectrum(kd, BANDS, **CASE1)
    assert cdom_only.dof[0] == plain.dof[0] + 1 and full.dof[0] == plain.dof[0] + 3
    assert abs(np.log(cdom_only.cdom[0] / 0.0585)) < abs(np.log(plain.cdom[0] / 0.0585))
    assert full.chl_ci[0, 0] > 0  # the prior closes C's interval at the bottom


def test_case1_covers_on_its_own_worlds():
    """On K_d spectra made by the model with a_CDOM, a_NAP and a_phi drawn from the relations
    (their scatter included) and the fit's per-band error, the 95 % intervals of C cover the
    truth at about the nominal rate: the prior and the machinery are consistent."""
    rng = np.random.default_rng(5)
    w = forward.resolve_water(None)
    rel = read_case1()
    n = 80
    chl = np.exp(rng.uniform(np.log(0.05), np.log(20.0), n))
    draw = {q: rel[q].predict(chl) * np.exp(rel[q].sd * rng.standard_normal(n))
            for q in CASE1_QUANTITIES}
    params = {"chl": chl, "cdom": draw["cdom"],
              "nap_scale": draw["nap"] / chl ** w.nap_exponent,
              "phyto_scale": draw["phyto"] / chl ** w.phyto_exponent}
    kd = KdModel(BANDS).kd(params)[0]
    kd = kd * np.exp(np.hypot(0.05, 0.15) * rng.standard_normal(kd.shape))
    fit = fit_spectrum(kd, BANDS, **CASE1)
    inside = (fit.chl_ci[:, 0] <= chl) & (chl <= fit.chl_ci[:, 1])
    # binomial(80, 0.95): P(< 0.85) ~ 1e-3
    assert inside.mean() >= 0.85
    assert np.mean(np.isfinite(fit.chl_ci[:, 1]) & (fit.chl_ci[:, 0] > 0)) >= 0.9


# ------------------------------------------------------------------ in the camera's estimators
def test_estimate_batch_and_precision_take_case1():
    """A chart of Case-1 water (a_CDOM on the relation at C = 1): the prior closes C's
    interval at the bottom in the single fit; the batch gives the same; a design with it
    bounds C tighter than without."""
    sim = forward.simulate_chart(1.0, 0.058, 5.0, 1.0, seed=2)
    without = sca.estimate(sim.rgb, depth=5.0, distance=1.0, sigma=sim.rgb_sigma, mode="lm")
    est = sca.estimate(sim.rgb, depth=5.0, distance=1.0, sigma=sim.rgb_sigma, mode="lm",
                       auxiliary={"case1": True})
    assert without.chl_ci[0] == 0 and est.chl_ci[0] > 0
    assert est.chl_ci[0] <= 1.0 <= est.chl_ci[1]
    batch = sca.estimate_batch(np.stack([sim.rgb, sim.rgb]), depth=5.0, distance=1.0,
                               sigma=sim.rgb_sigma, auxiliary={"case1": True})
    np.testing.assert_allclose(batch.chl, est.chl, rtol=1e-3)
    p0 = sca.precision(1.0, 0.058, depth=5.0, distance=1.0)
    p1 = sca.precision(1.0, 0.058, depth=5.0, distance=1.0, auxiliary={"case1": True})
    assert p1.chl_sd < p0.chl_sd


# ------------------------------------------------------------------ Morel and the scores
def test_morel_inversion_recovers_c_with_its_interval():
    from experiments.realwater.estimators import fit_morel
    from experiments.realwater.nomad import morel_1988_kd

    chl = np.array([0.03, 0.3, 3.0, 30.0])
    kd = morel_1988_kd(BANDS, chl)
    exact = fit_morel(kd, BANDS)
    np.testing.assert_allclose(exact.chl, chl, rtol=1e-5)
    assert np.all(exact.p_value > 0.99)
    rng = np.random.default_rng(1)
    kd_noisy = kd * np.exp(0.05 * rng.standard_normal(kd.shape))
    noisy = fit_morel(kd_noisy, BANDS)
    assert np.all((noisy.chl_ci[:, 0] < chl) & (chl < noisy.chl_ci[:, 1]))
    # the interval is the chi^2_1 (3.84) rise of the same weighted least squares
    from experiments.realwater.estimators import morel_problem

    prob = morel_problem(BANDS, kd_noisy[1:2], np.hypot(0.05, 0.15))
    u = noisy.chl_ci[1] ** 0.65
    f_hat = prob.evaluate([0], np.array([[noisy.chl[1] ** 0.65]]), False).f[0]
    rise = [prob.evaluate([0], np.array([[x]]), False).f[0] - f_hat for x in u]
    np.testing.assert_allclose(rise, 3.84, rtol=0.02)


def test_score_floors_zero_and_defines_each_number():
    from experiments.realwater.estimators import CHL_FLOOR, score

    ref = np.array([1.0, 1.0, 1.0, 1.0])
    est = np.array([2.0, 0.5, 1.0, 0.0])
    lo = np.array([1.5, 0.0, 0.5, 0.0])
    hi = np.array([3.0, 2.0, np.inf, 0.1])
    s = score(est, ref, lo, hi)
    assert s["n_zero"] == 1
    r = np.log(np.array([2.0, 0.5, 1.0, CHL_FLOOR]))
    assert s["factor_error"] == pytest.approx(np.exp(np.median(np.abs(r))))
    assert s["bias_log"] == pytest.approx(np.median(r))
    assert s["coverage"] == 0.5 and s["closed"] == 0.25 and s["measured"] == 0.25
    assert score(np.full(4, 0.7), np.array([0.1, 1.0, 3.0, 9.0]))["r2_log"] == 0.0
    assert np.isnan(score(est, ref)["coverage"])


def test_criterion_needs_all_three():
    """The criterion judges the real-water choice's coverage among its reliable stations."""
    from experiments.realwater.empirical import criterion

    morel = {"factor_error": 2.0, "coverage": 0.3, "closed": 0.9}
    good = {"factor_error": 1.9, "coverage": 0.5, "coverage_reliable": 0.95, "closed": 0.6}
    assert criterion({"morel": morel, "real_water": good})["met"]
    for k, v in (("factor_error", 2.1), ("coverage_reliable", 0.9), ("coverage_reliable", 0.99),
                 ("closed", 0.4)):
        c = criterion({"morel": morel, "real_water": {**good, k: v}})
        assert not c["met"] and not c[k.removesuffix("_reliable")]
    assert criterion({"morel": morel, "real_water": {**good, "coverage_reliable": 0.9}})[
        "coverage_margin"] == pytest.approx(-0.02)


# ------------------------------------------------------------------ real data
@needs_data
def test_case1_table_is_learned_on_the_even_rows_only():
    """The table is what the even rows give; the odd rows never enter it (their values may
    change without changing it)."""
    from experiments.realwater import biooptical, nomad

    st = nomad.load_nomad()
    learned = biooptical.learn_relations(st)
    assert biooptical.agrees(learned, read_case1())
    odd = st.station % 2 == 1
    scrambled = st.subset(np.arange(len(st)))
    scrambled.ag443[odd] = 10.0
    scrambled.ad443[odd] = np.nan
    again = biooptical.learn_relations(scrambled)
    for q in CASE1_QUANTITIES:
        assert (again[q].alpha, again[q].beta, again[q].sd) == \
            (learned[q].alpha, learned[q].beta, learned[q].sd)
    test = biooptical.held_out(st, read_case1())
    assert all(test[q]["n"] > 250 for q in CASE1_QUANTITIES)
