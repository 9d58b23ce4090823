"""The camera as a measuring instrument: predicted precision of C and a_CDOM, camera comparison.

    python -m experiments.instrument [--out figures] [--doc INSTRUMENT.md] [--camera-csv FILE]

The paper: "We use the inverse estimation method as a metric to evaluate how well any digital
camera can be used to measure environmental parameters." Here with the Cramér-Rao bound of
:func:`sca.precision` with the default uncertainty budget (:data:`sca.budget.DEFAULT_UNCERTAIN`),
the camera-only bound (photon and read noise alone, ``uncertain={}``) beside it for contrast
(the estimator attains the camera-only bound: the validation table; DESIGN.md checks the
budget's dive designs on an independent world), and the designs of :func:`sca.design`:

* cameras: Nikon 5100 and Sigma SDMerill (colour-science's NPL curves; the Sigma's stop at
  680 nm, so its grid is 400-680 nm), a hypothetical 6-band camera (:data:`BANDS_NM`, Gaussian,
  20 nm FWHM, peak 1) and any user camera CSV (``--camera-csv``);
* water types :data:`WATERS`; depths :data:`DEPTHS_M`; distances 1 and 5 m; daylight
  (20 000 lx) and dim light (200 lx); the default sensor otherwise;
* what a dive buys: :data:`DESIGN_TARGETS` for each water type over :data:`DESIGN_DEPTHS_M` and
  :data:`DESIGN_DISTANCES_M` (:func:`design_table`), with the budget and camera-only;
* writes ``instrument_precision.csv`` (every condition), ``instrument_validation.csv`` (bound
  vs the estimator's spread over :data:`DRAWS` noise draws), ``instrument.png`` and the tables of
  INSTRUMENT.md.
"""

from __future__ import annotations

import argparse
import itertools
from pathlib import Path

import numpy as np

import forward
import sca

from .common import figures_dir, read_csv, save_figure, style, write_csv
from .sweep import pearson


def _paper_like_setting():
    from .grids import setting

    return setting("paper-like")


__all__ = ["cameras", "precision_table", "validation", "depth_limit", "depth_ranges",
           "format_ranges", "budget_table", "BUDGET_DEPTHS_M", "design_table", "DESIGN_TARGETS",
           "DESIGN_DEPTHS_M", "DESIGN_DISTANCES_M", "C_LEVEL",
           "paper_connection", "connection_text", "plot", "doc", "main", "WATERS", "DEPTHS_M",
           "DISTANCES_M", "LIGHTS_LUX", "BANDS_NM", "FWHM_NM", "DRAWS", "GAINS",
           "VALIDATION_SEED", "VALIDATION_DEPTHS_M", "VALIDATION_DISTANCE_M",
           "CONNECTION_DRAWS", "CONNECTION_SEED", "reference_light", "reference_table",
           "PATCH_LEVELS", "REFERENCE_SHOTS"]

#: name: (C mg m^-3, a_CDOM(440) m^-1)
WATERS = {"clear ocean": (0.1, 0.01), "coastal": (1.0, 0.1), "turbid": (10.0, 0.5)}
DEPTHS_M = (1.0, 2.0, 3.0, 5.0, 7.0, 10.0, 15.0, 20.0, 25.0, 30.0)
DISTANCES_M = (1.0, 5.0)
LIGHTS_LUX = (20000.0, 200.0)
#: centres of the hypothetical multispectral camera's bands (nm), 20 nm FWHM
BANDS_NM = (425.0, 475.0, 525.0, 575.0, 625.0, 675.0)
FWHM_NM = 20.0
#: The validation: noise draws per condition, their seeds VALIDATION_SEED + the draw's index,
#: at these depths and distance (m)
DRAWS = 300
VALIDATION_SEED = 7000
VALIDATION_DEPTHS_M = (5.0, 10.0, 20.0)
VALIDATION_DISTANCE_M = 1.0
#: The bound against Fig 12 at the paper-like setting: fresh noise draws of the figure's
#: grid (seeds CONNECTION_SEED + ...), fitted as the figure is (unweighted, the setting's grid)
CONNECTION_DRAWS = 30
CONNECTION_SEED = 9000
GAINS = ("known", "free", "channels")
#: The level of the depth table's attenuation column: c at every standard band within +-10 %.
C_LEVEL = 0.10
#: What a dive buys (:func:`design_table`): the targets designed for, over this depth range
#: and these distances (m) -- a diver's dive (the issue's 2-15 m and 1-3 m).
DESIGN_TARGETS = ({"chl": 0.30}, {"c": 0.05})
DESIGN_DEPTHS_M = (2.0, 15.0)
DESIGN_DISTANCES_M = (1.0, 3.0)


def cameras(camera_csv=None) -> dict:
    """name: dict(camera=..., wavelengths=...) for chart_setup."""
    wl = forward.wavelength_grid()
    sd = FWHM_NM / (2 * np.sqrt(2 * np.log(2)))
    bands = np.exp(-0.5 * ((wl[:, None] - np.array(BANDS_NM)) / sd) ** 2)
    out = {"Nikon 5100": dict(camera="Nikon 5100 (NPL)", wavelengths=None),
           "Sigma SDMerill": dict(camera="Sigma SDMerill (NPL)",
                                  wavelengths=np.arange(400.0, 681.0, 1.0)),
           "6-band (20 nm)": dict(camera=bands, wavelengths=None)}
    if camera_csv:
        out[Path(camera_csv).stem] = dict(camera=str(camera_csv), wavelengths=None)
    return out


