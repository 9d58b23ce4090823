"""Physics of eqs 4-12 against the paper's formulas and hand-computed values."""

import math

import numpy as np
import pytest

import forward

WL = forward.wavelength_grid()
I440 = int(np.flatnonzero(WL == 440)[0])


@pytest.mark.parametrize("chl", [0.01, 0.5, 1.0, 2.0, 30.0])
def test_eq10_phytoplankton_absorption_at_440(chl):
    a_phi = forward.phytoplankton_absorption(WL, chl)
    assert a_phi[I440] == pytest.approx(0.0378 * chl**0.627, rel=1e-12)
    assert forward.phytoplankton_absorption_440(2.0) == pytest.approx(0.05837, rel=1e-3)


@pytest.mark.parametrize("cdom", [0.0, 0.05, 1.0])
def test_eq6_cdom_at_440_and_slope(cdom):
    a = forward.cdom_absorption(WL, cdom)
    assert a[I440] == pytest.approx(cdom)
    assert a[WL == 540][0] == pytest.approx(cdom * math.exp(-1.4))


@pytest.mark.parametrize("chl", [0.1, 1.0, 10.0])
def test_eq7_eq8_nap(chl):
    a = forward.nap_absorption(WL, chl)
    assert a[I440] == pytest.approx(0.0124 * chl**0.724, rel=1e-12)
    assert a[WL == 640][0] == pytest.approx(0.0124 * chl**0.724 * math.exp(-2.2), rel=1e-12)


# eq 12 worked by hand at C = 1 mg m^-3: small = 0.78 (1 - e^-1.1449) = 0.5317664
#   b_p(470) = 0.0046*0.5317664 + 0.0005*(1 - 0.5317664) + 0.00068 = 0.00336022
#   b_p(400) = 0.0046*0.5317664*(400/470)^-0.7 + 0.0005*0.4682336*(400/470)^0.2
#              + 0.00068*(400/470)^-1.9                                  = 0.00388892
#   b_p(700) = 0.0046*0.5317664*(700/470)^-0.7 + 0.0005*0.4682336*(700/470)^0.2
#              + 0.00068*(700/470)^-1.9                                  = 0.00242341
@pytest.mark.parametrize("wl,expected", [(470.0, 0.00336022), (400.0, 0.00388892), (700.0, 0.00242341)])
def test_eq12_particle_scattering_hand_values(wl, expected):
    b = forward.particle_scattering(np.array([400.0, 470.0, 700.0]), 1.0)
    idx = {400.0: 0, 470.0: 1, 700.0: 2}[wl]
    assert b[idx] == pytest.approx(expected, rel=2e-5)


def test_pure_water_scattering_morel():
    bw = forward.pure_water_scattering(np.array([400.0, 500.0, 700.0]))
    np.testing.assert_allclose(bw, [0.00288 * 0.8**-4.32, 0.00288, 0.00288 * 1.4**-4.32])


def test_eq4_eq5_eq11_sums():
    c = forward.attenuation_coefficient(WL, 2.0, 0.3)
    a = (forward.pure_water_absorption(WL) + forward.phytoplankton_absorption(WL, 2.0)
         + forward.cdom_absorption(WL, 0.3) + forward.nap_absorption(WL, 2.0))
    b = forward.pure_water_scattering(WL) + forward.particle_scattering(WL, 2.0)
    np.testing.assert_allclose(forward.absorption(WL, 2.0, 0.3), a)
    np.testing.assert_allclose(forward.scattering(WL, 2.0), b)
    np.testing.assert_allclose(c, a + b)


def test_derivatives_match_finite_differences():
    for chl in (0.05, 1.0, 20.0):
        h = 1e-6 * chl
        v, d = forward.particle_scattering(WL, chl, derivative=True)
        fd = (forward.particle_scattering(WL, chl + h) - forward.particle_scattering(WL, chl - h)) / (2 * h)
        np.testing.assert_allclose(d, fd, rtol=1e-6)
        v, d = forward.nap_absorption(WL, chl, derivative=True)
        fd = (forward.nap_absorption(WL, chl + h) - forward.nap_absorption(WL, chl - h)) / (2 * h)
        np.testing.assert_allclose(d, fd, rtol=1e-6)
    v, d = forward.phytoplankton_absorption_440(0.0, derivative=True)
    assert v == 0 and np.isinf(d)


def test_broadcast_over_concentrations():
    chl = np.array([0.1, 1.0, 10.0])
    cdom = np.array([0.0, 0.1, 1.0])
    c = forward.attenuation_coefficient(WL, chl, cdom)
    assert c.shape == (3, WL.size)
    for j in range(3):
        np.testing.assert_allclose(c[j], forward.attenuation_coefficient(WL, chl[j], cdom[j]))


def test_other_grids():
    for step in (5.0, 20.0):
        wl = np.arange(400, 700 + step / 2, step)
        c = forward.attenuation_coefficient(wl, 1.0, 0.1)
        c10 = forward.attenuation_coefficient(None, 1.0, 0.1)
        # the common wavelengths agree exactly (linear interpolation is exact at nodes)
        common = np.intersect1d(wl, forward.wavelength_grid())
        np.testing.assert_allclose(c[np.isin(wl, common)], c10[np.isin(forward.wavelength_grid(), common)])


def test_path_coefficient_returns_fresh_arrays_not_its_tables():
    # a derivative that is one table times 1 (d c / d a_CDOM = the CDOM shape) is summed
    # without the product: the caller still gets its own array, never the table itself
    terms = forward.Water().on_grid(np.arange(400.0, 701.0, 10.0))
    for chl in (1.0, np.array([0.5, 2.0]), np.full(20, 3.0)):  # one chart, few, many
        c, d = terms.path_coefficient(chl, 0.2, wrt=("chl", "cdom"), floor=1e-3)
        np.testing.assert_array_equal(d["cdom"], np.broadcast_to(terms.cdom_shape, c.shape))
        for arr in (c, d["cdom"], d["chl"]):
            assert not np.shares_memory(arr, terms.cdom_shape)
            assert not np.shares_memory(arr, terms.pure_water_absorption)
    before = terms.cdom_shape.copy()
    c, d = terms.path_coefficient(1.0, 0.2, wrt=("cdom",))
    d["cdom"][...] = 0.0  # the caller's own array
    np.testing.assert_array_equal(terms.cdom_shape, before)
