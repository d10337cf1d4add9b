"""The ``main`` of every feeder node."""

from __future__ import annotations

from typing import Callable

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node

from feeder_planner.errors import InputError

__all__ = ["run_node"]

EXIT_BAD_CONFIGURATION = 2


def run_node(factory: Callable[[], Node], name: str, args: list[str] | None = None) -> None:
    """Build and spin one node: a bad configuration is a FATAL log and exit 2; Ctrl-C a clean stop."""
    rclpy.init(args=args)
    try:
        node = factory()
    except InputError as error:
        rclpy.logging.get_logger(name).fatal(f"bad configuration: {error}")
        rclpy.try_shutdown()
        raise SystemExit(EXIT_BAD_CONFIGURATION) from None
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
