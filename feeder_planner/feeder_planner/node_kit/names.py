"""One node per fully qualified name: a node that finds a namesake at start-up refuses to run.

Two nodes under one name run side by side without a word from ROS 2: their streams interleave, stamps go
backwards, and every service has two servers (a lifecycle ``change_state`` may reach either). A cell must
never run two devices under one name, so each feeder node watches the ROS graph for its first
``DUPLICATE_WINDOW`` seconds (discovery of a node already running takes a moment) and, if another node
has its fully qualified name, logs an error naming it and ends with ``EXIT_DUPLICATE_NAME``.

Managed devices end too rather than refusing to configure: an unconfigured lifecycle node still serves
its lifecycle and parameter services under the shared name, which is what must not happen.
"""

from __future__ import annotations

import time

from rclpy.clock import Clock, ClockType
from rclpy.node import Node

__all__ = ["DUPLICATE_WINDOW", "EXIT_DUPLICATE_NAME", "DuplicateNameError", "namesakes", "watch_for_namesake"]

# s (steady). Fast DDS discovery on one host takes well under a second on an idle machine, but on a loaded
# 2-core machine (the load tests' nodes all running) a newcomer once saw its namesake only after 2 s.
DUPLICATE_WINDOW = 5.0
# A process starved of CPU may look for the first time late in its window: the watch ends only after this
# many looks too.
MIN_LOOKS = 20
EXIT_DUPLICATE_NAME = 1
_POLL = 0.1  # s between looks at the graph


class DuplicateNameError(RuntimeError):
    """Another node in the graph has this node's fully qualified name."""


def namesakes(node: Node) -> int:
    """Return how many other nodes in the graph have ``node``'s name and namespace."""
    own = (node.get_name(), node.get_namespace())
    return sum(1 for entry in node.get_node_names_and_namespaces() if entry == own) - 1


def watch_for_namesake(node: Node, window: float = DUPLICATE_WINDOW) -> list[str]:
    """Look for a namesake every 0.1 s for ``window`` s (and MIN_LOOKS looks) while the node spins.

    Return the findings.

    A namesake found is logged as an error naming the name, appended to the returned list, and shuts
    the node's context down, which ends the executor's spin; ``run_node`` then ends the process with
    ``EXIT_DUPLICATE_NAME``. (An exception raised in a timer does not reliably leave a multi-threaded
    executor's spin, so the context is the signal.)
    """
    start = time.monotonic()
    timer = None
    found: list[str] = []
    looks = 0

    def look() -> None:
        nonlocal looks
        looks += 1
        if namesakes(node) > 0:
            name = node.get_fully_qualified_name()
            node.get_logger().error(
                f"another node named {name} is already running: one name, one node "
                f"(exit {EXIT_DUPLICATE_NAME}); start this one under another name or namespace"
            )
            found.append(name)
            node.context.try_shutdown()
            return
        if time.monotonic() - start > window and looks >= MIN_LOOKS and timer is not None:
            node.destroy_timer(timer)

    timer = node.create_timer(_POLL, look, clock=Clock(clock_type=ClockType.STEADY_TIME))
    return found
