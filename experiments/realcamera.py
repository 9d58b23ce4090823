"""The real camera as rows of REPRODUCTION.md (issue 39): the authors' 17 Canon G7X charts.

    python -m experiments realcamera [--out figures]     (part of ``make reproduce-figures``)

Three numbers per chart, each judged on data the fit did not see (:mod:`experiments.realwater.
g7x`):

* **the model fit, cross-validated**: every patch predicted by fits that did not see it (six
  folds, one chart column each), the paper's model (and with measure's light field, and with
  each optional physics of :mod:`forward.chart_physics`) against two baselines that know no
  water (affine: 3 x 3 + offset on the chart in air; diagonal: a gain per channel); the number
  is the per-patch relative error beyond photon noise of the held-out residuals
  (:func:`measure.camera.patch_systematic`), as REALWATER.md gives it in-sample;
* **the grey correction on held-out greys**: the model fitted without neutral 8, 6.5 and 5,
  its von Kries correction applied to them, against white-patch (from the white) and grey-world
  (from the other patches);
* **the user's own path**: each chart drawn as a DNG with flat patches and measured by
  ``uw3p measure`` with the G7X curves, the default budget, depth told 9 +- 6 m and distance
  1 +- 0.5 m; its correction of the greys against grey-world and white-patch on the patches
  measure sampled, its reliability and flags.

**The metric, named before the paired test** (:data:`PRIMARY_METRIC`): the per-patch relative
error beyond photon noise of the held-out residuals. It is the quantity the instrument carries
(the budget's per-patch term, ``sca.budget.DEFAULT_UNCERTAIN['patch']``, and ``uw3p calibrate``'s
``patch_sd``: what a chart's misfit costs a measurement), it weighs every patch alike (the dark
patches, which carry the veiling light, as much as the white; a relative RMS is set by the bright
ones), and it was the rows' number before the comparison below existed (issue 39). The relative
RMS is printed beside it and judged by nothing. Per chart the model (with measure's light field)
and the affine baseline are compared on that metric, paired (:func:`paired_test`: the sign
test, two-sided, and Wilcoxon's signed-rank test), and by leave-one-chart-out prediction
(:func:`leave_one_chart_out`: the method with the lower median on the other charts, scored on
the chart left out).

Results are cached (``cache/realcamera-<fingerprint>.json``; the fingerprint covers the code and
data they come from), so a rerun costs nothing. Without ``../shared/realdata`` the study writes
that it could not run, and the report says so.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from forward.files import write_atomic
from .common import figures_dir, save_figure, style, write_csv

__all__ = ["main", "run", "summarise", "fingerprint", "leave_one_chart_out", "paired_test",
           "CACHE", "METHODS_CV", "PAIRED", "PRIMARY_METRIC", "RESULT"]

#: The file the report reads (in ``<out>/realcamera/``)
RESULT = "realcamera.json"
#: The cross-validated variants in the order of the report
METHODS_CV = ("model", "model + light field", "model + in-water reflectance",
              "model + forward scattering", "model + tilted chart", "affine", "diagonal")
#: The one metric the real-camera verdicts judge, named before the paired test (the module's
#: docstring says why): the per-patch relative error beyond photon noise, held out
PRIMARY_METRIC = "systematic"
#: The pair compared chart by chart: the model as ``uw3p measure`` fits it, the affine baseline
PAIRED = ("model + light field", "affine")
#: The cache folder (the sweep's)
CACHE = Path(os.environ.get("UW3P_CACHE", "cache"))
ROOT = Path(__file__).resolve().parents[1]


def fingerprint() -> str:
    """A hash of everything the numbers come from: the code of forward, sca, measure, uw3p and
    this study, the data tables and the G7X files."""
    from .realwater import g7x

    h = hashlib.sha256()
    files = [p for pkg in ("forward", "sca", "measure", "uw3p") for p in sorted((ROOT / pkg).rglob("*.py"))]
    files += [Path(__file__), ROOT / "experiments" / "realwater" / "g7x.py"]
    files += sorted((ROOT / "data").glob("*.csv"))
    files += sorted((g7x.REALDATA / "g7x").glob("*.mat"))
    for p in files:
        h.update(p.name.encode())
        h.update(p.read_bytes())
    return h.hexdigest()[:16]


def _chart(args) -> dict:
    """Cross-validation and held-out greys of one chart (a pool task)."""
    i, rgb = args
    from measure.camera import camera_setup

    from .realwater import g7x

    wl, curves = g7x.load_curves()
    setup = camera_setup(curves, quantal=True, wavelengths=wl)
    cv = g7x.cross_validate(rgb, setup)
    return {"cv": {k: {"systematic": v["systematic"], "rms": v["rms"]} for k, v in cv.items()},
            "greys": g7x.held_out_greys(rgb, setup)}


def _pool_map(fn, jobs, workers):
    if workers <= 1:
        return [fn(j) for j in jobs]
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    # spawn: rawpy (measure's reader) is not fork-safe
    with ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn")) as pool:
        return list(pool.map(fn, jobs))


def _measured_greys(m, setup) -> dict:
    """Angles (degrees) of the greys corrected by measure, grey-world and white-patch, on the
    patches measure sampled."""
    from forward.spectra import WHITE_PATCH

    from .realwater.g7x import GREYS, _angle

    rgb = np.asarray(m["rgb"], float)
    gains, offset = np.asarray(m["gains"], float), np.asarray(m["offset"], float)
    air = setup.sensitivities.T @ (setup.illuminant[:, None] * setup.reflectances)
    corrected = {"uw3p measure": gains[:, None] * (rgb - offset[:, None]),
                 "grey-world": (air.mean(axis=1) / rgb.mean(axis=1))[:, None] * rgb,
                 "white-patch": (air[:, WHITE_PATCH] / rgb[:, WHITE_PATCH])[:, None] * rgb}
    return {k: float(np.mean(_angle(v[:, list(GREYS)], setup.white_response)))
            for k, v in corrected.items()}


def run(workers: int = 2, cache_dir=None, charts=None) -> dict:
    """Every real-camera number (cached).

    Parameters
    ----------
    workers : int, optional
        Processes (default 2).
    cache_dir : str or Path, optional
        The cache folder (default :data:`CACHE`).
    charts : sequence of int, optional
        The charts (default all; the reduced grid takes one).

    Returns
    -------
    dict
        ``available`` False with a ``reason`` without the data; else ``names`` and per chart
        ``charts`` (``cv``, ``greys``, ``measure``), ``seconds`` (the computation's wall time, 0
        from the cache) and ``fingerprint``.
    """
    from .realwater import g7x

    if not (g7x.REALDATA / "g7x").is_dir():
        return {"available": False,
                "reason": f"{g7x.REALDATA / 'g7x'} is absent (../shared/realdata beside the "
                          "repository)"}
    fp = fingerprint()
    which = "all" if charts is None else "-".join(str(int(i)) for i in charts)
    cache = Path(cache_dir or CACHE) / f"realcamera-{which}-{fp}.json"
    if cache.exists():
        out = json.loads(cache.read_text())
        out["seconds"] = 0.0
        return out
    t0 = time.perf_counter()
    names, all_charts = g7x.load_charts()
    keep = list(range(len(names))) if charts is None else [int(i) for i in charts]
    names, charts = [names[i] for i in keep], all_charts[keep]
    per = _pool_map(_chart, list(enumerate(charts)), workers)
    from measure.camera import camera_setup

    wl, curves = g7x.load_curves()
    setup = camera_setup(curves, quantal=True, wavelengths=wl)
    with tempfile.TemporaryDirectory(prefix="uw3p-g7x-") as tmp:
        measured = g7x.measure_path(charts, tmp, workers=workers)
    for p, m in zip(per, measured):
        p["measure"] = {k: m[k] for k in ("exit", "reliable", "flags", "chl", "cdom", "chi2_dof")}
        p["measure"]["nuisance"] = m["nuisance"]
        p["measure"]["greys"] = _measured_greys(m, setup)
    out = {"available": True, "names": names, "charts": per, "fingerprint": fp,
           "seconds": time.perf_counter() - t0}
    cache.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(cache, json.dumps(out))
    return out


def paired_test(a, b) -> dict:
    """Paired per-chart comparison of two methods' errors (lower is better).

    Parameters
    ----------
    a, b : array_like, (N,)
        Each chart's error of method a and of method b.

    Returns
    -------
    dict
        ``wins`` (charts where a < b), ``losses``, ``ties``, ``n``; ``p_sign`` (the sign test:
        :func:`scipy.stats.binomtest` of the wins among the untied charts at 1/2, two-sided) and
        ``p_wilcoxon`` (:func:`scipy.stats.wilcoxon` of a - b, two-sided; None with fewer than
        two untied charts); ``median_difference`` (median of a - b).
    """
    from scipy import stats

    d = np.asarray(a, float) - np.asarray(b, float)
    wins, losses = int((d < 0).sum()), int((d > 0).sum())
    untied = wins + losses
    return {"wins": wins, "losses": losses, "ties": int(d.size - untied), "n": int(d.size),
            "p_sign": float(stats.binomtest(wins, untied, 0.5).pvalue) if untied else None,
            "p_wilcoxon": float(stats.wilcoxon(d[d != 0]).pvalue) if untied >= 2 else None,
            "median_difference": float(np.median(d))}


def leave_one_chart_out(errors: dict) -> dict:
    """Leave-one-chart-out prediction: for each chart, the method whose median error over the
    other charts is lower, scored on the chart left out.

    Parameters
    ----------
    errors : dict
        method -> (N,) per-chart errors (:data:`PRIMARY_METRIC`).

    Returns
    -------
    dict
        ``chosen`` (N,) the method chosen without each chart, ``error`` (N,) its error on that
        chart, ``median`` of those errors, ``counts``: method -> times chosen.
    """
    names = list(errors)
    e = np.array([np.asarray(errors[k], float) for k in names])
    chosen, scored = [], []
    for i in range(e.shape[1]):
        rest = np.delete(e, i, axis=1)
        j = int(np.argmin(np.median(rest, axis=1)))
        chosen.append(names[j])
        scored.append(float(e[j, i]))
    return {"chosen": chosen, "error": scored, "median": float(np.median(scored)),
            "counts": {k: chosen.count(k) for k in names}}


def _stats(values) -> dict:
    v = np.asarray(values, float)
    return {"median": float(np.median(v)), "min": float(v.min()), "max": float(v.max())}


def summarise(out: dict) -> dict:
    """The medians (and ranges) over the charts that the report prints.

    Parameters
    ----------
    out : dict
        :func:`run`'s result.

    Returns
    -------
    dict
        ``available`` (and ``reason``), ``n``; ``cv_systematic`` and ``cv_rms``: variant ->
        {median, min, max}; ``greys_held_out`` and ``greys_measure``: method -> stats;
        ``measure_reliable`` (count), ``measure_flags`` (flag -> count), ``beats_affine``:
        variant -> whether its median cross-validated error is below the affine baseline's,
        ``wins``: variant -> charts where it is below the affine baseline's; ``metric``
        (:data:`PRIMARY_METRIC`), ``paired`` (:func:`paired_test` of :data:`PAIRED` on it) and
        ``loco`` (:func:`leave_one_chart_out` of :data:`PAIRED` on it, without the per-chart
        lists).
    """
    if not out.get("available"):
        return {"available": False, "reason": out.get("reason", "")}
    ch = out["charts"]
    cv = {k: _stats([c["cv"][k]["systematic"] for c in ch]) for k in METHODS_CV}
    rms = {k: _stats([c["cv"][k]["rms"] for c in ch]) for k in METHODS_CV}
    flags = {}
    for c in ch:
        for f in c["measure"]["flags"]:
            flags[f] = flags.get(f, 0) + 1
    aff = cv["affine"]["median"]
    per = {k: [c["cv"][k][PRIMARY_METRIC] for c in ch] for k in PAIRED}
    loco = leave_one_chart_out(per)
    return {
        "metric": PRIMARY_METRIC, "paired_methods": list(PAIRED),
        "paired": paired_test(*(per[k] for k in PAIRED)),
        "loco": {"median": loco["median"], "counts": loco["counts"]},
        "available": True, "n": len(ch), "cv_systematic": cv, "cv_rms": rms,
        "greys_held_out": {k: _stats([c["greys"][k] for c in ch]) for k in ch[0]["greys"]},
        "greys_measure": {k: _stats([c["measure"]["greys"][k] for c in ch])
                          for k in ch[0]["measure"]["greys"]},
        "measure_reliable": sum(bool(c["measure"]["reliable"]) for c in ch),
        "measure_flags": dict(sorted(flags.items(), key=lambda kv: -kv[1])),
        "measure_balance": [float(np.median([c["measure"]["nuisance"].get("balance", [0.0] * 3)[j]
                                             for c in ch])) for j in range(3)],
        "beats_affine": {k: cv[k]["median"] < aff for k in METHODS_CV if k.startswith("model")},
        "wins": {k: sum(c["cv"][k][PRIMARY_METRIC] < c["cv"]["affine"][PRIMARY_METRIC] for c in ch)
                 for k in METHODS_CV if k.startswith("model")},
        "seconds": out.get("seconds", 0.0),
    }


def _figure(out, outdir):
    import matplotlib.pyplot as plt

    ch = out["charts"]
    names = [n.replace("IMG_", "") for n in out["names"]]
    fig, (a, b) = plt.subplots(2, 1, figsize=(7.2, 5.2), constrained_layout=True)
    x = np.arange(len(ch))
    shown = ("model", "model + light field", "affine", "diagonal")
    for j, k in enumerate(shown):
        a.bar(x + (j - 1.5) * 0.2, [100 * c["cv"][k]["systematic"] for c in ch], 0.2, label=k)
    a.set_ylabel("held-out error beyond\nphoton noise (% per patch)")
    a.set_ylim(0.0, 1.35 * max(100 * c["cv"][k]["systematic"] for c in ch for k in shown))
    a.set_xticks(x, names, rotation=90, fontsize=8)
    a.legend(fontsize=8, ncol=4, loc="upper center")
    a.set_title("Real G7X charts, leave-patches-out cross-validation")
    for j, k in enumerate(("uw3p measure", "grey-world", "white-patch")):
        b.bar(x + (j - 1) * 0.27, [c["measure"]["greys"][k] for c in ch], 0.27, label=k)
    b.set_ylabel("greys from neutral (°)")
    b.set_ylim(0.0, 1.35 * max(v for c in ch for v in c["measure"]["greys"].values()))
    b.set_xticks(x, names, rotation=90, fontsize=8)
    b.legend(fontsize=8, ncol=3, loc="upper center")
    b.set_title("uw3p measure on the charts as DNGs (G7X curves, default budget, 9 ± 6 m, 1 ± 0.5 m)")
    save_figure(fig, "realcamera", outdir)
    plt.close(fig)


def main(outdir=None, grid_name=None, cache_dir=None, workers=None):
    """Compute (or read from the cache) and write ``<outdir>/realcamera/`` (JSON, CSV, figure).

    Parameters
    ----------
    outdir : str or Path, optional
        The figures folder.
    grid_name : str, optional
        The grid: 'paper' (default) takes every chart, 'reduced' one.
    cache_dir : str or Path, optional
        The result cache.
    workers : int, optional
        Processes (default 2).

    Returns
    -------
    dict
        :func:`summarise` of the result.
    """
    from .grids import grid as get_grid

    style()
    out = run(workers or 2, cache_dir, get_grid(grid_name)["realcamera_charts"])
    folder = figures_dir(Path(outdir or "figures") / "realcamera")
    summary = summarise(out)
    if out.get("available"):
        _figure(out, folder)
        rows = []
        for name, c in zip(out["names"], out["charts"]):
            rows.append([name] + [f"{c['cv'][k]['systematic']:.4f}" for k in METHODS_CV]
                        + [f"{c['greys'][k]:.3f}" for k in ("model", "grey-world", "white-patch")]
                        + [f"{c['measure']['greys'][k]:.3f}" for k in ("uw3p measure", "grey-world",
                                                                      "white-patch")]
                        + [c["measure"]["reliable"], " ".join(c["measure"]["flags"])])
        write_csv(folder / "realcamera_charts.csv",
                  ["image"] + [f"cv_{k.replace(' ', '_').replace('+', 'plus')}" for k in METHODS_CV]
                  + ["held_grey_model_deg", "held_grey_grey_world_deg", "held_grey_white_patch_deg",
                     "measure_grey_deg", "measure_grey_world_deg", "measure_white_patch_deg",
                     "measure_reliable", "measure_flags"], rows,
                  comment="The real G7X charts (experiments.realcamera): cross-validated per-patch "
                          "error beyond photon noise of each variant (fraction), held-out grey "
                          "angles (degrees), uw3p measure's grey angles on its own samples")
    text = json.dumps(summary, indent=1, sort_keys=True)
    write_atomic(folder / RESULT, text + "\n")
    if out.get("available"):
        print(f"realcamera: {summary['n']} charts, {summary['seconds']:.0f} s")
    else:
        print(f"realcamera: not run ({summary['reason']})")
    return summary


if __name__ == "__main__":
    main()
