"""The optical depth of the light's path tau = c (depth + distance) as a reported quantity, and
verdicts a scientist reads correctly (issue 47, item 3; decision 0072-verdicts-loosely-measured).
"""

import csv

import numpy as np
import pytest
from scipy import stats

import forward
import sca
from measure import dive
from measure.dive.summary import summary_row, write_summary
from measure.statements import one_line, statements
from measure.dive.survey import write_survey
from conftest import budget_prior_world
from sca.derived import (BANDS_NM, MEASURED_RATIO, TAU_MEASURED_HALF_WIDTH, describe, quantity_values, verdict,
                         verdicts_of)

TAUS = tuple(f"tau_{b:.0f}" for b in BANDS_NM)
#: Charts of the budget-prior world (the independent renderer; drawn from the budget's own
#: priors, so its coverage is tested on both sides) and their own seed.
N = 40
SEED = 11
#: A two-sided binomial p below this fails the coverage test.
COVERAGE_P = 0.01


# --------------------------------------------------------------------------- verdicts
@pytest.mark.parametrize("lo, hi, name, said", [
    (0.22, 1.94, "chl", "loosely measured"),        # a clear lower end: not "may be zero"
    (0.075, 0.278, "c_443", "loosely measured"),
    (0.19, 0.21, "c_490", "measured"),
    (0.0, 5.0, "chl", "upper bound"),                # may be zero
    (1e-5, 0.3, "a_nw_440", "upper bound"),          # a lower end below 1 % of the upper
    (0.05, np.inf, "cdom", "not constrained"),
    (0.0, 0.15, "tau_490", "measured"),             # +-0.075: tau's absolute precision
    (0.0, 0.15, "c_490", "upper bound"),             # the same interval of c may be zero
    (2.8, 3.41, "tau_670", "measured"),              # +-10 %: the ratio rule
    (0.3, 1.2, "tau_443", "loosely measured"),       # +-0.45, a factor 4
])
def test_the_verdict_words_of_constructed_intervals(lo, hi, name, said):
    assert verdict(lo, hi, name) == said
    assert describe("q", (lo + min(hi, 10)) / 2, lo, hi, "m^-1", where="this photo",
                    name=name).startswith(f"q: {'only an ' if said == 'upper bound' else ''}"
                                          f"{said}")


def test_tau_is_measured_at_the_documented_half_width():
    w = 2 * TAU_MEASURED_HALF_WIDTH
    assert verdict(0.0, w, "tau_555") == "measured"
    assert verdict(0.0, w * 1.01, "tau_555") == "upper bound"
    got = verdicts_of(np.array([[0.22, 1.94]]), np.array([[0.0, 0.2]]),
                      {"tau_555": np.array([[0.5, 0.5 + w]]), "c_555": np.array([[0.5, 2.0]])})
    assert {k: str(v[0]) for k, v in got.items()} == {
        "chl": "loosely measured", "cdom": "upper bound", "tau_555": "measured",
        "c_555": "loosely measured"}


def test_one_line_groups_the_loosely_measured():
    est = {"chl": 1.0, "chl_ci": [0.22, 1.94], "cdom": 0.1, "cdom_ci": [0.0, 0.3],
           "quantities": {"tau_490": 0.5}, "quantity_intervals": {"tau_490": [0.45, 0.55]}}
    assert one_line(est) == ("measured: tau(490) 0.5 [0.45, 0.55]; loosely measured: C 1 "
                             "[0.22, 1.94] mg m^-3; only an upper bound: a_CDOM(440) <= 0.3 "
                             "m^-1; not constrained: -")
    assert statements(est, "photo")[2] == "tau(490): measured, 0.5 (95 %: 0.45-0.55)"


