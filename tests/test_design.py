"""Designs that reach a precision (issue 37 item 4): sca.precision's derived quantities,
sca.design's search (sca.protocols) and ``uw3p design``."""

import io

import numpy as np
import pytest

import forward
import sca
from forward.imaging import resolve_setup
from sca.derived import is_optical_depth, quantity_values
from sca.joint import estimate_joint
from sca.protocols import AUXILIARY_OPTIONS, Protocol, ladder
from uw3p.cli import main

SETUP = resolve_setup(None, forward.DEFAULT_CAMERA, None, None, None)
#: The coastal water of INSTRUMENT.md and the dive a diver can make there.
COASTAL = dict(chl=1.0, cdom=0.1, depth=(2.0, 15.0), distance=(1.0, 3.0))


def run(argv):
    out, err = io.StringIO(), io.StringIO()
    code = main([str(a) for a in argv], out, err)
    return code, out.getvalue(), err.getvalue()


# --------------------------------------------------------------------------- the bound
def test_precision_derived_sds_are_the_delta_method_by_finite_differences():
    """Camera only, exposure free: C and a_CDOM are the only parameters a quantity depends on,
    so its variance is g^T Sigma g with g by central differences and Sigma from the bound's
    sds and correlation."""
    c, a, d, r = 1.0, 0.1, 6.0, 1.5
    p = sca.precision(c, a, depth=d, distance=r, gain="free", uncertain={})
    cov = np.array([[p.chl_sd ** 2, p.correlation * p.chl_sd * p.cdom_sd],
                    [p.correlation * p.chl_sd * p.cdom_sd, p.cdom_sd ** 2]])
    water = forward.Water()

    def value(name, chl, cdom):
        params = {"chl": np.array([chl]), "cdom": np.array([cdom]), "depth": np.array([d]),
                  "distance": np.array([r])}
        return float(quantity_values(water, params)[name][0][0])

    for name in p.quantities:
        h = 1e-6
        g = np.array([(value(name, c + h, a) - value(name, c - h, a)) / (2 * h),
                      (value(name, c, a + h) - value(name, c, a - h)) / (2 * h)])
        assert p.quantities[name] == pytest.approx(value(name, c, a), rel=1e-12)
        assert p.quantity_sd[name] == pytest.approx(np.sqrt(g @ cov @ g), rel=1e-5), name
        assert p.quantity_rel95[name] == pytest.approx(1.959963984540054 * p.quantity_sd[name]
                                                       / p.quantities[name])


@pytest.mark.parametrize("uncertain", [{}, None])
def test_precision_derived_sds_are_the_estimators_on_a_noise_free_chart(uncertain):
    """The estimator's delta-method interval of each quantity, on a noise-free chart (its
    covariance is the bound's), gives the bound's sd: sd(ln h) = ln(hi / lo) / (2 x 1.96)."""
    c, a, d, r = 0.3, 0.05, 10.0, 2.0
    sim = forward.simulate_chart(c, a, d, r, noise=False)
    b = sca.estimate_batch(sim.rgb[None], depth=d, distance=r, sigma=sim.rgb_sigma[None],
                           gain="free", uncertain=uncertain, path_models=("beam",))
    p = sca.precision(c, a, depth=d, distance=r, gain="free", uncertain=uncertain)
    assert set(p.quantity_sd) == set(b.quantity_intervals)
    for name, ci in b.quantity_intervals.items():
        lo, hi = ci[0]
        assert np.log(hi / lo) / (2 * 1.959963984540054) == pytest.approx(
            p.quantity_sd[name] / p.quantities[name], rel=1e-6), name


def test_a_dive_of_one_photo_has_the_single_photos_derived_sds_and_more_photos_narrow_them():
    one = sca.precision(1.0, 0.1, depth=6.0, distance=1.5, gain="free")
    dive = sca.precision(1.0, 0.1, depth=[6.0], distance=[1.5], gain="free", dive=True)
    more = sca.precision(1.0, 0.1, depth=[3.0, 6.0, 12.0], distance=[1.5] * 3, gain="free",
                         dive=True)
    # tau is a photo's (its own depth and distance): the joint estimate does not report it
    assert set(dive.quantity_sd) == {k for k in one.quantity_sd if not is_optical_depth(k)}
    for name in dive.quantity_sd:
        assert dive.quantity_sd[name] == pytest.approx(one.quantity_sd[name], rel=1e-6)
        assert more.quantity_sd[name] < one.quantity_sd[name]
    assert dive.fitted == {"path_model": "beam", "chl": 1.0, "cdom": 0.1, "objective": 0.0,
                           "converged": True}


