"""QoS profiles every feeder node uses, defined once so publishers and subscribers always match."""

from __future__ import annotations

from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

__all__ = ["LATCHED", "STREAM_DEPTH", "EVENT_DEPTH"]

# Descriptions (parts, field programs, regions) change rarely and a late subscriber needs the current
# one: reliable, transient-local, keep only the last (the ROS 2 "latched" idiom).
LATCHED = QoSProfile(
    depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
)

# Periodic state streams: a subscriber wants the newest sample; ten covers a slow consumer's hiccup.
STREAM_DEPTH = 10

# Discrete events (throws, sensor edges) must not be lost to a short stall of a subscriber.
EVENT_DEPTH = 50
