"""The first of the three parameters: the phytoplankton absorption shape w (eq 9, z > 1).

Basis (read, never copied: ``../shared/realdata/ocean_optics_tables/bricaud_1998_aph.txt``,
NASA GIOP's table of Bricaud et al. 1998, a_phi(lambda) = A(lambda) C^E(lambda)): z = 2
shapes, the Bricaud spectrum of oligotrophic water (C = :data:`CHL_OLIGO`) and of eutrophic
water (C = :data:`CHL_EUTRO`), each scaled to 1 at 440 nm. A mixture w = (w_1, w_2) with eq
17 (t440 . w = a_phi(440) = 0.0378 C^0.627) has one free number beyond C: the eutrophic
fraction f = w_2 / (w_1 + w_2) of the absorption at 440 nm (the package effect: larger cells
flatten the spectrum).

What is done (:func:`run`):

* **Simulated camera data**: charts simulated with the basis and a true f
  (:func:`forward.simulate_chart`, ``basis=``, ``weights=``), estimated with
  :func:`sca.estimate` (free gain, ``basis=``: w free under eq 17), :data:`SEEDS` noise draws
  per condition: the estimated f against the truth (bias, spread).
* **What a camera can tell**: the Cramér-Rao bound of f from the Jacobian of the one model
  function (:meth:`sca.model.ChartModel.predict`, ``free=('chl', 'cdom', 'w', 'gain',
  'backscatter')``) with eq 17 as a constraint (the bound on the constraint's null space).
  :func:`sca.precision` refuses a basis with z > 1, so the same information is assembled here
  from the same model function; the sensor's noise is :func:`forward.simulate_chart`'s.
* **NOMAD** (real a_phi = a_p - a_d at up to 20 bands, 405-683 nm): how much of a measured
  a_phi's shape one basis function (the package's) leaves unexplained, and how much two (the
  Bricaud pair) do, by nonnegative least squares on each station's spectrum.
"""

from __future__ import annotations

import gzip
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import scipy.linalg
import scipy.optimize

import forward
import sca
from sca.model import ChartModel

from ..common import save_figure, style

__all__ = ["CHL_EUTRO", "CHL_OLIGO", "COMMAND", "CONDITIONS", "FRACTION_TRUE", "FREE",
           "NOMAD_MIN_BANDS", "REALDATA", "SEEDS", "bricaud_basis", "constrained_covariance",
           "fraction", "fraction_bound", "nomad_shapes", "run", "simulate_fraction"]

#: ``../shared/realdata`` beside the repository (absent in an installed package).
REALDATA = Path(__file__).resolve().parents[2].parent / "shared" / "realdata"
#: C of the oligotrophic and eutrophic Bricaud shapes, mg m^-3 (the ends of the open-ocean
#: range of Bricaud et al. 1998, 0.02-25 mg m^-3, brought in by a decade).
CHL_OLIGO, CHL_EUTRO = 0.1, 10.0
#: The true eutrophic fraction of the simulations.
FRACTION_TRUE = 0.5
#: Conditions of the simulations: (C mg m^-3, a_CDOM(440) m^-1, depth m, distance m).
CONDITIONS = ((0.3, 0.02, 2.0, 1.0), (1.0, 0.05, 5.0, 1.0), (3.0, 0.1, 5.0, 1.0),
              (10.0, 0.1, 2.0, 1.0))
#: Noise draws per condition.
SEEDS = 10
#: The per-patch systematic term of the second bound (the package's default budget, relative).
PATCH_SD = float(sca.budget.DEFAULT_UNCERTAIN["patch"])
#: Fewest a_phi bands a NOMAD station needs to be fitted.
NOMAD_MIN_BANDS = 10
#: Grid of the simulations, nm (the package's estimation grid step; fast and fine enough for
#: the smooth a_phi).
GRID = np.arange(400.0, 701.0, 5.0)
#: The command that produces every number here.
COMMAND = ("OPENBLAS_NUM_THREADS=1 .venv/bin/python -c \"from pathlib import Path; "
           "from experiments.realwater import phyto; "
           "print(phyto.run(Path('figures/realwater'))[0])\"")


def _bricaud():
    path = REALDATA / "ocean_optics_tables" / "bricaud_1998_aph.txt"
    if not path.exists():
        raise FileNotFoundError(f"realdata: {path} is absent (../shared/realdata beside the "
                                "repository)")
    t = np.loadtxt(path, delimiter=",")
    return t[:, 0], t[:, 3], t[:, 4]  # wl, A_phi, E_phi