def _precision(cam, chl, cdom, depth, distance, lux, uncertain=None, **kw):
    """The bound with the default budget (``uncertain`` None) or as given ({}: camera only)."""
    setup = forward.chart_setup(cam["camera"], wavelengths=cam["wavelengths"])
    return sca.precision(chl, cdom, depth=depth, distance=distance, setup=setup,
                         sensor=forward.SensorSettings(illuminance_lux=lux),
                         uncertain=uncertain, **kw)


def _c_rel95(p) -> np.ndarray:
    """The worst standard band's 95 % half-width of the path's attenuation coefficient."""
    from sca.protocols import C_BANDS

    return np.max([p.quantity_rel95[b] for b in C_BANDS], axis=0)


def precision_table(cams) -> list:
    """Every condition's 95 % half-widths: camera only (``uncertain={}``; keys without a suffix)
    and with the default budget (``_budget``)."""
    rows = []
    grid = list(itertools.product(WATERS.items(), DEPTHS_M, DISTANCES_M))
    chl = np.array([w[1][0] for w, _, _ in grid])
    cdom = np.array([w[1][1] for w, _, _ in grid])
    depth = np.array([d for _, d, _ in grid])
    dist = np.array([r for _, _, r in grid])
    for (name, cam), lux in itertools.product(cams.items(), LIGHTS_LUX):
        res, fixc, fixs = {}, {}, {}
        for tag, unc in (("", {}), ("_budget", None)):
            for g in GAINS:
                res[g + tag] = _precision(cam, chl, cdom, depth, dist, lux, unc, gain=g)
            fixc[tag] = _precision(cam, chl, cdom, depth, dist, lux, unc, gain="free",
                                   fix={"cdom": None})
            fixs[tag] = _precision(cam, chl, cdom, depth, dist, lux, unc, gain="free",
                                   fix={"backscatter": None})
        for j, ((water, _), d, r) in enumerate(grid):
            row = dict(camera=name, lux=lux, water=water, chl=chl[j], cdom=cdom[j], depth=d,
                       distance=r)
            for tag in ("", "_budget"):
                free = res["free" + tag]
                row.update({f"chl_rel95_{g}{tag}": float(res[g + tag].chl_rel95[j])
                            for g in GAINS})
                row.update({f"cdom_rel95_{g}{tag}": float(res[g + tag].cdom_rel95[j])
                            for g in GAINS})
                row.update({f"c_rel95_free{tag}": float(_c_rel95(free)[j]),
                            f"chl_rel95_free_fix_cdom{tag}": float(fixc[tag].chl_rel95[j]),
                            f"chl_rel95_free_fix_backscatter{tag}": float(
                                fixs[tag].chl_rel95[j]),
                            f"correlation_free{tag}": float(free.correlation[j]),
                            f"flags{tag}": " ".join(free.flags[j])})
            row["limiting_free_budget"] = res["free_budget"].limiting[j]
            rows.append(row)
    return rows


def validation() -> list:
    """The bound against the estimator's spread (weighted fits, known gain) over DRAWS draws."""
    rows = []
    r = VALIDATION_DISTANCE_M
    for (water, (c, a)), d, lux in itertools.product(WATERS.items(), VALIDATION_DEPTHS_M,
                                                     LIGHTS_LUX):
        sensor = forward.SensorSettings(illuminance_lux=lux)
        p = sca.precision(c, a, depth=d, distance=r, sensor=sensor, uncertain={})
        # the noise-free chart once, captured DRAWS times: the values of
        # simulate_chart(..., seed=VALIDATION_SEED + s, sensor=sensor) (tests/test_rules.py)
        nf = forward.simulate_chart(c, a, d, r, noise=False)
        caps = [forward.capture(nf.rgb_expected, nf.setup, sensor,
                                rng=np.random.default_rng(VALIDATION_SEED + s)) for s in range(DRAWS)]
        b = sca.estimate_batch(np.array([x["rgb"] for x in caps]), depth=d, distance=r,
                               sigma=np.array([x["sigma"] for x in caps]), intervals=False,
                               uncertain={})
        rows.append(dict(water=water, chl=c, cdom=a, depth=d, lux=lux,
                         chl_sd_bound=float(p.chl_sd), chl_sd_estimator=float(b.chl.std(ddof=1)),
                         chl_ratio=float(b.chl.std(ddof=1) / p.chl_sd),
                         cdom_ratio=float(b.cdom.std(ddof=1) / p.cdom_sd),
                         attained=bool(p.attained), flags=" ".join(p.flags)))
    return rows


#: Depths of the honest-instrument table (distance 1 m, daylight, exposure unknown).
BUDGET_DEPTHS_M = (1.0, 5.0, 10.0, 20.0)


def budget_table() -> list:
    """C's 95 % half-width with the camera's photon and read noise alone (``uncertain={}``)
    against the default uncertainty budget (:data:`sca.budget.DEFAULT_UNCERTAIN`), with the
    source that limits it: the default camera, 20 000 lx, distance 1 m, exposure unknown; and
    C's and c's with the budget's per-patch term at each of :data:`PATCH_LEVELS` (the real G7X
    charts leave 12-43 % per patch beyond photon noise: REPRODUCTION.md)."""
    from sca.budget import DEFAULT_UNCERTAIN

    out = []
    for water, (c, a) in WATERS.items():
        for d in BUDGET_DEPTHS_M:
            kw = dict(depth=d, distance=1.0, gain="free")
            cam = sca.precision(c, a, uncertain={}, **kw)
            hon = sca.precision(c, a, **kw)
            shares = hon.budget.get("chl", {}).get("shares", {})
            levels = {v: sca.precision(c, a, uncertain={**DEFAULT_UNCERTAIN, "patch": v}, **kw)
                      for v in PATCH_LEVELS}
            out.append(dict(water=water, depth=d, chl_rel95_camera=float(cam.chl_rel95),
                            chl_rel95_patch={v: float(p.chl_rel95) for v, p in levels.items()},
                            c_rel95_patch={v: float(_c_rel95(p)) for v, p in levels.items()},
                            chl_rel95_budget=float(hon.chl_rel95),
                            cdom_rel95_camera=float(cam.cdom_rel95),
                            cdom_rel95_budget=float(hon.cdom_rel95),
                            c_rel95_camera=float(_c_rel95(cam)),
                            c_rel95_budget=float(_c_rel95(hon)), limiting=hon.limiting,
                            limiting_share=float(shares.get(hon.limiting, float("nan")))))
    return out


