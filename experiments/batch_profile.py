"""Where the time of the default batch goes: model evaluations per chart by caller.

    python -m experiments.batch_profile [--charts 1000] [--json FILE]

Runs :func:`sca.estimate_batch` at its defaults (the default uncertainty budget, every path
model, intervals, the 1 nm grid on the certified quadrature) on the noisy charts of ``make
bench`` (:func:`experiments.chartset.chart_set`, tiled to ``--charts``), once untimed (numba
and the quadrature's caches) and once counted: every call of the inference layer's objective
(:meth:`sca.problem.Problem.evaluate`, the model function and the compiled variable projection)
and every direct call of the model function (:meth:`sca.ChartModel.predict`) is timed and
attributed to the estimator's step that made it, by the innermost of these functions on the
call stack:

* ``start grid`` (:func:`sca.batch.start_grid`): the coarse (C, a_CDOM) grid, values only, at
  the grid's points (shared by the charts of one path length: counted as points, not as
  chart-evaluations);
* ``fit`` (:func:`sca.batch._solve_chunk`'s two Levenberg-Marquardt runs -- the paper's model,
  then every nuisance released -- and the evaluation at the optimum);
* ``known-gain test`` (:func:`sca.batch.scale_test`: two Levenberg-Marquardt fits with the gain
  free);
* ``interval ends: Newton`` (:func:`sca.intervals._vm_ends`, Venzon-Moolgavkar);
* ``interval ends: profile points`` (:func:`sca.intervals._profile_ends`: bracketing and
  Illinois, each point a Levenberg-Marquardt with the parameter held);
* ``budget shares`` (:func:`sca.batch._budget_shares`), ``gain variance``;
* ``certification`` (:func:`sca.quadrature.reduction_error`: the optimum on the full grid) and
  ``attenuation`` (k on the full grid).

A chart-evaluation is one chart's values (and Jacobian, where asked) at one point; a call of a
batch of k charts is k chart-evaluations. Each call is timed twice: wall-clock (the machine's
other load included) and the process's CPU time (``time.process_time``: every thread of this
process, numba's and the model function's thread pool included; on a shared machine the better
measure of the work itself, since a process waiting for a core uses none). What is not inside
these calls (the drivers' own Python, the compiled LM steps, the flags, the combination of the
path models) is reported as ``outside the model``.
"""

from __future__ import annotations

import argparse
import sys
import threading
import time
from collections import defaultdict

import numpy as np

__all__ = ["CALLERS", "Counter", "GRID_POINTS", "main", "profile_default_batch", "summary_rows",
           "table"]

#: The functions that name a caller (in order of priority: the first on the stack wins), and
#: the row its evaluations count in.
CALLERS = {
    "start_grid": "start grid",
    "scale_test": "known-gain test",
    "_vm_ends": "interval ends: Newton",
    "_profile_ends": "interval ends: profile points",
    "_budget_shares": "budget shares",
    "gain_variance": "gain variance",
    "reduction_error": "certification",
    "_solve_chunk": "fit",
    "_solve_certified": "attenuation",
}
#: Rows in the order the batch runs them.
ORDER = ("start grid", "fit", "known-gain test", "interval ends: Newton",
         "interval ends: profile points", "budget shares", "gain variance", "certification",
         "attenuation", "other")
#: The kind of the start grid's rows: evaluated at the grid's points, not per chart.
GRID_POINTS = "model, at the grid's points"


def _caller(callers) -> str:
    """The step that is evaluating: the first function of ``callers`` (name -> row, in order
    of priority) on the call stack, else 'other'."""
    frame, seen = sys._getframe(2), set()
    while frame is not None:
        seen.add(frame.f_code.co_name)
        frame = frame.f_back
    return next((row for name, row in callers.items() if name in seen), "other")


