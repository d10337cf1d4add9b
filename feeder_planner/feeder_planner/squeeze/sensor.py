"""The jaw-width sensor: the width between the jaws after a squeeze (Goldberg 1993, section 6).

After a squeeze the part rests at a minimum of the diameter function, and the jaws read its width
d(f_j). Stable orientations whose widths differ by more than the sensor's resolution are told apart by
one reading, which a plan alone (orienting only up to the squeeze function's symmetry) cannot do: a 2 x 1
rectangle reads 1 or 2 after one squeeze, so one squeeze and one reading identify its orientation mod pi.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from feeder_planner.fields_io import positive_number
from feeder_planner.squeeze.diameter import wrap
from feeder_planner.squeeze.squeeze_function import SqueezeFunction

__all__ = ["JawReading", "distinguishable_groups", "orientations_for_width", "read_width"]


@dataclass(frozen=True)
class JawReading:
    """One reading: the width (m) and the stable orientations (rad, mod pi) it is consistent with."""

    width: float
    orientations: tuple[float, ...]


def orientations_for_width(squeeze: SqueezeFunction, width: float, resolution: float) -> tuple[float, ...]:
    """Return the stable orientations (rad in [0, pi)) whose width is within ``resolution`` of ``width``."""
    resolution = positive_number(resolution, "resolution")
    width = positive_number(width, "width")
    return tuple(wrap(f, math.pi) for f in squeeze.minima if abs(squeeze.diameter(f) - width) <= resolution)


def read_width(squeeze: SqueezeFunction, theta: float, resolution: float) -> JawReading:
    """Squeeze from ``theta`` (relative to the gripper) and read the jaws: the ideal sensor."""
    width = squeeze.width_after(theta)
    return JawReading(width, orientations_for_width(squeeze, width, resolution))


def distinguishable_groups(squeeze: SqueezeFunction, resolution: float) -> list[tuple[float, ...]]:
    """Return the stable orientations grouped by what one reading tells apart (widths within resolution)."""
    resolution = positive_number(resolution, "resolution")
    ranked = sorted((squeeze.diameter(f), wrap(f, math.pi)) for f in squeeze.minima)
    groups: list[list[float]] = []
    last = -math.inf
    for width, angle in ranked:
        if width - last > resolution:
            groups.append([])
        groups[-1].append(angle)
        last = width
    return [tuple(sorted(g)) for g in groups]