def bricaud_basis(wavelengths=GRID) -> np.ndarray:
    """The z = 2 basis: Bricaud et al. 1998's a_phi shape at C = 0.1 and at C = 10 mg m^-3.

    Parameters
    ----------
    wavelengths : array_like
        The grid, nm (within 400-700).

    Returns
    -------
    numpy.ndarray, (q, 2)
        A(lambda) C^E(lambda) on the grid, each column scaled to 1 at 440 nm.

    Raises
    ------
    FileNotFoundError
        When the table in ``../shared/realdata`` is absent.

    References
    ----------
    A. Bricaud, A. Morel, M. Babin, K. Allali and H. Claustre, "Variations of light absorption
    by suspended particles with chlorophyll a concentration in oceanic (case 1) waters",
    J. Geophys. Res. 103(C13), 31033-31044 (1998).
    """
    wl, A, E = _bricaud()
    cols = []
    for c in (CHL_OLIGO, CHL_EUTRO):
        a = A * c ** E
        cols.append(np.interp(wavelengths, wl, a) / np.interp(440.0, wl, a))
    return np.column_stack(cols)


def fraction(w) -> float:
    """The eutrophic fraction f = w_2 / (w_1 + w_2) of a_phi(440) (t440 = (1, 1))."""
    w = np.asarray(w, float)
    return float(w[1] / w.sum())


def simulate_fraction(basis, chl, cdom, depth, distance, seeds=SEEDS) -> dict:
    """Estimate f from simulated charts whose true fraction is :data:`FRACTION_TRUE`.

    Parameters
    ----------
    basis : numpy.ndarray, (q, 2)
        The basis on :data:`GRID`.
    chl, cdom, depth, distance : float
        The condition (mg m^-3, m^-1, m, m).
    seeds : int
        Noise draws.

    Returns
    -------
    dict
        'f' (estimates), 'chl' (estimates), 'converged' (count), 'sigma' (the last draw's
        noise sd, (3, 24)), 'backscatter' and 'expected' (noise-free values) of the truth for
        the bound.
    """
    shape = np.array([1.0 - FRACTION_TRUE, FRACTION_TRUE])
    f, chls, ok = [], [], 0
    sim = None
    for seed in range(seeds):
        sim = forward.simulate_chart(chl, cdom, depth, distance, seed=seed, wavelengths=GRID,
                                     basis=basis, weights=shape)
        est = sca.estimate(sim.rgb, depth=depth, distance=distance, sigma=sim.rgb_sigma,
                           gain="free", basis=basis, wavelengths=GRID, uncertain={})
        f.append(fraction(est.w))
        chls.append(float(est.chl))
        ok += bool(est.converged)
    return {"f": f, "chl": chls, "converged": ok, "sigma": sim.rgb_sigma,
            "backscatter": np.asarray(sim.backscatter, float), "expected": sim.rgb_expected}


FREE = ("chl", "cdom", "w", "gain", "backscatter")


def constrained_covariance(model: ChartModel, params: dict, sigma) -> np.ndarray:
    """Cramér-Rao covariance of theta = (C, a_CDOM, w, gain, s) with eq 17 as a constraint.

    The Fisher information F = J^T diag(sigma^-2) J from :meth:`sca.model.ChartModel.predict`
    (``free`` = :data:`FREE`); eq 17, g(theta) = t440 . w - 0.0378 C^0.627 = 0, restricts
    theta to the null space U of its gradient, so cov = U (U^T F U)^-1 U^T. For z = 1 this is
    :func:`sca.precision`'s bound (tests/test_realwater_g7x.py checks it).

    Parameters
    ----------
    model : sca.model.ChartModel
        The chart model (its basis sets z).
    params : dict
        The condition: 'chl', 'cdom', 'depth', 'distance', 'w' (z,), 'gain', 'backscatter'.
    sigma : array_like, (3, 24)
        The noise sd of each patch value (model units).

    Returns
    -------
    numpy.ndarray, (4 + z + 2, 4 + z + 2)
        Covariance in the order C, a_CDOM, w_1..w_z, gain, s_R, s_G, s_B.

    References
    ----------
    J. D. Gorman and A. O. Hero, "Lower bounds for parametric estimation with constraints",
    IEEE Trans. Inf. Theory 36(6), 1285-1301 (1990).
    """
    pred = model.predict(params, free=FREE)
    J = pred.jacobian.reshape(-1, pred.jacobian.shape[-1]) / np.ravel(sigma)[:, None]
    F = J.T @ J
    grad = np.zeros(F.shape[0])
    grad[0] = -float(model.phyto_scale(params["chl"], derivative=True)[1])
    grad[2:2 + model.z] = model.t440
    U = scipy.linalg.null_space(grad[None, :])
    return U @ np.linalg.pinv(U.T @ F @ U) @ U.T


