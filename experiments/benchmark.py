"""Speed against error: every estimation method on the same charts, at 10, 5, 2 and 1 nm.

    python -m experiments.benchmark [--quick]      (``make bench``)

Writes ``benchmarks/results.json`` (one record per method x resolution, the interval coverage
study, the equal-optimum check), ``BENCHMARKS.md`` and ``figures/benchmark_speed_error.png``.
All methods run in this one process, one after another, so their ratios are comparable.

Charts: a grid with the estimator's hard cases (C from 1e-3 to 100 mg m^-3, a_CDOM from 0 to
2 m^-1, depth 1-30 m, distance 0.5-10 m), half noise-free and half with the default sensor
noise, simulated in a 1 nm world (the finest grid the data support); every estimator is given
the sensor's noise model (``sigma``) and estimates on the grid of the resolution under test; k
is compared with the true k on that grid. Relative errors of C and a_CDOM use max(truth, 1e-3)
in the denominator (a_CDOM = 0 is among the cases).

This module runs the benchmark; :mod:`experiments.benchmark_report` writes its files.
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
from .benchmark_report import write_outputs
from .chartset import CDOMS, CHLS, DEPTHS, DISTANCES, SEED, chart_set
from .sweep import rrmse_bands

__all__ = ["chart_set", "run_single", "run_batch", "coverage", "equal_optimum", "machine",
           "main", "RESOLUTIONS_NM", "METHODS", "COVERAGE_LUX", "BATCH_N",
           "BATCH_REPEATS", "BUDGET_BATCH_N", "BUDGET_REPEATS", "SEED",
           "SINGLE_RESOLUTIONS_NM", "WAIT_COMMANDS", "loop_optimum", "peak_memory_mb", "process_age_s",
           "INCLUDED", "JOINT_REPEATS", "PROFILE_N", "included", "issue36_studies"]

RESOLUTIONS_NM = (10.0, 5.0, 2.0, 1.0)
#: The one-chart-at-a-time methods run at these resolutions only (the batch rows at all of
#: RESOLUTIONS_NM): the default grid and the coarsest (``make bench`` within 2 minutes)
SINGLE_RESOLUTIONS_NM = (10.0, 1.0)
#: cvx_rebuild (the DPP comparison: same iterates as sca_paper) runs at this resolution only
REBUILD_RESOLUTION_NM = 10.0
#: ... and the default budget's rows (sca_budget, batch_budget) at the default grid only
BUDGET_RESOLUTION_NM = 1.0
METHODS = ("cvx_rebuild", "sca_paper", "sca_safeguarded", "scipy_least_squares",
           "batch_no_intervals", "batch", "sca_budget", "batch_budget")
#: The uncertainty budget of each method: the paper's exact model, except the ``*_budget``
#: rows, which run the estimators' default budget (sca.budget.DEFAULT_UNCERTAIN).
PAPER_MODEL = {}


def _uncertain(method):
    return None if method.endswith("_budget") else PAPER_MODEL
#: light levels of the coverage study (lx): the default sensor's daylight and a dim scene
COVERAGE_LUX = (20000.0, 200.0)
#: Charts in the batch throughput stack (the chart set tiled); QUICK_BATCH_N with --quick
BATCH_N = 2000
QUICK_BATCH_N = 600
#: Charts of the untimed warm-up batch call before the timed ones (numba compilation, caches;
#: more than sca.projection.SERIAL_BELOW: the parallel kernels too)
WARMUP_N = 200
#: Timed batch runs (0.1-1 s each): their median is the batch rows' speed
BATCH_REPEATS = 3
#: The ``batch_budget`` rows: charts timed and runs (the default budget fits every chart under
#: three path models with ten nuisance parameters: about 100x the exact model's work).
BUDGET_BATCH_N, BUDGET_REPEATS = 120, 1
#: Relative errors of C and a_CDOM divide by max(truth, REL_ERR_FLOOR) (a_CDOM = 0 is a case)
REL_ERR_FLOOR = 1e-3
#: Coverage study: noise seeds COVERAGE_SEED + the chart's index; every QUICK_COVERAGE_STRIDE-th
#: chart with --quick; sca.estimate's verdict compared with the batch's on every AGREE_STRIDE-th
COVERAGE_SEED = 90000
QUICK_COVERAGE_STRIDE = 6
AGREE_STRIDE = 30
#: A fit misfits when its chi^2 p-value is below this (as sca.assess.MISFIT_P)
MISFIT_P = 1e-3
#: Equal-optimum study: random charts per noise setting (QUICK_EQUAL_OPTIMUM_N with --quick)
EQUAL_OPTIMUM_N = 100
QUICK_EQUAL_OPTIMUM_N = 100
#: ... and its criteria (BENCHMARKS.md states them: keep experiments.benchmark_report in step):
#: noise-free, C and a_CDOM within EQUAL_RTOL relative + EQUAL_ATOL absolute; noisy, the batch's
#: objective within OBJECTIVE_RTOL of the loop's or lower
EQUAL_RTOL = 1e-6
EQUAL_ATOL = 1e-9
OBJECTIVE_RTOL = 1e-9
#: An objective below this fraction of sum (M / sigma)^2 is an exact fit (rounding level)
EXACT_OBJECTIVE = 1e-12
#: Cases listed per noise setting where the two differ
MAX_CASES_LISTED = 10


def _rel(est, truth):
    return abs(est - truth) / max(truth, REL_ERR_FLOOR)


def _covered(ci, truth):
    return bool(ci[0] <= truth <= ci[1])


def _record(method, res_nm, conds, estimates, times, iterations, grid, extra=None):
    k_err, e_chl, e_cdom, fails = [], [], [], 0
    misfit, reliable, covered, wrong = [], [], [], []
    for cond, est in zip(conds, estimates):
        k_true = forward.attenuation(grid, cond["chl"], cond["cdom"], cond["depth"], cond["distance"])
        k_err.append(rrmse_bands(grid, est["attenuation"], k_true))
        e_chl.append(_rel(est["chl"], cond["chl"]))
        e_cdom.append(_rel(est["cdom"], cond["cdom"]))
        fails += not est["converged"]
        misfit.append("misfit" in est["flags"])
        reliable.append(est["reliable"])
        cov = _covered(est["chl_ci"], cond["chl"]) and _covered(est["cdom_ci"], cond["cdom"])
        covered.append(cov)
        wrong.append(est["reliable"] and not cov)
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
        failures=int(fails), misfit_fraction=float(np.mean(misfit)),
        reliable_fraction=float(np.mean(reliable)), covered_fraction=float(np.mean(covered)),
        reliable_outside=int(np.sum(wrong)),
    )
    if extra:
        rec.update(extra)
    return rec


def _as_dict(e):
    return dict(chl=e.chl, cdom=e.cdom, attenuation=e.attenuation, converged=e.converged,
                objective=e.objective, chl_ci=e.chl_ci, cdom_ci=e.cdom_ci, flags=e.flags,
                reliable=e.reliable)


def run_single(method, conds, rgbs, sigmas, grid):
    """One chart at a time; returns estimates, per-fit times, iterations, and solver timings."""
    setup = forward.chart_setup(wavelengths=grid)
    ests, times, iters, solve_t, clarabel_t = [], [], [], 0.0, 0.0
    for cond, rgb, sig in zip(conds, rgbs, sigmas):
        kw = dict(depth=cond["depth"], distance=cond["distance"], setup=setup, sigma=sig,
                  uncertain=_uncertain(method))
        trace = dict(n_solves=0, solve_time_s=0.0, clarabel_time_s=0.0)
        t0 = time.perf_counter()
        if method in ("cvx_rebuild", "sca_paper", "sca_safeguarded", "sca_budget"):
            sig = kw.pop("sigma")
            cls = RebuildEstimator if method == "cvx_rebuild" else sca.Estimator
            mode = "paper" if method in ("cvx_rebuild", "sca_paper") else "safeguarded"
            e = cls(**kw).fit(rgb, sigma=sig, mode=mode, trace=trace)
        elif method == "scipy_least_squares":
            e = estimate_least_squares(rgb, **kw)
        else:
            raise ValueError(method)
        times.append(time.perf_counter() - t0)
        iters.append(max(trace["n_solves"], 1) if method != "scipy_least_squares" else e.iterations)
        solve_t += trace["solve_time_s"]
        clarabel_t += trace["clarabel_time_s"]
        ests.append(_as_dict(e))
    return ests, times, iters, dict(solve_call_s=solve_t, clarabel_s=clarabel_t)


def run_batch(conds, rgbs, sigmas, grid, n_total, intervals, uncertain=PAPER_MODEL,
              repeats=BATCH_REPEATS, warmup=WARMUP_N):
    """:func:`sca.estimate_batch` on the chart set (for the errors), then timed on ``n_total``
    charts (the set tiled; the median of BATCH_REPEATS runs after a warm-up of WARMUP_N);
    returns estimates, per-fit times, iterations and the batch timings, as :func:`run_single`."""
    setup = forward.chart_setup(wavelengths=grid)
    depth = np.array([c["depth"] for c in conds])
    dist = np.array([c["distance"] for c in conds])
    kw = dict(setup=setup, intervals=intervals, uncertain=uncertain)
    res = sca.estimate_batch(rgbs, depth=depth, distance=dist, sigma=sigmas, **kw)
    ests = [dict(chl=res.chl[i], cdom=res.cdom[i], attenuation=res.attenuation[i],
                 converged=res.converged[i], objective=res.objective[i], chl_ci=res.chl_ci[i],
                 cdom_ci=res.cdom_ci[i], flags=res.flags[i], reliable=res.reliable[i])
            for i in range(len(conds))]
    # throughput on a stack of n_total charts (the set tiled)
    reps = -(-n_total // len(conds))
    big = np.tile(rgbs, (reps, 1, 1))[:n_total]
    bs = np.tile(sigmas, (reps, 1, 1))[:n_total]
    bd, br = np.tile(depth, reps)[:n_total], np.tile(dist, reps)[:n_total]
    w = warmup
    sca.estimate_batch(big[:w], depth=bd[:w], distance=br[:w], sigma=bs[:w], **kw)
    runs = []
    for _ in range(repeats):  # a 0.1-1 s measurement: the median of several
        t0 = time.perf_counter()
        rb = sca.estimate_batch(big, depth=bd, distance=br, sigma=bs, **kw)
        runs.append(time.perf_counter() - t0)
    elapsed = float(np.median(runs))
    per_fit = elapsed / n_total
    return ests, [per_fit] * n_total, rb.iterations, dict(
        batch_n=n_total, batch_elapsed_s=elapsed, batch_runs_s=runs,
        batch_converged=int(rb.converged.sum()))


def coverage(quick=False):
    """Interval coverage over the Fig 10 and Fig 12 grids (paper grids, one noise seed each),
    in the 1 nm world, at each light level of COVERAGE_LUX; fitted by the batch at its default
    grid with the sensor's noise model. Also checks, on every 10th chart, that sca.estimate gives
    the same verdict."""
    from .grids import grid as get_grid

    g = get_grid("paper")
    cells = [(c, a, d, r) for d, r, c, a in itertools.product(
        g["fig10_depths_m"], g["fig10_distances_m"], g["fig10_chl"], g["fig10_cdom"])]
    cells += [(c, a, d, g["fig12_distance_m"]) for d, c, a in itertools.product(
        g["fig12_depths_m"], g["fig12_chl"], g["fig12_cdom"])]
    if quick:
        cells = cells[::QUICK_COVERAGE_STRIDE]
    out = []
    for lux in COVERAGE_LUX:
        sensor = forward.SensorSettings(illuminance_lux=lux)
        sims = [forward.simulate_chart(c, a, d, r, seed=COVERAGE_SEED + i, sensor=sensor)
                for i, (c, a, d, r) in enumerate(cells)]
        M = np.array([s.rgb for s in sims])
        S = np.array([s.rgb_sigma for s in sims])
        D = np.array([s.depth for s in sims])
        R = np.array([s.distance for s in sims])
        b = sca.estimate_batch(M, depth=D, distance=R, sigma=S, uncertain=PAPER_MODEL)
        chl = np.array([c[0] for c in cells])
        cdom = np.array([c[1] for c in cells])
        cov_c = (b.chl_ci[:, 0] <= chl) & (chl <= b.chl_ci[:, 1])
        cov_a = (b.cdom_ci[:, 0] <= cdom) & (cdom <= b.cdom_ci[:, 1])
        agree = [sca.estimate(M[j], depth=D[j], distance=R[j], sigma=S[j],
                              uncertain=PAPER_MODEL).reliable == b.reliable[j]
                 for j in range(0, len(cells), AGREE_STRIDE)]
        out.append(dict(
            illuminance_lux=lux, n=len(cells), coverage_chl=float(cov_c.mean()),
            coverage_cdom=float(cov_a.mean()), reliable=float(b.reliable.mean()),
            misfit=float(np.mean(b.chi2_p < MISFIT_P)),
            unbounded=float(np.mean(~np.isfinite(b.chl_ci[:, 1]) | ~np.isfinite(b.cdom_ci[:, 1]))),
            coverage_chl_reliable=float(cov_c[b.reliable].mean()) if b.reliable.any() else float("nan"),
            coverage_cdom_reliable=float(cov_a[b.reliable].mean()) if b.reliable.any() else float("nan"),
            reliable_outside=int(np.sum(b.reliable & ~(cov_c & cov_a))),
            single_batch_agree=f"{int(np.sum(agree))}/{len(agree)}"))
    return out


def equal_optimum(n=EQUAL_OPTIMUM_N, seed=11):
    """Batch vs the sca safeguarded loop at the default grid (1 nm) on n random noise-free and n
    noisy charts (unweighted: the paper's objective). The charts: C log-uniform in 1e-3-100
    mg m^-3, a_CDOM 0 for a tenth of them and else log-uniform in 0.01-2 m^-1, depth and
    distance drawn from the grid's values. Same: see EQUAL_RTOL, EQUAL_ATOL, OBJECTIVE_RTOL.
    Both fit the grid as given (``quadrature='full'``): one objective, compared to 1e-9 (the
    certified quadrature's own error is measured apart, :mod:`experiments.quadrature_check`)."""
    rng = np.random.default_rng(seed)
    C = 10 ** rng.uniform(-3, 2, n)
    A = np.where(rng.random(n) < 0.1, 0.0, 10 ** rng.uniform(-2, np.log10(2), n))
    D = rng.choice([1.0, 5.0, 10.0, 20.0, 30.0], n)
    R = rng.choice([0.5, 1.0, 5.0, 10.0], n)
    out = {}
    for noise in (False, True):
        M = np.array([forward.simulate_chart(C[i], A[i], D[i], R[i], noise=noise, seed=i).rgb
                      for i in range(n)])
        b = sca.estimate_batch(M, depth=D, distance=R, uncertain=PAPER_MODEL, quadrature="full")
        ref = [sca.estimate(M[i], depth=D[i], distance=R[i], uncertain=PAPER_MODEL,
                            quadrature="full") for i in range(n)]
        chl = np.array([e.chl for e in ref])
        cdom = np.array([e.cdom for e in ref])
        obj = np.array([e.objective for e in ref])
        ok_ref = np.array([e.converged for e in ref])
        if not noise:
            same = ((np.abs(b.chl - chl) <= EQUAL_RTOL * chl + EQUAL_ATOL)
                    & (np.abs(b.cdom - cdom) <= EQUAL_RTOL * cdom + EQUAL_ATOL))
            key = "noise_free"
        else:
            same = b.objective <= obj * (1 + OBJECTIVE_RTOL)
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
                   for i in worse[:MAX_CASES_LISTED]],
        )
    return out


