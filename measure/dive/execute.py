"""Running a dive's jobs: on a Dask cluster (a ``distributed.LocalCluster``, or an existing
scheduler) or in this process, one after another; Ctrl-C stops the run and says which jobs
did not run (:func:`execute`)."""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import threading

from . import worker

__all__ = ["CLOSE_TIMEOUT_S", "execute"]

#: Seconds given to the Dask cluster to shut down
CLOSE_TIMEOUT_S = 20


@contextlib.contextmanager
def _client(scheduler, n):
    """A dask.distributed Client: of an existing scheduler, or of a LocalCluster of ``n``
    single-threaded worker processes started by spawn (no fork: no fork warnings) that ignore
    Ctrl-C (the client handles it)."""
    import dask
    from distributed import Client, LocalCluster

    if scheduler:
        client = Client(scheduler)
        try:
            yield client
        finally:
            client.close(timeout=CLOSE_TIMEOUT_S)
        return
    main = threading.current_thread() is threading.main_thread()
    old = signal.signal(signal.SIGINT, signal.SIG_IGN) if main else None
    try:
        with dask.config.set({"distributed.worker.multiprocessing-method": "spawn"}):
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                   dashboard_address=":0", memory_limit=0,
                                   silence_logs=logging.ERROR)
    finally:
        if main:
            signal.signal(signal.SIGINT, old)
    client = Client(cluster)
    try:
        yield client
    finally:
        client.close(timeout=CLOSE_TIMEOUT_S)
        cluster.close(timeout=CLOSE_TIMEOUT_S)


def execute(jobs, scheduler, on_result):
    """Run the jobs; ``on_result(job, result)`` as each ends. Returns the keys not run (on
    Ctrl-C; the KeyboardInterrupt is swallowed and reported by the return)."""
    pending = {job["key"]: job for job in jobs}
    if scheduler == "synchronous":
        try:
            for job in jobs:
                result = worker.run_job(job)
                pending.pop(job["key"])
                on_result(job, result)
        except KeyboardInterrupt:
            return set(pending)
        return set()
    from distributed import as_completed

    n = max(1, min(len(jobs), os.cpu_count() or 1))
    with _client(scheduler, n) as client:
        futures = {client.submit(worker.run_job, job, key=f"uw3p-{job['key']}", pure=False): job
                   for job in jobs}
        try:
            for fut in as_completed(futures):
                job = futures[fut]
                result = fut.result() if fut.status == "finished" else {
                    "status": "error", "error": f"failed: {fut.exception()!r}"}
                pending.pop(job["key"])
                on_result(job, result)
        except KeyboardInterrupt:
            client.cancel([f for f, j in futures.items() if j["key"] in pending])
            return set(pending)
    return set()
