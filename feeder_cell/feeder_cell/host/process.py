"""The cell host's process: build the nodes, install the clock's hub, spin them, end them cleanly."""

from __future__ import annotations

import json
import sys
import threading
from pathlib import Path
from typing import Callable, Protocol, cast

import rclpy
from rclpy.executors import Executor, ExternalShutdownException
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from feeder_cell.host.executor import HostExecutor
from feeder_cell.host.hub import ClockHub
from feeder_cell.node_modules import node_class, node_module
from feeder_planner.errors import InputError
from feeder_planner.node_kit import lockstep
from feeder_planner.node_kit.introspection import configure_service_introspection
from feeder_planner.node_kit.runner import EXIT_BAD_CONFIGURATION, StopRequest, profiled

__all__ = ["main", "node_factory", "parse_arguments"]

EXIT_BAD_ARGUMENTS = 2
WORK_STOP_S = 5.0  # wall s a hosted node's work may take to end once a stop is requested


END_FILE = "--end-file="


def parse_arguments(argv: list[str]) -> tuple[list[tuple[str, str]], list[str], str]:
    """Split ``[--end-file=PATH] PACKAGE/EXECUTABLE ... --ros-args ...`` (nodes, ROS arguments, end file)."""
    split = argv.index("--ros-args") if "--ros-args" in argv else len(argv)
    nodes = []
    end_file = ""
    for item in argv[:split]:
        if item.startswith(END_FILE):
            end_file = item[len(END_FILE) :]
            continue
        package, _, executable = item.partition("/")
        if not package or not executable:
            raise InputError("nodes", f"each node is PACKAGE/EXECUTABLE, got {item!r}")
        nodes.append((package, executable))
    if not nodes:
        raise InputError("nodes", "name at least one PACKAGE/EXECUTABLE to host")
    return nodes, argv[split:], end_file


class HostedWork(Protocol):
    """A node whose work runs on a thread of its own (the reference controller's cycles)."""

    def hosted_work(self, stop: StopRequest) -> int:
        """Do the node's work until it is done or ``stop`` is requested; return its exit code."""
        ...


def start_work(
    built: list[Node], stop: StopRequest, ended: list[tuple[str, int]], executor: Executor
) -> list[threading.Thread]:
    """Start each hosted node's own work on a thread; its end (name, exit code) ends the host."""
    workers = []
    for node in built:
        if not hasattr(node, "hosted_work"):
            continue

        def work(node: Node = node) -> None:
            code = cast(HostedWork, node).hosted_work(stop)
            ended.append((node.get_fully_qualified_name(), code))
            executor.wake()

        worker = threading.Thread(target=work, name=f"work:{node.get_name()}", daemon=True)
        worker.start()
        workers.append(worker)
    return workers


def node_factory(package: str, executable: str) -> Callable[[], Node]:
    """Return the node class a node module offers for hosting (its ``NODE``), naming what is missing."""
    if node_module(package, executable) is None:
        raise InputError("nodes", f"{package}/{executable}: no module {package}.nodes.{executable}")
    factory = node_class(package, executable)
    if factory is None:
        raise InputError("nodes", f"{package}/{executable} cannot be hosted (its module has no NODE)")
    return cast(Callable[[], Node], factory)


class HostedClock(Protocol):
    """What the host needs of the hosted cell clock: its hub, and the time readers it feeds by call."""

    hub: ClockHub
    hosted_readers: list[Callable[..., None]]


def _build(nodes: list[tuple[str, str]]) -> tuple[list[Node], HostedClock | None]:
    """Build every node, the cell clock first: the devices' participants join its hub as they are built.

    Returns the nodes and the hosted clock (the node that offers a hub), None when the host has none.
    """
    factories = [(package, executable, node_factory(package, executable)) for package, executable in nodes]
    factories.sort(key=lambda item: item[1] != "cell_clock")  # stable: the scene's order otherwise
    built: list[Node] = []
    clock: HostedClock | None = None
    for _package, executable, factory in factories:
        try:
            node = factory()
        except InputError as error:
            rclpy.logging.get_logger(executable).fatal(f"bad configuration: {error}")
            for done in built:
                done.destroy_node()
            raise SystemExit(EXIT_BAD_CONFIGURATION) from None
        configure_service_introspection(node)
        built.append(node)
        if clock is None and getattr(node, "hub", None) is not None:
            clock = cast(HostedClock, node)
            lockstep.host_in_process(clock.hub)
    return built, clock


