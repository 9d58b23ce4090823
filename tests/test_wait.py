"""Start-up and speed-path correctness (issue 21): what the command line imports, the cached
colour-science spectra, the light field's Gauss-Newton search. No timings (those are in
``experiments/wait_bench.py``)."""

import dataclasses
import subprocess
import sys

import numpy as np
import pytest

import forward
from forward import spectra
from measure import lightfield

#: Packages the command line must not load before a command needs them
HEAVY = ("scipy", "cvxpy", "matplotlib", "colour", "numba", "pandas", "rawpy", "cv2")


def _loaded(code: str) -> set:
    """Top-level packages of HEAVY (and numpy) that ``code`` leaves in sys.modules, run in a
    fresh interpreter."""
    probe = (f"{code}\nimport sys\n"
             "print('\\n' + ' '.join(sorted({m.split('.')[0] for m in sys.modules})))")
    # the last line only: what ``code`` prints (a help text's words) is not a module
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                         check=True).stdout.splitlines()[-1].split()  # not the code's own output
    return set(out) & set(HEAVY + ("numpy",))


def test_importing_the_cli_loads_nothing_heavy():
    assert _loaded("import uw3p.cli") == set()


def test_help_and_bad_input_load_no_numerics():
    # --help builds every subcommand's parser; a missing image is refused before any work
    help_ = ("from uw3p.cli import main\n"
             "try:\n    main(['measure', '--help'])\nexcept SystemExit:\n    pass")
    assert _loaded(help_) == set()
    bad = ("import io\nfrom uw3p.cli import main\n"
           "assert main(['measure', 'missing.dng', '--depth', '5', '--distance', '1', '--out', "
           "'x'], out=io.StringIO(), err=io.StringIO()) == 2")
    assert _loaded(bad) == set()  # forward.InputError needs no numerics (forward.errors)


def test_forward_loads_its_names_on_first_use():
    assert _loaded("import forward") == set()
    assert _loaded("from forward.errors import InputError") == set()
    from forward.imaging import chart_setup
    from forward.validate import InputError

    assert forward.chart_setup is chart_setup and forward.InputError is InputError
    assert all(getattr(forward, name) is not None for name in forward.__all__)
    assert forward.water.Water is forward.Water  # submodules as attributes
    with pytest.raises(AttributeError, match="no attribute 'nonexistent'"):
        forward.nonexistent  # noqa: B018


def test_sca_loads_its_names_on_first_use():
    assert _loaded("import sca") <= {"numpy"}
    assert _loaded("import sca; sca.DEFAULT_UNCERTAIN") <= {"numpy"}
    import sca
    from sca.budget import DEFAULT_UNCERTAIN
    from sca.loop import estimate

    assert sca.estimate is estimate and sca.DEFAULT_UNCERTAIN is DEFAULT_UNCERTAIN
    assert all(getattr(sca, name) is not None for name in sca.__all__)
    assert set(sca.__all__) <= set(dir(sca))
    assert sca.budget.DEFAULT_UNCERTAIN is DEFAULT_UNCERTAIN  # submodules as attributes
    with pytest.raises(AttributeError, match="no attribute 'nonexistent'"):
        sca.nonexistent  # noqa: B018


def test_default_spectra_and_tables_need_no_colour_science():
    code = ("import forward\nfrom uw3p.common import camera_note\n"
            "forward.Water().on_grid(forward.wavelength_grid())\n"
            "assert camera_note('Nikon 5100 (NPL)') == ''\nforward.camera_sensitivities()\n"
            "forward.illuminant_spd()\nforward.chart_reflectances()\nforward.cie_1931_cmfs()")
    assert "colour" not in _loaded(code)


def test_the_colour_matrix_training_set_needs_no_colour_science():
    """The colour matrix's 29 training reflectances come from the cached table (issue 48):
    the same samples, in colour-science's order and with its names, without importing it."""
    code = ("import forward\nfrom measure.correct_matrix import training_reflectances\n"
            "training_reflectances(forward.wavelength_grid())")
    assert "colour" not in _loaded(code)
    from colour.quality import datasets

    from measure.correct_matrix import TRAINING_SETS, training_reflectances

    names, refl = training_reflectances(spectra.wavelength_grid())
    assert names == tuple(f"{name} {k}" for db, name in TRAINING_SETS
                          for k in getattr(datasets, db)[name])
    np.testing.assert_array_equal(refl, np.hstack([spectra.colour_spectrum(db, name)
                                                   for db, name in TRAINING_SETS]))


