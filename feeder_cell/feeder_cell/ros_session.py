"""A short-lived rclpy node for a ``feeder`` subcommand, on its own context, ended cleanly on Ctrl-C."""

from __future__ import annotations

import signal
from typing import Any, Callable, TypeVar

__all__ = ["with_node"]

Result = TypeVar("Result")


def with_node(name: str, work: Callable[[Any, Any, Callable[[], bool]], Result]) -> Result:
    """Run ``work(node, executor, keep_going)`` with a node on its own context; Ctrl-C ends ``keep_going``."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    stop = {"requested": False}
    previous = signal.signal(signal.SIGINT, lambda *_: stop.__setitem__("requested", True))
    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node(name, context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    try:
        return work(node, executor, lambda: not stop["requested"])
    finally:
        signal.signal(signal.SIGINT, previous)
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=context)
