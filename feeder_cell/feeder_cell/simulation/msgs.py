"""Conversions between the standard's messages and the ROS-free simulation types (one place, both ways)."""

from __future__ import annotations

from typing import Any

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Pose, Twist
from simulation_interfaces.msg import EntityState as EntityStateMsg
from simulation_interfaces.msg import Result

from feeder_cell.simulation.entities import EntityState

__all__ = ["result_msg", "state_msg", "pose_tuple", "twist_tuples", "accel_tuple", "nanoseconds"]

NANOSECONDS = 1_000_000_000


def result_msg(code: int, message: str = "") -> Result:
    """Return a simulation_interfaces/Result."""
    return Result(result=code, error_message=message)


def nanoseconds(stamp: Time) -> int:
    """Return a builtin_interfaces/Time as integer nanoseconds."""
    return int(stamp.sec) * NANOSECONDS + int(stamp.nanosec)


def state_msg(state: EntityState) -> EntityStateMsg:
    """Return the standard's EntityState of a ROS-free one (acceleration zero: not observed)."""
    msg = EntityStateMsg()
    msg.header.frame_id = state.frame_id
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(state.stamp_ns, NANOSECONDS)
    p, q = msg.pose.position, msg.pose.orientation
    p.x, p.y, p.z = state.position
    q.x, q.y, q.z, q.w = state.orientation
    v, w = msg.twist.linear, msg.twist.angular
    v.x, v.y, v.z = state.linear
    w.x, w.y, w.z = state.angular
    return msg


def pose_tuple(pose: Pose) -> tuple[tuple[float, float, float], tuple[float, float, float, float]]:
    """Return (position, orientation x y z w) of a geometry_msgs/Pose."""
    p, q = pose.position, pose.orientation
    return (float(p.x), float(p.y), float(p.z)), (float(q.x), float(q.y), float(q.z), float(q.w))


def twist_tuples(twist: Twist) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """Return (linear, angular) of a geometry_msgs/Twist."""
    v, w = twist.linear, twist.angular
    return (float(v.x), float(v.y), float(v.z)), (float(w.x), float(w.y), float(w.z))


def accel_tuple(accel: Any) -> tuple[float, ...]:
    """Return the six numbers of a geometry_msgs/Accel."""
    v, w = accel.linear, accel.angular
    return (float(v.x), float(v.y), float(v.z), float(w.x), float(w.y), float(w.z))