def loop_optimum(conds, rgbs, sigmas, step_nm=1.0):
    """Issue 21's target 4 on the benchmark's own charts: the batch (no intervals, the paper's
    model) against the DPP ``sca`` loop, both weighted by the sensor's noise, on the grid of
    ``step_nm``. Where the loop converges the batch must converge too, to an objective within
    OBJECTIVE_RTOL of the loop's or lower (an exact fit, objective at rounding level: C and
    a_CDOM within EQUAL_RTOL + EQUAL_ATOL).

    Returns
    -------
    dict
        ``n``, ``loop_converged``, ``batch_converged``, ``at_optimum`` (charts where the loop
        converged and the batch met the criterion) and ``misses`` (their conditions and
        numbers).
    """
    setup = forward.chart_setup(wavelengths=np.arange(400.0, 700.0 + step_nm / 2, step_nm))
    depth = np.array([c["depth"] for c in conds])
    dist = np.array([c["distance"] for c in conds])
    # both on the grid as given: the same objective (the certified quadrature is measured
    # against the full grid apart, in the quadrature rows)
    b = sca.estimate_batch(rgbs, depth=depth, distance=dist, sigma=sigmas, setup=setup,
                           intervals=False, uncertain=PAPER_MODEL, quadrature="full")
    loop_ok = at = 0
    misses = []
    for i, cond in enumerate(conds):
        e = sca.estimate(rgbs[i], depth=depth[i], distance=dist[i], sigma=sigmas[i], setup=setup,
                         uncertain=PAPER_MODEL, quadrature="full")
        if not e.converged:
            continue
        loop_ok += 1
        if e.objective > EXACT_OBJECTIVE * float(np.sum((rgbs[i] / sigmas[i]) ** 2)):
            same = b.objective[i] <= e.objective * (1 + OBJECTIVE_RTOL)
        else:
            same = (abs(b.chl[i] - e.chl) <= EQUAL_RTOL * e.chl + EQUAL_ATOL
                    and abs(b.cdom[i] - e.cdom) <= EQUAL_RTOL * e.cdom + EQUAL_ATOL)
        if b.converged[i] and same:
            at += 1
        else:
            misses.append(dict(cond, batch_status=str(b.status[i]),
                               batch_objective=float(b.objective[i]),
                               sca_objective=float(e.objective)))
    return dict(n=len(conds), step_nm=step_nm, loop_converged=loop_ok,
                batch_converged=int(b.converged.sum()), at_optimum=at, misses=misses)