#: The reference shot's table: in-air charts (seeds 0..REFERENCE_SHOTS-1) whose median
#: measured sd is the typical light's, and the per-patch term's levels beside it.
REFERENCE_SHOTS = 10
PATCH_LEVELS = (0.01, 0.03, 0.10, 0.20)


def reference_light():
    """The typical light of a reference shot: :func:`sca.reference.measure_light` on
    :data:`REFERENCE_SHOTS` charts simulated in air (D65, the default camera), centre 0 and the
    median of their sds (:class:`sca.reference.Light`)."""
    from sca.reference import Light, measure_light

    sds = []
    for seed in range(REFERENCE_SHOTS):
        sim = forward.simulate_chart(0.0, 0.0, 0.0, 0.0, seed=seed, backscatter=False)
        sds.append(measure_light(sim.rgb, sim.rgb_sigma).sd)
    return Light(0.0, float(np.median(sds)), float(forward.chart_setup().daylight_cct), 1.0)


def _dtau95(p, length) -> dict:
    """band -> 95 % half-width of the optical depth tau at the band: Z95 sd of 'tau_<band>'
    where :func:`sca.precision` has it, else of c times ``length`` (depth + distance)."""
    from sca.bound import Z95
    from sca.derived import BANDS_NM

    out = {}
    for b in BANDS_NM:
        tau = f"tau_{b:.0f}"
        sd = p.quantity_sd[tau] if tau in p.quantity_sd else p.quantity_sd[f"c_{b:.0f}"] * length
        out[f"{b:.0f}"] = Z95 * np.asarray(sd, float)
    return out


def reference_table(light=None) -> tuple:
    """Δτ (95 % half-width of tau = c (depth + distance) at the standard bands, ``sca.precision``,
    exposure unknown, distance 1 m, :data:`BUDGET_DEPTHS_M`) for every water type with the
    default budget, with the reference shot (``light``, default :func:`reference_light`, 10
    minutes before the dive: :func:`sca.reference.with_reference`), and with the reference and
    the per-patch term at each of :data:`PATCH_LEVELS`. Returns (rows, the budget's daylight
    prior)."""
    from sca.budget import DEFAULT_UNCERTAIN
    from sca.reference import with_reference

    ref = with_reference(None, reference_light() if light is None else light)
    budgets = {"default": None, "reference": ref}
    budgets.update({f"patch {100 * v:g} %": {**ref, "patch": v} for v in PATCH_LEVELS
                    if v != DEFAULT_UNCERTAIN["patch"]})
    grid = list(itertools.product(WATERS.items(), BUDGET_DEPTHS_M))
    chl, cdom = (np.array([w[1][i] for w, _ in grid]) for i in (0, 1))
    depth = np.array([d for _, d in grid])
    dtau = {k: _dtau95(sca.precision(chl, cdom, depth=depth, distance=1.0, gain="free",
                                     uncertain=u), depth + 1.0) for k, u in budgets.items()}
    rows = [dict(water=w, depth=d, **{k: {b: float(v[j]) for b, v in t.items()}
                                      for k, t in dtau.items()})
            for j, ((w, _), d) in enumerate(grid)]
    return rows, ref["daylight"]


def design_table() -> list:
    """What a dive buys: :func:`sca.design` for every water type and target of
    :data:`DESIGN_TARGETS` over :data:`DESIGN_DEPTHS_M` and :data:`DESIGN_DISTANCES_M` (the
    default camera, 20 000 lx), with the default budget and with the camera alone; one row per
    water, target and budget."""
    out = []
    for (water, (c, a)), targets, unc in itertools.product(WATERS.items(), DESIGN_TARGETS,
                                                           (None, {})):
        d = sca.design(c, a, depth=DESIGN_DEPTHS_M, distance=DESIGN_DISTANCES_M,
                       targets=targets, uncertain=unc)
        shown = d.protocol if d.meets else d.best
        (name, level), = targets.items()
        out.append(dict(water=water, target=name, level=level, budget=unc is None,
                        meets=d.meets, protocol=shown.protocol.describe(),
                        n_photos=shown.protocol.n_photos, auxiliary=shown.protocol.auxiliary,
                        chl_rel95=shown.rel95["chl"], c_rel95=shown.rel95["c"],
                        cdom_rel95=shown.rel95["cdom"], bound_chl_rel95=shown.bound_rel95["chl"],
                        span=" and ".join(shown.span), limiting=d.limiting,
                        without_limiting=d.without_limiting,
                        one_photo_chl=d.one_photo.rel95["chl"],
                        one_photo_c=d.one_photo.rel95["c"]))
    return out


