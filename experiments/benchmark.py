"""Speed against error: every estimation method on the same charts, at 5, 10 and 20 nm.

    python -m experiments.benchmark [--quick]      (``make bench``)

Writes ``benchmarks/results.json`` (one record per method x resolution), ``BENCHMARKS.md``
(the table, the machine, the equal-optimum check) and ``figures/benchmark_speed_error.png``.
All methods run in this one process, one after another, so their ratios are comparable.

Charts: a grid with the estimator's hard cases (C from 1e-3 to 100 mg m^-3, a_CDOM from 0 to
2 m^-1, depth 1-30 m, distance 0.5-10 m), half noise-free and half with the default sensor
noise, simulated on a 5 nm grid (the reference physics); each method estimates on the grid of
the resolution under test, and k is compared with the true k on that grid. Relative errors
of C and a_CDOM use max(truth, 1e-3) in the denominator (a_CDOM = 0 is among the cases).
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import platform
import time
from pathlib import Path

import numpy as np

import forward
import sca
from sca.lsq import estimate_least_squares

from .baselines import RebuildEstimator

RESOLUTIONS_NM = (5.0, 10.0, 20.0)
CHLS = (1e-3, 0.05, 1.0, 20.0, 100.0)
CDOMS = (0.0, 0.05, 0.5, 2.0)
DEPTHS = (1.0, 10.0, 30.0)
DISTANCES = (0.5, 5.0)
METHODS = ("cvx_rebuild", "sca_paper", "sca_safeguarded", "scipy_least_squares", "batch")
BATCH_N = 20000
BATCH_REPEATS = 5
SEED = 7


def chart_set(quick=False):
    """(conditions, rgb on the 5 nm grid); every 4th grid case, noise-free and noisy."""
    grid = list(itertools.product(CHLS, CDOMS, DEPTHS, DISTANCES))
    picked = grid[:: (8 if quick else 4)]
    fine = np.arange(400.0, 700.1, 5.0)
    conds, rgbs = [], []
    for noise in (False, True):
        for i, (c, a, d, r) in enumerate(picked):
            sim = forward.simulate_chart(c, a, d, r, noise=noise, seed=SEED * 1000 + i, wavelengths=fine)
            conds.append(dict(chl=c, cdom=a, depth=d, distance=r, noise=noise))
            rgbs.append(sim.rgb)
    return conds, np.array(rgbs)


def _rel(est, truth):
    return abs(est - truth) / max(truth, 1e-3)


def _record(method, res_nm, conds, estimates, times, iterations, grid, extra=None):
    k_err, e_chl, e_cdom, fails = [], [], [], 0
    for cond, est in zip(conds, estimates):
        k_true = forward.attenuation(grid, cond["chl"], cond["cdom"], cond["depth"], cond["distance"])
        k_err.append(sca.rrmse(est["attenuation"], k_true))
        e_chl.append(_rel(est["chl"], cond["chl"]))
        e_cdom.append(_rel(est["cdom"], cond["cdom"]))
        fails += not est["converged"]
    t = np.asarray(times)
    rec = dict(
        method=method, resolution_nm=res_nm, n_fits=len(conds),
        fits_per_s=len(t) / float(t.sum()), median_ms_per_fit=1e3 * float(np.median(t)),
        p95_ms_per_fit=1e3 * float(np.percentile(t, 95)),
        iterations_median=float(np.median(iterations)),
        ms_per_iteration=1e3 * float(t.sum()) / max(1, int(np.sum(iterations))),
        rrmse_k_median=float(np.median(k_err)), rrmse_k_max=float(np.max(k_err)),
        rel_err_chl_median=float(np.median(e_chl)), rel_err_chl_max=float(np.max(e_chl)),
        rel_err_cdom_median=float(np.median(e_cdom)), rel_err_cdom_max=float(np.max(e_cdom)),
        failures=int(fails),
    )
    if extra:
        rec.update(extra)
    return rec


def _as_dict(e):
    return dict(chl=e.chl, cdom=e.cdom, attenuation=e.attenuation, converged=e.converged,
                objective=e.objective)


def run_single(method, conds, rgbs, grid):
    """One chart at a time; returns estimates, per-fit times, iterations, and solver timings."""
    setup = forward.chart_setup(wavelengths=grid)
    ests, times, iters, solve_t, clarabel_t = [], [], [], 0.0, 0.0
    for cond, rgb in zip(conds, rgbs):
        kw = dict(depth=cond["depth"], distance=cond["distance"], setup=setup)
        t0 = time.perf_counter()
        if method == "cvx_rebuild":
            e = RebuildEstimator(**kw).fit(rgb, mode="paper")
        elif method == "sca_paper":
            e = sca.estimate(rgb, mode="paper", **kw)
        elif method == "sca_safeguarded":
            e = sca.estimate(rgb, **kw)
        elif method == "scipy_least_squares":
            e = estimate_least_squares(rgb, **kw)
        else:
            raise ValueError(method)
        times.append(time.perf_counter() - t0)
        iters.append(max(e.n_solves, 1) if method != "scipy_least_squares" else e.iterations)
        solve_t += e.solve_time_s
        clarabel_t += e.clarabel_time_s
        ests.append(_as_dict(e))
    return ests, times, iters, dict(solve_call_s=solve_t, clarabel_s=clarabel_t)


def run_batch(conds, rgbs, grid, n_total):
    setup = forward.chart_setup(wavelengths=grid)
    depth = np.array([c["depth"] for c in conds])
    dist = np.array([c["distance"] for c in conds])
    res = sca.estimate_batch(rgbs, depth=depth, distance=dist, setup=setup)
    ests = [dict(chl=res.chl[i], cdom=res.cdom[i], attenuation=res.attenuation[i],
                 converged=res.converged[i], objective=res.objective[i]) for i in range(len(conds))]
    # throughput on a stack of n_total charts (the set tiled)
    reps = -(-n_total // len(conds))
    big = np.tile(rgbs, (reps, 1, 1))[:n_total]
    bd, br = np.tile(depth, reps)[:n_total], np.tile(dist, reps)[:n_total]
    sca.estimate_batch(big[:2000], depth=bd[:2000], distance=br[:2000], setup=setup)  # warm-up
    runs = []
    for _ in range(BATCH_REPEATS):  # a 0.1-0.2 s measurement: the median of several
        t0 = time.perf_counter()
        rb = sca.estimate_batch(big, depth=bd, distance=br, setup=setup)
        runs.append(time.perf_counter() - t0)
    elapsed = float(np.median(runs))
    per_fit = elapsed / n_total
    return ests, [per_fit] * n_total, rb.iterations, dict(
        batch_n=n_total, batch_elapsed_s=elapsed, batch_runs_s=runs,
        batch_converged=int(rb.converged.sum()))


def equal_optimum(n=600, seed=11):
    """Batch vs the sca safeguarded loop at 10 nm on n random noise-free and n noisy charts."""
    rng = np.random.default_rng(seed)
    C = 10 ** rng.uniform(-3, 2, n)
    A = np.where(rng.random(n) < 0.1, 0.0, 10 ** rng.uniform(-2, np.log10(2), n))
    D = rng.choice([1.0, 5.0, 10.0, 20.0, 30.0], n)
    R = rng.choice([0.5, 1.0, 5.0, 10.0], n)
    out = {}
    for noise in (False, True):
        M = np.array([forward.simulate_chart(C[i], A[i], D[i], R[i], noise=noise, seed=i).rgb
                      for i in range(n)])
        b = sca.estimate_batch(M, depth=D, distance=R)
        ref = [sca.estimate(M[i], depth=D[i], distance=R[i]) for i in range(n)]
        chl = np.array([e.chl for e in ref])
        cdom = np.array([e.cdom for e in ref])
        obj = np.array([e.objective for e in ref])
        ok_ref = np.array([e.converged for e in ref])
        if not noise:
            same = (np.abs(b.chl - chl) <= 1e-6 * chl + 1e-9) & (np.abs(b.cdom - cdom) <= 1e-6 * cdom + 1e-9)
            key = "noise_free"
        else:
            same = b.objective <= obj * (1 + 1e-9)
            key = "noisy"
        worse = np.flatnonzero(~same)
        out[key] = dict(
            n=n, same_fraction=float(same.mean()), batch_flagged=int((~b.converged).sum()),
            sca_not_converged=int((~ok_ref).sum()),
            silent_differences=int(np.sum(~same & b.converged & ok_ref)),
            cases=[dict(chl=float(C[i]), cdom=float(A[i]), depth=float(D[i]), distance=float(R[i]),
                        batch_chl=float(b.chl[i]), sca_chl=float(chl[i]),
                        batch_objective=float(b.objective[i]), sca_objective=float(obj[i]),
                        batch_status=str(b.status[i]), sca_status=ref[i].status)
                   for i in worse[:10]],
        )
    return out


def machine():
    import clarabel
    import cvxpy

    cpu = "unknown"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return dict(cpu=cpu, cores=os.cpu_count(), python=platform.python_version(),
                openblas_num_threads=os.environ.get("OPENBLAS_NUM_THREADS", "unset"),
                numpy=np.__version__, cvxpy=cvxpy.__version__,
                clarabel=getattr(clarabel, "__version__", "?"), platform=platform.platform())


def plot(records, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    markers = {5.0: "o", 10.0: "s", 20.0: "^"}
    colours = dict(zip(METHODS, plt.rcParams["axes.prop_cycle"].by_key()["color"]))
    for r in records:
        ax.scatter(r["fits_per_s"], max(r["rrmse_k_median"], 1e-16), marker=markers[r["resolution_nm"]],
                   color=colours[r["method"]], s=40)
    for m in METHODS:
        ax.scatter([], [], color=colours[m], label=m)
    for res, mk in markers.items():
        ax.scatter([], [], marker=mk, color="grey", label=f"{res:g} nm")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("fits per second (2 cores)")
    ax.set_ylabel("median RRMSE of k (eq 19)")
    ax.legend(fontsize=7, ncol=2)
    ax.set_title("speed against error", fontsize=9)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=150)
    fig.savefig(path.with_suffix(".pdf"))
    plt.close(fig)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="fewer charts and a smaller batch (a check)")
    p.add_argument("--out", default="benchmarks/results.json")
    p.add_argument("--report", default="BENCHMARKS.md")
    p.add_argument("--figure", default="figures/benchmark_speed_error.png")
    args = p.parse_args(argv)
    t_start = time.perf_counter()
    conds, rgbs = chart_set(args.quick)
    records = []
    for res_nm in RESOLUTIONS_NM:
        grid = np.arange(400.0, 700.0 + res_nm / 2, res_nm)
        for method in METHODS:
            t0 = time.perf_counter()
            if method == "batch":
                ests, times, iters, extra = run_batch(conds, rgbs, grid, 2000 if args.quick else BATCH_N)
            else:
                ests, times, iters, extra = run_single(method, conds, rgbs, grid)
            rec = _record(method, res_nm, conds, ests, times, iters, grid, extra)
            records.append(rec)
            print(f"{method:20s} {res_nm:4g} nm: {rec['fits_per_s']:10.1f} fits/s, median RRMSE "
                  f"{rec['rrmse_k_median']:.2e}, failures {rec['failures']} "
                  f"({time.perf_counter() - t0:.1f} s)", flush=True)
    eq = equal_optimum(100 if args.quick else 600)
    print("equal optimum:", {k: v["same_fraction"] for k, v in eq.items()}, flush=True)
    out = dict(machine=machine(), command="make bench  (python -m experiments.benchmark)",
               quick=args.quick, charts=dict(n=len(conds), chl=CHLS, cdom=CDOMS, depth=DEPTHS,
                                             distance=DISTANCES, truth_grid_nm=5.0),
               records=records, equal_optimum=eq,
               elapsed_s=time.perf_counter() - t_start)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(out, indent=1))
    plot(records, Path(args.figure))
    Path(args.report).write_text(report(out))
    print(f"wrote {args.out}, {args.report}, {args.figure} in {out['elapsed_s']:.0f} s")


def _find(records, method, res):
    return next(r for r in records if r["method"] == method and r["resolution_nm"] == res)


def report(out) -> str:
    recs = out["records"]
    m = out["machine"]
    lines = [
        "# BENCHMARKS — speed against error",
        "",
        "Generated by `make bench` (`python -m experiments.benchmark`), which also writes",
        "`benchmarks/results.json` and `figures/benchmark_speed_error.png`. Do not edit by hand:",
        "rerun the command.",
        "",
        f"Machine: {m['cpu']}, {m['cores']} cores; Python {m['python']}, numpy {m['numpy']}, "
        f"cvxpy {m['cvxpy']}, Clarabel {m['clarabel']}; {m['platform']}; "
        f"OPENBLAS_NUM_THREADS={m.get('openblas_num_threads', 'unset')}."
        + (" **Quick run (reduced sizes).**" if out["quick"] else ""),
        "",
        f"Charts: {out['charts']['n']} (every 4th case of C {out['charts']['chl']} x a_CDOM "
        f"{out['charts']['cdom']} x depth {out['charts']['depth']} x distance "
        f"{out['charts']['distance']}, noise-free and with default sensor noise), simulated on a "
        "5 nm grid; each method estimates on the grid of the row's resolution. All methods ran in "
        "one process, one after another. The batch row's speed is the median of "
        f"{BATCH_REPEATS} runs on {next(r for r in recs if r['method'] == 'batch').get('batch_n', '?')} "
        "charts (the set tiled; its ms/fit columns are that time divided by the charts); its errors "
        "are on the same charts as the other methods.",
        "",
        "| method | nm | fits/s | median ms/fit | p95 ms/fit | iterations (median) | ms/iteration "
        "| RRMSE(k) median | RRMSE(k) max | rel err C median / max | rel err CDOM median / max | failures | n |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in recs:
        lines.append(
            f"| {r['method']} | {r['resolution_nm']:g} | {r['fits_per_s']:.4g} | {r['median_ms_per_fit']:.3g} "
            f"| {r['p95_ms_per_fit']:.3g} | {r['iterations_median']:g} | {r['ms_per_iteration']:.3g} "
            f"| {r['rrmse_k_median']:.2e} | {r['rrmse_k_max']:.2e} "
            f"| {r['rel_err_chl_median']:.1e} / {r['rel_err_chl_max']:.1e} "
            f"| {r['rel_err_cdom_median']:.1e} / {r['rel_err_cdom_max']:.1e} | {r['failures']} | {r['n_fits']} |")
    b10 = _find(recs, "batch", 10.0)
    s10 = _find(recs, "sca_safeguarded", 10.0)
    p10 = _find(recs, "sca_paper", 10.0)
    c10 = _find(recs, "cvx_rebuild", 10.0)
    lines += [
        "",
        "## Headline ratios at 10 nm (this run)",
        f"- batch: {b10['fits_per_s']:.0f} fits/s on {b10.get('batch_n')} charts "
        f"({b10.get('batch_converged')} converged) = {b10['fits_per_s'] / s10['fits_per_s']:.0f}x the DPP `sca` "
        f"safeguarded loop ({s10['fits_per_s']:.1f} fits/s) and "
        f"{b10['fits_per_s'] / p10['fits_per_s']:.0f}x its paper mode.",
        f"- DPP loop vs rebuild-every-iteration (both paper mode, same iterates): "
        f"{c10['ms_per_iteration']:.2f} vs {p10['ms_per_iteration']:.2f} ms per iteration = "
        f"{c10['ms_per_iteration'] / p10['ms_per_iteration']:.1f}x.",
        f"- Where the DPP loop's time goes (safeguarded, 10 nm): {1e3 * s10['solve_call_s'] / s10['n_fits']:.2f} ms "
        f"per fit inside cvxpy's `solve` calls, of which Clarabel's own timer reports "
        f"{1e3 * s10['clarabel_s'] / s10['n_fits']:.2f} ms; the rest of the {s10['median_ms_per_fit']:.2f} ms "
        "median fit is the Jacobian, the QR, the active-set polish and the loop itself.",
        "",
        "## Equal optimum: batch vs the `sca` safeguarded loop (10 nm)",
    ]
    for key, v in out["equal_optimum"].items():
        crit = ("C and a_CDOM within 1e-6 relative (1e-9 absolute for a truth of 0)" if key == "noise_free"
                else "objective equal within 1e-9 relative, or lower")
        lines.append(f"- {key.replace('_', '-')}: {v['same_fraction'] * 100:.2f} % of {v['n']} random charts "
                     f"meet \"{crit}\"; batch flagged {v['batch_flagged']} as not converged; "
                     f"the sca loop did not converge on {v['sca_not_converged']}; differences where both "
                     f"claim convergence: {v['silent_differences']}.")
        for c in v["cases"]:
            lines.append(f"  - C {c['chl']:.3g}, CDOM {c['cdom']:.3g}, depth {c['depth']:g}, distance "
                         f"{c['distance']:g}: batch C {c['batch_chl']:.6g} (objective "
                         f"{c['batch_objective']:.6e}, {c['batch_status']}) vs sca C {c['sca_chl']:.6g} "
                         f"(objective {c['sca_objective']:.6e}, {c['sca_status']})")
    lines += [
        "",
        "## Reading the table",
        "- Resolution (\"model only what a scene needs\"): the charts are simulated at 5 nm; the 10 and",
        "  20 nm rows show what a coarser model costs in accuracy (noise-free charts no longer fit",
        "  exactly, because the camera integral and the spectra are sampled more coarsely).",
        "- `sca_paper` fails (not converged) where a full Taylor step overshoots: see DECISIONS.md.",
        "- The DPP loop compiles its problem once; what remains per iteration is cvxpy's own work",
        "  in each `solve` call (mapping the parameter values into Clarabel's matrices and back:",
        f"  {1e3 * (s10['solve_call_s'] - s10['clarabel_s']) / s10['n_fits']:.2f} ms per fit here, "
        f"against Clarabel's {1e3 * s10['clarabel_s'] / s10['n_fits']:.2f} ms) plus our numpy work",
        "  (Jacobian, QR, polish). So it is *not* dominated by the Clarabel solve; for throughput use",
        "  the batched solver, which reaches the same optimum (section above).",
        "- The max columns are set by charts the data cannot decide: noise-free charts simulated at",
        "  5 nm and fitted at 10/20 nm with a small true C (the coarse model's bias), and a chart so",
        "  dark (depth 30 m, C 100, a_CDOM 0.5, brightest patch 5e-6) that every method fits the",
        "  noise equally well with absurd C (the `sca` loop stops at C = 200, the batch at 1e10,",
        "  both at the same objective). Neither flags this yet (see the closing note of the issue).",
        "- `scipy_least_squares` (trust-region reflective on the reduced problem, analytic Jacobian)",
        "  is a faster single-chart method than the QP loop and reaches the same optimum here.",
        "- The relative errors of C and a_CDOM with noise are those of the estimation problem itself",
        "  (weakly identifiable C at great depth), not of the solver: compare the methods row by row.",
        "",
        f"Total benchmark time: {out['elapsed_s']:.0f} s.",
    ]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
