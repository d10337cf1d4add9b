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

from feeder_planner.drawing import Shape, lift, part_shapes, rotation_z, triangulate_loops
from feeder_planner.parts import Part
from feeder_sim.throwing.arm import ThrowingArm

__all__ = ["display_length", "arm_shapes", "sensor_shapes", "part_on_arm_shapes", "ArmDrawing"]

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


class ArmDrawing:
    """The arm's whole drawing at a pose shown; the part is triangulated once per part, not per update."""

    def __init__(self) -> None:
        self._triangles: tuple[object, np.ndarray | None] = (None, None)

    def shapes(
        self,
        arm: ThrowingArm,
        shown: tuple[Sequence[float], float] | None,
        sensor: tuple[float, float, bool | None],
    ) -> list[Shape]:
        """Return the arm at its joint angle, the sensor (radius, sensing height, bit), the part if on it."""
        pose, joint = shown if shown is not None else (arm.rest_pose(), 0.0)
        sensor_radius, sensing_height, bit = sensor
        length = display_length(arm.arm_length, arm.radius, arm.part.radius, sensor_radius)
        width = 0.01 * length
        offset = arm.params.offset
        shapes = arm_shapes(length, offset, joint, width)
        shapes += sensor_shapes(sensor_radius, offset, sensing_height, bit, width)
        if arm.on_arm:
            if self._triangles[0] is not arm.part:
                self._triangles = (arm.part, triangulate_loops(arm.part.part.loops()))
            shapes += part_on_arm_shapes(arm.part.part, pose, self._triangles[1])
        return shapes
