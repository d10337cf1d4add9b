"""The ``main`` of every feeder node."""

from __future__ import annotations

import os
import signal
import threading
import time
from pathlib import Path
from typing import Callable, TypeVar

import rclpy
from rclpy.executors import Executor, ExternalShutdownException, MultiThreadedExecutor, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions
from rclpy.task import Future

from feeder_planner.entry_points import STOP_SIGNALS, held_signal
from feeder_planner.errors import InputError
from feeder_planner.node_kit.introspection import configure_service_introspection
from feeder_planner.node_kit.lockstep import Participant
from feeder_planner.node_kit.names import EXIT_DUPLICATE_NAME, DuplicateNameError, watch_for_namesake

__all__ = ["StopRequest", "build_node", "run_node", "profiled"]

EXIT_BAD_CONFIGURATION = 2
# Wall seconds a stopping node waits for the callbacks still running on its executor's threads.
STOP_WAIT_S = 2.0
# Wall seconds between a lockstep participant's looks at a stop request (it polls for its answers anyway).
STOP_POLL_S = 0.1


class StopRequest:
    """SIGINT and SIGTERM as one request to stop, taken by a Python handler that never raises.

    rclpy 7.1's own handlers made a node's stop a race it sometimes lost with signal 11 (the demo scene's
    Ctrl-C reaches each node two or three times: the terminal, the launcher, the test):
    - a signal raised KeyboardInterrupt wherever the main thread was: in the node's construction, or,
      arriving again before the clean-up could ignore it, inside ``destroy_node``, leaving handles half
      destroyed for the interpreter's exit to free in any order;
    - its deferred-signal thread shuts every context down (rcl_shutdown) and triggers the executors'
      signal guard conditions while the main thread destroys the node and those guard conditions
      (fixed upstream in ros2/rclpy#1353, after 7.1).
    Here a signal only completes ``future``; the spin loop (``executor.spin_until_future_complete``)
    sees it and ends, and the clean-up runs on the main thread alone, whatever more signals come. A Python
    handler runs only once the main thread is back from rcl_wait, so the signal also reaches a thread of
    its own through ``signal.set_wakeup_fd``, which completes the future at once and so wakes an idle
    executor. (A poll, ``spin_once(timeout_sec)`` in a loop, leaks: rclpy 7.1 makes a timeout timer per
    call and never destroys it.) Install it before ``rclpy.init``, and init rclpy with
    ``SignalHandlerOptions.NO`` (``build_node(stop=...)`` does both, in that order).
    """

    def __init__(self) -> None:
        self.future: Future = Future()

    def install(self) -> "StopRequest":
        """Take SIGINT and SIGTERM from now on (Python's default SIGINT handler raises; this one does not)."""
        read_end, write_end = os.pipe()
        os.set_blocking(write_end, False)  # set_wakeup_fd's requirement: a signal never blocks on it
        signal.set_wakeup_fd(write_end)
        threading.Thread(target=self._watch, args=(read_end,), name="stop-signals", daemon=True).start()
        for number in STOP_SIGNALS:
            signal.signal(number, self._on_signal)
        held = held_signal()  # one that came while the console script imported the node (entry_points)
        if held is not None:
            self._complete(held)
        return self

    def _watch(self, read_end: int) -> None:
        """Complete the future from the first signal byte Python's C handler writes (any thread's)."""
        while True:
            data = os.read(read_end, 64)
            if not data:
                return
            for number in data:
                if number in STOP_SIGNALS:
                    self._complete(number)

    def _complete(self, number: int) -> None:
        if not self.future.done():
            self.future.set_result(number)

    @property
    def requested(self) -> bool:
        """Whether a stop signal has come."""
        return self.future.done()

    def ignore_from_now(self) -> None:
        """Ignore the stop signals from now on: the stop is under way.

        At the interpreter's exit Python resets a handler it installed to the default, which would end
        the process by the signal (exit -2) when the launcher's SIGINT comes late.
        """
        for number in STOP_SIGNALS:
            signal.signal(number, signal.SIG_IGN)

    def _on_signal(self, number: int, _frame: object) -> None:
        self._complete(number)


NodeType = TypeVar("NodeType", bound=Node)


def build_node(
    factory: Callable[[], NodeType], name: str, args: list[str] | None = None, stop: StopRequest | None = None
) -> NodeType:
    """Init rclpy and build one node: a bad configuration is a FATAL log naming the field, and exit 2.

    With ``stop``, it takes the stop signals (installed first: one during construction is kept for the
    spin loop) and rclpy installs none of its own; without, rclpy's handlers end the context on a signal.
    """
    if stop is not None:
        stop.install()
    rclpy.init(
        args=args,
        signal_handler_options=SignalHandlerOptions.NO if stop is not None else SignalHandlerOptions.ALL,
    )
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
    participant (its ``lockstep`` attribute) spins through it: drained before every answer. SIGINT and
    SIGTERM, however many and whenever they come, end the spin once (``StopRequest``); a node that hangs
    while stopping is still ended by its launcher's SIGKILL.
    """
    dump_profile = profiled(name)
    stop = StopRequest()
    node = build_node(factory, name, args, stop)
    executor: Executor = (
        MultiThreadedExecutor(num_threads=threads) if threads > 1 else SingleThreadedExecutor()
    )
    executor.add_node(node)
    namesakes = watch_for_namesake(node)
    code = 0
    participant = getattr(node, "lockstep", None)
    try:
        if isinstance(participant, Participant):
            participant.spin(executor, STOP_POLL_S, lambda: stop.requested)
        else:
            executor.spin_until_future_complete(stop.future)
    except ExternalShutdownException:
        pass
    except DuplicateNameError:
        code = EXIT_DUPLICATE_NAME
    finally:
        if namesakes:
            code = EXIT_DUPLICATE_NAME
        stop.ignore_from_now()
        executor.shutdown(timeout_sec=1.0)
        _wait_for_running_callbacks(executor, STOP_WAIT_S)
        node.destroy_node()
        rclpy.try_shutdown()
        dump_profile()
    if code:
        raise SystemExit(code)


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