def depth_limit(rows, camera, lux, water, distance, key, level):
    """The deepest depth of DEPTHS_M at which C is within ``level`` (95 %), or None. (Precision
    need not fall monotonically with depth: a longer path also carries more of the water's
    signal, so a shallow chart can be worse than a deeper one.)"""
    ok = [r["depth"] for r in rows if r["camera"] == camera and r["lux"] == lux
          and r["water"] == water and r["distance"] == distance and r[key] <= level]
    return max(ok) if ok else None


def depth_ranges(rows, camera, lux, water, distance, key, level) -> list:
    """The runs of consecutive depths of DEPTHS_M at which C is within ``level`` (95 %), as
    [(first, last), ...]: every depth where it holds, not only the deepest."""
    ok = {r["depth"] for r in rows if r["camera"] == camera and r["lux"] == lux
          and r["water"] == water and r["distance"] == distance and r[key] <= level}
    runs, cur = [], None
    for d in DEPTHS_M:
        if d in ok:
            cur = (cur[0], d) if cur else (d, d)
        elif cur:
            runs.append(cur)
            cur = None
    return runs + ([cur] if cur else [])


def format_ranges(runs) -> str:
    """"1–30 m", "1–3, 10–30 m", "20 m" or "–" (at no depth)."""
    if not runs:
        return "–"
    return ", ".join(f"{a:g}" if a == b else f"{a:g}–{b:g}" for a, b in runs) + " m"


def paper_connection(figdir: Path, grid_name=None):
    """Fig 12 at the paper-like setting: r^2 predicted from the bound against the figure's r^2
    and against the r^2 of CONNECTION_DRAWS fresh noise draws of the figure's grid, fitted as
    the figure is (unweighted, the paper's exact model ``uncertain={}``) on the setting's
    estimation grid and on the 1 nm grid of the world (the same draws); with the fits' bias
    and their scatter relative to the bound. The bound is the 1 nm world's (the information in
    the data): an estimator on a coarser grid adds a model error it does not contain. One row
    per depth and estimator grid (``step``)."""
    from .grids import grid as get_grid
    from .grids import setting as get_setting
    from .paper_like import World
    from .sweep import estimation_grid

    g, s = get_grid(grid_name or "paper"), get_setting("paper-like")
    sensor = forward.SensorSettings(illuminance_lux=s["illuminance_lux"], exposure_mode=s["exposure"])
    steps = list(dict.fromkeys([float(s["estimation_step_nm"]), 1.0]))
    out = []
    observed = {}
    path = Path(figdir) / "paper-like" / "fig12_chlorophyll.csv"
    if path.exists():

        observed = {float(r["depth_m"]): float(r["r2"]) for r in read_csv(path)}
    cells = list(itertools.product(g["fig12_chl"], g["fig12_cdom"]))
    c = np.array([x[0] for x in cells])
    a = np.array([x[1] for x in cells])
    n, dist = len(cells), g["fig12_distance_m"]
    for i, d in enumerate(g["fig12_depths_m"]):
        p = sca.precision(c, a, depth=d, distance=dist, sensor=sensor, uncertain={})
        var_t = c.var()
        r2 = var_t / (var_t + np.mean(p.chl_sd ** 2))
        sims = [forward.simulate_chart(ci, ai, d, dist, noise=False) for ci, ai in cells]
        M = np.concatenate([World.capture(sims, sensor, CONNECTION_SEED + (i * CONNECTION_DRAWS + k) * n)
                            for k in range(CONNECTION_DRAWS)])
        for step in steps:
            b = sca.estimate_batch(M, depth=d, distance=dist, intervals=False, uncertain={},
                                   wavelengths=estimation_grid(step))
            chl = b.chl.reshape(CONNECTION_DRAWS, n)
            r2_draws = np.array([pearson(c, e) ** 2 for e in chl])
            ratio = chl.std(axis=0, ddof=1) / p.chl_sd
            bias = {cv: float(np.mean(chl[:, c == cv]) / cv - 1) for cv in g["fig12_chl"]}
            worst = max(bias, key=lambda cv: abs(bias[cv]))
            out.append(dict(depth=d, step=step, figures=step == steps[0], r2_bound=float(r2),
                            r2_figure=observed.get(d, float("nan")) if step == steps[0] else float("nan"),
                            r2_draws_min=float(r2_draws.min()),
                            r2_draws_median=float(np.median(r2_draws)),
                            r2_draws_max=float(r2_draws.max()),
                            sd_ratio_median=float(np.median(ratio)),
                            bias_worst_chl=float(worst), bias_worst=bias[worst],
                            not_attained=int(np.sum(~p.attained)), n=n))
    return out


def _outside(rows):
    """Depths at which the bound's r^2 is outside the draws' range, at the printed precision
    (two decimals, as every r^2 of the tables)."""
    r = lambda v: round(v, 2)  # noqa: E731
    return [c["depth"] for c in rows
            if not r(c["r2_draws_min"]) <= r(c["r2_bound"]) <= r(c["r2_draws_max"])]


def _consistent(rows):
    return not _outside(rows)


def _where(rows):
    out = _outside(rows)
    return ("within that range at every depth" if not out else
            "outside that range at " + ", ".join(f"{d:g}" for d in out) + " m")


def _facts(rows):
    deep = rows[-1]
    ratios = [c["sd_ratio_median"] for c in rows]
    return (f"at {deep['depth']:g} m its C is biased (mean over a_CDOM and draws, worst group: "
            f"{100 * deep['bias_worst']:+.0f} % at C = {deep['bias_worst_chl']:g} mg m⁻³) and its "
            f"fits scatter {min(ratios):.2f}–{max(ratios):.2f}× the bound (median over charts, by "
            "depth)")


