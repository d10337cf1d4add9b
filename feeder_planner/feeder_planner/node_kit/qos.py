"""QoS profiles every feeder node uses, defined once so publishers and subscribers always match."""

from __future__ import annotations

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

__all__ = [
    "LATCHED",
    "LATCHED_EVENTS",
    "STREAM_DEPTH",
    "EVENT_DEPTH",
    "DEFAULT_REQUEST_QUEUE_DEPTH",
    "MAX_REQUEST_QUEUE_DEPTH",
    "request_qos",
]

# Descriptions (parts, field programs, regions) change rarely and a late subscriber needs the current
# one: reliable, transient-local, keep only the last (the ROS 2 "latched" idiom).
LATCHED = QoSProfile(
    depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
)

# Periodic state streams: a subscriber wants the newest sample; ten covers a slow consumer's hiccup.
STREAM_DEPTH = 10

# Discrete events (throws, sensor edges) must not be lost to a short stall of a subscriber.
EVENT_DEPTH = 50

# Events a late subscriber still needs, each of them (a program, and the prediction made for it): latched and
# deep, on both ends. A depth-1 writer or reader keeps only the newest of two events sent back to back, so a
# reader stalled by a loaded machine, or joining after both (a recorder), lost the first (ci46).
LATCHED_EVENTS = QoSProfile(
    depth=EVENT_DEPTH, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
)

# Requests to services and action servers: rclpy's default keeps the last 10, so a burst of 200 calls
# loses 190 without a word. A deep reliable queue keeps every request of a burst until it is served;
# nodes take the depth from their ``request_queue_depth`` parameter (node_kit.services).
DEFAULT_REQUEST_QUEUE_DEPTH = 1000
MAX_REQUEST_QUEUE_DEPTH = 100_000


def request_qos(depth: int = DEFAULT_REQUEST_QUEUE_DEPTH) -> QoSProfile:
    """Return the QoS of a service's or action server's request queue (and a bursting client's replies).

    Parameters
    ----------
    depth
        Requests kept while the server is busy (keep last, reliable, volatile).
    """
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=depth,
        reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.VOLATILE,
    )
