"""The optional real-camera physics of a chart underwater (forward.chart_physics, issue 39):
each model against its literature values and limits, and the opt-in parameters of
forward.simulate_chart (off: the paper's model, unchanged)."""

import numpy as np
import pytest

import forward
from forward import chart_physics as cp


def test_saunderson_constants_are_saunderson_s_in_air_and_smaller_in_water():
    k1, k2 = cp.saunderson_constants(1.5, 1.0)
    assert k1 == pytest.approx(0.04, abs=1e-12)
    assert k2 == pytest.approx(0.596, abs=0.002)  # Saunderson 1942: ~0.6 for n = 1.5
    k1w, k2w = cp.saunderson_constants(1.5, cp.N_SEAWATER)
    assert k1w < 0.004 and 0.15 < k2w < 0.3


def test_fresnel_limits():
    assert cp.fresnel(1.0, 1.5) == pytest.approx(0.04)
    assert cp.fresnel(0.0, 1.5) == pytest.approx(1.0)
    assert cp.fresnel(0.5, 1 / 1.5) == 1.0  # beyond the critical angle from inside
    assert cp.diffuse_fresnel(1.0) == pytest.approx(0.0, abs=1e-12)


def test_in_water_reflectance_keeps_a_perfect_white_and_lifts_dark_patches():
    R = np.array([0.9, 0.19, 0.031])
    Rw = cp.in_water_reflectance(R)
    assert Rw[0] == pytest.approx(0.96, abs=0.01)
    rel_air, rel_water = R / R[0], Rw / Rw[0]
    assert np.all(rel_water[1:] > 1.4 * rel_air[1:])  # less light trapped under the surface
    np.testing.assert_allclose(cp.in_water_reflectance(R, n_water=1.0), R, rtol=1e-12)


def test_forward_scatter_mixing_is_a_share_and_vanishes_with_the_path():
    W = cp.forward_scatter_mixing(1.0)
    assert W.shape == (24, 25) and np.all(W >= 0) and np.all(W.sum(axis=1) <= 1.0 + 1e-9)
    assert np.all(np.diag(W[:, :24]) > W[:, :24].sum(axis=1) - np.diag(W[:, :24]))
    R = forward.chart_setup().reflectances
    np.testing.assert_allclose(cp.forward_scatter_reflectance(R, np.zeros(R.shape[0]), 1.0), R)
    assert cp.forward_scatter_fraction(np.full(3, 0.004), 0.0).max() == 0.0
    # Petzold's ratio: b_p is ~55 x b_bp, so 1 m through b_bp = 0.004 scatters ~20 %
    assert cp.forward_scatter_fraction(np.array([0.004]), 1.0)[0] == pytest.approx(0.196, abs=0.01)


def test_fournier_forand_is_normalised_with_petzold_backscattering():
    th = np.linspace(1e-6, np.pi, 400001)
    f = 2 * np.pi * np.sin(th) * cp.fournier_forand(th)
    total = np.trapezoid(f, th)
    back = np.trapezoid(f[th >= np.pi / 2], th[th >= np.pi / 2])
    assert total == pytest.approx(1.0, abs=0.01)
    assert back == pytest.approx(cp.PETZOLD_BACKSCATTER_RATIO, rel=0.05)


def test_tilted_light_is_the_model_s_on_a_level_chart_at_the_surface():
    wl = np.arange(400.0, 701.0, 10.0)
    c = forward.Water().on_grid(wl).beam_coefficient(1.0, 0.1)
    np.testing.assert_allclose(cp.tilted_chart_light(wl, c, 0.0, 0.0), 1.0, rtol=1e-12)
    vertical = cp.tilted_chart_light(wl, c, 5.0, 90.0)
    assert np.all(vertical < 1.0) and np.ptp(vertical / vertical.mean()) > 0.01  # a colour too


def test_simulate_chart_options_are_off_by_default_and_change_the_chart_when_on():
    base = forward.simulate_chart(1.0, 0.1, 5.0, 1.0, noise=False)
    same = forward.simulate_chart(1.0, 0.1, 5.0, 1.0, noise=False, chart_in_water=False,
                                  forward_scatter=False, chart_tilt_deg=None)
    np.testing.assert_array_equal(base.rgb, same.rgb)
    for kw in ({"chart_in_water": True}, {"forward_scatter": True}, {"chart_tilt_deg": 60.0}):
        other = forward.simulate_chart(1.0, 0.1, 5.0, 1.0, noise=False, **kw)
        assert np.max(np.abs(other.rgb / base.rgb - 1)) > 0.01, kw
    with pytest.raises(ValueError):
        forward.simulate_chart(1.0, 0.1, 5.0, 1.0, chart_in_water="yes")
