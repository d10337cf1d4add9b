"""The cell clock for clients that follow it: whether /clock runs, and its time while a client follows it.

Each discovery tells the server whether the graph has a /clock publisher (a client that connects then
follows the cell clock for its whole connection); while some client follows it, /clock is subscribed
and each time handed to the server. Runs on the ROS thread only, so nothing is locked. Its own module:
the time source is a concern apart from topics, which a client subscribes one by one.
"""

from __future__ import annotations

from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.subscription import Subscription
from rclpy.topic_endpoint_info import TopicEndpointInfo
from rosgraph_msgs.msg import Clock

from feeder_cell.bridge.ws import FoxgloveServer

__all__ = ["ClockFeed"]


class ClockFeed:
    """Tell ``server`` whether /clock runs, and feed it /clock while followed."""

    def __init__(self, node: Node, server: FoxgloveServer) -> None:
        self.node = node
        self.server = server
        self._clock: Subscription | None = None
        self._clock_running = False

    def see(self, publishers: dict[str, list[TopicEndpointInfo]]) -> None:
        """Take the topics' publishers discovery found: the server is told when /clock starts or stops."""
        running = bool(publishers.get("/clock"))
        if running != self._clock_running:
            self._clock_running = running
            self.server.clock_running(running)

    def follow_clock(self, follow: bool) -> None:
        """Subscribe /clock while some client follows the cell clock."""
        if follow and self._clock is None:
            # Best effort matches every /clock writer, reliable or not; only the newest time matters.
            qos = QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT)
            self._clock = self.node.create_subscription(
                Clock, "/clock", lambda m: self.server.time(m.clock.sec * 10**9 + m.clock.nanosec), qos
            )
        elif not follow and self._clock is not None:
            self.node.destroy_subscription(self._clock)
            self._clock = None
