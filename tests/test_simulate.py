"""The forward simulation: eq 1 / 15 structure, monotonic attenuation, sensor noise statistics."""

import numpy as np
import pytest

import forward

WL = forward.wavelength_grid()


@pytest.mark.parametrize("param", ["depth", "distance", "chl", "cdom"])
def test_k_falls_monotonically(param):
    base = dict(chl=1.0, cdom=0.1, depth=5.0, distance=2.0)
    values = {"depth": [0, 1, 5, 10, 20, 30], "distance": [0, 0.5, 1, 5, 10],
              "chl": [0, 0.01, 0.1, 1, 10, 100], "cdom": [0, 0.01, 0.1, 1, 2]}[param]
    ks = []
    for v in values:
        kw = dict(base, **{param: v})
        ks.append(forward.attenuation(WL, kw["chl"], kw["cdom"], kw["depth"], kw["distance"]))
    ks = np.array(ks)
    assert np.all(np.diff(ks, axis=0) < 0), f"k does not fall with {param}"
    assert np.all((ks > 0) & (ks <= 1))


def test_absorption_path_model_is_eq13():
    k = forward.attenuation(WL, 1.0, 0.1, 10.0, 5.0, path_model="absorption")
    np.testing.assert_allclose(k, np.exp(-15.0 * forward.absorption(WL, 1.0, 0.1)))
    kb = forward.attenuation(WL, 1.0, 0.1, 10.0, 5.0)
    np.testing.assert_allclose(kb, np.exp(-15.0 * forward.attenuation_coefficient(WL, 1.0, 0.1)))
    assert np.all(kb < k)


def test_noise_free_rgb_equals_matrix_formula():
    sim = forward.simulate_chart(2.0, 0.2, 8.0, 3.0, noise=False)
    P, i, k, R, s = sim.camera, sim.illuminant, sim.attenuation, sim.reflectances, sim.backscatter
    expected = P.T @ np.diag(i) @ np.diag(k) @ R + s[:, None]
    np.testing.assert_allclose(sim.rgb, expected, rtol=1e-13, atol=0)
    assert sim.rgb.shape == (3, 24) and k.shape == (301,) and s.shape == (3,)
    assert np.all(s > 0)
    # backscatter is P^T of the veiling light, and vanishes at zero distance
    sim0 = forward.simulate_chart(2.0, 0.2, 8.0, 0.0, noise=False)
    np.testing.assert_allclose(sim0.backscatter, 0.0, atol=0)


def test_units_white_in_air_is_one():
    sim = forward.simulate_chart(0.0, 0.0, 0.0, 0.0, noise=False, backscatter=False,
                                 reflectances=np.ones((301, 1)))
    assert sim.rgb.max() == pytest.approx(1.0)


def test_determinism_per_seed():
    a = forward.simulate_chart(1.0, 0.1, 10.0, 5.0, seed=7)
    b = forward.simulate_chart(1.0, 0.1, 10.0, 5.0, seed=7)
    c = forward.simulate_chart(1.0, 0.1, 10.0, 5.0, seed=8)
    np.testing.assert_array_equal(a.rgb, b.rgb)
    assert not np.array_equal(a.rgb, c.rgb)


def _noisy_stack(n_seeds, **kw):
    return np.array([forward.simulate_chart(1.0, 0.1, 5.0, 2.0, seed=s, **kw).rgb for s in range(n_seeds)])


def test_noise_mean_converges_to_expectation():
    stack = _noisy_stack(400)
    exp = forward.simulate_chart(1.0, 0.1, 5.0, 2.0, noise=False).rgb
    mean = stack.mean(0)
    se = stack.std(0, ddof=1) / np.sqrt(stack.shape[0])
    z = (mean - exp) / se
    assert np.max(np.abs(z)) < 5.0
    # and the noise is real: each value scatters
    assert np.all(stack.std(0) > 0)


def test_variance_follows_shot_noise():
    settings = forward.SensorSettings()
    stack = _noisy_stack(300)
    sim = forward.simulate_chart(1.0, 0.1, 5.0, 2.0, noise=False)
    gt = forward.sensor.electrons_per_second(sim.setup, settings) * sim.exposure_s
    var_e = stack.var(0, ddof=1) * gt**2 * settings.pixels_per_patch  # per-pixel variance in e-^2
    expected_var = sim.rgb * gt + settings.read_noise_e**2 + settings.lsb_e**2 / 12
    ratio = var_e / expected_var
    # chi-square scatter of a 300-sample variance is ~8 %; all 72 ratios within 35 %
    assert np.all(np.abs(ratio - 1) < 0.35), ratio
    # variance grows with signal: rank correlation of variance with mean close to 1
    from scipy.stats import spearmanr
    assert spearmanr(sim.rgb.ravel(), var_e.ravel()).statistic > 0.95


