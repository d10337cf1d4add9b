"""The ``main`` of every feeder node."""

from __future__ import annotations

from typing import Callable, TypeVar

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node

from feeder_planner.errors import InputError

__all__ = ["build_node", "run_node"]

EXIT_BAD_CONFIGURATION = 2

NodeType = TypeVar("NodeType", bound=Node)


def build_node(factory: Callable[[], NodeType], name: str, args: list[str] | None = None) -> NodeType:
    """Init rclpy and build one node: a bad configuration is a FATAL log naming the field, and exit 2."""
    rclpy.init(args=args)
    try:
        return factory()
    except InputError as error:
        rclpy.logging.get_logger(name).fatal(f"bad configuration: {error}")
        rclpy.try_shutdown()
        raise SystemExit(EXIT_BAD_CONFIGURATION) from None


def run_node(factory: Callable[[], Node], name: str, args: list[str] | None = None) -> None:
    """Build and spin one node: a bad configuration is a FATAL log and exit 2; Ctrl-C a clean stop."""
    node = build_node(factory, name, args)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
