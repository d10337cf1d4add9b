"""The devices' heartbeat watch: a device not heard for STATUS_TIMEOUT is offline, and its lost goal ended.

Its own module because it is the one place the gateway acts on silence rather than on a message: a
steady-clock timer in the executor's thread, reading and writing each ``DeviceLink`` under the link's
lock (and posting or ending the goal only after releasing it).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping

from rclpy.clock import Clock, ClockType
from rclpy.node import Node

from feeder_cell.gateway.device_link import DeviceLink
from feeder_cell.gateway.server import GatewayServer

__all__ = ["STATUS_TIMEOUT", "Watchdog"]

# A device whose ~/status (1 Hz heartbeat) is not heard for this long is offline (Online false, PackML
# Undefined); five missed heartbeats, so that a starved process on a loaded host does not flap it. A goal
# in progress is given up (LOST) only once the device's action server has left the graph as well: a
# device that is merely slow still delivers its result.
STATUS_TIMEOUT = 5.0

# Ends a goal in the variables: (link, outcome, outcome code, message); ``goals.GoalRunner.finish``.
Finish = Callable[[DeviceLink, str, int, str], None]


class Watchdog:
    """Marks a silent device offline and ends its goal once its action server has left the graph too."""

    def __init__(
        self, node: Node, links: Mapping[str, DeviceLink], server: GatewayServer, finish: Finish
    ) -> None:
        self.node, self.links, self.server, self.finish = node, links, server, finish
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        node.create_timer(0.5, self.check, clock=steady)

    def check(self) -> None:
        """Check every device's last status (timer, executor thread)."""
        now = time.monotonic()
        for link in self.links.values():
            with link.lock:
                silent = now - link.heard > STATUS_TIMEOUT
                went_offline = link.online and silent
                if went_offline:
                    link.online = False
                lost = silent and link.goal is not None and not link.action.server_is_ready()
                if lost:
                    link.goal = None
            if went_offline:
                self.node.get_logger().warning(
                    f"{link.entry.node}: no ~/status for {now - link.heard:.1f} s: offline (PackML Undefined)"
                )
                self.server.post_all(
                    link.entry.key,
                    {"Status.Online": False, "Status.PackMLState": "Undefined", "Status.PackMLStateCode": 0},
                )
            if lost:
                self.finish(
                    link, "LOST", 0, "the device stopped reporting and its action server left the graph"
                )
