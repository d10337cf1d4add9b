"""The cell host's process: build the nodes, install the clock's hub, spin them, end them cleanly."""

from __future__ import annotations

import importlib
import sys
from typing import Callable

import rclpy
from rclpy.executors import Executor, ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from feeder_cell.host.hub import ClockHub
from feeder_planner.errors import InputError
from feeder_planner.node_kit import lockstep
from feeder_planner.node_kit.introspection import configure_service_introspection
from feeder_planner.node_kit.runner import EXIT_BAD_CONFIGURATION, STOP_POLL_S, StopRequest, profiled

__all__ = ["main", "node_factory", "parse_arguments"]

EXIT_BAD_ARGUMENTS = 2


def parse_arguments(argv: list[str]) -> tuple[list[tuple[str, str]], list[str]]:
    """Split ``PACKAGE/EXECUTABLE ... --ros-args ...`` into the nodes and the ROS arguments."""
    split = argv.index("--ros-args") if "--ros-args" in argv else len(argv)
    nodes = []
    for item in argv[:split]:
        package, _, executable = item.partition("/")
        if not package or not executable:
            raise InputError("nodes", f"each node is PACKAGE/EXECUTABLE, got {item!r}")
        nodes.append((package, executable))
    if not nodes:
        raise InputError("nodes", "name at least one PACKAGE/EXECUTABLE to host")
    return nodes, argv[split:]


def node_factory(package: str, executable: str) -> Callable[[], Node]:
    """Return the node class a node module offers for hosting (its ``NODE``), naming what is missing."""
    try:
        module = importlib.import_module(f"{package}.nodes.{executable}")
    except ImportError as error:
        raise InputError(
            "nodes", f"{package}/{executable}: no module {package}.nodes.{executable}"
        ) from error
    factory = getattr(module, "NODE", None)
    if factory is None:
        raise InputError("nodes", f"{package}/{executable} cannot be hosted (its module has no NODE)")
    return factory


def _build(nodes: list[tuple[str, str]]) -> list[Node]:
    """Build every node, the cell clock first: the devices' participants join its hub as they are built."""
    factories = [(package, executable, node_factory(package, executable)) for package, executable in nodes]
    factories.sort(key=lambda item: item[1] != "cell_clock")  # stable: the scene's order otherwise
    built: list[Node] = []
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
        hub = getattr(node, "hub", None)
        if executable == "cell_clock" and hub is not None:
            lockstep.host_in_process(hub)
    return built


def answer_hosted(hub: ClockHub, executor: Executor) -> None:
    """Answer every hosted participant with an announcement pending, after one drain for them all.

    The hosted participants are tick participants (devices): their drain is the executor's tasks (the
    goals their ticks resumed), once for all, in place of a drain of every entity per participant.
    """
    pending = [p for p in hub.participants() if p.pending]
    if not pending:
        return
    lockstep.run_tasks(executor)
    for participant in pending:
        participant.answer_pending(executor, drained=participant.role == "tick")


def main(argv: list[str] | None = None) -> None:
    """Run the hosted nodes until SIGINT or SIGTERM; exit 0, or 2 on a bad configuration."""
    try:
        nodes, ros_args = parse_arguments(list(sys.argv[1:] if argv is None else argv))
    except InputError as error:
        print(f"cell host: {error}", file=sys.stderr)
        raise SystemExit(EXIT_BAD_ARGUMENTS) from None
    dump_profile = profiled("cell_host")
    stop = StopRequest().install()
    rclpy.init(args=["cell_host", *ros_args], signal_handler_options=SignalHandlerOptions.NO)
    built: list[Node] = []
    executor = SingleThreadedExecutor()
    try:
        built = _build(nodes)
        for node in built:
            executor.add_node(node)
        hub = next((n.hub for n in built if getattr(n, "hub", None) is not None), None)
        while rclpy.ok() and not stop.requested:
            executor.spin_once(timeout_sec=STOP_POLL_S)
            if hub is not None:
                answer_hosted(hub, executor)
    except ExternalShutdownException:
        pass
    finally:
        stop.ignore_from_now()
        lockstep.host_in_process(None)
        executor.shutdown(timeout_sec=1.0)
        for node in reversed(built):
            node.destroy_node()
        rclpy.try_shutdown()
        dump_profile()