def test_auto_exposure_caps_deep_scenes():
    shallow = forward.simulate_chart(1.0, 0.1, 1.0, 1.0, noise=False)
    deep = forward.simulate_chart(1.0, 0.1, 30.0, 10.0, noise=False)
    settings = forward.SensorSettings()
    assert shallow.exposure_s < settings.max_exposure_s
    assert deep.exposure_s == settings.max_exposure_s
    assert shallow.codes.max() == pytest.approx(settings.target_fraction * (2**14 - 1), rel=1e-9)
    assert deep.codes.max() < 0.2 * shallow.codes.max()


def test_other_cameras_grids_and_custom_arrays(tmp_path):
    wl = np.arange(400, 681, 10.0)
    sim = forward.simulate_chart(1, 0.1, 5, 1, camera="Sigma SDMerill (NPL)", wavelengths=wl, noise=False)
    assert sim.rgb.shape == (3, 24) and sim.wavelengths[-1] == 680
    for step in (5.0, 20.0):
        g = np.arange(400, 701, step)
        s = forward.simulate_chart(1, 0.1, 5, 1, wavelengths=g, noise=False)
        s1 = forward.simulate_chart(1, 0.1, 5, 1, noise=False)  # the default grid: 1 nm
        # integrals converge: 5/20 nm within a few % of the default 1 nm
        np.testing.assert_allclose(s.rgb, s1.rgb, rtol=0.1, atol=1e-4)
    # user arrays and CSV files give the same result as the named data
    P = forward.camera_sensitivities("Nikon 5100 (NPL)", None)
    R = forward.chart_reflectances(None, None)
    i = forward.illuminant_spd("D65", None)
    ref = forward.simulate_chart(1, 0.1, 5, 1, noise=False)
    arr = forward.simulate_chart(1, 0.1, 5, 1, noise=False, camera=P, reflectances=R, illuminant=i)
    np.testing.assert_allclose(arr.rgb, ref.rgb, rtol=1e-12)
    f = tmp_path / "cam.csv"
    np.savetxt(f, np.column_stack([WL, P]), delimiter=",", header="wavelength,r,g,b", comments="")
    csv = forward.simulate_chart(1, 0.1, 5, 1, noise=False, camera=str(f))
    np.testing.assert_allclose(csv.rgb, ref.rgb, rtol=1e-12)


def test_z2_basis():
    T1, _ = forward.phytoplankton_basis()
    T = np.column_stack([T1[:, 0], np.linspace(1.0, 0.2, 301)])
    a = forward.phytoplankton_absorption(WL, 2.0, basis=T, weights=[1.0, 0.5])
    assert a[WL == 440][0] == pytest.approx(0.0378 * 2**0.627)
    sim = forward.simulate_chart(2.0, 0.1, 5, 1, basis=T, weights=[1.0, 0.5], noise=False)
    assert np.all(np.isfinite(sim.rgb))


def test_to_json_roundtrip():
    import json
    sim = forward.simulate_chart(1, 0.1, 5, 1, seed=3)
    d = json.loads(sim.to_json())
    np.testing.assert_allclose(d["rgb"], sim.rgb)
    assert d["seed"] == 3 and d["sensor"]["pixels_per_patch"] == 100


def test_a_camera_file_is_read_again_when_it_changes(tmp_path):
    """No cache outlives the numbers it was built from: a sensitivity file edited in place
    (any extension) gives a new setup."""
    wl = forward.wavelength_grid()
    base = forward.camera_sensitivities(forward.DEFAULT_CAMERA, wl)
    path = tmp_path / "camera.dat"
    rows = ["wavelength,red,green,blue"] + [f"{w},{r},{g},{b}" for w, (r, g, b) in zip(wl, base)]
    path.write_text("\n".join(rows))
    first = forward.chart_setup(str(path))
    # another shape of the green curve (each channel is normalised to its peak)
    rows = ["wavelength,red,green,blue"] + [f"{w},{r},{g * w / 700},{b}"
                                              for w, (r, g, b) in zip(wl, base)]
    path.write_text("\n".join(rows))
    second = forward.chart_setup(str(path))
    assert not np.allclose(first.sensitivities, second.sensitivities)