def connection_text(conn) -> str:
    """The verdict on "does the bound explain the fall of r^2 with depth", by a stated rule:
    "consistent" when the bound's r^2 lies within the range of the draws' r^2 at every depth,
    both to two decimals (never "explained": bias and scatter say what else is at work); for
    the figures' estimator grid and for the 1 nm estimator of the exact model."""
    figs = [c for c in conn if c["figures"]]
    exact = [c for c in conn if c["step"] == 1.0 and not c["figures"]]
    step = figs[-1]["step"]
    out = [("Consistent, not proven" if _consistent(figs) else "No")
           + f", for the figures' estimator ({step:g} nm): the r² the bound predicts without a "
           f"single fit, set against the range of r² over {CONNECTION_DRAWS} fresh noise draws "
           "of the figure's grid (both to two decimals), lies " + _where(figs) + "; " + _facts(figs)
           + f"; the bound is not attained on {figs[-1]['not_attained']}/{figs[-1]['n']} charts "
           f"at {figs[-1]['depth']:g} m (flags)."]
    if exact:
        out.append("With the 1 nm estimator of the exact model on the same draws the bound's r² "
                   "lies " + _where(exact) + "; " + _facts(exact) + ".")
    b0, b1 = figs[0]["r2_bound"], figs[-1]["r2_bound"]
    if round(b0, 2) > round(b1, 2):
        role = (f"The bound's own r² falls with depth ({b0:.2f} → {b1:.2f}): the camera's loss of "
                "precision (fewer photons per patch as the light falls and the exposure is capped) "
                + ("is consistent with the fall of r² in Fig 12, not shown to be its only cause."
                   if _consistent(figs) else
                   "contributes to the fall of r² in Fig 12 but does not account for all of it."))
    else:
        role = "The bound's own r² does not fall with depth, so precision does not explain the fall."
    out.append("The bound is that of an unbiased, weighted estimator of the exact model; the "
               "figures' fits are unweighted (the paper's objective) and biased where the grid or "
               "the bound at 0 pulls them. " + role)
    return " ".join(out)


def plot(rows, outdir):
    import matplotlib.pyplot as plt

    style()
    fig, axes = plt.subplots(1, len(WATERS), figsize=(7.5, 3.0), sharey=True, constrained_layout=True)
    cams = list(dict.fromkeys(r["camera"] for r in rows))
    colours = dict(zip(cams, plt.rcParams["axes.prop_cycle"].by_key()["color"]))
    for ax, water in zip(axes, WATERS):
        for cam, lux in itertools.product(cams, LIGHTS_LUX):
            for key, alpha, lw in (("chl_rel95_free_budget", 1.0, 1.2), ("chl_rel95_free", 0.35, 0.7)):
                sel = sorted((r["depth"], r[key]) for r in rows if r["camera"] == cam
                             and r["lux"] == lux and r["water"] == water and r["distance"] == 1.0)
                ax.plot([d for d, _ in sel], [100 * v for _, v in sel],
                        "-" if lux > 1000 else "--", color=colours[cam], marker="o", ms=2,
                        alpha=alpha, lw=lw,
                        label=f"{cam}, {lux:g} lx" if water == list(WATERS)[0] and alpha == 1.0
                        else None)
        ax.axhline(30, color="grey", lw=0.8, ls=":")
        ax.set(yscale="log", xlabel="depth (m)", title=f"{water} (C {WATERS[water][0]:g} mg m$^{{-3}}$, "
               f"a$_{{CDOM}}$ {WATERS[water][1]:g} m$^{{-1}}$)")
        ax.title.set_fontsize(8)
    axes[0].set_ylabel("C: 95 % half-width (% of C)")
    fig.legend(loc="outside lower center", ncol=3, fontsize=8)
    fig.suptitle("Predicted precision of C, one photo, distance 1 m, exposure unknown "
                 "(Cramér-Rao bound; default budget, faint: the camera alone)")
    save_figure(fig, "instrument", outdir)
    plt.close(fig)


def _budget_section(brows) -> list:
    pct = lambda v: "not bounded" if not np.isfinite(v) else f"±{100 * v:.0f} %"  # noqa: E731
    L = ["## The honest instrument: the camera alone against the uncertainty budget "
         "(default camera, 20 000 lx, distance 1 m, exposure unknown)", "",
         "The camera alone is its own limit: photon and read noise, every other input exact. A "
         "real measurement also depends on inputs known only approximately; the default budget "
         "of the estimators (`sca.budget.DEFAULT_UNCERTAIN`: depth 0.2 m, distance 5 %, eq 6's "
         "and eq 7's slopes 0.0025 nm⁻¹, channel balance 1 %, camera curves 1 nm, daylight "
         "colour 30 mired, 1 % per patch; decision 0011-default-budget) gives the honest 95 % "
         "half-widths below "
         "(`sca.precision` with and without `uncertain={}`; c: the path's attenuation "
         "coefficient at its worst standard band), and the source with the largest share of C's "
         "variance.", "",
         "| water | depth | C, camera alone | C, with the budget | a_CDOM, camera alone | "
         "a_CDOM, with the budget | c, camera alone | c, with the budget | limited by (share of "
         "var C) |", "|---|---|---|---|---|---|---|---|---|"]
    for b in brows:
        L.append(f"| {b['water']} | {b['depth']:g} m | {pct(b['chl_rel95_camera'])} | "
                 f"{pct(b['chl_rel95_budget'])} | {pct(b['cdom_rel95_camera'])} | "
                 f"{pct(b['cdom_rel95_budget'])} | {_pct(b['c_rel95_camera'])} | "
                 f"{_pct(b['c_rel95_budget'])} | {b['limiting']} "
                 f"({100 * b['limiting_share']:.0f} %) |")
    L += ["", "A calibration photo measures the per-patch term of its camera and chart "
          "(`uw3p calibrate`: the profile's `patch_sd`), which replaces the budget's 1 %.", ""]
    return L + _patch_sensitivity(brows)