@pytest.mark.parametrize("wavelengths", [None, np.arange(400.0, 701.0, 10.0),
                                         np.array([410.0, 555.0, 699.0])])
def test_colour_cache_is_colour_science_bit_for_bit(wavelengths):
    """Every cached column equals colour-science's own (the installed version's) resampling,
    on the cache's 1 nm grid and on grids of some of its nodes."""
    for (database, name) in spectra.COLOUR_CACHE_COLUMNS:
        wl = spectra.wavelength_grid(wavelengths)
        cached = spectra._cached(database, name, wl)
        assert cached is not None
        np.testing.assert_array_equal(cached, spectra.colour_spectrum(database, name, wl))


@pytest.mark.parametrize("table", ["pure_water_absorption_smith_baker_1981.csv",
                                   "phytoplankton_absorption_basis.csv"])
def test_resampling_is_colour_sciences_linear_interpolator_bit_for_bit(table):
    import colour

    src, vals = spectra.read_spectral_table(table)
    for wl in (spectra.wavelength_grid(), np.linspace(400.0, 700.0, 77)):
        ours = spectra.resample(src, vals, wl, name="table")
        for j in range(vals.shape[1]):
            sd = colour.SpectralDistribution(vals[:, j], src,
                                             interpolator=colour.LinearInterpolator)
            np.testing.assert_array_equal(ours[:, j], sd[wl])


#: How far colour-science's own sRGB numbers move between CPUs (measured on an AVX2 machine
#: against the cache written on an AVX-512 one): the decoding's levels by 1 ulp (numpy's power
#: is SVML's on AVX-512, the C library's otherwise), the reference chart by up to 40 ulp,
#: 6e-15 relative (BLAS/LAPACK's matrix kernels, with cancellation in its darkest values). A
#: change of colour-science's numbers (a constant, a chromaticity) moves them by 1e-4 or more.
SRGB_RTOL = 1e-12


def test_srgb_cache_is_colour_sciences():
    """The sRGB table is colour-science's matrix and its encoding's 8-bit levels (to the
    rounding of the CPU's power function, :data:`SRGB_RTOL`), with the published
    IEC 61966-2-1 values."""
    import colour

    matrix, levels = spectra.srgb_8bit()
    np.testing.assert_array_equal(matrix, colour.RGB_COLOURSPACES["sRGB"].matrix_XYZ_to_RGB)
    np.testing.assert_allclose(levels, colour.cctf_decoding((np.arange(1, 256) - 0.5) / 255,
                                                            function="sRGB"),
                               rtol=SRGB_RTOL, atol=0)
    assert tuple(matrix[0]) == (3.2406, -1.5372, -0.4986)  # IEC 61966-2-1, first row
    assert levels[0] == pytest.approx(0.5 / 255 / 12.92, rel=1e-12)  # the linear segment
    assert not matrix.flags.writeable and not levels.flags.writeable
    from experiments.colour_tables import reference_chart_from_colour

    chart = spectra.reference_chart_linear_srgb()
    np.testing.assert_allclose(chart, reference_chart_from_colour(), rtol=SRGB_RTOL, atol=0)
    assert chart.shape == (24, 3) and not chart.flags.writeable


def test_srgb_codes_at_the_encodings_steps():
    """Every float32 value within 4 ulp of each of the 255 levels gets colour-science's
    rounded code (the steps are where an off-by-one would show); NaN gives 0."""
    import colour

    from measure.output import encode_srgb_8bit

    _, levels = spectra.srgb_8bit()
    x = levels.astype(np.float32)[:, None]
    for _ in range(4):
        x = np.concatenate([np.nextafter(x[:, :1], np.float32(-1)), x,
                            np.nextafter(x[:, -1:], np.float32(2))], axis=1)
    ref = (colour.cctf_encoding(np.clip(x, 0.0, 1.0), function="sRGB") * 255 + 0.5
           ).astype(np.uint8)
    np.testing.assert_array_equal(encode_srgb_8bit(x), ref)
    assert encode_srgb_8bit(np.array([np.nan, -1.0, 2.0], np.float32)).tolist() == [0, 0, 255]


