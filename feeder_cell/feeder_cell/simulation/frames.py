"""Frames of the standard's poses: ``world`` is the cell's root frame, device frames hang under it.

The standard (EntityState.msg: "Empty frame defaults to world"; SpawnEntity.srv: the frame "defaults to
global 'world' frame" and "must be known to the simulator") needs one global frame. In the cell that is
the root of the ``/tf_static`` tree every device places its base frame in (``cell_frame``, ``cell`` by
default): ``world``, the empty frame id and the root's own name all mean it. A device's named frame
(``cell/mems_array``, ``cell/arm_pivot``) is accepted as well; a pose in it is used as the device reads it.

Only static transforms are composed (``/tf_static``): a frame on ``/tf`` (the fixture's tilting
``cell/assembly``) is not a frame a pose can be given in, and states in it are answered in it, named.
ROS-free: poses are (position, quaternion x y z w) tuples.
"""

from __future__ import annotations

import math
from typing import Mapping

from feeder_cell.simulation.entities import EntityState
from feeder_cell.simulation.results import OPERATION_FAILED, SimulationError

__all__ = ["WORLD", "Pose", "Frames", "compose", "inverse", "rotate"]

WORLD = "world"
Pose = tuple[tuple[float, float, float], tuple[float, float, float, float]]
Vector = tuple[float, float, float]
Quaternion = tuple[float, float, float, float]
IDENTITY: Pose = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
MAX_DEPTH = 64  # frames between a frame and the root: a cycle in /tf_static is refused, not followed


def _multiply(a: Quaternion, b: Quaternion) -> Quaternion:
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


def rotate(q: Quaternion, v: Vector) -> Vector:
    """Return the vector ``v`` rotated by the unit quaternion ``q`` (q v q*)."""
    x, y, z, _ = _multiply(_multiply(q, (v[0], v[1], v[2], 0.0)), (-q[0], -q[1], -q[2], q[3]))
    return (x, y, z)


def compose(a: Pose, b: Pose) -> Pose:
    """Return a * b: the pose ``b`` (given in frame B) in the frame A that ``a`` places B in."""
    (ta, qa), (tb, qb) = a, b
    moved = rotate(qa, tb)
    return (
        (ta[0] + moved[0], ta[1] + moved[1], ta[2] + moved[2]),
        _multiply(qa, qb),
    )


def inverse(a: Pose) -> Pose:
    """Return the inverse transform of ``a``."""
    t, q = a
    conjugate = (-q[0], -q[1], -q[2], q[3])
    back = rotate(conjugate, t)
    return ((-back[0], -back[1], -back[2]), conjugate)


class Frames:
    """The static frame tree as last seen on ``/tf_static``: child frame -> its pose in its parent."""

    def __init__(self, static: Mapping[str, EntityState]) -> None:
        self.static = static

    def root(self) -> str:
        """Return the root of the tree (the cell frame): the parent no transform places."""
        roots = {s.frame_id for s in self.static.values()} - set(self.static)
        return sorted(roots)[0] if len(roots) == 1 else "cell"

    def is_world(self, frame_id: str) -> bool:
        """Whether ``frame_id`` names the world: empty, ``world`` or the root's own name."""
        return frame_id in ("", WORLD) or frame_id == self.root()

    def in_world(self, frame_id: str) -> Pose:
        """Return the pose of ``frame_id`` in the world (composed along ``/tf_static``)."""
        if self.is_world(frame_id):
            return IDENTITY
        pose, frame = IDENTITY, frame_id
        for _ in range(MAX_DEPTH):
            link = self.static.get(frame)
            if link is None:
                raise SimulationError(
                    OPERATION_FAILED, f"frame {frame!r}: no /tf_static transform of it seen yet"
                )
            pose = compose((link.position, link.orientation), pose)
            frame = link.frame_id
            if self.is_world(frame):
                return pose
        raise SimulationError(OPERATION_FAILED, f"frame {frame_id!r}: /tf_static has a cycle above it")

    def to_world(self, frame_id: str, pose: Pose) -> Pose:
        """Return ``pose``, given in ``frame_id``, in the world."""
        return compose(self.in_world(frame_id), pose)

    def from_world(self, frame_id: str, pose: Pose) -> Pose:
        """Return ``pose``, given in the world, in ``frame_id``."""
        return compose(inverse(self.in_world(frame_id)), pose)

    def state_in_world(self, state: EntityState) -> EntityState:
        """Return ``state`` in the world frame: pose composed, twist rotated (static frames add none)."""
        if self.is_world(state.frame_id):
            return EntityState(WORLD, state.stamp_ns, state.position, state.orientation,
                               state.linear, state.angular, dict(state.extra))  # fmt: skip
        frame = self.in_world(state.frame_id)
        position, orientation = compose(frame, (state.position, state.orientation))
        return EntityState(
            WORLD,
            state.stamp_ns,
            position,
            _normalized(orientation),
            rotate(frame[1], state.linear),
            rotate(frame[1], state.angular),
            dict(state.extra),
        )


def _normalized(q: Quaternion) -> Quaternion:
    norm = math.sqrt(sum(c * c for c in q)) or 1.0
    return (q[0] / norm, q[1] / norm, q[2] / norm, q[3] / norm)