def _patch_sensitivity(brows) -> list:
    """The budget's numbers at each per-patch term of :data:`PATCH_LEVELS`."""
    levels = list(brows[0]["chl_rel95_patch"])
    head = " | ".join(f"C, {100 * v:g} %" for v in levels) + " | " + " | ".join(
        f"c, {100 * v:g} %" for v in levels)
    L = ["### Sensitivity to the per-patch term", "",
         "Every number with the budget above, and the depth table, the cost table and the "
         "designs, assume the budget's per-patch term; the real G7X charts leave ten times more or "
         "beyond photon noise on patches the fit did not see (REPRODUCTION.md, the real "
         "camera's held-out error per patch). The same bound with the per-patch term at "
         + ", ".join(f"{100 * v:g} %" for v in levels) + " (the rest of the budget as it is):",
         "", f"| water | depth | {head} |", "|" + "---|" * (2 + 2 * len(levels))]
    for b in brows:
        L.append(f"| {b['water']} | {b['depth']:g} m | "
                 + " | ".join(_pct(b["chl_rel95_patch"][v]) for v in levels) + " | "
                 + " | ".join(_pct(b["c_rel95_patch"][v]) for v in levels) + " |")
    return L + [""]


def _pct(v) -> str:
    """'±12 %', '±0.5 %' (below 10 %: two digits) or 'not bounded'."""
    if not np.isfinite(v):
        return "not bounded"
    return f"±{100 * v:.0f} %" if v >= 0.095 else f"±{100 * v:.2g} %"


def _design_section(drows) -> list:
    """What a dive buys: the designs of :func:`design_table`."""
    names = {"chl": "C", "c": "c (every band)"}
    L = ["## What a dive buys: designs (`sca.design`, `uw3p design`)", "",
         f"The cheapest protocol of `sca.design`'s space (1-12 photos over a depth ladder in "
         f"{DESIGN_DEPTHS_M[0]:g}-{DESIGN_DEPTHS_M[1]:g} m, from "
         + " or ".join(f"{r:g}" for r in DESIGN_DISTANCES_M) + " m or both, with or without a "
         "water sample's a_CDOM(440) (sd 0.0025 m⁻¹) and a Secchi depth) whose predicted 95 % "
         "half-width meets the target; where none does, the most precise protocol and what "
         "limits it. Default camera, 20 000 lx. The prediction is the joint estimate's bound, "
         "widened where its interval spans path models the photos cannot tell apart "
         "(`sca.protocols`); DESIGN.md checks it on dives an independent renderer made. The "
         "camera alone (photon and read noise only) for contrast.", "",
         "| water | target | budget | meets | protocol (or the best) | C | c (worst band) | "
         "one photo: C, c | limited by |", "|---|---|---|---|---|---|---|---|---|"]
    for r in drows:
        lim = r["limiting"] or "–"
        if r["limiting"] and np.isfinite(r["without_limiting"]):
            lim += f" (known exactly: {_pct(r['without_limiting'])})"
        L.append(f"| {r['water']} | {names.get(r['target'], r['target'])} "
                 f"±{100 * r['level']:g} % | {'default' if r['budget'] else 'camera alone'} | "
                 f"{'yes' if r['meets'] else 'no'} | {r['protocol']} | {_pct(r['chl_rel95'])} | "
                 f"{_pct(r['c_rel95'])} | {_pct(r['one_photo_chl'])}, {_pct(r['one_photo_c'])} | "
                 f"{lim} |")
    L += ["", "\"path model\": the bound alone would meet the target, but the photos cannot tell "
          "beam attenuation from absorption along the path, and the estimate's interval spans "
          "both; no number of photos in this space resolves it.", ""]
    return L


def _reference_section(rrows, prior) -> list:
    """Δτ with and without the reference shot, and the per-patch term's levels beside it."""
    if not rrows:
        return []
    from sca.budget import DEFAULT_UNCERTAIN

    bands = list(rrows[0]["default"])
    patch = [k for k in rrows[0] if k.startswith("patch")]
    first = f"{100 * DEFAULT_UNCERTAIN['patch']:g} %"
    cell = lambda t: " / ".join(f"{t[b]:.3f}" for b in bands)  # noqa: E731
    L = ["## The surface reference shot: Δτ with and without it (default camera, 20 000 lx, "
         "distance 1 m, exposure unknown)", "",
         "Δτ: the 95 % half-width of the optical depth τ = c (d + L) at "
         + ", ".join(bands) + " nm (`sca.precision`; the issue's target ≤ 0.10), with the "
         "default budget (daylight colour: a prior of 30 mired) and with the light measured at "
         "the site by a reference shot (`sca.reference.with_reference`: the daylight's prior "
         f"sd {prior['sd']:.1f} mired = the typical sd `measure_light` gives on a chart "
         f"simulated in air, {prior['sd_fit']:.1f} mired (median of {REFERENCE_SHOTS}), and "
         f"the sky's change over {prior['minutes']:g} minutes, {prior['sd_sky']:.1f} mired; "
         "decision 0069-reference-shot). Beside them, with the reference, the per-patch term "
         f"(the budget's {first}) at " + ", ".join(f"{100 * v:g} %" for v in PATCH_LEVELS) +
         ". Each cell: Δτ at " + " / ".join(bands) + " nm.", "",
         f"| water | depth | default budget | with the reference (patch {first}) | " +
         " | ".join(f"reference, {k}" for k in patch) + " |",
         "|" + "---|" * (4 + len(patch))]
    for r in rrows:
        L.append(f"| {r['water']} | {r['depth']:g} m | {cell(r['default'])} | "
                 f"{cell(r['reference'])} | " +
                 " | ".join(cell(r[k]) for k in patch) + " |")
    return L + [""]


