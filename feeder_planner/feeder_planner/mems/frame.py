"""A rigid part in its own frame: what the fields need of it, computed once, and where a pose puts it.

A moving part changes only its pose (x, y, theta); its edges and area moments in its own frame do not.
``PartFrame`` holds them, so that a field's wrench at a pose (``Field.wrench_at``) is evaluated in the
part frame, with the field carried into it, instead of rebuilding the placed part's edges at every pose.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from feeder_planner.mems import lifted
from feeder_planner.mems.regions import area_moments
from feeder_planner.parts import Part

__all__ = ["PartFrame", "Placement"]


class Placement(NamedTuple):
    """A pose (x, y, theta) as the rotation and translation it applies: r = R(theta) q + (x, y).

    A named tuple, not a frozen dataclass: one is made at every velocity evaluation of the ideal model,
    and a tuple is made in a third of the time.
    """

    x: float
    y: float
    cos: float
    sin: float

    @staticmethod
    def of(pose: np.ndarray) -> Placement:
        """Return the placement of ``pose`` (x, y, theta)."""
        x, y, theta = pose.tolist()
        return Placement(x, y, math.cos(theta), math.sin(theta))

    def to_part(self, point: tuple[float, float]) -> tuple[float, float]:
        """Return the part-frame coordinates q = R^T (r - (x, y)) of the plane point ``point``."""
        dx, dy = point[0] - self.x, point[1] - self.y
        return (self.cos * dx + self.sin * dy, self.cos * dy - self.sin * dx)

    def rotate(self, vector: tuple[float, float]) -> tuple[float, float]:
        """Return R vector: a part-frame vector (a force) in the plane frame."""
        return (self.cos * vector[0] - self.sin * vector[1], self.sin * vector[0] + self.cos * vector[1])


@dataclass(frozen=True)
class PartFrame:
    """A part with its edges and area in its own frame (centroid at the origin).

    ``area`` is that of the loops (Green's theorem, as for placed loops); the first moments about the
    frame's origin vanish, so a constant field's force acts there, with no torque about the centroid.
    """

    part: Part
    edges: lifted.Edges
    area: float
    radius: float  # Part.radius, which computes it at every call

    @classmethod
    def of(cls, part: Part) -> PartFrame:
        """Return the frame of ``part``: its edges (eqs. 5-9 need them) and area, once."""
        return cls(part, lifted.part_edges(part), float(area_moments(part.loops())[0]), part.radius)

    def placed(self, pose: np.ndarray) -> tuple[np.ndarray, ...]:
        """Return the loops placed at ``pose`` in the plane frame (for fields without a part-frame form).

        The part's own placement, so that such a field's wrench is the one on ``Part.placed`` to the bit.
        """
        return self.part.placed(float(pose[0]), float(pose[1]), float(pose[2]))