def test_another_path_model_is_fitted_to_the_dive_and_refused_without_one():
    p = sca.precision(1.0, 0.1, depth=[2.0, 15.0], distance=[1.0, 1.0], gain="free", dive=True,
                      path_model="absorption")
    # absorption alone must take more C to dim the light as the beam attenuation does
    assert p.fitted["path_model"] == "absorption" and p.fitted["chl"] > 1.0
    assert 0 < p.fitted["objective"]
    with pytest.raises(ValueError, match="^path_model:"):
        sca.precision(1.0, 0.1, depth=2.0, distance=1.0, path_model="absorption")
    with pytest.raises(ValueError, match="^path_model:"):
        sca.precision(1.0, 0.1, depth=[2.0], distance=[1.0], gain="free", dive=True,
                      path_model="sideways")


@pytest.mark.slow
def test_the_joint_fit_takes_an_auxiliary_measurement_with_several_photos():
    """The per-photo fits of the joint estimate (its photo scatter and heterogeneity test:
    one (C, a_CDOM) per photo) carry the auxiliary measurement of each (they crashed)."""
    M, sig = [], []
    for i, (d, r) in enumerate(((3.0, 1.0), (12.0, 1.0))):
        s = forward.simulate_chart(1.0, 0.1, d, r, seed=40 + i)
        M.append(s.rgb)
        sig.append(s.rgb_sigma)
    kw = dict(depth=[3.0, 12.0], distance=[1.0, 1.0], sigma=np.array(sig), setup=SETUP,
              path_models=("beam",))
    bare = estimate_joint(np.array(M), **kw)
    fused = estimate_joint(np.array(M), auxiliary={"cdom": (0.1, 0.0025)}, **kw)
    assert fused.cdom_ci[1] - fused.cdom_ci[0] < 0.5 * (bare.cdom_ci[1] - bare.cdom_ci[0])
    assert fused.chl_ci[1] - fused.chl_ci[0] < bare.chl_ci[1] - bare.chl_ci[0]
    assert fused.chl_ci[0] <= 1.0 <= fused.chl_ci[1]
    # the Case-1 prior (sca.biooptical) is an auxiliary input of the same core
    case1 = estimate_joint(np.array(M), auxiliary={"case1": True}, **kw)
    assert case1.chl_ci[0] <= 1.0 <= case1.chl_ci[1] and np.isfinite(case1.chl_ci[1])


# --------------------------------------------------------------------------- the search
def test_ladders_are_nested_and_within_the_range():
    for n in range(1, 13):
        small, big = ladder(2.0, 15.0, n, 8.5), ladder(2.0, 15.0, n + 1, 8.5)
        assert big[:n] == small and len(set(big)) == n + 1
        assert all(2.0 <= x <= 15.0 for x in big) and big[0] == 8.5
    assert ladder(5.0, 5.0, 3) == (5.0, 5.0, 5.0)
    assert Protocol((2.0, 15.0), (1.0, 3.0), "sample").n_photos == 4
    with pytest.raises(ValueError, match="^n:"):
        ladder(1.0, 2.0, 0)


@pytest.fixture(scope="module")
def designs():
    return {
        "one photo": sca.design(**COASTAL, targets={"c": 0.30}),
        "dive": sca.design(**COASTAL, targets={"chl": 0.90}, auxiliary=("none",)),
        "photos only, C 30 %": sca.design(**COASTAL, targets={"chl": 0.30},
                                          auxiliary=("none",)),
        # a precise sample (long-path spectrophotometry): the default 0.015 m^-1 does not reach
        # C +-30 % here (decision 0075-design-reference-shot)
        "auxiliary": sca.design(**COASTAL, targets={"chl": 0.30}, sample_sd=0.0025),
        "nothing": sca.design(**COASTAL, targets={"chl": 0.05}),
    }