def test_chart_detection_reads_its_reference_colours_without_colour_science():
    assert "colour" not in _loaded("from measure import detect\ndetect.reference_rgb()")


def test_srgb_preview_is_colour_sciences_encoding():
    """srgb_preview's 8-bit codes are colour-science's sRGB encoding of the clipped linear
    values, rounded, on every pixel (below 0, above 1, the linear segment and the power
    law)."""
    import colour

    from measure.output import srgb_preview

    rng = np.random.default_rng(3)
    img = np.concatenate([rng.uniform(-0.1, 1.3, (40, 50, 3)),
                          rng.uniform(0.0, 0.004, (40, 50, 3))]) * 5000.0
    setup = forward.chart_setup()
    white = np.array([4000.0, 5000.0, 4500.0])
    ours = srgb_preview(img, setup, white)
    to_xyz = forward.camera_to_xyz_matrix(setup)
    srgb = colour.RGB_COLOURSPACES["sRGB"]
    A = srgb.matrix_XYZ_to_RGB @ to_xyz / float((to_xyz @ white)[1])
    lin = np.asarray(img, np.float32) @ A.T.astype(np.float32)
    ref = (srgb.cctf_encoding(np.clip(lin, 0.0, 1.0)) * 255 + 0.5).astype(np.uint8)
    assert ours.dtype == np.uint8 and ours.shape == img.shape
    np.testing.assert_array_equal(ours, ref)
    assert ours.min() == 0 and ours.max() == 255


def test_cached_data_ranges_are_colour_sciences():
    import colour

    for (database, name), (lo, hi) in spectra.COLOUR_CACHE_RANGES_NM.items():
        wl = getattr(colour, database)[name].wavelengths
        assert (lo, hi) == (wl[0], wl[-1])
    assert spectra.colour_wavelength_range("MSDS_CAMERA_SENSITIVITIES", "Sigma SDMerill (NPL)"
                                           )[1] == 680.0


def test_grids_off_the_cache_come_from_colour_science():
    wl = np.array([400.5, 550.25, 699.5])
    assert spectra._cached("SDS_ILLUMINANTS", "D65", wl) is None
    np.testing.assert_array_equal(forward.illuminant_spd(wavelengths=wl),
                                  np.clip(spectra.colour_spectrum("SDS_ILLUMINANTS", "D65", wl),
                                          0, None)
                                  / spectra.colour_spectrum("SDS_ILLUMINANTS", "D65", wl).max())
    assert spectra._cached("MSDS_CAMERA_SENSITIVITIES", "Nikon 5100 (NPL)", wl) is None
    assert spectra._cached("MSDS_CAMERA_SENSITIVITIES", "Sony ILCE-7RII", wl[:1]) is None


def _lit_chart(theta, seed):
    setup = forward.chart_setup()
    field = 1.0 + lightfield.field_basis()[:, :len(theta)] @ np.asarray(theta, float)
    lit = dataclasses.replace(setup, reflectances=setup.reflectances * field[None, :])
    sim = forward.simulate_chart(1.0, 0.1, 5.0, 1.5, setup=lit, seed=seed)
    return setup, sim.rgb * 3000.0, sim.rgb_sigma * 3000.0


@pytest.mark.parametrize("theta,model", [((0.05, -0.03), "plane"),
                                         ((0.02, 0.01, -0.04), "plane+radial")])
def test_light_field_search_reaches_the_minimum(theta, model):
    """The Gauss-Newton search picks the true model, recovers the field to within the noise,
    and stops at a minimum of the fit's chi^2: no coordinate step of 1e-4 lowers it."""
    setup, M, sigma = _lit_chart(theta, seed=1)
    res = lightfield.fit_light_field(M, sigma, setup, 5.0, 1.5, uncertain={"patch": 0.01})
    assert res["model"] == model
    np.testing.assert_allclose(res["coefficients"], theta, atol=3e-3)
    basis = lightfield.field_basis()
    noise_sd = np.sqrt(sigma ** 2 + (0.01 * M) ** 2)
    for name, k in lightfield.FIELDS.items():
        if k == 0:
            continue
        best = res["tests"][name]["chi2"]
        th = np.asarray(res["coefficients"], float) if name == model else None
        if th is None:  # the other model's optimum: search again from zero
            th, chi2 = lightfield._minimise(np.zeros(k), basis, M, sigma, noise_sd, setup, 5.0,
                                            1.5, None, {"patch": 0.01})
            assert chi2 == pytest.approx(best, abs=1e-4)
        for j in range(k):
            for h in (-1e-4, 1e-4):
                step = th.copy()
                step[j] += h
                b = lightfield._fit_at(step, basis, M, sigma, setup, 5.0, 1.5, None,
                                       {"patch": 0.01})[0]
                assert float(b.objective[0]) >= best - 1e-6


