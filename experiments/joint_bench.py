"""How long the joint fit of a six-photo dive takes: issue 36's target (<= 1 s).

    python -m experiments.joint_bench [--photos 6] [--repeats 3] [--dives 2]

A dive of ``--photos`` photographs is drawn and rendered as :mod:`experiments.dive_honesty`
draws them (the independent renderer; one water, chart and camera per dive, each photo its own
depth, distance and exposure, depth and distance told with the default budget's errors). Each
photo is first fitted alone (:func:`sca.estimate_batch` with ``gain='free'`` and the default
budget, as ``uw3p measure`` fits a photograph; untimed), and then the dive's joint fit is
timed as :func:`measure.fit_joint` calls it: :func:`sca.joint.estimate_joint` with the default
budget, every photo's own depth and distance sds, and the photos' own fits as its start
(``start=``). Also timed: the same call without ``start`` (the joint fit then makes its own
starts, as :mod:`experiments.dive_honesty` calls it). Each call is made ``--repeats`` times
after one untimed warm-up call (numba's and the quadrature's caches); the best and the median
are kept.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

__all__ = ["JOINT_CALLERS", "PHOTOS", "REPEATS", "SEED", "VARIANTS", "main", "profile_joint",
           "time_joint"]

#: Photos per dive (issue 36: "the joint fit of a six-photo dive").
PHOTOS = 6
#: Timed calls of each variant (after one warm-up call).
REPEATS = 3
#: Seed of the dives' draw (:func:`experiments.dive_honesty.draw_dive`).
SEED = 36
#: The joint fit's steps (:func:`sca.joint.estimate_joint`), by the function that evaluates
#: (in order of priority; :class:`experiments.batch_profile.Counter`).
JOINT_CALLERS = {
    "_single_starts": "photos' own fits (the start)",
    "_photo_scatter": "photo scatter (one water per photo)",
    "_heterogeneity": "heterogeneity test (refits by group)",
    "_intervals": "intervals (profile ends)",
    "estimate_joint": "the path models' fits",
}


def _dive(rng, photos):
    from .dive_honesty import draw_dive, render_dive

    dive = draw_dive(rng, n=photos)
    return dive, render_dive(dive, rng)


#: The variants of the call (:func:`time_joint`).
VARIANTS = ("as_fit_joint", "own_start")


def time_joint(photos: int = PHOTOS, repeats: int = REPEATS, dives: int = 1,
               seed: int = SEED, variants=VARIANTS) -> dict:
    """Time :func:`sca.joint.estimate_joint` on ``dives`` rendered dives of ``photos`` photos.

    Parameters
    ----------
    photos : int, optional
        Photos per dive.
    repeats : int, optional
        Timed calls of each variant per dive (after one untimed call).
    dives : int, optional
        Dives drawn (each timed in turn).
    seed : int, optional
        The draw's seed.
    variants : sequence of str, optional
        Which calls to time (:data:`VARIANTS`; default both).

    Returns
    -------
    dict
        ``photos``, ``repeats``, ``seed`` and ``dives``: one dict per dive with the truth
        (``chl``, ``cdom``), the joint estimate (``chl_est``, ``chl_ci``, ``reliable``,
        ``path_model``) and, per variant (``as_fit_joint``: with the photos' fits as start;
        ``own_start``: without), ``seconds`` (every timed call), ``best`` and ``median``.
    """
    import forward
    import sca
    from forward.imaging import resolve_setup
    from sca.budget import DEFAULT_UNCERTAIN
    from sca.joint import estimate_joint

    rng = np.random.default_rng(seed)
    setup = resolve_setup(None, forward.DEFAULT_CAMERA, None, None, None)
    rel = float(DEFAULT_UNCERTAIN["distance"].rstrip("%")) / 100
    out = []
    for _ in range(dives):
        dive, rendered = _dive(rng, photos)
        depth, dist = dive["depth_told"], dive["distance_told"]
        own = sca.estimate_batch(rendered["rgb"], depth=depth, distance=dist,
                                 sigma=rendered["sigma"], gain="free")
        start = {"chl": own.chl, "cdom": own.cdom, "gain": own.gain,
                 "backscatter": own.backscatter}
        names = [f"photo {i + 1}" for i in range(photos)]
        common = dict(depth=depth, distance=dist, sigma=rendered["sigma"], setup=setup,
                      names=names)
        calls = {
            "as_fit_joint": dict(common, depth_sd=np.full(photos, DEFAULT_UNCERTAIN["depth"]),
                                 distance_sd=rel * dist, start=start),
            "own_start": common,
        }
        rec = {"chl": dive["chl"], "cdom": dive["cdom"]}
        for name in variants:
            kw = calls[name]
            j = estimate_joint(rendered["rgb"], **kw)  # warm-up
            secs, cpus = [], []
            for _ in range(repeats):
                t0, c0 = time.perf_counter(), time.process_time()
                j = estimate_joint(rendered["rgb"], **kw)
                secs.append(time.perf_counter() - t0)
                cpus.append(time.process_time() - c0)
            rec[name] = {"seconds": secs, "cpu_seconds": cpus, "best": min(secs),
                         "median": float(np.median(secs)), "cpu_best": min(cpus)}
            if name == "as_fit_joint":
                rec.update(chl_est=j.chl, chl_ci=list(j.chl_ci), cdom_est=j.cdom,
                           cdom_ci=list(j.cdom_ci), reliable=bool(j.reliable),
                           path_model=j.path_model, flags=list(j.flags))
        out.append(rec)
    return {"photos": photos, "repeats": repeats, "seed": seed, "dives": out}


def profile_joint(photos: int = PHOTOS, seed: int = SEED) -> dict:
    """Count and time the objective evaluations of one joint fit (as :func:`measure.fit_joint`
    calls it) by the step that makes them (:data:`JOINT_CALLERS`).

    Parameters
    ----------
    photos : int, optional
        Photos of the dive.
    seed : int, optional
        The draw's seed (the first dive of :func:`time_joint`).

    Returns
    -------
    dict
        As :func:`experiments.batch_profile.profile_default_batch` with one unit, the dive:
        ``n`` (1), ``wall_s``, ``cpu_s``, ``rows`` (``per_chart``: evaluations of the whole dive),
        ``inside_s``, ``outside_s``.
    """
    import forward
    import sca
    from forward.imaging import resolve_setup
    from sca.budget import DEFAULT_UNCERTAIN
    from sca.joint import estimate_joint

    from .batch_profile import Counter, summary_rows

    rng = np.random.default_rng(seed)
    dive, rendered = _dive(rng, photos)
    setup = resolve_setup(None, forward.DEFAULT_CAMERA, None, None, None)
    depth, dist = dive["depth_told"], dive["distance_told"]
    own = sca.estimate_batch(rendered["rgb"], depth=depth, distance=dist,
                             sigma=rendered["sigma"], gain="free")
    rel = float(DEFAULT_UNCERTAIN["distance"].rstrip("%")) / 100
    kw = dict(depth=depth, distance=dist, sigma=rendered["sigma"], setup=setup,
              depth_sd=np.full(photos, DEFAULT_UNCERTAIN["depth"]), distance_sd=rel * dist,
              start={"chl": own.chl, "cdom": own.cdom, "gain": own.gain,
                     "backscatter": own.backscatter})
    estimate_joint(rendered["rgb"], **kw)  # warm-up
    with Counter(JOINT_CALLERS) as counter:
        t0, c0 = time.perf_counter(), time.process_time()
        estimate_joint(rendered["rgb"], **kw)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    rows, inside, inside_cpu = summary_rows(counter, 1, wall, order=list(JOINT_CALLERS.values()))
    return dict(n=1, photos=photos, wall_s=wall, cpu_s=cpu, rows=rows, inside_s=inside,
                inside_cpu_s=inside_cpu, outside_s=wall - inside, outside_cpu_s=cpu - inside_cpu)


def main(argv=None) -> int:
    """``python -m experiments.joint_bench``: print the times (and write JSON)."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--photos", type=int, default=PHOTOS)
    p.add_argument("--repeats", type=int, default=REPEATS)
    p.add_argument("--dives", type=int, default=1)
    p.add_argument("--profile", action="store_true",
                   help="also count the evaluations of one joint fit by step")
    p.add_argument("--json", default=None)
    args = p.parse_args(argv)
    from .common import commit_of

    load, date = os.getloadavg()[0], time.strftime("%Y-%m-%d %H:%M:%S %Z")
    res = time_joint(args.photos, args.repeats, args.dives)
    res.update(command="python -m experiments.joint_bench " + " ".join(
        sys.argv[1:] if argv is None else argv), commit=commit_of("WORKTREE"),
        date=date, load_at_start=load)
    for i, d in enumerate(res["dives"]):
        print(f"dive {i + 1}: C {d['chl']:.3g} -> {d['chl_est']:.3g} {d['chl_ci']}, reliable "
              f"{d['reliable']}; as fit_joint: best {d['as_fit_joint']['best']:.2f} s, median "
              f"{d['as_fit_joint']['median']:.2f} s (CPU {d['as_fit_joint']['cpu_best']:.2f} s); own start: best "
              f"{d['own_start']['best']:.2f} s, median {d['own_start']['median']:.2f} s")
    if args.profile:
        from .batch_profile import table

        res["profile"] = profile_joint(args.photos)
        print(f"\none joint fit, counted: {res['profile']['wall_s']:.2f} s wall, "
              f"{res['profile']['cpu_s']:.2f} s CPU\n")
        print(table(res["profile"], unit="dive"))
    if args.json:
        from .stopwatch import write_json

        write_json(args.json, res)
    return 0


if __name__ == "__main__":
    sys.exit(main())