def process_age_s():
    """Seconds since this process started (imports included; Linux's /proc), or None."""
    try:
        start = int(Path("/proc/self/stat").read_text().rsplit(")", 1)[1].split()[19])
        uptime = float(Path("/proc/uptime").read_text().split()[0])
        return uptime - start / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError):
        return None


def peak_memory_mb() -> dict:
    """Peak resident memory (MB) of this process and of the largest child it waited for
    (``resource.getrusage``; Linux reports kilobytes)."""
    import resource

    return {"self": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
            "children": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0}


def machine():
    """The machine and library versions of the run (CPU, cores, Python, numpy, cvxpy, ...)."""
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


# --------------------------------------------------------------------------- photographs
#: Whole-process waits (:mod:`experiments.wait_bench`) in ``make bench``: its commands run here
#: (issue 21's targets 1 and 2, and the floor of the libraries uw3p estimate needs), rounds
#: (each keeps its best), and the --quick frame (h, w; the full run uses wait_bench's 24 MP)
WAIT_COMMANDS = ("decode", "measure", "estimate", "help", "measure --help", "bad input",
                 "library floor")
WAIT_REPEATS = 2
QUICK_PHOTO_FRAME = (1000, 1500)

# --------------------------------------------------------------------------- issue 36
#: Charts of the counted default batch (:mod:`experiments.batch_profile`); QUICK_PROFILE_N
#: with --quick
PROFILE_N, QUICK_PROFILE_N = 300, 60
#: Timed joint fits of the six-photo dive (:mod:`experiments.joint_bench`, after a warm-up)
JOINT_REPEATS = 2
#: The quadrature check's single fits on every QUICK_SINGLE_STRIDE-th chart with --quick
QUICK_SINGLE_STRIDE = 30
#: The slower studies ``make bench`` does not run but reports, each from the JSON its own
#: command writes (``make bench-slow`` runs them): name -> (file, the command that writes it)
INCLUDED = {
    "compare": ("benchmarks/compare_default.json",
                "python -m experiments.compare_commits ffa6454 WORKTREE --workload default "
                "--batch 1000,120 --rounds 3 --json benchmarks/compare_default.json"),
    "cold_start": ("benchmarks/cold_start.json",
                   "python -m experiments.cold_start --json benchmarks/cold_start.json"),
    "joint_profile": ("benchmarks/joint_profile.json",
                      "python -m experiments.joint_bench --profile --json "
                      "benchmarks/joint_profile.json"),
    "make_times": ("benchmarks/make_times.json",
                   "python -m experiments.stopwatch NAME -- COMMAND (make reproduce-figures "
                   "runs each of its steps so; the test tiers were timed so by hand)"),
}