class Counter:
    """Counts and times :meth:`sca.problem.Problem.evaluate` and direct calls of
    :meth:`sca.ChartModel.predict` by caller while active (a context manager).

    Parameters
    ----------
    callers : dict, optional
        Function name -> the row its evaluations count in, in order of priority (default
        :data:`CALLERS`, the batch's steps).

    Attributes
    ----------
    rows : dict
        (caller, kind, grid size) -> {'calls', 'units' (units evaluated: charts, dives, or the
        start grid's points), 'seconds' (wall), 'cpu' (the process's CPU seconds)}.
    """

    def __init__(self, callers=None):
        self.callers = CALLERS if callers is None else dict(callers)
        self.rows = defaultdict(lambda: {"calls": 0, "units": 0, "seconds": 0.0, "cpu": 0.0})
        self._local = threading.local()

    def _record(self, kind, k, t0, c0, q):
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        caller = getattr(self._local, "caller", "other")
        if caller == "start grid" and kind == "model":
            kind = GRID_POINTS
        r = self.rows[(caller, kind, q)]
        r["calls"] += 1
        r["units"] += int(k)
        r["seconds"] += wall
        r["cpu"] += cpu

    def __enter__(self):
        from sca.model import ChartModel
        from sca.problem import Problem

        self._evaluate, self._predict = Problem.evaluate, ChartModel.predict
        counter = self

        def evaluate(prob, idx, theta, grad=True):
            counter._local.caller = _caller(counter.callers)
            counter._local.inside = True
            t0, c0 = time.perf_counter(), time.process_time()
            try:
                return counter._evaluate(prob, idx, theta, grad)
            finally:
                mdl = getattr(prob, "model", None) or (getattr(prob, "models", None) or [None])[0]
                q = getattr(mdl, "wavelengths", np.zeros(0)).size
                counter._local.inside = False
                counter._record("objective" + (" + Jacobian" if grad else ""), len(idx), t0, c0,
                                q)

        def predict(mdl, params, free=(), **kw):
            if getattr(counter._local, "inside", False):
                return counter._predict(mdl, params, free, **kw)
            counter._local.caller = _caller(counter.callers)
            t0, c0 = time.perf_counter(), time.process_time()
            out = counter._predict(mdl, params, free, **kw)
            jac = kw.get("jacobian", True) and bool(free)
            counter._record("model" + (" + Jacobian" if jac else ""),
                            out.values.shape[0] if out.values.ndim > 1 else 1, t0, c0,
                            mdl.wavelengths.size)
            return out

        Problem.evaluate, ChartModel.predict = evaluate, predict
        return self

    def __exit__(self, *exc):
        from sca.model import ChartModel
        from sca.problem import Problem

        Problem.evaluate, ChartModel.predict = self._evaluate, self._predict
        return False