def _consistent(pred, targets):
    """A prediction is never narrower than its bound, and meets = every target met."""
    for k in ("chl", "cdom", "c"):
        assert pred.rel95[k] >= pred.bound_rel95[k] * (1 - 1e-12)
    assert pred.meets == all(pred.rel95[k] <= v for k, v in targets.items())


@pytest.mark.slow
def test_a_target_one_photo_meets(designs):
    d = designs["one photo"]
    assert d.meets and d.protocol.protocol.n_photos == 1
    assert d.protocol.protocol.auxiliary == "none" and d.one_photo.meets
    assert d.protocol.rel95["c"] <= 0.30 < d.protocol.rel95["chl"]  # c is measured, C is not
    _consistent(d.protocol, d.targets)


@pytest.mark.slow
def test_a_target_that_needs_a_dive(designs):
    """With the default budget (the per-patch error shared between photos in the chart's part
    only, sca.joint.PATCH_CORRELATION), photos alone reach C to about +-80 % in coastal water."""
    d = designs["dive"]
    p = d.protocol
    assert d.meets and p.protocol.n_photos > 1 and p.protocol.auxiliary == "none"
    assert not d.one_photo.meets and d.one_photo.rel95["chl"] > 0.90 >= p.rel95["chl"]
    _consistent(p, d.targets)
    # the fewest photos: none of the protocols with fewer meets the target
    fewer = sca.design(**COASTAL, targets={"chl": 0.90}, auxiliary=("none",),
                       max_photos=p.protocol.n_photos - 1)
    assert not fewer.meets and fewer.best.rel95["chl"] > 0.90


@pytest.mark.slow
def test_a_target_that_needs_an_auxiliary_measurement(designs):
    alone, d = designs["photos only, C 30 %"], designs["auxiliary"]
    assert not alone.meets and alone.best.rel95["chl"] > 0.30
    assert alone.best.protocol.n_photos == 12 and alone.limiting in sca.DEFAULT_UNCERTAIN
    p = d.protocol
    assert d.meets and p.protocol.auxiliary in ("sample", "sample+secchi")
    assert p.rel95["chl"] <= 0.30 < d.one_photo.rel95["chl"]
    _consistent(p, d.targets)
    # the data cannot tell absorption from beam attenuation: the interval spans both
    assert p.span == ("beam", "absorption") and p.rel95["chl"] > p.bound_rel95["chl"]


@pytest.mark.slow
def test_a_target_nothing_meets_says_what_limits_it(designs):
    d = designs["nothing"]
    assert not d.meets and d.protocol is None
    assert d.best.rel95["chl"] > 0.05 and d.best.protocol.auxiliary == "sample+secchi"
    assert d.limiting in sca.DEFAULT_UNCERTAIN
    assert d.without_limiting < d.best.bound_rel95["chl"]


def test_camera_only_design_is_the_bound_and_cheap():
    d = sca.design(1.0, 0.1, depth=5.0, distance=1.0, uncertain={}, targets={"chl": 0.3})
    assert d.camera_only and d.meets and d.protocol.protocol.n_photos == 1
    assert d.protocol.span == ("beam",)
    assert d.protocol.rel95["chl"] == pytest.approx(d.protocol.bound_rel95["chl"])
    p = sca.precision(1.0, 0.1, depth=5.0, distance=1.0, gain="free", uncertain={})
    assert d.protocol.bound_rel95["chl"] == pytest.approx(p.chl_rel95, rel=1e-6)
    none = sca.design(1.0, 0.1, depth=5.0, distance=1.0, uncertain={}, targets={"chl": 0.001},
                      max_photos=2, auxiliary=("none",))
    assert not none.meets and none.limiting == "noise"


@pytest.mark.parametrize("kw,name", [
    (dict(chl=0.0), "chl"), (dict(cdom=-0.1), "cdom"), (dict(depth=(1.0, 2.0, 3.0)), "depth"),
    (dict(depth=-1.0), "depth"), (dict(distance=(1.0, np.nan)), "distance"),
    (dict(targets={"C": 0.3}), "targets"), (dict(targets={"chl": 0.0}), "targets"),
    (dict(max_photos=0), "max_photos"), (dict(auxiliary=("diver",)), "auxiliary"),
    (dict(sample_sd=-1.0), "sample_sd"), (dict(gain="maybe"), "gain")])