def fraction_bound(basis, chl, cdom, depth, distance, sigma, backscatter) -> float:
    """Cramér-Rao standard deviation of f (:func:`constrained_covariance`, delta method).

    Parameters
    ----------
    basis : numpy.ndarray, (q, 2)
        The basis on :data:`GRID`.
    chl, cdom, depth, distance : float
        The condition.
    sigma : numpy.ndarray, (3, 24)
        The noise sd of each patch value (model units).
    backscatter : numpy.ndarray, (3,)
        The veiling light (model units).

    Returns
    -------
    float
        sd(f), dimensionless.
    """
    model = ChartModel(forward.chart_setup(wavelengths=GRID), basis=basis)
    w = model.feasible_w(chl, np.array([1.0 - FRACTION_TRUE, FRACTION_TRUE]))
    cov = constrained_covariance(model, {"chl": chl, "cdom": cdom, "depth": depth,
                                         "distance": distance, "w": w, "gain": 1.0,
                                         "backscatter": backscatter}, sigma)
    s = w.sum()
    df = np.zeros(cov.shape[0])
    df[2:4] = [-w[1] / s ** 2, w[0] / s ** 2]  # d f / d w
    return float(np.sqrt(df @ cov @ df))


def nomad_shapes(package_basis, bricaud) -> dict:
    """How much of real a_phi's shape one or two basis functions explain (NOMAD v2).

    a_phi = a_p - a_d at the NOMAD bands (405-683 nm); stations with at least
    :data:`NOMAD_MIN_BANDS` valid, positive values. Each spectrum is fitted by nonnegative
    least squares with (1) the package's single shape and (2) the Bricaud pair; the number is
    the relative RMS residual ||a - T w|| / ||a||.

    Parameters
    ----------
    package_basis : callable
        wavelengths -> (q, 1) the package's shape.
    bricaud : callable
        wavelengths -> (q, 2) the Bricaud pair.

    Returns
    -------
    dict
        'n' stations, 'one' and 'two' (relative RMS residuals, per station), 'fraction'
        (Bricaud eutrophic fraction per station), 'chl' (mg m^-3).

    Raises
    ------
    FileNotFoundError
        When the NOMAD file is absent.
    """
    path = REALDATA / "nomad" / "nomad_seabass_v2.a_2008200.txt.gz"
    if not path.exists():
        raise FileNotFoundError(f"realdata: {path} is absent")
    with gzip.open(path, "rt", encoding="latin-1") as fh:
        lines = [ln for ln in fh if not ln.startswith("!")]
    header = lines[0].strip().split(",")
    data = np.genfromtxt(lines[1:], delimiter=",", usecols=range(len(header)), dtype=float)
    col = {h: i for i, h in enumerate(header)}
    bands = [int(h[2:]) for h in header if h.startswith("ap") and h[2:].isdigit()
             and f"ad{h[2:]}" in col]
    ap = data[:, [col[f"ap{b}"] for b in bands]]
    ad = data[:, [col[f"ad{b}"] for b in bands]]
    chl = data[:, col["chl"]]
    if "chl_a" in col:  # HPLC where present, else fluorometric
        chl = np.where(data[:, col["chl_a"]] > 0, data[:, col["chl_a"]], chl)
    wl = np.array(bands, float)
    T1, T2 = package_basis(wl), bricaud(wl)
    bwl, A, E = _bricaud()
    one, two, at_c, frac, chls = [], [], [], [], []
    for k in range(data.shape[0]):
        a = ap[k] - ad[k]
        good = (ap[k] > -999) & (ad[k] > -999) & (a > 0)
        if good.sum() < NOMAD_MIN_BANDS:
            continue
        y = a[good]
        for T, out in ((T1, one), (T2, two)):
            w, res = scipy.optimize.nnls(T[good], y)
            out.append(float(res / np.linalg.norm(y)))
            if T is T2:
                frac.append(fraction(w) if w.sum() > 0 else float("nan"))
        if chl[k] > 0:  # one function chosen by the station's own C: A C^E
            Tc = np.interp(wl, bwl, A * chl[k] ** E)[good, None]
            _, res = scipy.optimize.nnls(Tc, y)
            at_c.append(float(res / np.linalg.norm(y)))
        chls.append(float(chl[k]))
    return {"n": len(one), "one": one, "two": two, "at_c": at_c, "fraction": frac, "chl": chls,
            "bands_nm": bands}


