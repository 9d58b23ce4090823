"""The sweep runner shared by all estimation figures.

Each condition (C, a_CDOM, depth, distance, seed, illuminance, exposure, the estimator's
grid, mode, world) is rendered -- by :func:`forward.simulate_chart` in the 1 nm world
(``world='forward'``, the estimator's own code) or by the independent renderer
(``world='independent'``, :func:`render_independent`: no code shared with ``forward``) -- and
fitted with :func:`sca.estimate` (the paper's exact model, ``uncertain={}``) on the condition's
estimation grid. Results are cached on disk, one JSON file per condition, written atomically (temporary
file + ``os.replace``), so an interrupted run loses nothing and a rerun computes only what is
missing. The cache key is the condition and :data:`FINGERPRINT`: the source of ``forward``,
``sca`` and this module, the data tables and the versions of the libraries the numbers come
from (numpy's random streams, the solver, the colour tables), so no cached fit outlives what it
was computed from. Work is spread over a process pool (both cores by default) with a
tqdm progress bar. The pool never outlives the run: on Ctrl-C or any error it is terminated at
once, and a worker whose parent process has died (``kill -9``) exits by itself.
"""

from __future__ import annotations

import hashlib
import json
import os
import signal
import threading
import time
import zlib
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np

from forward.files import write_atomic
# Eq 19 divides by sqrt(q): the figures evaluate it on the paper's q = 31 bands of the true and
# estimated k, whatever grid they are simulated and fitted on (re-exported for the figures).
from sca import RRMSE_BANDS_NM, rrmse_bands  # noqa: F401

from .grids import BASE_SEED

__all__ = ["run", "condition", "key", "fit_condition", "pearson", "FINGERPRINT",
           "DEFAULT_CACHE", "DEFAULT_WORKERS", "SEED_MULTIPLIER", "ORPHAN_CHECK_S",
           "RRMSE_BANDS_NM", "rrmse_bands", "estimation_grid", "rrmse_on_grid", "q_eq19",
           "FINGERPRINT_PACKAGES", "WORKER_EXIT_S", "render_independent", "WORLDS"]

#: The renderers of a condition's chart: ``forward`` (the estimator's own code) or the
#: independent renderer (:mod:`experiments.independent_world`)
WORLDS = ("forward", "independent")

DEFAULT_CACHE = Path(os.environ.get("UW3P_CACHE", "cache"))
#: Worker processes when not given (at most the machine's cores): the reference machine's two
DEFAULT_WORKERS = 2
#: Seconds a terminated worker is given to exit before it is killed.
WORKER_EXIT_S = 2.0
#: A condition's noise seed is (BASE_SEED * SEED_MULTIPLIER + crc32 of the condition) mod 2^31
#: (a prime multiplier, so that another BASE_SEED gives unrelated seeds)
SEED_MULTIPLIER = 100003


#: Distributions whose versions enter :data:`FINGERPRINT` (random streams, solvers, the
#: colour tables of colour-science: camera curves, illuminant, chart)
FINGERPRINT_PACKAGES = ("numpy", "scipy", "cvxpy", "clarabel", "colour-science", "numba")


def _code_fingerprint() -> str:
    from importlib import metadata

    h = hashlib.sha256()
    root = Path(__file__).resolve().parents[1]
    files = [p for pkg in ("forward", "sca") for p in sorted((root / pkg).rglob("*.py"))]
    files += [Path(__file__).resolve(), Path(__file__).with_name("independent_world.py")]
    files += sorted((root / "data").glob("*.csv"))
    for path in files:
        h.update(str(path.relative_to(root)).encode())
        h.update(path.read_bytes())
    for name in FINGERPRINT_PACKAGES:
        try:
            version = metadata.version(name)
        except metadata.PackageNotFoundError:
            version = "absent"
        h.update(f"{name}={version}".encode())
    return h.hexdigest()[:16]


FINGERPRINT = _code_fingerprint()


def condition(chl, cdom, depth, distance, replicate=0, *, illuminance_lux=20000.0,
              exposure="capped", mode="safeguarded", estimation_step_nm=1.0, world="forward",
              world_options=None) -> dict:
    """A condition dict with its noise seed derived from the condition and the replicate (not
    from the estimation grid nor the world: the same seed is used on every grid and in both
    worlds).

    Parameters
    ----------
    chl, cdom, depth, distance : float
        C (mg m^-3), a_CDOM(440) (m^-1), depth and distance (m).
    replicate : int, optional
        The noise replicate.
    illuminance_lux : float, optional
        Surface illuminance, lx.
    exposure : {'capped', 'iset'}, optional
        The sensor's exposure mode.
    mode : str, optional
        :func:`sca.estimate`'s mode.
    estimation_step_nm : float, optional
        The estimator's grid step, nm.
    world : {'forward', 'independent'}, optional
        The chart's renderer (:data:`WORLDS`).
    world_options : dict, optional
        The independent renderer's options (:class:`experiments.independent_world.WorldOptions`
        fields; ``world='independent'`` only; default none).

    Returns
    -------
    dict
        The condition, with its ``seed``.
    """
    if world not in WORLDS:
        raise ValueError(f"world: must be one of {WORLDS}, got {world!r}")
    c = dict(chl=float(chl), cdom=float(cdom), depth=float(depth), distance=float(distance),
             illuminance_lux=float(illuminance_lux), exposure=exposure, mode=mode,
             replicate=int(replicate), estimation_step_nm=float(estimation_step_nm))
    tag = json.dumps([c[k] for k in ("chl", "cdom", "depth", "distance", "illuminance_lux",
                                     "replicate")])
    c["seed"] = int(BASE_SEED * SEED_MULTIPLIER + zlib.crc32(tag.encode())) % (2**31)
    if world != "forward":  # the forward world's keys (and so its cache) as before
        c["world"] = world
        c["world_options"] = dict(sorted((world_options or {}).items()))
    return c


