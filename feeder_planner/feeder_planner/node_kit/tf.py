"""/tf and /tf_static: the devices placed in one cell frame, as standard ``tf2_msgs/msg/TFMessage``.

The registry's wheels do not ship tf2_msgs, so the workspace builds the standard package from its own
definitions (``standard_interfaces/tf2_msgs``; a test checks every type's RIHS01 hash against the
standard's): RViz, ``tf2_echo``, Foxglove's 3D panel and bags see standard tf, and on a full install the
overlay is identical to the system package.
"""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Quaternion, TransformStamped
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from tf2_msgs.msg import TFMessage

from feeder_planner.node_kit.parameters import ParameterSpec, non_empty_string

__all__ = [
    "TFMessage",
    "TF_TYPE",
    "TF_STATIC_QOS",
    "TF_QOS",
    "CELL_FRAME",
    "TF_PARAMETERS",
    "ZERO_POSE",
    "tf_parameters",
    "namespaced_frame",
    "cell_transform",
    "check_cell_pose",
    "quaternion_from_rpy",
    "quaternion_from_matrix",
    "transform",
    "StaticFrames",
    "FramePublisher",
]

TF_TYPE = "tf2_msgs/msg/TFMessage"

# tf2_ros's own profiles: a static broadcaster latches its one message of every transform it holds; the
# dynamic topic is a deep volatile stream.
TF_STATIC_QOS = QoSProfile(
    depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
)
TF_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)

CELL_FRAME = "cell"


def check_cell_pose(value: object) -> str | None:
    """Check a cell_pose parameter: six finite numbers [x, y, z, roll, pitch, yaw] (m, rad)."""
    values = list(value) if isinstance(value, (list, tuple)) else None
    ok = (
        values is not None
        and len(values) == 6
        and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in values)
    )
    return None if ok else f"must be six finite numbers [x, y, z, roll, pitch, yaw] (m, rad), got {value!r}"


ZERO_POSE = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


def tf_parameters(cell_pose: Sequence[float] = ZERO_POSE) -> tuple[ParameterSpec, ...]:
    """Return the parameters placing a node's base frame in the cell, ``cell_pose`` its default."""
    return (
        ParameterSpec(
            "cell_pose",
            [float(v) for v in cell_pose],
            "pose of this node's base frame in the cell frame, [x, y, z, roll, pitch, yaw] (m, rad), "
            "published on /tf_static",
            check_cell_pose,
            read_only=True,
        ),
        ParameterSpec(
            "cell_frame",
            CELL_FRAME,
            "the cell frame every device is placed in (the root of the frame tree)",
            non_empty_string("the cell frame"),
            read_only=True,
        ),
    )


TF_PARAMETERS = tf_parameters()


def quaternion_from_rpy(roll: float, pitch: float, yaw: float) -> tuple[float, float, float, float]:
    """Return (x, y, z, w) of the rotation Rz(yaw) Ry(pitch) Rx(roll) (the ROS fixed-axis convention)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
        cr * cp * cy + sr * sp * sy,
    )


def quaternion_from_matrix(rotation: np.ndarray) -> tuple[float, float, float, float]:
    """Return (x, y, z, w), w >= 0, of a 3 x 3 rotation matrix (Shepperd's method: stable for any angle)."""
    m = np.asarray(rotation, float)
    trace = float(np.trace(m))
    if trace > 0:
        s = 2.0 * math.sqrt(1.0 + trace)
        q = ((m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, 0.25 * s)
    else:
        i = int(np.argmax(np.diag(m)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * math.sqrt(max(1.0 + m[i, i] - m[j, j] - m[k, k], 0.0))
        v = [0.0, 0.0, 0.0]
        v[i] = 0.25 * s
        v[j] = (m[j, i] + m[i, j]) / s
        v[k] = (m[k, i] + m[i, k]) / s
        q = (v[0], v[1], v[2], (m[k, j] - m[j, k]) / s)
    if q[3] < 0:
        q = (-q[0], -q[1], -q[2], -q[3])
    return (float(q[0]), float(q[1]), float(q[2]), float(q[3]))


def transform(
    parent: str,
    child: str,
    translation: Sequence[float],
    rotation: Sequence[float],
    stamp: Time,
) -> TransformStamped:
    """Return the TransformStamped placing ``child`` in ``parent``; ``rotation`` is (x, y, z, w)."""
    t = TransformStamped()
    t.header.frame_id, t.header.stamp, t.child_frame_id = parent, stamp, child
    t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = (
        float(v) for v in translation
    )
    x, y, z, w = (float(v) for v in rotation)
    t.transform.rotation = Quaternion(x=x, y=y, z=z, w=w)
    return t


def namespaced_frame(node: Node, base: str) -> str:
    """Return a per-instance frame id: ``base`` under the node's namespace (``cell/feeder_a/base``).

    Devices name their frames so (``ManagedDevice.frame``), and a planner's markers use the same rule for
    the frame of the device it plans for.
    """
    namespace = node.get_namespace().strip("/")
    return f"{namespace}/{base}" if namespace else base


def cell_transform(cell_frame: str, child: str, pose: Sequence[float], stamp: Time) -> TransformStamped:
    """Return the static transform placing ``child`` at ``pose`` [x, y, z, roll, pitch, yaw] in the cell."""
    return transform(cell_frame, child, pose[:3], quaternion_from_rpy(*pose[3:6]), stamp)


class StaticFrames:
    """A node's latched /tf_static message: every static transform it holds, republished when one changes."""

    def __init__(self, node: Node) -> None:
        self.node = node
        self.publisher = node.create_publisher(TFMessage, "/tf_static", TF_STATIC_QOS)
        self.transforms: dict[str, TransformStamped] = {}

    def set(self, transforms: Sequence[TransformStamped]) -> None:
        """Hold exactly ``transforms`` (keyed by child frame) and publish them if anything changed."""
        new = {t.child_frame_id: t for t in transforms}
        if self._key(new) != self._key(self.transforms):
            self.transforms = new
            self.publisher.publish(TFMessage(transforms=list(new.values())))

    @staticmethod
    def _key(transforms: dict[str, TransformStamped]) -> list[tuple[Any, ...]]:
        return sorted(
            (
                child,
                t.header.frame_id,
                t.transform.translation.x,
                t.transform.translation.y,
                t.transform.translation.z,
                t.transform.rotation.x,
                t.transform.rotation.y,
                t.transform.rotation.z,
                t.transform.rotation.w,
            )
            for child, t in transforms.items()
        )


class FramePublisher:
    """A node's moving frames on /tf (the fixture's tilting table)."""

    def __init__(self, node: Node) -> None:
        self.publisher = node.create_publisher(TFMessage, "/tf", TF_QOS)

    def publish(self, transforms: Sequence[TransformStamped]) -> None:
        """Publish ``transforms`` (nothing when there are none)."""
        if transforms:
            self.publisher.publish(TFMessage(transforms=list(transforms)))