def _package_basis(wl) -> np.ndarray:
    T, _ = forward.phytoplankton_basis(np.clip(wl, 400.0, 700.0))
    return T


def run(outdir: Path) -> tuple[str, dict]:
    """The w experiment: simulated recovery, Cramér-Rao bound, NOMAD shapes.

    Parameters
    ----------
    outdir : pathlib.Path
        Folder of the figure ``phyto_w.png``.

    Returns
    -------
    markdown : str
        The section for REALWATER.md.
    numbers : dict
        Every number of the section.

    Raises
    ------
    FileNotFoundError
        When ``../shared/realdata`` is absent.
    """
    style()
    T = bricaud_basis(GRID)
    rows = []
    for chl, cdom, depth, distance in CONDITIONS:
        sim = simulate_fraction(T, chl, cdom, depth, distance)
        bound = fraction_bound(T, chl, cdom, depth, distance, sim["sigma"], sim["backscatter"])
        with_patch = np.sqrt(sim["sigma"] ** 2 + (PATCH_SD * sim["expected"]) ** 2)
        bound_patch = fraction_bound(T, chl, cdom, depth, distance, with_patch,
                                     sim["backscatter"])
        f = np.asarray(sim["f"])
        rows.append({"chl": chl, "cdom": cdom, "depth_m": depth, "distance_m": distance,
                     "f_mean": float(f.mean()), "f_sd": float(f.std(ddof=1)),
                     "f_bound_sd": bound, "f_bound_sd_patch": bound_patch, "converged": sim["converged"], "seeds": SEEDS,
                     "chl_median": float(np.median(sim["chl"]))})
    try:
        nomad = nomad_shapes(_package_basis, bricaud_basis)
    except FileNotFoundError as exc:
        nomad = {"n": 0, "error": str(exc)}
    numbers = {"fraction_true": FRACTION_TRUE, "basis_chl": [CHL_OLIGO, CHL_EUTRO],
               "simulated": rows, "nomad": _nomad_summary(nomad)}
    numbers["figures"] = [str(p) for p in _figure(T, nomad, outdir)]
    return _markdown(numbers), numbers


def _nomad_summary(nomad) -> dict:
    if not nomad.get("n"):
        return nomad
    one, two = np.asarray(nomad["one"]), np.asarray(nomad["two"])
    frac = np.asarray(nomad["fraction"])
    chl = np.asarray(nomad["chl"])
    ok = np.isfinite(frac) & (chl > 0)
    r = float(np.corrcoef(np.log(chl[ok]), frac[ok])[0, 1]) if ok.sum() > 2 else float("nan")
    q = [0.5, 0.9]
    return {"n": nomad["n"], "bands_nm": nomad["bands_nm"],
            "one_median": float(np.median(one)), "one_p90": float(np.quantile(one, 0.9)),
            "two_median": float(np.median(two)), "two_p90": float(np.quantile(two, 0.9)),
            "at_c_n": len(nomad["at_c"]), "at_c_median": float(np.median(nomad["at_c"])),
            "at_c_p90": float(np.quantile(nomad["at_c"], 0.9)),
            "fraction_quantiles": np.nanquantile(frac, [0.1, 0.5, 0.9]).tolist(),
            "r_fraction_lnchl": r, "quantiles": q,
            "one": one.tolist(), "two": two.tolist()}


