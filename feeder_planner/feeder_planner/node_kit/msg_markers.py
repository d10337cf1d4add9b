"""visualization_msgs markers from the ROS-free shapes of ``feeder_planner.drawing``; colours defined once.

Every node draws through here, so a part, a ghost or a sensor looks the same in every device and planner.
Markers of one namespace are numbered in the order of their shapes; a ``MarkerBook`` remembers what it
sent per namespace and deletes the markers a later update no longer has (a lost part disappears), without
a DELETEALL, which would also wipe the latched geometry of the other namespaces.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
from builtin_interfaces.msg import Duration, Time
from geometry_msgs.msg import Point
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from feeder_planner.drawing import Shape

__all__ = ["STYLES", "KINDS", "colour", "marker", "marker_array", "MarkerBook"]

# RGBA per style: what a shape means decides its colour, in every node alike.
STYLES: dict[str, tuple[float, float, float, float]] = {
    "device": (0.55, 0.57, 0.60, 0.6),  # the array surface, the arm, the table
    "outline": (0.10, 0.10, 0.10, 1.0),  # edges of parts and devices
    "part": (0.15, 0.45, 0.85, 0.9),  # a part where the simulator has it
    "ghost": (0.95, 0.60, 0.10, 0.35),  # a planner's prediction (equilibrium pose)
    "force": (0.20, 0.65, 0.30, 0.9),  # cell force vectors
    "sensor_on": (0.10, 0.85, 0.20, 1.0),  # the one-bit sensor reading true
    "sensor_off": (0.85, 0.15, 0.15, 1.0),  # ... reading false
    "body": (0.30, 0.55, 0.80, 0.9),  # an assembly body in equilibrium
    "unbalanced": (0.90, 0.10, 0.10, 0.95),  # a body that loses equilibrium
    "grounded": (0.45, 0.45, 0.45, 0.9),  # a body held by the fixture
    "gravity": (0.80, 0.20, 0.80, 1.0),  # the gravity arrow
    "region": (0.10, 0.70, 0.40, 0.9),  # the stable region's boundary on the sphere
    "sphere": (0.70, 0.70, 0.75, 0.15),  # the unit sphere of gravity directions
    "center": (0.05, 0.40, 0.20, 1.0),  # the region's centre
    "path": (0.95, 0.75, 0.05, 1.0),  # the current safe path
    "text": (1.0, 1.0, 1.0, 1.0),
}

KINDS = {
    "triangles": Marker.TRIANGLE_LIST,
    "line_strip": Marker.LINE_STRIP,
    "line_list": Marker.LINE_LIST,
    "arrow": Marker.ARROW,
    "sphere": Marker.SPHERE,
    "points": Marker.POINTS,
    "text": Marker.TEXT_VIEW_FACING,
}

# Lifetime 0: a marker stays until replaced or deleted (a paused device's parts stay drawn where they are).
FOREVER = Duration(sec=0, nanosec=0)


def colour(style: str) -> ColorRGBA:
    """Return the colour of a style of ``STYLES``; an unknown style is a programming error (KeyError)."""
    r, g, b, a = STYLES[style]
    return ColorRGBA(r=r, g=g, b=b, a=a)


def _points(points: np.ndarray) -> list[Point]:
    return [Point(x=float(p[0]), y=float(p[1]), z=float(p[2])) for p in np.asarray(points, float)]


def marker(shape: Shape, frame_id: str, stamp: Time, marker_id: int) -> Marker:
    """Return the ADD marker of ``shape`` in ``frame_id`` (identity pose: the points are in the frame)."""
    m = Marker()
    m.header.frame_id, m.header.stamp = frame_id, stamp
    m.ns, m.id, m.type, m.action = shape.namespace, marker_id, KINDS[shape.kind], Marker.ADD
    m.pose.orientation.w = 1.0
    m.color = colour(shape.style)
    m.lifetime = FOREVER
    m.frame_locked = True  # a marker in a moving frame (the tilting table) moves with it
    size = float(shape.size)
    if shape.kind == "triangles":
        m.scale.x = m.scale.y = m.scale.z = 1.0
    elif shape.kind in ("line_strip", "line_list"):
        m.scale.x = size
    elif shape.kind == "arrow":
        m.scale.x, m.scale.y, m.scale.z = size, 2.0 * size, 3.0 * size  # shaft, head diameter and length
    elif shape.kind == "sphere":
        m.pose.position.x, m.pose.position.y, m.pose.position.z = (float(v) for v in shape.points[0])
        m.scale.x = m.scale.y = m.scale.z = size
        return m
    elif shape.kind == "points":
        m.scale.x = m.scale.y = size
    elif shape.kind == "text":
        m.pose.position.x, m.pose.position.y, m.pose.position.z = (float(v) for v in shape.points[0])
        m.scale.z, m.text = size, shape.text
        return m
    m.points = _points(shape.points)
    return m


def marker_array(shapes: Sequence[Shape], frame_id: str, stamp: Time) -> MarkerArray:
    """Return the markers of ``shapes``, numbered 0, 1, ... within each namespace in their order."""
    counts: dict[str, int] = {}
    markers = []
    for shape in shapes:
        index = counts.get(shape.namespace, 0)
        counts[shape.namespace] = index + 1
        markers.append(marker(shape, frame_id, stamp, index))
    return MarkerArray(markers=markers)


class MarkerBook:
    """Numbers the markers of successive updates and deletes those an update no longer has."""

    def __init__(self) -> None:
        self.sent: dict[str, int] = {}  # namespace -> markers the last update had
        self.frame_id = ""

    def update(self, shapes: Sequence[Shape], frame_id: str, stamp: Time) -> MarkerArray:
        """Return the markers of ``shapes`` plus a DELETE for every marker of the last update now gone."""
        array = marker_array(shapes, frame_id, stamp)
        counts: dict[str, int] = {}
        for m in array.markers:
            counts[m.ns] = counts.get(m.ns, 0) + 1
        array.markers.extend(self._deletions(counts, stamp))
        self.sent, self.frame_id = counts, frame_id
        return array

    def clear(self, stamp: Time) -> MarkerArray:
        """Return the DELETE of every marker sent (the device was cleaned up: nothing left to draw)."""
        array = MarkerArray(markers=self._deletions({}, stamp))
        self.sent = {}
        return array

    def _deletions(self, counts: dict[str, int], stamp: Time) -> list[Marker]:
        deletions = []
        for namespace, sent in self.sent.items():
            for index in range(counts.get(namespace, 0), sent):
                m = Marker(ns=namespace, id=index, action=Marker.DELETE)
                m.header.frame_id, m.header.stamp = self.frame_id, stamp
                deletions.append(m)
        return deletions