def doc(rows, val, conn, brows=(), drows=(), rrows=(), prior=None) -> str:
    cams = list(dict.fromkeys(r["camera"] for r in rows))
    L = ["# INSTRUMENT — how well can a camera measure the water?", "",
         "_Generated by `make reproduce-figures` (alone: `python -m experiments.instrument --doc "
         "INSTRUMENT.md`, after Fig 12 at the paper-like setting); do not "
         "edit by hand. Method: `sca.precision`, the Cramér-Rao bound of C, a_CDOM(440) and the "
         "path's attenuation coefficient c (443, 490, 555, 670 nm) from the sensor's noise model "
         "and the analytic Jacobian, **with the default uncertainty budget** "
         "(`sca.budget.DEFAULT_UNCERTAIN`: depth, distance, eq 6-7 slopes, camera balance and "
         "curves, daylight colour, 1 % per patch; decision 0011-default-budget) unless a column "
         "says \"camera "
         "alone\": photon and read noise only, every other input exact (`uncertain={}`, "
         "`uw3p design --camera-only`), the camera's own limit, shown for contrast. 95 % "
         "half-widths in % of the value; the default sensor otherwise (decision "
         "0019-sensor-defaults); exposure "
         "unknown (gain free) unless said._", "",
         f"Cameras: {', '.join(cams)} (6-band: Gaussian bands at "
         f"{', '.join(f'{b:g}' for b in BANDS_NM)} nm, {FWHM_NM:g} nm FWHM, peak 1). Water types: "
         + "; ".join(f"{k}: C {v[0]:g} mg m⁻³, a_CDOM(440) {v[1]:g} m⁻¹" for k, v in WATERS.items())
         + ". Depths 1–30 m, distances 1 and 5 m, daylight 20 000 lx and dim 200 lx.", "",
         "## At which depths can C be measured? (distance 1 m)", "",
         "One photo, exposure unknown.", "",
         f"| camera | light | water | c ±{100 * C_LEVEL:g} % (every band) | C ±100 % | C ±30 % | "
         "C ±30 %, camera alone |", "|---|---|---|---|---|---|---|"]
    for cam, lux, water in itertools.product(cams, LIGHTS_LUX, WATERS):
        L.append(f"| {cam} | {lux:g} lx | {water} | " + " | ".join(
            format_ranges(depth_ranges(rows, cam, lux, water, 1.0, key, level))
            for key, level in (("c_rel95_free_budget", C_LEVEL), ("chl_rel95_free_budget", 1.0),
                               ("chl_rel95_free_budget", 0.3), ("chl_rel95_free", 0.3))) + " |")
    L += ["", f"Every depth of the grid ({', '.join(f'{d:g}' for d in DEPTHS_M)} m) at which the "
          "bound is within the level, as ranges of consecutive grid depths (\"–\": at none). "
          "With the budget one photo measures the path's attenuation coefficient, not C: C and "
          "a_CDOM trade off against each other and against the chart's and camera's errors "
          "(the next table; a dive and a water sample: the designs below). Precision does not "
          "always fall with depth: a longer path also carries more of the water's signal, so a "
          "shallow chart can fail where a deeper one passes.", "",
          "## What an unknown exposure and an uncalibrated camera cost, and what fixing buys "
          "(coastal water, 10 m, distance 1 m)", "",
          "| camera | light | budget | C known exposure | C unknown exposure | C uncalibrated | "
          "a_CDOM unknown exposure | c unknown exposure | C unknown exposure, a_CDOM fixed | "
          "C unknown exposure, backscatter fixed | corr(C, a_CDOM) |",
          "|---|---|---|---|---|---|---|---|---|---|---|"]
    for cam, lux in itertools.product(cams, LIGHTS_LUX):
        r = next(x for x in rows if x["camera"] == cam and x["lux"] == lux and x["water"] == "coastal"
                 and x["depth"] == 10.0 and x["distance"] == 1.0)
        for tag, label in (("_budget", "default"), ("", "camera alone")):
            L.append(f"| {cam} | {lux:g} lx | {label} | {_pct(r['chl_rel95_known' + tag])} | "
                     f"{_pct(r['chl_rel95_free' + tag])} | {_pct(r['chl_rel95_channels' + tag])} | "
                     f"{_pct(r['cdom_rel95_free' + tag])} | {_pct(r['c_rel95_free' + tag])} | "
                     f"{_pct(r['chl_rel95_free_fix_cdom' + tag])} | "
                     f"{_pct(r['chl_rel95_free_fix_backscatter' + tag])} | "
                     f"{r['correlation_free' + tag]:+.2f} |")
    L += ["", "Where |corr| is near 1, C and a_CDOM cannot be separated: the chart fixes one "
          "combination of them, and measuring a_CDOM separately (or fixing it) is what makes C "
          "measurable. `uw3p design` gives these numbers for any condition, and the protocol "
          "that reaches a precision.", ""]
    if drows:
        L += _design_section(drows)
    L += ["## Validation (same code): the camera-only bound against the estimator", "",
          "**Same code**: the charts are simulated by `forward` and fitted by `sca`, which share "
          "the model, so this checks the machinery (the bound's algebra against the fits' "
          "scatter), not the model; HONESTY.md tests the intervals on charts an independent "
          "renderer made. "
          f"Spread of `sca.estimate_batch` (weighted fits with the sensor's sigma, exposure known, "
          f"the paper's exact model) over {DRAWS} noise draws, divided by the camera-only bound "
          "(distance 1 m): noise draws test the noise's part of the bound; the budget's part "
          "(errors fixed within a photo, drawn between dives) is checked on dives in DESIGN.md "
          "and on single photos in HONESTY.md. Where the bound is attained (no flag) the ratio "
          "should be near 1; at 200 lx the sensor model's sigma is conservative for the darkest "
          "patches (decision 0008-trust-noise-fit-flags), so ratios below 1 are expected.",
          "", "| water | depth | light | sd C, bound | sd C, estimator | ratio C | ratio a_CDOM | "
          "flags |", "|---|---|---|---|---|---|---|---|"]
    for v in val:
        L.append(f"| {v['water']} | {v['depth']:g} m | {v['lux']:g} lx | {v['chl_sd_bound']:.3g} | "
                 f"{v['chl_sd_estimator']:.3g} | {v['chl_ratio']:.2f} | {v['cdom_ratio']:.2f} | "
                 f"{v['flags'] or '–'} |")
    if brows:
        L += [""] + _budget_section(brows)[:-1]
    if rrows:
        L += [""] + _reference_section(rrows, prior)[:-1]
    if conn:
        s = _paper_like_setting()
        L += ["", "## Does the bound explain why r falls with depth in Fig 12? (same code)", "",
              "**Same code**: the figure's charts and the fresh draws are simulated by `forward` "
              "at the paper-like setting and fitted by `sca`, which share the model. "
              f"Fig 12 (true vs estimated C over its grid, distance 1 m) at the paper-like "
              f"setting ({s['illuminance_lux']:g} lx, estimator on a {s['estimation_step_nm']:g} nm "
              "grid): r² predicted from the bound, var(C) / (var(C) + mean sd²), against the "
              "figure's own r² (`figures/paper-like/fig12_chlorophyll.csv`: the figure's seeds, the "
              f"sca loop) and against {CONNECTION_DRAWS} fresh noise draws of the grid (one seed "
              "per chart and draw, fitted as the figure is: unweighted, `sca.estimate_batch`, "
              "same optimum). The bound is the 1 nm world's; \"sd / bound\" is the fits' scatter "
              "over the draws divided by the bound (median over the charts); \"worst bias\" the "
              "C group whose mean estimate is furthest from the truth.", "",
              "| depth | estimator grid | r² from the bound | r² in the figure | r² over the "
              "draws (min–max, median) | sd / bound | worst bias | charts where the bound is not "
              "attained |", "|---|---|---|---|---|---|---|---|"]
        for c in conn:
            fig_r2 = (f"{c['r2_figure']:.2f}" if np.isfinite(c["r2_figure"]) else
                      "not made" if c["figures"] else "–")
            grid_txt = f"{c['step']:g} nm" + (" (the figures')" if c["figures"] else " (exact model)")
            L.append(f"| {c['depth']:g} m | {grid_txt} | {c['r2_bound']:.2f} | {fig_r2} | "
                     f"{c['r2_draws_min']:.2f}–{c['r2_draws_max']:.2f} ({c['r2_draws_median']:.2f}) | "
                     f"{c['sd_ratio_median']:.2f} | {100 * c['bias_worst']:+.0f} % at C = "
                     f"{c['bias_worst_chl']:g} | {c['not_attained']}/{c['n']} |")
        L += ["", connection_text(conn), ""]
    return "\n".join(L)


