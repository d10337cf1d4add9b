"""The Dask cluster the throwing-design studies and the production experiments run on. ROS-free.

Either a LocalCluster of single-threaded worker processes on this machine, or an existing scheduler at an
address; set up one way for every caller, and always closed.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import signal
from typing import TYPE_CHECKING, Iterator

from feeder_planner.errors import InputError

if TYPE_CHECKING:
    from multiprocessing.process import BaseProcess

    from dask.distributed import Client, LocalCluster
    from distributed.deploy.spec import SpecCluster

__all__ = ["CONNECT_TIMEOUT", "MAX_WORKERS", "QUIET_WORKERS", "WORKERS_TIMEOUT", "dask_client"]

# Worker processes of a LocalCluster at most: each imports numpy and the models (~100 MB); more than
# this on one machine only adds memory and start-up time.
MAX_WORKERS = 64
# Seconds to wait for an existing scheduler to answer (Dask retries a refused connection until then),
# and for the workers to arrive.
CONNECT_TIMEOUT = 10
WORKERS_TIMEOUT = 60
# The worker processes' own logging: task errors reach the client as exceptions, so what a worker logs
# itself is the cluster's shutdown (a heartbeat to a scheduler that has closed, logged with its traceback
# when Ctrl-C ends a run), which is not the user's business. Set in the environment the nanny spawns the
# worker with (distributed.nanny.pre-spawn-environ): distributed configures its logging when it is
# imported, so the LocalCluster's env= (applied in the worker after that) left the workers at INFO
# (measured: logging level 20 in each worker), and a CI run's Ctrl-C printed a heartbeat's traceback.
QUIET_WORKERS = {"DASK_LOGGING__DISTRIBUTED": "critical"}


# Loggers of this process that a cluster closed by Ctrl-C reports its shutdown on: the LocalCluster's
# scheduler runs here, and removing workers mid-task logs errors with tracebacks ("Removing worker ...
# caused the cluster to lose scattered data", a KeyError from its bookkeeping: a CI run under load).
SHUTDOWN_LOGGERS = ("distributed", "tornado", "asyncio")


def _silence_shutdown_logs() -> None:
    """After Ctrl-C: the run is over and says so in one line; its cluster's shutdown is not reported.

    Not restored: the close and distributed's exit handlers still run after this, and the process ends.
    """
    import logging

    for name in SHUTDOWN_LOGGERS:
        logging.getLogger(name).setLevel(logging.CRITICAL + 1)


def _abandon_start(older_processes: set[BaseProcess], older_clusters: set[SpecCluster]) -> None:
    """After Ctrl-C inside a LocalCluster's start: kill the worker processes made so far; leave the rest.

    A start cut short leaves a half-made cluster no close can end cleanly (distributed's exit handler
    closed it with a traceback, or waited for its start: up to 6.6 s under a CI run's load, against issue
    33's 2 s). Nothing has been computed yet, so nothing is lost: the worker processes (multiprocessing's
    children that were not the caller's before the start; the resource tracker is not one) are killed and
    reaped, and the half-made cluster is left to the process's end, its exit-handler close switched off
    (``shutdown_on_close``, a SpecCluster parameter). Its scheduler and IO loop live in a daemon thread of
    this process and end with it. Measured: 0.2-0.6 s from Ctrl-C to exit 130 at 20 moments of the start
    under two CPU burners.
    """
    from distributed.deploy.spec import SpecCluster

    children = [child for child in multiprocessing.active_children() if child not in older_processes]
    for child in children:
        child.kill()
    for child in children:
        child.join()
    for half_made in set(SpecCluster._instances) - older_clusters:
        half_made.shutdown_on_close = False


def _kill_workers(cluster: LocalCluster) -> None:
    """After Ctrl-C: end the LocalCluster's worker processes at once, by SIGKILL.

    The run is abandoned, so what a worker is computing is of no use; a graceful close waits for the
    task each worker runs (one robust design point: 1-2 s, 3-6 s under load; a CI run's Ctrl-C took
    5.7 s to end). With the workers gone, the cluster's close has nothing to wait for. Only the workers
    (each nanny's process): multiprocessing's resource tracker, also a child of this process, must see
    the end of what it tracks, or it prints a traceback.
    """
    from distributed.core import Status

    for nanny in cluster.workers.values():
        # A nanny restarts a worker that dies while it runs (and the close then waits for the new one to
        # start: 1.5 s under load); closing gracefully, it closes itself instead, by distributed's own path.
        nanny.status = Status.closing_gracefully
        pid = getattr(getattr(getattr(nanny, "process", None), "process", None), "pid", None)
        if pid is not None:
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)


@contextlib.contextmanager
def dask_client(workers: int, scheduler: str | None, field: str = "scheduler") -> Iterator[Client]:
    """Yield a client whose workers have arrived; it and its cluster close when the block ends, however.

    The cluster is a LocalCluster of ``workers`` (``scheduler`` None), or the one at ``scheduler``.

    Raises
    ------
    InputError
        ``field`` (the caller's name for the address) when the scheduler cannot be reached.
    """
    import dask
    from dask.distributed import Client, LocalCluster
    from distributed.deploy.spec import SpecCluster

    cluster: LocalCluster | None = None
    client: Client | None = None
    older_processes, older_clusters = set(multiprocessing.active_children()), set(SpecCluster._instances)
    try:
        # Ctrl-C (KeyboardInterrupt) may come anywhere inside the start below: _abandon_start ends what it
        # made. The client stays the process's default: the studies' as_completed looks it up.
        if scheduler is None:
            quiet = {f"distributed.nanny.pre-spawn-environ.{k}": v for k, v in QUIET_WORKERS.items()}
            with dask.config.set(quiet):
                cluster = LocalCluster(
                    n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None
                )
            client = Client(cluster)
        else:
            try:
                client = Client(scheduler, timeout=CONNECT_TIMEOUT)
            except (OSError, TimeoutError, ValueError) as error:
                why = " ".join(str(error).split()) or type(error).__name__
                raise InputError(field, f"cannot reach the Dask scheduler at {scheduler!r}: {why}") from None
        client.wait_for_workers(1 if scheduler is not None else workers, timeout=WORKERS_TIMEOUT)
        yield client
    except KeyboardInterrupt:
        _silence_shutdown_logs()
        if cluster is None or client is None:
            _abandon_start(older_processes, older_clusters)
            cluster = client = None
        else:
            _kill_workers(cluster)
        raise
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