def _figure(T, nomad, outdir) -> list:
    fig, axes = plt.subplots(1, 2, figsize=(7.2, 2.6), constrained_layout=True)
    axes[0].plot(GRID, T[:, 0], label=f"Bricaud C = {CHL_OLIGO:g}")
    axes[0].plot(GRID, T[:, 1], label=f"Bricaud C = {CHL_EUTRO:g}")
    axes[0].plot(GRID, _package_basis(GRID)[:, 0], "k--", label="package (uwSim)")
    axes[0].set_xlabel("wavelength (nm)")
    axes[0].set_ylabel("a_φ / a_φ(440)")
    axes[0].legend(fontsize=7)
    if nomad.get("n"):
        bins = np.linspace(0, 0.6, 31)
        axes[1].hist(nomad["one"], bins, alpha=0.6, label="one function (package)")
        axes[1].hist(nomad["two"], bins, alpha=0.6, label="two (Bricaud pair)")
        axes[1].set_xlabel("relative RMS residual of NOMAD a_φ")
        axes[1].set_ylabel("stations")
        axes[1].legend(fontsize=7)
    else:
        axes[1].set_axis_off()
    return save_figure(fig, "phyto_w", outdir)


def _markdown(n) -> str:
    lines = [
        "## The phytoplankton shape w (eq 9 with z = 2)",
        "",
        (f"Command: `{COMMAND}` (figure `phyto_w.png`). Basis: Bricaud et al. 1998's a_φ shape "
        f"at C = {CHL_OLIGO:g} and {CHL_EUTRO:g} mg m⁻³ (read from "
        "`../shared/realdata/ocean_optics_tables/bricaud_1998_aph.txt`); with eq 17 the one "
        "number w adds is f, the eutrophic fraction of a_φ(440). Simulated charts: Nikon 5100 "
        f"(NPL), D65, the package's sensor noise, free exposure gain, true f = "
        f"{n['fraction_true']:g}, {SEEDS} noise draws per condition; bound: Cramér–Rao with "
        "eq 17 as a constraint, from `sca.model.ChartModel.predict`'s Jacobian "
        "(`sca.precision` refuses z > 1)."),
        "",
        ("| C (mg m⁻³) | a_CDOM(440) (m⁻¹) | depth + distance (m) | mean f̂ | sd f̂ | "
         f"Cramér–Rao sd | sd with {PATCH_SD:.0%} per-patch error | converged |"),
        "|---|---|---|---|---|---|---|---|",
    ]
    lines += [f"| {r['chl']:g} | {r['cdom']:g} | {r['depth_m']:g} + {r['distance_m']:g} | "
              f"{r['f_mean']:.3f} | {r['f_sd']:.3f} | {r['f_bound_sd']:.3f} | "
              f"{r['f_bound_sd_patch']:.3f} | {r['converged']}/{r['seeds']} |"
              for r in n["simulated"]]
    lines += ["", "The bound's assembly gives `sca.precision`'s sd of C exactly for z = 1 "
              "(tests/test_realwater_g7x.py). The estimates' spread is "
              + ", ".join(f"{r['f_sd'] / r['f_bound_sd']:.2f}" for r in n["simulated"])
              + f" × the bound over {SEEDS} draws (a sample sd of {SEEDS} draws is uncertain "
              "by ~±25 %)."]
    nm = n["nomad"]
    lines.append("")
    if nm.get("n"):
        lines.append(
            f"**NOMAD** ({nm['n']} stations with ≥ {NOMAD_MIN_BANDS} bands of a_φ = a_p − a_d, "
            f"{nm['bands_nm'][0]}–{nm['bands_nm'][-1]} nm): relative RMS residual of a "
            f"nonnegative fit with the package's one shape: median {nm['one_median']:.1%} "
            f"(90th percentile {nm['one_p90']:.1%}); with the Bricaud pair: median "
            f"{nm['two_median']:.1%} ({nm['two_p90']:.1%}); with one Bricaud shape chosen by the "
            f"station's own C (A C^E, {nm['at_c_n']} stations with C): median "
            f"{nm['at_c_median']:.1%} ({nm['at_c_p90']:.1%}). The pair's eutrophic fraction "
            f"spans {nm['fraction_quantiles'][0]:.2f}–{nm['fraction_quantiles'][2]:.2f} "
            f"(10th–90th percentile, median {nm['fraction_quantiles'][1]:.2f}); correlation "
            f"with ln C: r = {nm['r_fraction_lnchl']:.2f}.")
    else:
        lines.append(f"NOMAD part skipped: {nm.get('error', 'no stations')}.")
    return "\n".join(lines) + "\n"
