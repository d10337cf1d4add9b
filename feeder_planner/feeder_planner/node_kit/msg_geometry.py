"""Conversions between numpy vectors and planar poses and the geometry_msgs types."""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np
from geometry_msgs.msg import Point, Pose, Quaternion, Vector3

from feeder_planner.assembly.tolerances import MIN_DIRECTION_NORM
from feeder_planner.errors import InputError

__all__ = ["vec", "from_vec", "point", "yaw_quaternion", "planar_pose"]


def vec(v: Sequence[float] | np.ndarray) -> Vector3:
    """Build a geometry_msgs/Vector3 from the first three components of ``v``."""
    return Vector3(x=float(v[0]), y=float(v[1]), z=float(v[2]))


def point(v: Sequence[float] | np.ndarray) -> Point:
    """Build a geometry_msgs/Point from the first three components of ``v``."""
    return Point(x=float(v[0]), y=float(v[1]), z=float(v[2]))


def from_vec(msg: Vector3, field: str) -> np.ndarray:
    """Return a finite, non-zero direction from a request's Vector3; errors name ``field``."""
    g = np.array([msg.x, msg.y, msg.z], dtype=float)
    if not np.all(np.isfinite(g)):
        raise InputError(field, f"must be finite, got {g.tolist()}")
    if np.linalg.norm(g) < MIN_DIRECTION_NORM:
        raise InputError(field, "must be a non-zero direction")
    return g


def yaw_quaternion(theta: float) -> Quaternion:
    """Return the unit quaternion of a rotation by ``theta`` (rad) about +z."""
    return Quaternion(x=0.0, y=0.0, z=math.sin(theta / 2), w=math.cos(theta / 2))


def planar_pose(x: float, y: float, theta: float) -> Pose:
    """Build a geometry_msgs/Pose in the z = 0 plane, rotated by ``theta`` about +z."""
    pose = Pose()
    pose.position.x, pose.position.y = float(x), float(y)
    pose.orientation = yaw_quaternion(float(theta))
    return pose
