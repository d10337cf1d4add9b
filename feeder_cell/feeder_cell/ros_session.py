"""A short-lived rclpy node for a ``feeder`` subcommand, on its own context, ended cleanly on Ctrl-C."""

from __future__ import annotations

import signal
from typing import Any, Callable, TypeVar

__all__ = ["with_node"]

Result = TypeVar("Result")

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


def with_node(
    name: str, work: Callable[[Any, Any, Callable[[], bool]], Result], use_sim_time: bool = False
) -> Result:
    """Run ``work(node, executor, keep_going)`` on a node of its own context; a stop signal ends it."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    stop = {"requested": False}
    # Ctrl-C, `kill` (SIGTERM, as timeout and docker stop send) and a closed terminal (SIGHUP) all end
    # the work cleanly: the work sees keep_going() turn false and releases what it started.
    previous = {
        sig: signal.signal(sig, lambda *_: stop.__setitem__("requested", True)) for sig in STOP_SIGNALS
    }
    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node(name, context=context)
    if use_sim_time:
        from rclpy.parameter import Parameter

        node.set_parameters([Parameter("use_sim_time", Parameter.Type.BOOL, True)])
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    try:
        return work(node, executor, lambda: not stop["requested"])
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=context)
