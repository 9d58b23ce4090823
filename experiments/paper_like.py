"""Which sensor setting reproduces the paper's numbers? A documented search.

    python -m experiments.paper_like [--out figures]       (part of ``make reproduce-figures``)

The paper does not publish its ISET settings, nor its spectral grid ("a small number, q, of
narrow wavelength bands"). Its headline numbers are (text and captions):

* Fig 10: per depth x distance cell (each averaged over C and a_CDOM), RRMSE "about 2 %, but
  increases slightly with larger depths and target distances";
* Figs 12-13: "Pearson's correlation coefficient r^2 varies between 1 and 0.7 and decreases
  with an increase in depth" (the text: r "consistently above 0.7").

Searched: surface illuminance (the grid's ``search_lux``) x exposure model ('capped': ours, at
most 1/30 s, so deeper scenes get fewer photons; 'iset': ISET's auto-exposure, the brightest
value at 95 % of the well whatever the light, which makes the recorded values independent of
the light: evaluated once) x the estimator's grid (``search_steps_nm``: 1 nm, ours; 10 nm,
ISET's default, q = 31; 5 and 20 nm) x the reading of eq 19 (as printed, divided by sqrt(q); or
without the sqrt(q)). Charts: the Fig 10 paper grid (one seed) and the Fig 12 grid (one seed),
simulated in the 1 nm world and fitted with the paper's unweighted objective and exact model
(``uncertain={}``) by ``sca.estimate_batch`` (which reaches the same optimum as the sca loop:
BENCHMARKS.md). Eq 19 is evaluated on the estimator's nodes that are 10 nm nodes
(:func:`experiments.sweep.rrmse_on_grid`: q = 31 for the 1, 5 and 10 nm grids, q = 16 for
20 nm), so "as printed" divides by sqrt(16) on the 20 nm grid.

Criteria (each the "yes" of the report's rule for that claim, :mod:`experiments.rules`): the
mean of the Fig 10 cells about 2 % (:func:`~experiments.rules.verdict_level`); the cells rise
slightly with depth and with distance (:func:`~experiments.rules.verdict_rises_slightly`);
r^2 of C and of a_CDOM each "between 1 and 0.7" over depth
(:func:`~experiments.rules.verdict_r2_range`); r^2 of both falls with depth
(:func:`~experiments.rules.verdict_trend`). Ranked by the number of criteria met, then by
closeness to "2 %" and "0.7" (``|ln(mean / 0.02)| + |ln(min r^2 / 0.7)|``). Writes
``paper_like_search.csv`` and ``paper_like_search.png`` and returns the rows;
:data:`experiments.grids.SETTINGS` ``['paper-like']`` is the setting this search ranks first
(set by hand: a change of ranking shows in the table first).
"""

from __future__ import annotations

import argparse
import itertools

import numpy as np

import forward
import sca

from . import rules
from .common import figures_dir, write_csv
from .grids import grid as get_grid
from .sweep import RRMSE_BANDS_NM, estimation_grid, pearson, rrmse_on_grid

__all__ = ["search", "evaluate", "criteria", "photon_budget", "plot", "best", "main", "World",
           "EXPOSURES", "READINGS", "SEED", "FIG12_SEED_OFFSET", "PHOTON_BUDGET", "TARGET_RRMSE",
           "TARGET_R2", "R2_FLOOR", "CRITERIA", "ANY_LIGHT"]

EXPOSURES = ("capped", "iset")
#: eq 19 as printed, and without its 1/sqrt(q)
READINGS = ("eq19", "eq19_without_sqrt_q")
#: Noise seeds: SEED + the chart's index for the Fig 10 grid, + FIG12_SEED_OFFSET for Fig 12's
SEED = 4242
FIG12_SEED_OFFSET = 10000
#: The ranking's targets: "about 2 %" and "0.7" (r^2 floored at R2_FLOOR in the logarithm)
TARGET_RRMSE = 0.02
TARGET_R2 = 0.7
R2_FLOOR = 1e-6
#: The criteria, in the order of the table
CRITERIA = ("about_2_percent", "rises_slightly", "r2_from_1_to_0_7", "r2_falls_with_depth")
#: The illuminance column of the 'iset' rows (the light does not change what ISET records)
ANY_LIGHT = "any"


