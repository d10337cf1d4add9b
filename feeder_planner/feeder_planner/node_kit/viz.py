"""A device's ``~/markers`` and its frames: what a simulator node adds to be seen in RViz or Foxglove.

``DeviceViz`` asks its node for a ``Drawing`` (ROS-free shapes in the device frame, the device's base
frame and any moving frame) and publishes it on ``~/markers`` (visualization_msgs/MarkerArray) by two
latched publishers on the one topic: the static geometry (the array outline, the table, the assembly's
bodies), sent when it changes, and the updates (parts, arm, sensor bit, gravity...) at ``marker_rate`` Hz
of the steady clock, so a viewer sees a paused or a ten-times-fast cell at a steady frame rate and a late
subscriber (a bag recorder, the bridge) gets both at once. The base frame is placed in the cell frame by
``cell_pose`` on /tf_static; moving frames go on /tf with each update.

``ResultMarkers`` is the planners' side: a latched ``~/markers`` of their latest result (ghosts, the
stable region), published when a result is computed.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

from rcl_interfaces.msg import SetParametersResult
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.parameter import Parameter
from visualization_msgs.msg import MarkerArray

from feeder_planner.drawing import Shape
from feeder_planner.errors import InputError
from feeder_planner.node_kit.msg_markers import MarkerBook
from feeder_planner.node_kit.parameters import ParameterSpec, check_value, in_range
from feeder_planner.node_kit.qos import LATCHED
from feeder_planner.node_kit.tf import (
    ZERO_POSE,
    FramePublisher,
    StaticFrames,
    cell_transform,
    check_cell_pose,
    tf_parameters,
    transform,
)

__all__ = [
    "MAX_MARKER_RATE",
    "VIZ_PARAMETERS",
    "viz_parameters",
    "MovingFrame",
    "Drawing",
    "DeviceViz",
    "ResultMarkers",
]

# Markers are for eyes: above 30 Hz a viewer sees nothing more and the device pays for every message.
MAX_MARKER_RATE = 30.0
# With marker_rate 0 the frames are still kept on /tf_static, looked at this often (Hz, steady clock).
IDLE_RATE = 1.0

MARKER_RATE = ParameterSpec(
    "marker_rate",
    5.0,
    f"rate (Hz, steady clock) of the ~/markers updates and moving /tf frames, in [0, {MAX_MARKER_RATE:g}]; "
    "0: no markers (the /tf_static placement stays); runtime",
    in_range(0.0, MAX_MARKER_RATE, unit="Hz"),
)


def viz_parameters(cell_pose: Sequence[float] = ZERO_POSE) -> tuple[ParameterSpec, ...]:
    """Return marker_rate, cell_pose (its default ``cell_pose``) and cell_frame."""
    return (MARKER_RATE, *tf_parameters(cell_pose))


VIZ_PARAMETERS = viz_parameters()


@dataclass(frozen=True)
class MovingFrame:
    """A frame that moves with the device: ``child`` in ``parent``, rotation (x, y, z, w)."""

    parent: str
    child: str
    translation: tuple[float, float, float]
    rotation: tuple[float, float, float, float]


@dataclass
class Drawing:
    """What a device shows now: shapes in ``frame_id``, the base frame the cell places, moving frames."""

    frame_id: str
    base_frame: str
    static: list[Shape] = field(default_factory=list)
    dynamic: list[Shape] = field(default_factory=list)
    moving: list[MovingFrame] = field(default_factory=list)


def _shapes_key(shapes: Sequence[Shape], frame_id: str) -> tuple[object, ...]:
    return (frame_id, *((s.kind, s.namespace, s.style, s.size, s.text, s.points.tobytes()) for s in shapes))


class DeviceViz:
    """Publishes a node's ``Drawing`` on ``~/markers``, /tf_static and /tf.

    ``draw`` returns None when there is nothing to draw (unconfigured), which deletes what was drawn.
    """

    def __init__(self, node: Node, draw: Callable[[], Drawing | None]) -> None:
        self.node, self.draw = node, draw
        self.static_pub = node.create_publisher(MarkerArray, "~/markers", LATCHED)
        self.update_pub = node.create_publisher(MarkerArray, "~/markers", LATCHED)
        self.static_book, self.update_book = MarkerBook(), MarkerBook()
        self.static_key: tuple[object, ...] | None = None
        self.frames = StaticFrames(node)
        self.moving: FramePublisher | None = None  # made for the first moving frame: no idle /tf writer
        self.steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.rate = self._valid_rate(node.get_parameter("marker_rate").value)
        self.timer: Any = None
        self._schedule()
        node.add_on_set_parameters_callback(self._check_parameters)
        node.add_post_set_parameters_callback(self._apply_parameters)

    @staticmethod
    def _valid_rate(value: object) -> float:
        # A bad start value fails the device's configure (the kit checks every spec); until then, off.
        # (The check passes finite numbers only: the isinstance says so to mypy.)
        valid = MARKER_RATE.check and MARKER_RATE.check(value) is None
        return float(value) if valid and isinstance(value, (int, float)) else 0.0

    def _schedule(self) -> None:
        if self.timer is not None:
            self.node.destroy_timer(self.timer)
        period = 1.0 / self.rate if self.rate > 0 else 1.0 / IDLE_RATE
        self.timer = self.node.create_timer(period, self.update, clock=self.steady)

    def _check_parameters(self, changes: list[Parameter]) -> SetParametersResult:
        for change in changes:
            if change.name == MARKER_RATE.name:
                try:
                    check_value(MARKER_RATE, change.value)
                except InputError as error:
                    return SetParametersResult(successful=False, reason=str(error))
        return SetParametersResult(successful=True)

    def _apply_parameters(self, changes: list[Parameter]) -> None:
        for change in changes:
            if change.name == MARKER_RATE.name:
                self.rate = float(change.value)
                if self.rate == 0:
                    self._clear()
                self._schedule()

    def _clear(self) -> None:
        stamp = self.node.get_clock().now().to_msg()
        if self.static_book.sent:
            self.static_pub.publish(self.static_book.clear(stamp))
        if self.update_book.sent:
            self.update_pub.publish(self.update_book.clear(stamp))
        self.static_key = None

    def update(self) -> None:
        """Publish the placement, then (marker_rate > 0) the static geometry if changed and an update.

        Drawn whether or not anybody subscribes: the update is latched, and a viewer that subscribes later
        must get the present drawing first, not one from before it came (skipping unwatched drawings, tried
        for the cell host's speed, handed a late bridge client a sensor drawn off).
        """
        drawing = self.draw()
        if drawing is None:
            self._clear()
            return
        stamp = self.node.get_clock().now().to_msg()
        pose = self.node.get_parameter("cell_pose").value
        cell = self.node.get_parameter("cell_frame").value
        if check_cell_pose(pose) is None and isinstance(cell, str) and cell:
            # Stamp 0 ("always valid") would be the tf2 idiom for a static transform, but Foxglove and
            # RViz both accept a real stamp; the first stamp is kept so that the message stays unchanged.
            self.frames.set([cell_transform(cell, drawing.base_frame, list(pose), stamp)])
        if self.rate <= 0:
            return
        key = _shapes_key(drawing.static, drawing.frame_id)
        if key != self.static_key:
            self.static_key = key
            self.static_pub.publish(self.static_book.update(drawing.static, drawing.frame_id, stamp))
        self.update_pub.publish(self.update_book.update(drawing.dynamic, drawing.frame_id, stamp))
        if drawing.moving:
            if self.moving is None:
                self.moving = FramePublisher(self.node)
            self.moving.publish(
                [transform(f.parent, f.child, f.translation, f.rotation, stamp) for f in drawing.moving]
            )


class ResultMarkers:
    """A planner's latched ``~/markers``: the shapes of its latest result, replacing the previous ones."""

    def __init__(self, node: Node) -> None:
        self.node = node
        self.publisher = node.create_publisher(MarkerArray, "~/markers", LATCHED)
        self.book = MarkerBook()
        self.lock = threading.Lock()  # a planner may answer its services on several threads

    def publish(self, shapes: Sequence[Shape], frame_id: str) -> None:
        """Publish ``shapes`` in ``frame_id`` (the markers of the last result no longer drawn are deleted)."""
        with self.lock:
            self.publisher.publish(self.book.update(shapes, frame_id, self.node.get_clock().now().to_msg()))
