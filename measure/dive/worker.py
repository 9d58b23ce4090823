"""What a Dask worker does for a dive: ignore the terminal's Ctrl-C from its start
(:func:`dask_setup`, run as the workers' preload), and measure one photo and write its folder
(:func:`run_job`).

A frame in which no chart is found (:class:`measure.ChartNotFound`) is reported as ``no chart``,
not as an error: a dive has such frames, and their inputs are kept for correcting them with the
dive's water.
"""

from __future__ import annotations

import os
import signal
import threading

from ..output import strict_json
from .plan import correction_range, run_setup

__all__ = ["dask_setup", "run_job"]


def dask_setup(worker) -> None:
    """A worker's start: Ctrl-C in the terminal is the client's to handle (it cancels the
    jobs and shuts the cluster down), so the worker process ignores SIGINT -- no worker
    tracebacks, no worker that goes on alone. Called by ``distributed`` for a preload module
    (``LocalCluster(preload=[__name__])``).

    Parameters
    ----------
    worker : distributed.Worker
        The worker starting (unused).
    """
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)


def _budget(options, inputs) -> dict | None:
    """``uncertain=`` for one photo: the options' budget with the row's sds over it and the
    daylight its reference shots measure (metadata ``reference``, ``reference_after``:
    :func:`measure.reference.reference_budget`, as ``uw3p measure --reference``)."""
    sds = {k: inputs[f"{k}_sd_m"] for k in ("depth", "distance")
           if inputs.get(f"{k}_sd_m") is not None}
    shots = [tuple(s) for s in inputs.get("reference") or []]
    if not sds and not shots:
        return options.get("uncertain")
    from ..camera import load_profile
    from ..measurement import budget_for

    prof = options.get("profile")
    prof = load_profile(prof) if isinstance(prof, (str, os.PathLike)) else prof
    base = budget_for(options.get("uncertain"), prof,
                      measured_chart=options.get("chart_reflectance") is not None)
    return _referenced(base, shots, options) | sds


def _referenced(base, shots, options) -> dict:
    """``base`` with the daylight the row's reference shots measure (the run's set-up)."""
    if not shots:
        return base
    from ..image import read_image
    from ..reference import reference_budget

    def read(photo):
        return read_image(photo, black_level=options.get("black_level"),
                          white_level=options.get("white_level"))
    return reference_budget(base, shots, read, run_setup(options),
                            options.get("layout", "patches"))


def _auxiliary(options, inputs) -> tuple:
    """``auxiliary=`` for one photo (its row's measurements over the run's,
    :func:`measure.auxiliary.merge_auxiliary`) and where each came from."""
    from ..auxiliary import merge_auxiliary

    defaults, own = options.get("auxiliary") or {}, inputs.get("auxiliary") or {}
    aux = merge_auxiliary(defaults, own)
    sources = {}
    for which, given in (("the run's default", defaults),
                         (inputs.get("auxiliary_source") or "metadata", own)):
        for kind, entry in given.items():
            keys = [f"kd {float(b):g}" for b in entry] if kind == "kd" else [kind]
            sources.update(dict.fromkeys(keys, which))
    return aux, sources


def run_job(job: dict) -> dict:
    """One photo, in a worker: measure it and write its folder.

    Parameters
    ----------
    job : dict
        :func:`measure.dive.plan.plan_photo`'s job (absolute paths).

    Returns
    -------
    dict
        ``status`` ('measured', 'no chart' or 'error') and ``record`` (measurement.json's
        content) with ``photo`` (the photo as the joint fit takes it,
        :meth:`measure.joint.JointPhoto.from_measurement`), or ``error`` (why).
    """
    from ..detect import ChartNotFound
    from ..joint import JointPhoto
    from ..measurement import measure
    from ..output import write_outputs

    from ..auxiliary import auxiliary_record

    inputs, options = job["inputs"], job["options"]
    try:
        aux, sources = _auxiliary(options, inputs)
        meas = measure(job["image"], corners=inputs["corners"], depth=inputs["depth_m"],
                       distance=inputs["distance_m"], uncertain=_budget(options, inputs),
                       auxiliary=aux, **{k: v for k, v in options.items()
                                         if k not in ("uncertain", "auxiliary")})
        meas.inputs.update({k: inputs[k] for k in ("depth_source", "distance_source",
                                                   "corners_source", "time")})
        meas.inputs["auxiliary"] = auxiliary_record(aux, sources)
        meas.inputs["command"] = job["command"]
        photo = JointPhoto.from_measurement(meas)  # what the dive's joint fit takes
        write_outputs(meas, job["out"], version=job["version"], report=job["report"],
                      range=correction_range(inputs), **job["images"],
                      overwrite=True, marker={"key": job["key"], "run": job["run"]})
        record = strict_json(meas.to_dict(job["version"]))
        return {"status": "measured", "record": record, "photo": photo}
    except ChartNotFound as exc:
        return {"status": "no chart", "error": str(exc)}
    except ValueError as exc:
        return {"status": "error", "error": str(exc)}
    except Exception as exc:  # noqa: BLE001 - a failure is reported in the row, never hidden
        return {"status": "error", "error": f"failed: {type(exc).__name__}: {exc}"}
