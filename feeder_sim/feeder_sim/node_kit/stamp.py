"""Message stamps from the node-clock instants the device kit ticks at."""

from __future__ import annotations

from builtin_interfaces.msg import Time
from rclpy.time import Time as RclTime
from std_msgs.msg import Header

__all__ = ["header", "stamp"]


def stamp(nanoseconds: int) -> Time:
    """Return a node-clock time (integer ns) as a message stamp."""
    return RclTime(nanoseconds=nanoseconds).to_msg()


def header(nanoseconds: int, frame_id: str) -> Header:
    """Return a header stamped at a node-clock time (integer ns) in ``frame_id``."""
    return Header(stamp=stamp(nanoseconds), frame_id=frame_id)