def _charts(g):
    f10 = [(c, a, d, r) for d, r, c, a in itertools.product(
        g["fig10_depths_m"], g["fig10_distances_m"], g["fig10_chl"], g["fig10_cdom"])]
    f12 = [(c, a, d, g["fig12_distance_m"]) for d, c, a in itertools.product(
        g["fig12_depths_m"], g["fig12_chl"], g["fig12_cdom"])]
    return f10, f12


class World:
    """The noise-free charts of the Fig 10 and Fig 12 grids (1 nm world), simulated once and
    captured by any sensor: ``forward.capture`` with the generator of ``simulate_chart``'s seed
    gives the same values as ``simulate_chart(..., seed=, sensor=)`` (tested)."""

    def __init__(self, g):
        self.g = g
        self.f10, self.f12 = _charts(g)
        self.sims10 = [forward.simulate_chart(c, a, d, r, noise=False) for c, a, d, r in self.f10]
        self.sims12 = [forward.simulate_chart(c, a, d, r, noise=False) for c, a, d, r in self.f12]

    @staticmethod
    def capture(sims, sensor, seed0):
        """The (N, 3, 24) recorded values of ``sims``, chart j with seed ``seed0 + j``."""
        return np.array([forward.capture(s.rgb_expected, s.setup, sensor,
                                         rng=np.random.default_rng(seed0 + j))["rgb"]
                         for j, s in enumerate(sims)])


def _fit(sims, M, step_nm):
    """Unweighted batch fits of the stack M on the estimator's grid; eq 19 per chart."""
    D = np.array([s.depth for s in sims])
    R = np.array([s.distance for s in sims])
    wl_hat = estimation_grid(step_nm)
    b = sca.estimate_batch(M, depth=D, distance=R, intervals=False, wavelengths=wl_hat,
                           uncertain={})
    wl_hat = sims[0].wavelengths if wl_hat is None else wl_hat
    err = np.array([rrmse_on_grid(wl_hat, b.attenuation[j], s.wavelengths, s.attenuation)
                    for j, s in enumerate(sims)])
    return b, err, int(np.isin(wl_hat, RRMSE_BANDS_NM).sum())


#: Illuminance x pixels per patch held fixed (2000 lx-pixels): if the noise were shot-noise
#: limited, these would give the same RRMSE.
PHOTON_BUDGET = ((2000.0, 1), (20.0, 100), (2.0, 1000))


def photon_budget(outdir=None, grid_name=None, world=None):
    """Mean Fig 10 RRMSE (eq 19, 1 nm estimator) for the :data:`PHOTON_BUDGET` splits of one
    photon budget; writes ``photon_budget.csv``."""
    g = get_grid(grid_name or "paper")
    world = world or World(g)
    rows = []
    for lux, px in PHOTON_BUDGET:
        sensor = forward.SensorSettings(illuminance_lux=lux, pixels_per_patch=px)
        _, err, _ = _fit(world.sims10, World.capture(world.sims10, sensor, SEED), 1.0)
        rows.append(dict(illuminance_lux=lux, pixels_per_patch=px, rrmse_mean=float(err.mean())))
    write_csv(figures_dir(outdir) / "photon_budget.csv",
              ["illuminance_lux", "pixels_per_patch", "rrmse_mean"],
              [[f"{r['illuminance_lux']:g}", r["pixels_per_patch"], f"{r['rrmse_mean']:.6g}"]
               for r in rows],
              comment="illuminance x pixels per patch fixed at 2000; mean RRMSE (eq 19, 31 bands) "
                      f"over the Fig 10 {g['name']} grid, capped exposure, batch fit at 1 nm")
    return rows