def issue36_studies(quick=False) -> dict:
    """Issue 36's measurements that ``make bench`` makes itself: the default batch counted by
    caller (:func:`experiments.batch_profile.profile_default_batch`), the certified
    quadrature against the full grid at the defaults (:func:`experiments.quadrature_check.run`)
    and the joint fit of a six-photo dive as ``measure.fit_joint`` calls it
    (:func:`experiments.joint_bench.time_joint`); each with its seconds."""
    from . import batch_profile, joint_bench, quadrature_check

    out = {}
    for name, fn in (
            ("profile", lambda: batch_profile.profile_default_batch(
                QUICK_PROFILE_N if quick else PROFILE_N)),
            ("quadrature", lambda: quadrature_check.run(
                QUICK_SINGLE_STRIDE if quick else quadrature_check.SINGLE_STRIDE)),
            ("joint", lambda: joint_bench.time_joint(
                repeats=1 if quick else JOINT_REPEATS, variants=("as_fit_joint",)))):
        t0 = time.perf_counter()
        out[name] = fn()
        out[name]["study_seconds"] = time.perf_counter() - t0
        print(f"({name} {out[name]['study_seconds']:.1f} s)", flush=True)
    return out


def included(root=None) -> dict:
    """The slower studies' results (:data:`INCLUDED`) as their commands last wrote them: name
    -> {'file', 'command', 'data' (None where the file is absent)}."""
    root = Path(__file__).resolve().parents[1] if root is None else Path(root)
    out = {}
    for name, (rel, command) in INCLUDED.items():
        try:
            data = json.loads((root / rel).read_text())
        except (OSError, ValueError):
            data = None
        out[name] = {"file": rel, "command": command, "data": data}
    return out