def profile_default_batch(n_charts: int = 1000) -> dict:
    """Count and time the model evaluations of one default :func:`sca.estimate_batch` call.

    Parameters
    ----------
    n_charts : int, optional
        Charts in the call: the noisy half of :func:`experiments.chartset.chart_set`, tiled.

    Returns
    -------
    dict
        ``n`` (charts), ``wall_s`` and ``cpu_s`` (the counted call), ``fits_per_s``,
        ``path_models`` (fitted per chart), ``rows`` (:func:`summary_rows`), ``inside_s``,
        ``inside_cpu_s``, ``outside_s``, ``outside_cpu_s``, ``converged``, ``reliable``.
    """
    import sca

    from .chartset import chart_set

    conds, rgbs, sigmas = chart_set()
    noisy = np.array([c["noise"] for c in conds])
    rgbs, sigmas = rgbs[noisy], sigmas[noisy]
    depth = np.array([c["depth"] for c in conds])[noisy]
    dist = np.array([c["distance"] for c in conds])[noisy]
    reps = -(-n_charts // len(rgbs))

    def tile(a):
        return np.concatenate([a] * reps)[:n_charts]
    M, S, D, R = tile(rgbs), tile(sigmas), tile(depth), tile(dist)
    sca.estimate_batch(M[:len(rgbs)], depth=D[:len(rgbs)], distance=R[:len(rgbs)],
                       sigma=S[:len(rgbs)])  # numba, the quadrature's rule
    with Counter() as counter:
        t0, c0 = time.perf_counter(), time.process_time()
        res = sca.estimate_batch(M, depth=D, distance=R, sigma=S)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    rows, inside, inside_cpu = summary_rows(counter, n_charts, wall)
    return dict(n=int(n_charts), wall_s=wall, cpu_s=cpu, fits_per_s=n_charts / wall,
                path_models=len(res.path_objective), rows=rows, inside_s=inside,
                inside_cpu_s=inside_cpu, outside_s=wall - inside, outside_cpu_s=cpu - inside_cpu,
                converged=int(res.converged.sum()), reliable=int(res.reliable.sum()))


def summary_rows(counter: Counter, n_units: int, wall: float, order=ORDER):
    """The counter's rows as dicts, in ``order`` of their callers, and the time inside them.

    Parameters
    ----------
    counter : Counter
        After the counted call.
    n_units : int
        Charts (or dives) of the counted call: ``per_chart`` is per one of them.
    wall : float
        The counted call's wall time, s (for ``share``).
    order : sequence of str, optional
        The callers' rows in the order to list them ('other' last).

    Returns
    -------
    rows : list of dict
        ``caller``, ``kind``, ``q``, ``calls``, ``units``, ``per_chart`` (units per chart, or
        per dive), ``seconds``, ``cpu``, ``ms_per_chart_eval`` (wall), ``cpu_ms_per_chart_eval``,
        ``share`` (of the wall time).
    inside, inside_cpu : float
        Wall and CPU seconds inside the counted calls.
    """
    rows = []
    for (caller, kind, q), r in counter.rows.items():
        k = max(r["units"], 1)
        rows.append(dict(caller=caller, kind=kind, q=int(q), calls=r["calls"], units=r["units"],
                         per_chart=r["units"] / n_units, seconds=r["seconds"], cpu=r["cpu"],
                         ms_per_chart_eval=1e3 * r["seconds"] / k,
                         cpu_ms_per_chart_eval=1e3 * r["cpu"] / k, share=r["seconds"] / wall))
    order = list(order) + ["other"]
    rows.sort(key=lambda r: (order.index(r["caller"]) if r["caller"] in order else len(order),
                             r["q"], r["kind"]))
    return rows, sum(r["seconds"] for r in rows), sum(r["cpu"] for r in rows)


def evaluations(prof: dict) -> float:
    """Chart-evaluations (or dive-evaluations) per chart of a profile (the start grid's points
    left out)."""
    return sum(r["per_chart"] for r in prof["rows"] if r["kind"] != GRID_POINTS)


def table(prof: dict, unit: str = "chart") -> str:
    """The profile as a markdown table (one row per caller, kind and grid); ``unit``: what one
    evaluation evaluates ('chart', or 'dive')."""
    lines = [f"| step (caller) | evaluated | grid (wavelengths) | calls | {unit}-evaluations "
             f"per {unit} | CPU ms per {unit}-evaluation | wall ms per {unit}-evaluation | CPU "
             "s | wall s | share of the wall time |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in prof["rows"]:
        per = (f"{r['units']} points" if r["kind"] == GRID_POINTS else f"{r['per_chart']:.1f}")
        lines.append(f"| {r['caller']} | {r['kind']} | {r['q']} | {r['calls']} | {per} | "
                     f"{r['cpu_ms_per_chart_eval']:.3f} | {r['ms_per_chart_eval']:.3f} | "
                     f"{r['cpu']:.2f} | {r['seconds']:.2f} | {100 * r['share']:.0f} % |")
    tot = evaluations(prof)
    n_eval = max(tot * prof["n"], 1)
    in_cpu = prof.get("inside_cpu_s", float("nan"))
    lines.append(f"| **all evaluations** | | | {sum(r['calls'] for r in prof['rows'])} | "
                 f"{tot:.0f} | {1e3 * in_cpu / n_eval:.3f} | "
                 f"{1e3 * prof['inside_s'] / n_eval:.3f} | {in_cpu:.2f} | "
                 f"{prof['inside_s']:.2f} | {100 * prof['inside_s'] / prof['wall_s']:.0f} % |")
    lines.append(f"| outside the model (drivers' Python, LM steps, flags, path models "
                 f"combined) | | | | | | | {prof.get('outside_cpu_s', float('nan')):.2f} | "
                 f"{prof['outside_s']:.2f} | "
                 f"{100 * prof['outside_s'] / prof['wall_s']:.0f} % |")
    return "\n".join(lines)


def main(argv=None) -> int:
    """``python -m experiments.batch_profile``: print the table (and write JSON)."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--charts", type=int, default=1000)
    p.add_argument("--json", default=None)
    args = p.parse_args(argv)
    prof = profile_default_batch(args.charts)
    print(f"{prof['n']} charts, {prof['path_models']} path models: {prof['wall_s']:.2f} s wall, "
          f"{prof['cpu_s']:.2f} s CPU ({prof['fits_per_s']:.1f} fits/s)\n")
    print(table(prof))
    if args.json:
        from .stopwatch import write_json

        write_json(args.json, prof)
    return 0


if __name__ == "__main__":
    sys.exit(main())