def test_design_bad_input_names_the_argument(kw, name):
    args = dict(chl=1.0, cdom=0.1, depth=5.0, distance=1.0, uncertain={})
    args.update(kw)
    with pytest.raises(ValueError, match=f"^{name}:"):
        sca.design(**args)


def test_auxiliary_options_are_cheapest_first():
    assert AUXILIARY_OPTIONS[0] == "none" and AUXILIARY_OPTIONS[-1] == "sample+secchi"


# --------------------------------------------------------------------------- the command
def test_cli_camera_only_one_photo_exit_0_and_labelled():
    code, out, err = run(["design", "--chl", 1, "--cdom", 0.1, "--depth", 5, "--distance", 1,
                          "--camera-only", "--target", "C=20%", "--target", "c=5%"])
    assert code == 0, err
    assert "camera only: photon and read noise" in out and "--camera-only" in out
    assert "protocol         1 photo at 5 m from 1 m" in out
    assert "target           C ±20 %, c (443-670 nm) ±5 % (95 %)" in out
    assert "a reliable measurement is possible" in out


def test_cli_none_meets_exit_1_and_says_what_limits():
    code, out, err = run(["design", "--chl", 1, "--cdom", 0.1, "--depth", 5, "--distance", 1,
                          "--camera-only", "--target", "C=0.1%", "--max-photos", 2,
                          "--no-auxiliary"])
    assert code == 1, err
    assert "best protocol    2 photos, all at 5 m from 1 m" in out
    assert "C cannot be measured to ±0.1 % here" in out and "camera's noise" in out


@pytest.mark.slow
def test_cli_default_budget_asks_for_a_water_sample():
    code, out, err = run(["design", "--chl", 1, "--cdom", 0.1, "--depth", 2, 15,
                          "--distance", 1, 3, "--target", "C=30%", "--sample-sd", 0.0025])
    assert code == 0, err
    assert "budget           the default uncertainty budget" in out
    assert "with a water sample's a_CDOM(440)" in out.split("protocol")[1]
    assert "span the path models beam and absorption" in out
    assert "the camera alone (photon and read noise only, --camera-only)" in out


@pytest.mark.parametrize("extra,message", [
    (["--target", "C"], "--target: expected NAME=PCT"),
    (["--target", "chlorophyll=3%"], "--target: unknown name"),
    (["--target", "C=-3%"], "--target: C's value must be > 0"),
    (["--target", "C=lots"], "--target: C's value must be a percentage"),
    (["--depth", 1, 2, 3], "--depth: give one value or two"),
    (["--sample-sd", 0], "--sample-sd:"), (["--max-photos", 0], "--max-photos:"),
    (["--cdom", 0], "--cdom: must be > 0")])
def test_cli_bad_input_exit_2_names_the_option(extra, message):
    argv = ["design", "--chl", 1, "--cdom", 0.1, "--depth", 5, "--distance", 1, "--camera-only"]
    code, _, err = run(argv + extra)
    assert code == 2 and err.startswith(f"uw3p design: error: {message}"), err