def key(cond: dict) -> str:
    text = json.dumps(cond, sort_keys=True) + FINGERPRINT
    return hashlib.sha256(text.encode()).hexdigest()[:24]



def estimation_grid(step_nm):
    """The estimator's wavelengths for a grid step (nm): None (its default, 400-700 nm at 1 nm)
    for 1 nm, else 400-700 nm every ``step_nm``."""
    step_nm = float(step_nm)
    if step_nm == 1.0:
        return None
    return np.arange(400.0, 700.0 + step_nm / 2, step_nm)


def q_eq19(step_nm) -> int:
    """q of eq 19 for an estimator on a ``step_nm`` grid: its nodes on the 10 nm grid."""
    wl = estimation_grid(step_nm)
    return int(RRMSE_BANDS_NM.size if wl is None else np.isin(wl, RRMSE_BANDS_NM).sum())


def rrmse_on_grid(wl_hat, k_hat, wl, k) -> float:
    """Eq 19 of an estimate ``k_hat`` on its grid ``wl_hat`` against the truth ``k`` of the
    world grid ``wl``: on the estimator's nodes that are 10 nm nodes (:func:`rrmse_bands`;
    q = 31 for a 1, 5 or 10 nm estimator, 16 for a 20 nm one)."""
    truth = np.interp(np.asarray(wl_hat, float), np.asarray(wl, float), np.asarray(k, float))
    return rrmse_bands(wl_hat, k_hat, truth)


def render_independent(cond: dict) -> dict:
    """The chart of ``cond`` rendered by the independent renderer with the sensor's photon budget.

    The renderer (:func:`experiments.independent_world.render_chart`, the condition's
    ``world_options``, its streams seeded by the condition's ``seed``) records values in model
    units times an exposure factor x, 1.0 being the full well. x is the default sensor's
    auto-exposure (:class:`forward.SensorSettings` at the condition's light and exposure mode):
    the brightest noise-free value at ``target_fraction`` of the well, at most the longest
    exposure's photon count (``exposure='capped'``), or at :data:`forward.sensor.
    ISET_EXPOSURE_FRACTION` (``'iset'``); its photon and read noise are the sensor's (full well,
    read noise, pixels per patch). Only these numbers come from ``forward``; the chart, the water,
    the camera's response and the noise are the renderer's own. The recorded values are divided
    by x (the known exposure), as ``forward.capture`` does.

    Parameters
    ----------
    cond : dict
        A condition of :func:`condition` with ``world='independent'``.

    Returns
    -------
    dict
        ``rgb`` (3, 24) model units; ``attenuation`` (q,) the true k and ``wavelengths`` (q,) its
        grid (nm, the renderer's); ``backscatter`` (3,) the true veiling light, model units;
        ``exposure`` x.
    """
    import forward

    from . import independent_world as iw

    sensor = forward.SensorSettings(illuminance_lux=cond["illuminance_lux"],
                                    exposure_mode=cond.get("exposure", "capped"))
    opts = dict(cond.get("world_options") or {})
    args = (cond["chl"], cond["cdom"], cond["depth"], cond["distance"])
    probe = iw.render_chart(*args, rng=cond["seed"], noise=False, clip=None, **opts)
    top = float(np.max(probe["expected"]))
    full = sensor.full_well_e
    if sensor.exposure_mode == "iset":
        x = forward.sensor.ISET_EXPOSURE_FRACTION / top
    else:
        per_unit = forward.sensor.electrons_per_second(forward.chart_setup(), sensor)
        x = min(sensor.target_fraction / top, per_unit * sensor.max_exposure_s / full)
    out = iw.render_chart(*args, rng=cond["seed"], exposure=x, electrons_full_scale=full,
                          read_noise_e=sensor.read_noise_e,
                          pixels_per_patch=sensor.pixels_per_patch, clip=1.0, **opts)
    return dict(rgb=out["rgb"] / x, attenuation=np.asarray(out["attenuation"]),
                wavelengths=np.asarray(out["wavelengths"]),
                backscatter=np.asarray(out["backscatter"]) / x, exposure=x)


