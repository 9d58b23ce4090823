"""HONESTY.md's reference-shot world (experiments/honesty.py, issue 47 item 6): the light
measured in air by sca.reference.measure_light on the independent renderer's chart, the sky
changed within its stated sd, the chart underwater fitted with that prior. Its intervals must
hold the truth at the nominal 95 %, no less and no more (two-sided binomial, p > 0.01), on
charts the estimator did not make."""

import numpy as np
import pytest

from experiments import honesty as h
from experiments import honesty as rw

#: Charts of the coastal water (one fit each: each chart has its own measured prior).
N_CHARTS = 40
#: An independent sample (the report uses h.SEED).
TEST_SEED = 3


@pytest.fixture(scope="module")
def reference():
    return rw.run_reference(N_CHARTS, TEST_SEED, waters=("coastal",), beyond=False)


def test_the_reference_world_is_covered_at_the_nominal_rate(reference):
    s = reference["pooled"]["reference"][rw.WITH_REF]
    assert s["n"] == N_CHARTS and s["reliable"] >= 0.9 * N_CHARTS, s
    for key, label in h.reported_quantities():
        if key in s["coverage"]:
            cov = s["coverage"][key]
            assert cov["p_two_sided"] > h.CONSISTENCY_P, (label, cov)
    assert all(rw.holds(reference).values())


def test_the_reference_narrows_tau_on_the_same_photos(reference):
    e = reference["waters"]["coastal"]["reference"]
    with_ref, default = e[rw.WITH_REF]["median_dtau95"], e[rw.REF_DEFAULT]["median_dtau95"]
    # at 443 nm the daylight's colour limits tau: the measured light must narrow it
    assert with_ref["443"] < 0.8 * default["443"], (with_ref, default)
    # the chart's response measured in air (opt-in) narrows tau beyond the light alone
    # (decision 0079-reference-patch-response)
    response = e[rw.RESPONSE]["median_dtau95"]
    assert all(response[b] < with_ref[b] for b in rw.DTAU_BANDS), (response, with_ref)
    # the light measured in air: far narrower than the 30-mired prior it replaces
    assert reference["waters"]["coastal"]["lights"]["sd_fit_median"] < 30.0 / 5


def test_the_report_says_whether_a_sky_beyond_its_sd_is_flagged_or_covered():
    cov = {"covered": 2, "misses": 3, "p": 1e-4, "p_two_sided": 1e-4, "fraction": 0.4}
    s = {"n": 5, "reliable": 5, "test": "one-sided", "coverage": {"c_443": cov},
         "flagged_or_covered": {"c_443": {"covered": 2, "flagged": 0, "neither": 3}}}
    text = "\n".join(rw._beyond_text({"pooled": {"sky-beyond": {rw.WITH_REF: s}}}))
    assert "3 neither" in text and "**Not honest** for c(443)" in text
    assert np.isclose(rw.BEYOND_SD[0], 3.0) and np.isclose(rw.BEYOND_SD[1], 4.0)


def test_instrument_tabulates_delta_tau_with_the_measured_light():
    from experiments import instrument
    from sca.reference import REFERENCE_MINUTES, sky_sd

    rows, prior = instrument.reference_table()
    # the stated sd is computed: the in-air fit's typical sd and the sky's change, in quadrature
    assert 0 < prior["sd_fit"] < 30.0 / 5
    assert prior["sd"] == pytest.approx(np.hypot(prior["sd_fit"], sky_sd(REFERENCE_MINUTES)))
    for r in rows:
        if r["water"] != "turbid":  # where the daylight's colour limits tau at 443 nm
            assert r["reference"]["443"] < 0.8 * r["default"]["443"], r
        # a larger per-patch term never narrows tau
        widths = [r["reference"]["555"]] + [r[f"patch {100 * v:g} %"]["555"]
                                            for v in instrument.PATCH_LEVELS[1:]]
        assert np.all(np.diff(widths) > 0), r
    text = "\n".join(instrument._reference_section(rows, prior))
    assert "with the reference" in text and " nan" not in text


def test_a_reference_shot_under_tungsten_light_is_refused():
    """HONESTY.md's wrong_illuminant world: the reference shot is what can tell the light is
    not daylight (issue 50 item 5); under D65 it is accepted."""
    from forward.errors import InputError
    from sca.reference import check_daylight, measure_light

    from experiments import independent_world as iw

    for light, refused in (("A", True), ("D65", False)):
        air = iw.render_calibration(rng=1, **{**h.CLEAN_OPTIONS, "illuminant": light,
                                              "exposure": 0.6})
        lt = measure_light(np.maximum(air["rgb"], 0.0), air["sigma"])
        if refused:
            with pytest.raises(InputError) as err:
                check_daylight(lt)
            assert err.value.argument == "--reference" and "not daylight" in str(err.value)
        else:
            assert check_daylight(lt) is lt
