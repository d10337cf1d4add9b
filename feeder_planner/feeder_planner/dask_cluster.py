"""The Dask cluster the throwing-design studies and the production experiments run on. ROS-free.

Either a LocalCluster of single-threaded worker processes on this machine, or an existing scheduler at an
address; set up one way for every caller, and always closed.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Iterator, TypeVar

from feeder_planner.errors import InputError

if TYPE_CHECKING:
    from dask.distributed import Client, LocalCluster

__all__ = ["CONNECT_TIMEOUT", "MAX_WORKERS", "QUIET_WORKERS", "WORKERS_TIMEOUT", "dask_client"]

T = TypeVar("T")

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


@contextlib.contextmanager
def stop_signals_blocked() -> Iterator[None]:
    """Block SIGINT in this thread (and in the threads and processes it starts) while the block runs.

    A SIGINT that comes meanwhile stays pending and is delivered (KeyboardInterrupt) as the block ends.
    SIGTERM stays unblocked: the nanny ends its workers with it.
    """
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


# The shell's status of a process that SIGINT ended (128 + 2): what the feeder command exits with.
EXIT_INTERRUPTED = 130
START_POLL_S = 0.05  # how often the main thread looks whether the cluster's start is done


def _descendants(pid: int) -> list[int]:
    """Every process below ``pid`` (Linux /proc), children before their own children."""
    children: dict[int, list[int]] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        with contextlib.suppress(OSError, ValueError, IndexError):
            # The command name (2nd field) may hold spaces and parentheses: the fields after its last ")".
            fields = stat.read_text().rsplit(")", 1)[1].split()
            children.setdefault(int(fields[1]), []).append(int(stat.parent.name))
    found, queue = [], [pid]
    while queue:
        for child in children.get(queue.pop(0), []):
            found.append(child)
            queue.append(child)
    return found


def _abandon_start() -> None:
    """Ctrl-C while a LocalCluster starts: kill what it has made, say so in one line, exit 130 at once.

    A start cut short cannot be closed cleanly: distributed's exit handler closed the half-made cluster with
    a traceback, or waited for the start (3.2 s under a CI run's load, against issue 33's 2 s). Nothing has
    been computed yet, so nothing is lost: the worker processes (and multiprocessing's helpers) are killed
    and the process ends without its exit handlers.
    """
    for pid in _descendants(os.getpid()):
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, signal.SIGKILL)
    sys.stdout.flush()
    sys.stderr.write("interrupted while the Dask cluster was starting\n")
    sys.stderr.flush()
    os._exit(EXIT_INTERRUPTED)


def start_abandonable(start: Callable[[], T]) -> T:
    """Run ``start`` (a cluster's start) so that Ctrl-C meanwhile ends the process within moments.

    The start runs on a thread of its own with SIGINT blocked, and so do the threads and worker processes
    it makes (they inherit the mask: a terminal's Ctrl-C, sent to the whole process group, reaches only
    this process's main thread). The main thread waits with SIGINT open, and Ctrl-C there abandons the
    start (``_abandon_start``). Off the main thread (no Python signal handler runs there) the start runs
    with SIGINT blocked, as before: a Ctrl-C meanwhile is raised once the start is done.
    """
    if threading.current_thread() is not threading.main_thread():
        with stop_signals_blocked():
            return start()
    outcome: list[T] = []
    failure: list[BaseException] = []

    def run() -> None:
        try:
            outcome.append(start())
        except BaseException as error:  # re-raised in the main thread, which the caller waits on
            failure.append(error)

    thread = threading.Thread(target=run, name="dask-cluster-start", daemon=True)
    try:
        with stop_signals_blocked():
            thread.start()
        while thread.is_alive():
            thread.join(START_POLL_S)
    except KeyboardInterrupt:
        _abandon_start()
    if failure:
        raise failure[0]
    return outcome[0]


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

    cluster: LocalCluster | None = None
    client: Client | None = None
    try:
        if scheduler is None:

            def start() -> tuple[LocalCluster, Client]:
                quiet = {f"distributed.nanny.pre-spawn-environ.{k}": v for k, v in QUIET_WORKERS.items()}
                with dask.config.set(quiet):
                    made = LocalCluster(
                        n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None
                    )
                return made, Client(made)

            # Ctrl-C inside a LocalCluster's start left it half made (start_abandonable says what it does).
            cluster, client = start_abandonable(start)
        else:
            try:
                client = start_abandonable(lambda: Client(scheduler, timeout=CONNECT_TIMEOUT))
            except (OSError, TimeoutError, ValueError) as error:
                why = " ".join(str(error).split()) or type(error).__name__
                raise InputError(field, f"cannot reach the Dask scheduler at {scheduler!r}: {why}") from None
        client.wait_for_workers(1 if scheduler is not None else workers, timeout=WORKERS_TIMEOUT)
        yield client
    except KeyboardInterrupt:
        _silence_shutdown_logs()
        if cluster is not None:
            _kill_workers(cluster)
        raise
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
