"""The ``main`` of every feeder node."""

from __future__ import annotations

from typing import Callable, TypeVar

import rclpy
from rclpy.executors import Executor, ExternalShutdownException, MultiThreadedExecutor, SingleThreadedExecutor
from rclpy.node import Node

from feeder_planner.errors import InputError
from feeder_planner.node_kit.introspection import configure_service_introspection
from feeder_planner.node_kit.names import EXIT_DUPLICATE_NAME, DuplicateNameError, watch_for_namesake

__all__ = ["build_node", "run_node"]

EXIT_BAD_CONFIGURATION = 2

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


def run_node(factory: Callable[[], Node], name: str, args: list[str] | None = None, threads: int = 1) -> None:
    """Build and spin one node: a bad configuration is a FATAL log and exit 2; Ctrl-C a clean stop.

    ``threads`` > 1 spins a multi-threaded executor: a planner whose services have their own callback
    groups (``services.serve(own_group=True)``) then serves a long request beside its other work. A
    namesake in the graph at start-up ends the node with exit 1 (node_kit.names).
    """
    node = build_node(factory, name, args)
    executor: Executor = (
        MultiThreadedExecutor(num_threads=threads) if threads > 1 else SingleThreadedExecutor()
    )
    executor.add_node(node)
    namesakes = watch_for_namesake(node)
    code = 0
    try:
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except DuplicateNameError:
        code = EXIT_DUPLICATE_NAME
    finally:
        if namesakes:
            code = EXIT_DUPLICATE_NAME
        executor.shutdown(timeout_sec=1.0)
        node.destroy_node()
        rclpy.try_shutdown()
    if code:
        raise SystemExit(code)
