"""Data tables: published values, headers that name their source, units and grid."""

import numpy as np
import pytest

import forward
from forward import spectra, water

# Smith & Baker (1981) via Mobley (1994) p. 90, m^-1 -- values as published
SMITH_BAKER = {380: 0.022, 400: 0.0171, 440: 0.0145, 500: 0.0257, 550: 0.0638, 600: 0.244,
               650: 0.349, 700: 0.65, 720: 1.169}


@pytest.mark.parametrize("wl,value", sorted(SMITH_BAKER.items()))
def test_pure_water_table_published_values(wl, value):
    grid, vals = spectra.read_spectral_table("pure_water_absorption_smith_baker_1981.csv")
    assert vals[grid == wl, 0][0] == pytest.approx(value, rel=1e-12)


def test_pure_water_absorption_on_model_grid():
    a_w = forward.pure_water_absorption(np.array([400.0, 440.0, 550.0, 700.0]))
    np.testing.assert_allclose(a_w, [0.0171, 0.0145, 0.0638, 0.65], rtol=1e-12)
    # linear interpolation between nodes: 445 nm lies between 0.0145 and 0.0145, 555 between
    a = forward.pure_water_absorption(np.array([400.0, 555.0, 700.0]))
    assert a[1] == pytest.approx((0.0638 + 0.0708) / 2)


def test_phytoplankton_basis_normalised_at_440_and_shape():
    T, t440 = forward.phytoplankton_basis()
    wl = forward.wavelength_grid()
    assert T.shape == (301, 1)
    assert T[wl == 440, 0][0] == pytest.approx(1.0)
    assert t440 == pytest.approx([1.0])
    # published relative values 0.0184 at 440, 0.0114 at 670, 0.0016 at 700
    assert T[wl == 670, 0][0] == pytest.approx(0.0114 / 0.0184)
    assert T[wl == 700, 0][0] == pytest.approx(0.0016 / 0.0184)


def test_table1_constants():
    t = water.table1()
    assert t == {"C_12": 0.78, "S_12": 1.1449, "b_p12_star": 0.0046, "b_p3_star": 0.0005,
                 "b_k": 0.00068, "gamma_12": 0.7, "gamma_3": -0.2, "gamma_k": 1.9,
                 "lambda_0": 470.0}


@pytest.mark.parametrize("name", ["pure_water_absorption_smith_baker_1981.csv",
                                  "phytoplankton_absorption_basis.csv",
                                  "particle_scattering_table1.csv",
                                  "diffuse_attenuation_morel_1988.csv",
                                  "case1_relations_nomad_even.csv",
                                  "colour_science_spectra_1nm.csv",
                                  "colour_science_srgb.csv"])
def test_every_table_header_names_source_units_grid(name):
    text = (spectra._data_dir() / name).read_text()
    header = "\n".join(l for l in text.splitlines() if l.startswith("#"))
    for word in ("Source:", "Units:", "Grid:"):
        assert word in header, f"{name} header lacks {word}"
    readme = (spectra._data_dir() / "README.md").read_text()
    assert name in readme


def test_colour_science_spectra():
    R = forward.chart_reflectances()
    P = forward.camera_sensitivities()
    i = forward.illuminant_spd()
    assert R.shape == (301, 24) and P.shape == (301, 3) and i.shape == (301,)
    assert np.all((R > 0) & (R < 1))
    np.testing.assert_allclose(P.max(axis=0), 1.0)
    assert i.max() == pytest.approx(1.0)
