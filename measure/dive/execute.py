"""Running a dive's jobs: on a Dask cluster (a ``distributed.LocalCluster``, or an existing
scheduler) or in this process, one after another (:func:`execute`).

Ctrl-C stops the run at every stage and says which jobs did not run: while the jobs run (the
pending ones are cancelled), while the client connects, and while the local cluster starts.
During the start a first Ctrl-C is recorded and acted on as soon as the cluster exists (it is
then shut down at once; a half-started cluster cannot be); a second one interrupts the start
itself. The local workers ignore SIGINT from their start (:func:`measure.dive.worker.dask_setup`,
their preload), so the terminal's Ctrl-C reaches only the client.
"""

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
def _ctrl_c_recorded():
    """While the block runs, a first Ctrl-C is recorded in the list yielded (a second one
    raises KeyboardInterrupt); outside the main thread, nothing changes."""
    asked = []
    if threading.current_thread() is not threading.main_thread():
        yield asked
        return

    def record(signum, frame):
        if asked:
            raise KeyboardInterrupt
        asked.append(signum)

    old = signal.signal(signal.SIGINT, record)
    try:
        yield asked
    finally:
        signal.signal(signal.SIGINT, old)


def _local_cluster(n):
    """A LocalCluster of ``n`` single-threaded worker processes started by spawn (no fork: no
    fork warnings), which ignore Ctrl-C; KeyboardInterrupt when Ctrl-C came while it started."""
    import dask
    import distributed

    with _ctrl_c_recorded() as asked:
        try:
            with dask.config.set({"distributed.worker.multiprocessing-method": "spawn"}):
                cluster = distributed.LocalCluster(
                    n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0",
                    memory_limit=0, silence_logs=logging.ERROR, preload=[worker.__name__])
        except Exception:
            if asked:  # the start failed because of the Ctrl-C (a worker it killed)
                raise KeyboardInterrupt from None
            raise
    if asked:
        cluster.close(timeout=CLOSE_TIMEOUT_S)
        raise KeyboardInterrupt
    return cluster


@contextlib.contextmanager
def _client(scheduler, n):
    """A dask.distributed Client: of an existing scheduler, or of a new local cluster."""
    import distributed

    if scheduler:
        client = distributed.Client(scheduler)
        try:
            yield client
        finally:
            client.close(timeout=CLOSE_TIMEOUT_S)
        return
    cluster = _local_cluster(n)
    try:
        client = distributed.Client(cluster)
        try:
            yield client
        finally:
            client.close(timeout=CLOSE_TIMEOUT_S)
    finally:
        cluster.close(timeout=CLOSE_TIMEOUT_S)


def execute(jobs, scheduler, on_result) -> set:
    """Run the jobs (:func:`measure.dive.worker.run_job`).

    Parameters
    ----------
    jobs : list of dict
        Each with its ``key``.
    scheduler : str or None
        None: a local cluster of min(jobs, cores) workers; an address: that cluster;
        'synchronous': in this process.
    on_result : callable
        ``on_result(job, result)`` as each job ends (a KeyboardInterrupt raised in it
        interrupts the run).

    Returns
    -------
    set
        The keys of the jobs that did not run (Ctrl-C; the KeyboardInterrupt is swallowed and
        reported by the return). A job a worker finished while the run was interrupted may be
        among them: its folder says so.
    """
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
    import distributed

    n = max(1, min(len(jobs), os.cpu_count() or 1))
    try:
        with _client(scheduler, n) as client:
            futures = {client.submit(worker.run_job, job, key=f"uw3p-{job['key']}",
                                     pure=False): job for job in jobs}
            try:
                for fut in distributed.as_completed(futures):
                    job = futures[fut]
                    result = fut.result() if fut.status == "finished" else {
                        "status": "error", "error": f"failed: {fut.exception()!r}"}
                    pending.pop(job["key"])
                    on_result(job, result)
            except KeyboardInterrupt:
                client.cancel([f for f, j in futures.items() if j["key"] in pending])
                return set(pending)
    except KeyboardInterrupt:  # while connecting, starting or shutting down
        return set(pending)
    return set()