# --------------------------------------------------------------------------- following the advice
def test_the_advice_is_a_command_uw3p_measure_takes_and_a_plan_it_reads(tmp_path):
    """The dive's command parses with uw3p's own parser (a folder, the plan, --joint, the
    sample as --cdom-sample with the design's sd) and the plan is a metadata CSV
    measure.dive.metadata reads, one row per photo of the protocol."""
    import shlex

    from measure.dive.metadata import METADATA_COLUMNS, read_metadata
    from uw3p.cli import build_parser
    from uw3p.cmd_design import PLAN_COLUMNS, follow, write_plan
    from uw3p.common import auxiliary_from_args

    assert PLAN_COLUMNS == METADATA_COLUMNS
    proto = Protocol((15.0, 2.0), (1.0, 3.0), "sample+secchi")
    plan = tmp_path / "my dive.csv"  # a name the shell must quote
    lines = follow(proto, {"sample": 0.0025, "secchi": 0.8}, str(plan))
    assert lines[0] == ("follow it        on the dive: photograph the chart at 15 m from 1 m, "
                        "15 m from 3 m, 2 m from 1 m, 2 m from 3 m; measure a water sample's "
                        "a_CDOM(440) (sd 0.0025 m^-1 or better); read a Secchi depth (sd 0.8 m "
                        "or better)")
    cmd = lines[1].split("then", 1)[1].strip()
    assert cmd.startswith("uw3p measure DIVE/ --metadata ")
    filled = cmd.replace("DIVE/", str(tmp_path)).replace("A:", "0.11:").replace("Z:", "7:")
    args = build_parser().parse_args(shlex.split(filled)[1:])
    assert args.joint and args.metadata == str(plan) and args.image == str(tmp_path)
    assert auxiliary_from_args(args) == {"cdom": (0.11, 0.0025), "secchi": (7.0, 0.8)}
    write_plan(str(plan), proto)
    rows = read_metadata(plan)
    assert [(r["depth_m"], r["distance_m"]) for r in rows.values()] == proto.photos
    # one photo: no folder, no --joint, the geometry as options
    one = follow(Protocol((5.0,), (1.0,)), {"sample": 0.0025, "secchi": 0.8})[1]
    args = build_parser().parse_args(shlex.split(one.split("then", 1)[1])[1:])
    assert (args.depth, args.distance, args.joint, args.cdom_sample) == (5.0, 1.0, False, None)
    with pytest.raises(ValueError, match="^--plan: cannot write"):
        write_plan(str(tmp_path / "no" / "such" / "dir.csv"), proto)


def test_cli_writes_the_plan_and_says_how_to_follow_it(tmp_path):
    plan = tmp_path / "dive.csv"
    code, out, err = run(["design", "--chl", 1, "--cdom", 0.1, "--depth", 5, "--distance", 1,
                          "--camera-only", "--target", "C=20%", "--plan", plan])
    assert code == 0, err
    assert "follow it        on the dive: photograph the chart at 5 m from 1 m\n" in out
    assert "uw3p measure PHOTO.dng --profile profile.json --depth 5 --distance 1 --out" in out
    assert "a camera-only design" in out
    assert plan.read_text().splitlines() == ["image,depth_m,distance_m", "PHOTO_01.dng,5,1"]
    code, _, err = run(["design", "--chl", 1, "--cdom", 0.1, "--depth", 5, "--distance", 1,
                        "--camera-only", "--plan", tmp_path / "missing" / "dive.csv"])
    assert code == 2 and err.startswith("uw3p design: error: --plan: cannot write"), err


def test_the_reference_shot_asks_for_no_more_photos_and_narrows_c443():
    from sca.reference import planned

    kw = dict(chl=1.0, cdom=0.1, depth=(2.0, 10.0), distance=1.0, targets={"c_443": 0.2})
    d = sca.design(**kw, reference_shot=True, reference_minutes=5)
    w = d.without_reference
    assert d.reference_shot and w is not None and not w.reference_shot
    assert d.meets and w.meets and d.protocol.protocol.n_photos <= w.protocol.protocol.n_photos
    one, one_w = d.one_photo, w.one_photo
    assert one.protocol == one_w.protocol
    for k in ("c_443", "chl"):
        assert one.rel95[k] < one_w.rel95[k]
    # the prediction is sca.precision's with the daylight a reference shot 5 min away measures
    depth, distance = one.protocol.photos[0]
    p = sca.precision(1.0, 0.1, depth=depth, distance=distance, gain="free",
                      uncertain=planned(None, 5))
    assert one.precision.quantity_sd["c_443"] == pytest.approx(p.quantity_sd["c_443"])


def test_cli_design_with_the_reference_shot_prints_both_and_the_command():
    code, text, _ = run(["design", "--chl", "1", "--cdom", "0.1", "--depth", "10",
                         "--distance", "1", "--target", "c_443=20%", "--reference-shot",
                         "--no-auxiliary", "--max-photos", "2"])
    assert code == 0 and "--reference AIR.dng:10" in text
    assert "  with it" in text and "  without it" in text