def fit_condition(cond: dict) -> dict:
    """Render (the condition's world) and fit (the condition's estimation grid) one condition;
    returns a JSON-ready dict."""
    import forward
    import sca

    wl_hat = estimation_grid(cond.get("estimation_step_nm", 1.0))
    if cond.get("world", "forward") == "independent":
        w = render_independent(cond)
        rgb, wl, k, s, exposure_s = (w["rgb"], w["wavelengths"], w["attenuation"],
                                     w["backscatter"], float("nan"))
    else:
        sensor = forward.SensorSettings(illuminance_lux=cond["illuminance_lux"],
                                        exposure_mode=cond.get("exposure", "capped"))
        sim = forward.simulate_chart(cond["chl"], cond["cdom"], cond["depth"], cond["distance"],
                                     seed=cond["seed"], sensor=sensor)
        rgb, wl, k, s, exposure_s = (sim.rgb, sim.wavelengths, sim.attenuation, sim.backscatter,
                                     sim.exposure_s)
    est = sca.estimate(rgb, depth=cond["depth"], distance=cond["distance"], mode=cond["mode"],
                       wavelengths=wl_hat, uncertain={})
    wl_hat = forward.chart_setup().wavelengths if wl_hat is None else wl_hat
    return dict(
        cond,
        chl_hat=est.chl, cdom_hat=est.cdom, converged=est.converged, status=est.status,
        iterations=est.iterations, objective=est.objective,
        rrmse_k=rrmse_on_grid(wl_hat, est.attenuation, wl, k),
        attenuation=np.asarray(k).tolist(), attenuation_hat=est.attenuation.tolist(),
        backscatter=np.asarray(s).tolist(), backscatter_hat=est.backscatter.tolist(),
        rgb=np.asarray(rgb).tolist(), exposure_s=exposure_s,
        wavelengths=np.asarray(wl).tolist(), wavelengths_hat=np.asarray(wl_hat).tolist(),
    )


def _write_atomic(path: Path, data: dict) -> None:
    write_atomic(path, json.dumps(data))


def _work(args):
    cond, path = args
    result = fit_condition(cond)
    _write_atomic(Path(path), result)
    return path


#: How often (s) a pool worker checks that the process that started it is still alive.
ORPHAN_CHECK_S = 0.5


def _watch_parent(parent: int):
    while True:
        time.sleep(ORPHAN_CHECK_S)
        if os.getppid() != parent:  # the parent died: we were re-parented
            os._exit(1)


def _init_worker(parent: int):
    """Pool worker set-up: Ctrl-C is the parent's to handle (it terminates the pool), and the
    worker exits when its parent dies."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    threading.Thread(target=_watch_parent, args=(parent,), daemon=True).start()


def _run_pool(todo, workers, bar):
    """Fit ``todo`` in a process pool. A worker that dies raises ``BrokenProcessPool`` (nothing
    hangs); on Ctrl-C or any error the workers are terminated at once."""
    pool = ProcessPoolExecutor(max_workers=workers, initializer=_init_worker,
                               initargs=(os.getpid(),))
    try:
        futures = [pool.submit(_work, item) for item in todo]
        for fut in as_completed(futures):
            fut.result()
            bar.update()
    except BaseException:
        procs = list(getattr(pool, "_processes", {}).values())
        for proc in procs:
            proc.terminate()
        for proc in procs:  # gone before we return (SIGKILL if SIGTERM was not enough)
            proc.join(WORKER_EXIT_S)
            if proc.is_alive():
                proc.kill()
                proc.join(WORKER_EXIT_S)
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown()


def run(conditions, *, cache_dir=None, workers=None, progress=True, desc="sweep"):
    """Results (list of dicts, in the order of ``conditions``) and how many were computed."""
    cache = Path(cache_dir or DEFAULT_CACHE)
    cache.mkdir(parents=True, exist_ok=True)
    paths = [cache / f"{key(c)}.json" for c in conditions]
    todo = []
    for c, p in zip(conditions, paths):
        if not _readable(p):
            todo.append((c, str(p)))
    # duplicates in the list are computed once
    todo = list({p: (c, p) for c, p in todo}.values())
    workers = workers or min(DEFAULT_WORKERS, os.cpu_count() or 1)
    if todo:
        from tqdm import tqdm

        bar = tqdm(total=len(todo), desc=desc, disable=not progress, unit="fit")
        try:
            if workers > 1 and len(todo) > 1:
                _run_pool(todo, workers, bar)
            else:
                for item in todo:
                    _work(item)
                    bar.update()
        finally:
            bar.close()
    return [json.loads(p.read_text()) for p in paths], len(todo)


def _readable(path: Path) -> bool:
    try:
        json.loads(path.read_text())
        return True
    except (OSError, ValueError):
        return False


def pearson(x, y) -> float:
    x, y = np.asarray(x, float), np.asarray(y, float)
    if x.size < 2 or np.std(x) == 0 or np.std(y) == 0:
        return float("nan")
    return float(np.corrcoef(x, y)[0, 1])
