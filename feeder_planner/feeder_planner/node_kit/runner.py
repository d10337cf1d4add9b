"""The ``main`` of every feeder node."""

from __future__ import annotations

import os
import signal
import time
from pathlib import Path
from typing import Callable, TypeVar

import rclpy
from rclpy.executors import Executor, ExternalShutdownException, MultiThreadedExecutor, SingleThreadedExecutor
from rclpy.node import Node

from feeder_planner.errors import InputError
from feeder_planner.node_kit.introspection import configure_service_introspection
from feeder_planner.node_kit.lockstep import Participant
from feeder_planner.node_kit.names import EXIT_DUPLICATE_NAME, DuplicateNameError, watch_for_namesake

__all__ = ["build_node", "run_node", "profiled"]

EXIT_BAD_CONFIGURATION = 2
# Wall seconds a stopping node waits for the callbacks still running on its executor's threads.
STOP_WAIT_S = 2.0

NodeType = TypeVar("NodeType", bound=Node)


def build_node(factory: Callable[[], NodeType], name: str, args: list[str] | None = None) -> NodeType:
    """Init rclpy and build one node: a bad configuration is a FATAL log naming the field, and exit 2."""
    rclpy.init(args=args)
    try:
        node = factory()
        configure_service_introspection(node)  # after the factory: every service and client exists
        return node
    except InputError as error:
        rclpy.logging.get_logger(name).fatal(f"bad configuration: {error}")
        rclpy.try_shutdown()
        raise SystemExit(EXIT_BAD_CONFIGURATION) from None


PROFILE_VARIABLE = "FEEDER_PROFILE"


def profiled(name: str) -> Callable[[], None]:
    """Start cProfile when $FEEDER_PROFILE names a folder; return what writes ``<folder>/<name>-<pid>.prof``.

    How the cell's per-node profile in docs/cell.md was taken: every node of a launch inherits the
    variable, and ``python -m pstats`` reads the files.
    """
    folder = os.environ.get(PROFILE_VARIABLE, "")
    if not folder:
        return lambda: None
    import cProfile

    profile = cProfile.Profile(time.process_time)  # CPU, not wall: waiting is not cost
    profile.enable()

    def dump() -> None:
        profile.disable()
        Path(folder).mkdir(parents=True, exist_ok=True)
        profile.dump_stats(str(Path(folder) / f"{name}-{os.getpid()}.prof"))

    return dump


def run_node(factory: Callable[[], Node], name: str, args: list[str] | None = None, threads: int = 1) -> None:
    """Build and spin one node: a bad configuration is a FATAL log and exit 2; Ctrl-C a clean stop.

    ``threads`` > 1 spins a multi-threaded executor: a planner whose services have their own callback
    groups (``services.serve(own_group=True)``) then serves a long request beside its other work. A
    namesake in the graph at start-up ends the node with exit 1 (node_kit.names). A node with a lockstep
    participant (its ``lockstep`` attribute) spins through it: drained before every answer.
    """
    dump_profile = profiled(name)
    node = build_node(factory, name, args)
    executor: Executor = (
        MultiThreadedExecutor(num_threads=threads) if threads > 1 else SingleThreadedExecutor()
    )
    executor.add_node(node)
    namesakes = watch_for_namesake(node)
    code = 0
    participant = getattr(node, "lockstep", None)
    try:
        if isinstance(participant, Participant):
            participant.spin(executor)
        else:
            executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except DuplicateNameError:
        code = EXIT_DUPLICATE_NAME
    finally:
        if namesakes:
            code = EXIT_DUPLICATE_NAME
        _ignore_stop_signals()
        executor.shutdown(timeout_sec=1.0)
        _wait_for_running_callbacks(executor, STOP_WAIT_S)
        node.destroy_node()
        rclpy.try_shutdown()
        dump_profile()
    if code:
        raise SystemExit(code)


def _ignore_stop_signals() -> None:
    """Let the clean-up run to its end: a second SIGINT or SIGTERM while stopping is ignored.

    Ctrl-C reaches a node and its launcher together, and the launcher then sends its own SIGINT: that
    second signal raised KeyboardInterrupt inside the clean-up (``destroy_node``; rclpy chains its handler
    to Python's). The clean-up stopped half way, rclpy was not shut down, and the process ended by the
    signal (exit -2), or, with handles left half destroyed for the interpreter's exit to free in any order,
    by signal 11. A node that hangs while stopping is still ended by its launcher's SIGKILL.
    """
    for number in (signal.SIGINT, signal.SIGTERM):
        signal.signal(number, signal.SIG_IGN)


def _wait_for_running_callbacks(executor: Executor, timeout_s: float) -> None:
    """Wait (at most ``timeout_s``) for the callbacks a multi-threaded executor still runs on its threads.

    rclpy 7.1's ``Executor.shutdown`` does not wait for them (it tests its own shutdown flag after setting
    it), so ``destroy_node`` could free a service or publisher a worker thread was still answering or
    publishing on (a planner stopped in the middle of a request).
    """
    if not isinstance(executor, MultiThreadedExecutor):
        return  # a single-threaded executor runs its callbacks on this thread: none is running now
    running = list(getattr(executor, "_futures", []))  # the Tasks handed to the thread pool
    deadline = time.monotonic() + timeout_s
    while any(not task.done() for task in running) and time.monotonic() < deadline:
        time.sleep(0.01)
    pool = getattr(executor, "_executor", None)
    if pool is not None:
        pool.shutdown(wait=False, cancel_futures=True)