def evaluate(lux, exposure, g, world=None, steps_nm=None):
    """Metrics of one sensor setting: a row per estimation grid and reading of eq 19."""
    world = world or World(g)
    steps_nm = steps_nm or g["search_steps_nm"]
    sensor = forward.SensorSettings(illuminance_lux=float(lux), exposure_mode=exposure)
    M10 = World.capture(world.sims10, sensor, SEED)
    M12 = World.capture(world.sims12, sensor, SEED + FIG12_SEED_OFFSET)
    f10, f12 = world.f10, world.f12
    depth = np.array([c[2] for c in f10])
    dist = np.array([c[3] for c in f10])
    depths, dists = g["fig10_depths_m"], g["fig10_distances_m"]
    out = []
    for step in steps_nm:
        _, err, q = _fit(world.sims10, M10, step)
        cells = {(d, r): err[(depth == d) & (dist == r)].mean() for d in depths for r in dists}
        cell = np.array(list(cells.values()))
        by_depth = [np.mean([cells[(d, r)] for r in dists]) for d in depths]
        by_dist = [np.mean([cells[(d, r)] for d in depths]) for r in dists]
        b12, _, _ = _fit(world.sims12, M12, step)
        r2 = {}
        for qty, truth_idx in (("chl", 0), ("cdom", 1)):
            for d in g["fig12_depths_m"]:
                sel = np.array([c[2] == d for c in f12])
                t = np.array([c[truth_idx] for c in f12])[sel]
                r2[(qty, d)] = pearson(t, getattr(b12, qty)[sel]) ** 2
        for reading in READINGS:
            factor = np.sqrt(q) if reading == "eq19_without_sqrt_q" else 1.0
            row = dict(illuminance_lux=ANY_LIGHT if exposure == "iset" else float(lux),
                       exposure=exposure, estimation_step_nm=float(step), q_eq19=q,
                       reading=reading,
                       cell_mean=float(cell.mean() * factor),
                       cell_median=float(np.median(cell) * factor),
                       cell_min=float(cell.min() * factor), cell_max=float(cell.max() * factor),
                       depth_ratio=float(by_depth[-1] / by_depth[0]),
                       distance_ratio=float(by_dist[-1] / by_dist[0]))
            for (qty, d), v in r2.items():
                row[f"r2_{qty}_{d:g}m"] = float(v)
            row.update(criteria(row, g, [v * factor for v in by_depth],
                                [v * factor for v in by_dist]))
            out.append(row)
    return out


def criteria(row, g, by_depth, by_distance) -> dict:
    """Each criterion (the "yes" of the report's rule), True/False, their count ``score`` and
    the ranking's ``distance`` to "2 %" and "0.7"."""
    d = g["fig12_depths_m"]
    r2 = {q: [row[f"r2_{q}_{x:g}m"] for x in d] for q in ("chl", "cdom")}
    crit = dict(
        about_2_percent=rules.verdict_level(row["cell_mean"], TARGET_RRMSE) == "yes",
        rises_slightly=rules.verdict_rises_slightly(g["fig10_depths_m"], by_depth,
                                                    g["fig10_distances_m"], by_distance) == "yes",
        r2_from_1_to_0_7=all(rules.verdict_r2_range(r2[q]) == "yes" for q in r2),
        r2_falls_with_depth=all(rules.verdict_trend(d, r2[q], -1, r2=True) == "yes" for q in r2),
    )
    crit["score"] = int(sum(crit.values()))
    low = min(min(v) for v in r2.values())
    crit["distance"] = float(abs(np.log(row["cell_mean"] / TARGET_RRMSE))
                             + abs(np.log(max(low, R2_FLOOR) / TARGET_R2)))
    return crit