# --------------------------------------------------------------------------- the quantity
def test_tau_and_its_derivatives_are_c_times_the_path():
    water = forward.Water()
    p = {"chl": np.array([0.7]), "cdom": np.array([0.08]), "depth": np.array([4.0]),
         "distance": np.array([1.5])}
    names = ("chl", "cdom", "depth", "distance")
    q = quantity_values(water, p, names)
    for b in BANDS_NM:
        tau, c = q[f"tau_{b:.0f}"], q[f"c_{b:.0f}"]
        assert tau[0][0] == pytest.approx(c[0][0] * 5.5, rel=1e-12)
        for n in names:  # central differences
            h_ = 1e-6 * p[n][0]
            up = quantity_values(water, {**p, n: p[n] + h_})[f"tau_{b:.0f}"][0][0]
            down = quantity_values(water, {**p, n: p[n] - h_})[f"tau_{b:.0f}"][0][0]
            assert tau[1][n][0] == pytest.approx((up - down) / (2 * h_), rel=1e-5), (b, n)


@pytest.fixture(scope="module")
def priors_world():
    est, r, cond = budget_prior_world(SEED, N)
    # the world's tau: its path coefficient times its true path (the told one is perturbed)
    length = cond["depth"] + cond["distance"]
    truth = {f"tau_{b:.0f}": np.asarray(r["truth"][f"c_{b:.0f}"]) * length for b in BANDS_NM}
    return est, truth


@pytest.mark.parametrize("name", TAUS)
def test_tau_covers_the_independent_renderers_truth_at_the_nominal_rate(priors_world, name):
    est, truth = priors_world
    ok = est.reliable
    assert ok.sum() >= 0.9 * N
    ci, t = est.quantity_intervals[name][ok], truth[name][ok]
    covered = int(np.sum((ci[:, 0] <= t) & (t <= ci[:, 1])))
    assert stats.binomtest(covered, int(ok.sum()), 0.95).pvalue > COVERAGE_P, covered
    # the typical chart measures tau (the verdicts' ratio rule at the median: hi / lo <= 3),
    # and every interval holds its estimate
    assert np.median(ci[:, 1] / ci[:, 0]) <= MEASURED_RATIO, np.median(ci[:, 1] - ci[:, 0]) / 2
    assert np.all((ci[:, 0] <= est.quantities[name][ok]) & (est.quantities[name][ok] <= ci[:, 1]))


# --------------------------------------------------------------------------- the outputs
def test_tau_reaches_measurement_json_summary_csv_and_survey_nc(uw_measured, tmp_path):
    import xarray as xr

    rec = uw_measured.to_dict()
    e = rec["estimate"]
    for name in TAUS:
        lo, hi = e["quantity_intervals"][name]
        assert 0 < lo < e["quantities"][name] < hi and e["verdicts"][name] in sca.derived.VERDICTS
        band = name.split("_")[1]
        assert e["quantities"][name] == pytest.approx(e["quantities"][f"c_{band}"] * 6.5,
                                                      rel=0.05)  # 5 m deep, 1.5 m away
    assert any(s.startswith("tau(490): ") for s in e["statements"])
    assert "tau_*" in e["units"]["quantities"]
    row = summary_row("a.dng", {}, "measured", rec)
    write_summary([row], tmp_path / "summary.csv")
    (got,) = csv.DictReader(open(tmp_path / "summary.csv", encoding="utf-8"))
    assert float(got["tau_490"]) == pytest.approx(e["quantities"]["tau_490"], rel=1e-12)
    assert got["tau_490_verdict"] == e["verdicts"]["tau_490"]
    ds = dive.survey_dataset([row], {"a.dng": rec})
    assert ds["tau_490_bounds"].attrs["units"] == "1"  # (xarray's reading drops a bounds' units)
    write_survey(ds, tmp_path / "survey.nc")
    with xr.open_dataset(tmp_path / "survey.nc", engine=dive.netcdf_engine()) as nc:
        v = nc["tau_490"]
        assert v.attrs["units"] == "1" and "standard_name" not in v.attrs
        assert "optical depth" in v.attrs["long_name"]
        assert float(v.values[0]) == pytest.approx(e["quantities"]["tau_490"], rel=1e-12)
        assert "loosely measured" in nc["tau_490_verdict"].attrs["long_name"]


def test_report_png_draws_tau_beside_c(uw_measured):
    from measure.output import report_figure

    fig = report_figure(uw_measured, np.zeros((240, 360, 3), np.uint8))
    labels = [b.get_ylabel() for a in fig.axes for b in a.child_axes]
    assert any(label.startswith("optical depth τ") for label in labels), labels