def main(outdir=None, grid_name=None, cache_dir=None, workers=None, camera_csv=None, doc_path=None):
    cams = cameras(camera_csv)
    rows = precision_table(cams)
    keys = list(rows[0])
    write_csv(figures_dir(outdir) / "instrument_precision.csv", keys,
              [[f"{r[k]:.6g}" if isinstance(r[k], float) else r[k] for k in keys] for r in rows],
              comment="python -m experiments.instrument: 95 % half-widths relative to the value "
                      "(Cramer-Rao bound, sca.precision)")
    val = validation() if (grid_name or "paper") == "paper" else []
    if val:
        vk = list(val[0])
        write_csv(figures_dir(outdir) / "instrument_validation.csv", vk,
                  [[f"{v[k]:.6g}" if isinstance(v[k], float) else v[k] for k in vk] for v in val],
                  comment=f"bound vs the spread of sca.estimate_batch over {DRAWS} draws")
    plot(rows, outdir)
    conn = paper_connection(Path(outdir or "figures"), grid_name)
    brows = budget_table() if (grid_name or "paper") == "paper" else []
    drows = design_table() if (grid_name or "paper") == "paper" else []
    rrows, prior = reference_table() if (grid_name or "paper") == "paper" else ([], None)
    if drows:
        dk = list(drows[0])
        write_csv(figures_dir(outdir) / "instrument_designs.csv", dk,
                  [[f"{r[k]:.6g}" if isinstance(r[k], float) else r[k] for k in dk]
                   for r in drows], comment="python -m experiments.instrument: sca.design")
    if doc_path:
        Path(doc_path).write_text(doc(rows, val, conn, brows, drows, rrows, prior),
                                  encoding="utf-8")
    return rows


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default="figures")
    p.add_argument("--doc", default=None, metavar="FILE", help="write INSTRUMENT.md")
    p.add_argument("--camera-csv", default=None, help="a user camera (wavelength, red, green, blue)")
    a = p.parse_args()
    main(a.out, camera_csv=a.camera_csv, doc_path=a.doc)