def hand_clock_directly(built: list[Node], clock: HostedClock) -> None:
    """Give the hosted nodes cell time by call from the hosted clock, not through their /clock readers.

    Each node on sim time has rclpy's time source reading /clock (best effort, depth 1): in the host that
    is one callback per node for every /clock message, the most frequent work of the host's executor after
    the lockstep itself. The clock calls each time source's own callback instead, with the same message
    when it publishes it. (rclpy offers no public way to feed a time source: ``_time_source`` and its
    ``_clock_sub`` are rclpy 7.1's; a time source re-subscribes by itself if ``use_sim_time`` is set again.)
    """
    for node in built:
        source = getattr(node, "_time_source", None)
        subscription = getattr(source, "_clock_sub", None)
        if node is clock or source is None or subscription is None:
            continue
        node.destroy_subscription(subscription)
        source._clock_sub = None
        clock.hosted_readers.append(source.clock_callback)


def answer_hosted(hub: ClockHub, executor: Executor) -> None:
    """Answer every hosted participant with an announcement pending, after the drain its role needs.

    Tick participants (the devices): the executor's tasks (the goals their ticks resumed), once for them
    all, in place of a drain of every entity per participant. A react participant (the hosted controller):
    its own node's callbacks (the samples it decides on), not every hosted node's.
    """
    pending = [p for p in hub.participants() if p.pending]
    if not pending:
        return
    lockstep.run_tasks(executor)
    for participant in pending:
        if participant.role != "tick":
            lockstep.drain(executor, nodes=[participant.node])
        participant.answer_pending(executor, drained=True)


def main(argv: list[str] | None = None) -> None:
    """Run the hosted nodes until SIGINT or SIGTERM; exit 0, or 2 on a bad configuration."""
    try:
        nodes, ros_args, end_file = parse_arguments(list(sys.argv[1:] if argv is None else argv))
    except InputError as error:
        print(f"cell host: {error}", file=sys.stderr)
        raise SystemExit(EXIT_BAD_ARGUMENTS) from None
    dump_profile = profiled("cell_host")
    stop = StopRequest().install()
    rclpy.init(args=["cell_host", *ros_args], signal_handler_options=SignalHandlerOptions.NO)
    built: list[Node] = []
    workers: list[threading.Thread] = []
    ended: list[tuple[str, int]] = []
    executor = HostExecutor()
    try:
        built, clock = _build(nodes)
        for node in built:
            executor.add_node(node)
        hub = None if clock is None else clock.hub
        if clock is not None:
            hand_clock_directly(built, clock)
        # No timeout on spin_once (rclpy 7.1 makes a timer per call with one and never frees it): a stop
        # wakes the executor, and so does the end of a hosted node's work.
        stop.future.add_done_callback(lambda _: executor.wake())
        workers = start_work(built, stop, ended, executor)
        while rclpy.ok() and not stop.requested and not ended:
            executor.spin_once()
            if hub is not None:
                answer_hosted(hub, executor)
    except ExternalShutdownException:
        pass
    finally:
        stop.ignore_from_now()
        if ended:
            what = ", ".join(f"{name} (exit code {code})" for name, code in ended)
            rclpy.logging.get_logger("cell_host").info(f"ending: the work of {what} is done")
        for worker in workers:
            worker.join(timeout=WORK_STOP_S)  # a stop request ends its work within its poll
        lockstep.host_in_process(None)
        executor.shutdown(timeout_sec=1.0)
        for node in reversed(built):
            node.destroy_node()
        rclpy.try_shutdown()
        dump_profile()
    if end_file:
        Path(end_file).write_text(json.dumps({"ended_by": [name for name, _ in ended]}))
    if ended:
        raise SystemExit(ended[0][1])
