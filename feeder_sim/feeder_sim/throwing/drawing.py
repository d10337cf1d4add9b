"""What a viewer draws of the throwing arm: the arm at its joint angle, the part on it, the sensor's bit.

ROS-free shapes in the arm frame (pivot at the origin, gravity along -y, the arm surface at y = h): the
part is drawn where ``Part.placed`` puts it for the pose the device shows (at rest, or along a flight
path), the sensor as the vertical slab it senses (x = sensor_radius, from the surface up by the sensing
height), green when its bit reads true, red when false.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from feeder_planner.drawing import Shape, lift, part_shapes, rotation_z
from feeder_planner.parts import Part

__all__ = ["display_length", "arm_shapes", "sensor_shapes", "part_on_arm_shapes"]

# An arm of unbounded length is drawn this much longer than what lies on it (the part, the sensor).
DISPLAY_MARGIN = 1.25


def display_length(arm_length: float, radius: float, part_radius: float, sensor_radius: float) -> float:
    """Return the length to draw: ``arm_length`` if finite, else beyond the part and the sensor."""
    if math.isfinite(arm_length):
        return float(arm_length)
    return DISPLAY_MARGIN * max(abs(radius) + part_radius, abs(sensor_radius), part_radius)


def arm_shapes(length: float, offset: float, joint_angle: float, width: float) -> list[Shape]:
    """Return the arm's surface segment (y = offset, x in [0, length]) rotated by the joint, and the pivot."""
    ends = np.array([[0.0, offset], [length, offset]]) @ rotation_z(joint_angle).T
    return [
        Shape("line_strip", lift(ends), "arm", "device", width),
        Shape("sphere", lift(np.zeros((1, 2))), "pivot", "outline", 2.0 * width),
    ]


def sensor_shapes(
    sensor_radius: float, offset: float, height: float, bit: bool | None, width: float
) -> list[Shape]:
    """Return the sensed slab as a segment and a dot at its foot, coloured by the bit (None: no reading)."""
    style = "sensor_on" if bit else "sensor_off"
    slab = lift(np.array([[sensor_radius, offset], [sensor_radius, offset + height]]))
    return [
        Shape("line_strip", slab, "sensor", style, width),
        Shape("sphere", slab[:1], "sensor_dot", style, 3.0 * width),
    ]


def part_on_arm_shapes(part: Part, pose: Sequence[float], triangles: np.ndarray | None = None) -> list[Shape]:
    """Return the part at pose (x, y, theta) in the arm frame (centre of mass at (x, y))."""
    return part_shapes(part, pose, "part", "part", triangles=triangles)