def test_even_light_keeps_no_field():
    setup, M, sigma = _lit_chart((0.0, 0.0), seed=2)
    res = lightfield.fit_light_field(M, sigma, setup, 5.0, 1.5)
    assert res["model"] == "none" and res["coefficients"] == []
    assert res["tests"]["plane"]["p_value"] > lightfield.LIGHT_FIELD_ALPHA
    assert res["tests"]["plane"]["chi2"] <= res["tests"]["none"]["chi2"]


def test_one_chart_and_one_photo_need_no_cvxpy_nor_scipy_stats():
    """The command line's default engine ('lm') fits one chart without cvxpy, and a photo's
    measurement does not load the dive's machinery (scipy.stats, scipy.optimize, Dask)."""
    fit = ("import numpy as np, forward, sca\n"
           "s = forward.simulate_chart(1.0, 0.1, 5.0, 1.5, seed=1)\n"
           "sca.estimate(s.rgb, depth=5.0, distance=1.5, sigma=s.rgb_sigma, mode='lm')\n"
           "import sys; assert not any(m.split('.')[0] in ('cvxpy', 'dask') or "
           "m.startswith(('scipy.stats', 'scipy.optimize')) for m in sys.modules), "
           "sorted(m for m in sys.modules if m.startswith(('cvxpy', 'scipy.stats', "
           "'scipy.optimize', 'dask')))[:5]")
    subprocess.run([sys.executable, "-c", fit], check=True, capture_output=True)
    assert "cvxpy" not in _loaded("import measure; measure.measure; measure.write_outputs")


def test_lm_mode_is_the_loops_optimum():
    """sca.estimate(mode='lm') (the batch's engine on one chart) and the DPP loop agree on the
    same grid: C and a_CDOM, their intervals and the verdict, with and without the budget."""
    import sca

    for c, a, d, r, unc in ((1.0, 0.1, 5.0, 1.5, None), (20.0, 0.5, 10.0, 5.0, {}),
                            (0.05, 2.0, 1.0, 0.5, None)):
        sim = forward.simulate_chart(c, a, d, r, seed=3)
        loop = sca.estimate(sim.rgb, depth=d, distance=r, sigma=sim.rgb_sigma, uncertain=unc,
                            quadrature="full")
        lm = sca.estimate(sim.rgb, depth=d, distance=r, sigma=sim.rgb_sigma, uncertain=unc,
                          mode="lm", quadrature="full")
        assert loop.converged and lm.converged and lm.mode == "lm"
        assert lm.objective <= loop.objective * (1 + 1e-9)
        assert lm.chl == pytest.approx(loop.chl, rel=1e-5)
        assert lm.cdom == pytest.approx(loop.cdom, rel=1e-5, abs=1e-9)
        np.testing.assert_allclose(lm.chl_ci, loop.chl_ci, rtol=1e-4)
        np.testing.assert_allclose(lm.cdom_ci, loop.cdom_ci, rtol=1e-4, atol=1e-9)
        assert lm.reliable == loop.reliable and lm.flags == loop.flags


def test_lm_mode_refuses_what_it_cannot_fit():
    """'lm' needs one basis function; measure.measure names a bad mode before any work."""
    import measure
    import sca

    T1, _ = forward.phytoplankton_basis()
    T = np.column_stack([T1[:, 0], np.linspace(1.0, 0.2, 301)])  # as tests/test_sca.py
    sim = forward.simulate_chart(2.0, 0.2, 5.0, 1.0, basis=T, weights=[1.0, 0.5], seed=4)
    with pytest.raises(ValueError, match="mode: 'lm' supports one basis function"):
        sca.estimate(sim.rgb, depth=5.0, distance=1.0, sigma=sim.rgb_sigma, basis=T, mode="lm")
    with pytest.raises(ValueError, match="mode: must be one of"):
        measure.measure("missing.dng", depth=5.0, distance=1.5, mode="fast")