def main(argv=None):
    """``python -m experiments.benchmark [--quick] [--out] [--report] [--figure]``: run every
    study, then write the results (:func:`experiments.benchmark_report.write_outputs`)."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="fewer charts and a smaller batch (a check)")
    p.add_argument("--out", default="benchmarks/results.json")
    p.add_argument("--report", default="BENCHMARKS.md")
    p.add_argument("--figure", default="figures/benchmark_speed_error.png")
    args = p.parse_args(argv)
    t_start = time.perf_counter()
    conds, rgbs, sigmas = chart_set(args.quick)
    records = []
    for res_nm in RESOLUTIONS_NM:
        grid = np.arange(400.0, 700.0 + res_nm / 2, res_nm)
        for method in METHODS:
            if res_nm not in SINGLE_RESOLUTIONS_NM and method not in ("batch", "batch_no_intervals"):
                continue  # the resolution sweep of the exact model's batch only
            if method.endswith("_budget") and res_nm != BUDGET_RESOLUTION_NM:
                continue
            if method == "cvx_rebuild" and res_nm != REBUILD_RESOLUTION_NM:
                continue
            t0 = time.perf_counter()
            if method.startswith("batch"):
                budget = method.endswith("_budget")
                n_total = (len(conds) if args.quick else BUDGET_BATCH_N) if budget else (
                    QUICK_BATCH_N if args.quick else BATCH_N)
                ests, times, iters, extra = run_batch(
                    conds, rgbs, sigmas, grid, n_total, intervals=method != "batch_no_intervals",
                    uncertain=_uncertain(method), repeats=BUDGET_REPEATS if budget else BATCH_REPEATS,
                    warmup=len(conds) if budget else WARMUP_N)
            else:
                ests, times, iters, extra = run_single(method, conds, rgbs, sigmas, grid)
            rec = _record(method, res_nm, conds, ests, times, iters, grid, extra)
            records.append(rec)
            print(f"{method:20s} {res_nm:4g} nm: {rec['fits_per_s']:10.1f} fits/s, median RRMSE "
                  f"{rec['rrmse_k_median']:.2e}, failures {rec['failures']} "
                  f"({time.perf_counter() - t0:.1f} s)", flush=True)
    t_sec = time.perf_counter()
    cov = coverage(args.quick)
    for c in cov:
        print(f"coverage at {c['illuminance_lux']:g} lx: C {c['coverage_chl']:.3f}, CDOM "
              f"{c['coverage_cdom']:.3f} over {c['n']} charts", flush=True)
    print(f"(coverage {time.perf_counter() - t_sec:.1f} s)", flush=True)
    t_sec = time.perf_counter()
    eq = equal_optimum(QUICK_EQUAL_OPTIMUM_N if args.quick else EQUAL_OPTIMUM_N)
    print("equal optimum:", {k: v["same_fraction"] for k, v in eq.items()}, flush=True)
    print(f"(equal optimum {time.perf_counter() - t_sec:.1f} s)", flush=True)
    t_sec = time.perf_counter()
    sixty = loop_optimum(conds, rgbs, sigmas)
    print(f"the benchmark's charts: the batch at the loop's optimum on {sixty['at_optimum']} of "
          f"{sixty['loop_converged']} where the loop converged", flush=True)
    print(f"(the benchmark's charts {time.perf_counter() - t_sec:.1f} s)", flush=True)
    issue36 = issue36_studies(args.quick)
    from . import wait_bench

    waits = wait_bench.run(repeats=WAIT_REPEATS, names=WAIT_COMMANDS,
                           frame=QUICK_PHOTO_FRAME if args.quick else wait_bench.FRAME)
    print(wait_bench.table(waits), flush=True)
    out = dict(machine=machine(), command="make bench  (python -m experiments.benchmark)",
               quick=args.quick, charts=dict(n=len(conds), chl=CHLS, cdom=CDOMS, depth=DEPTHS,
                                             distance=DISTANCES, truth_grid_nm=1.0),
               records=records, coverage=cov, equal_optimum=eq, loop_optimum=sixty,
               waits=waits, issue36=issue36, included=included(), sizes=dict(batch_n=QUICK_BATCH_N if args.quick else BATCH_N,
                                       batch_repeats=BATCH_REPEATS,
                                       budget_batch_n=len(conds) if args.quick else BUDGET_BATCH_N,
                                       single_resolutions_nm=list(SINGLE_RESOLUTIONS_NM),
                                       equal_optimum_n=(QUICK_EQUAL_OPTIMUM_N if args.quick
                                                        else EQUAL_OPTIMUM_N),
                                       agree_stride=AGREE_STRIDE),
               elapsed_s=time.perf_counter() - t_start, process_s=process_age_s(),
               peak_memory_mb=peak_memory_mb())
    write_outputs(out, args.out, args.report, args.figure)
    print(f"wrote {args.out}, {args.report}, {args.figure} in {out['elapsed_s']:.0f} s")


if __name__ == "__main__":
    main()
