"""The certified quadrature's accuracy at the defaults: the same fits on the 5 nm quadrature
and on the full 1 nm grid.

    python -m experiments.quadrature_check [--json FILE]

Issue 36's criteria: every estimate within :data:`ESTIMATE_SE` of its own standard error of the
same fit on the full grid (``quadrature="full"``), and every interval end within
:data:`END_WIDTH` of the interval's width. On the charts of ``make bench``
(:func:`experiments.chartset.chart_set`: 60, half noise-free, half with the sensor's noise):

* **the batch**: :func:`sca.estimate_batch` with its defaults (the default budget, every path
  model, intervals, 1 nm) and ``quadrature='reduced'`` (the default) against
  ``quadrature='full'``; the standard error of C and of a_CDOM is half the full fit's 95 %
  interval / 1.96;
* **single fits**: :func:`sca.estimate` with its defaults on every :data:`SINGLE_STRIDE`-th
  chart, reduced against full; the standard error is the full fit's ``chl_se`` /
  ``cdom_se``.

For each parameter: |x_reduced - x_full| / SE_full and, per end, |end_reduced - end_full| /
(hi_full - lo_full). An interval open on the full grid (an infinite end) has no finite
standard error or width: its estimate and ends are compared only where both fits agree that
the end is open (else the end counts as a miss); such charts are counted apart. A zero-width
interval (an exact fit whose noise is its own zero residual) compares as equal only where the
two agree exactly.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

__all__ = ["END_WIDTH", "ESTIMATE_SE", "SINGLE_STRIDE", "Z95", "compare", "main", "run"]

#: An estimate must lie within this many of its full-grid standard errors of the full fit's.
ESTIMATE_SE = 0.05
#: Each interval end must lie within this fraction of the full fit's interval width.
END_WIDTH = 0.01
#: The 95 % normal quantile: SE = half the 95 % interval / Z95.
Z95 = 1.959963984540054
#: Single fits on every SINGLE_STRIDE-th chart of the set.
SINGLE_STRIDE = 6


def _ratio(diff, scale):
    """|diff| / scale; 0 where diff is 0, inf where scale is 0 or not finite and diff is not."""
    diff, scale = np.abs(np.asarray(diff, float)), np.asarray(scale, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(diff == 0, 0.0, diff / scale)
    return np.where(np.isnan(r), np.inf, r)


def compare(x_r, x_f, ci_r, ci_f, se_f=None) -> dict:
    """The criteria for one parameter over many fits.

    Parameters
    ----------
    x_r, x_f : array_like, (K,)
        Estimates on the quadrature and on the full grid.
    ci_r, ci_f : array_like, (K, 2)
        Their 95 % intervals.
    se_f : array_like, (K,), optional
        The full fit's standard error (default: half its interval / :data:`Z95`).

    Returns
    -------
    dict
        ``n``; ``open`` (fits whose full interval has an infinite end); over the others:
        ``estimate_worst`` (max |x_r - x_f| / SE), ``estimate_ok`` (count within
        :data:`ESTIMATE_SE`), ``end_worst`` (max over both ends of |end_r - end_f| / width),
        ``end_ok`` (count with both ends within :data:`END_WIDTH`), ``compared``; and
        ``open_agree``: of the ``open`` fits, those whose reduced interval is open at the same
        ends.
    """
    x_r, x_f = np.asarray(x_r, float), np.asarray(x_f, float)
    ci_r, ci_f = np.asarray(ci_r, float), np.asarray(ci_f, float)
    width = ci_f[:, 1] - ci_f[:, 0]
    se = width / 2 / Z95 if se_f is None else np.asarray(se_f, float)
    open_ = ~np.all(np.isfinite(ci_f), axis=1)
    closed = ~open_ & np.isfinite(se)
    est = _ratio(x_r - x_f, se)[closed]
    with np.errstate(invalid="ignore"):  # inf - inf on open ends: not compared
        ends = np.max(_ratio(ci_r - ci_f, width[:, None]), axis=1)[closed]
    same_open = np.all(np.isinf(ci_r) == np.isinf(ci_f), axis=1)[open_]
    return {"n": int(x_r.size), "compared": int(closed.sum()), "open": int(open_.sum()),
            "open_agree": int(same_open.sum()),
            "estimate_worst": float(est.max()) if est.size else float("nan"),
            "estimate_ok": int(np.sum(est <= ESTIMATE_SE)),
            "end_worst": float(ends.max()) if ends.size else float("nan"),
            "end_ok": int(np.sum(ends <= END_WIDTH))}


def run(single_stride: int = SINGLE_STRIDE) -> dict:
    """Both comparisons on the chart set of ``make bench``.

    Parameters
    ----------
    single_stride : int, optional
        Single fits on every ``single_stride``-th chart.

    Returns
    -------
    dict
        ``batch`` and ``single``: {'chl': :func:`compare`'s dict, 'cdom': ..., 'seconds':
        {'reduced': s, 'full': s}, 'charts': K}.
    """
    import sca

    from .chartset import chart_set

    conds, rgbs, sigmas = chart_set()
    depth = np.array([c["depth"] for c in conds])
    dist = np.array([c["distance"] for c in conds])
    out = {}
    fits, secs = {}, {}
    for q in ("reduced", "full"):
        t0 = time.perf_counter()
        fits[q] = sca.estimate_batch(rgbs, depth=depth, distance=dist, sigma=sigmas,
                                     quadrature=q)
        secs[q] = time.perf_counter() - t0
    r, f = fits["reduced"], fits["full"]
    out["batch"] = {"chl": compare(r.chl, f.chl, r.chl_ci, f.chl_ci),
                    "cdom": compare(r.cdom, f.cdom, r.cdom_ci, f.cdom_ci),
                    "seconds": secs, "charts": len(conds),
                    "same_reliable": int(np.sum(r.reliable == f.reliable)),
                    "same_path_model": int(np.sum(r.path_model == f.path_model))}
    picks = range(0, len(conds), single_stride)
    single = {"reduced": [], "full": []}
    secs = {"reduced": 0.0, "full": 0.0}
    for i in picks:
        for q in ("reduced", "full"):
            t0 = time.perf_counter()
            single[q].append(sca.estimate(rgbs[i], depth=depth[i], distance=dist[i],
                                          sigma=sigmas[i], quadrature=q))
            secs[q] += time.perf_counter() - t0
    r, f = single["reduced"], single["full"]

    def arr(es, name):
        return np.array([getattr(e, name) for e in es], float)
    out["single"] = {k: compare(arr(r, k), arr(f, k), arr(r, f"{k}_ci"), arr(f, f"{k}_ci"),
                                arr(f, f"{k}_se")) for k in ("chl", "cdom")}
    out["single"].update(seconds=secs, charts=len(r),
                         same_reliable=int(sum(a.reliable == b.reliable for a, b in zip(r, f))))
    return out


def summary(res: dict) -> list:
    """Markdown lines: one row per estimator and parameter."""
    lines = ["| estimator | parameter | fits | estimate: worst \\|x_r - x_f\\| / SE (<= "
             f"{ESTIMATE_SE:g}) | within | interval ends: worst \\|end_r - end_f\\| / width "
             f"(<= {END_WIDTH:g}) | within | open on the full grid (same ends open) |",
             "|---|---|---:|---:|---:|---:|---:|---:|"]
    for est in ("batch", "single"):
        for k in ("chl", "cdom"):
            c = res[est][k]
            lines.append(f"| {est} | {'C' if k == 'chl' else 'a_CDOM'} | {c['n']} | "
                         f"{c['estimate_worst']:.3g} | {c['estimate_ok']} / {c['compared']} | "
                         f"{c['end_worst']:.3g} | {c['end_ok']} / {c['compared']} | "
                         f"{c['open']} ({c['open_agree']}) |")
    return lines


def main(argv=None) -> int:
    """``python -m experiments.quadrature_check``: print the table (and write JSON)."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--json", default=None)
    args = p.parse_args(argv)
    res = run()
    print("\n".join(summary(res)))
    if args.json:
        from .stopwatch import write_json

        write_json(args.json, res)
    return 0


if __name__ == "__main__":
    sys.exit(main())