def search(outdir=None, grid_name=None, world=None):
    g = get_grid(grid_name or "paper")
    world = world or World(g)
    rows = []
    for lux in g["search_lux"]:
        rows += evaluate(lux, "capped", g, world)
    rows += evaluate(g["search_lux"][0], "iset", g, world)  # the light does not matter
    keys = list(rows[0])
    write_csv(figures_dir(outdir) / "paper_like_search.csv", keys,
              [[f"{r[k]:.6g}" if isinstance(r[k], float) else r[k] for k in keys] for r in rows],
              comment=f"python -m experiments.paper_like: light level x exposure model x the "
                      f"estimator's grid x eq 19 reading; Fig 10 and Fig 12 {g['name']} grids, one "
                      "seed, 1 nm world, batch fit (unweighted, uncertain={}); eq 19 on the "
                      "estimator's 10 nm nodes (q_eq19); 'iset' rows hold at any light level")
    plot(rows, g, outdir)
    return rows


def plot(rows, g, outdir=None):
    import matplotlib.pyplot as plt

    from .common import percent_axis, save_figure, style

    style()
    d = g["fig12_depths_m"][-1]
    steps = g["search_steps_nm"]
    colours = dict(zip(steps, plt.get_cmap("viridis")(np.linspace(0, 0.85, len(steps)))))
    fig, (a0, a1) = plt.subplots(1, 2, figsize=(7.4, 3.9), constrained_layout=True)
    for step in steps:
        c = colours[step]
        for reading, ls in zip(READINGS, ("-", "--")):
            sel = [r for r in rows if r["exposure"] == "capped" and r["reading"] == reading
                   and r["estimation_step_nm"] == step]
            a0.plot([r["illuminance_lux"] for r in sel], [r["cell_mean"] for r in sel], ls,
                    marker="o", ms=3, color=c)
        sel = [r for r in rows if r["exposure"] == "capped" and r["reading"] == "eq19"
               and r["estimation_step_nm"] == step]
        lux = [r["illuminance_lux"] for r in sel]
        a1.plot(lux, [r[f"r2_chl_{d:g}m"] for r in sel], "-o", ms=3, color=c,
                label=f"{step:g} nm grid")
        a1.plot(lux, [r[f"r2_cdom_{d:g}m"] for r in sel], ":s", ms=3, color=c)
    a0.axhspan(0.01, 0.04, color="grey", alpha=0.15, lw=0)
    a0.set(xscale="log", yscale="log", xlabel="surface illuminance (lx), capped exposure",
           ylabel="Fig 10 RRMSE of k, mean of cells")
    percent_axis(a0)
    a0.set_title("solid: eq 19 as printed; dashed: without √q\n"
                 "grey band: \"about 2 %\" (1–4 %)", fontsize=8)
    a1.axhspan(0.6, 0.85, color="grey", alpha=0.15, lw=0)
    a1.set(xscale="log", xlabel="surface illuminance (lx), capped exposure",
           ylabel=f"r$^2$ at {d:g} m", ylim=(0, 1.05))
    a1.set_title("solid: C (Fig 12); dotted: a$_{CDOM}$ (Fig 13)\n"
                 "grey band: lowest r$^2$ \"about 0.7\" (0.6–0.85)", fontsize=8)
    fig.legend(*a1.get_legend_handles_labels(), loc="outside lower center", ncol=len(steps),
               title="the estimator's wavelength grid (ISET's exposure is not drawn: it "
                     "records the same at every light level; see the table)", title_fontsize=8)
    save_figure(fig, "paper_like_search", outdir)
    plt.close(fig)


def best(rows):
    """The row with the highest score (ties: the closest to "2 %" and "0.7")."""
    return max(rows, key=lambda r: (r["score"], -r["distance"]))


def main(outdir=None, grid_name=None, cache_dir=None, workers=None):
    g = get_grid(grid_name or "paper")
    world = World(g)
    rows = search(outdir, grid_name, world)
    photon_budget(outdir, grid_name, world)
    b = best(rows)
    print(f"paper-like (score {b['score']}/4): {b['illuminance_lux']} lx, exposure "
          f"{b['exposure']}, {b['estimation_step_nm']:g} nm grid, {b['reading']}")
    return rows


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default=None)
    p.add_argument("--grid", default=None)
    a = p.parse_args()
    main(a.out, a.grid)
