"""What a viewer draws of a limit set: where the part comes to rest on the arm, and the trigger range.

ROS-free shapes in the arm frame (pivot at the origin, gravity along -y, the arm surface at y = h): per
edge of the limit set, the segment of the arm surface its resting R covers (Lynch, Northrop and Pan's
forward limit set), set off from the arm plane by ``EDGE_SPACING`` per edge so they stay apart; the
sensor trigger range for the goal edge on the surface itself.
"""

from __future__ import annotations

import numpy as np

from feeder_planner.drawing import Shape
from feeder_planner.throwing.limit_set import LimitSet

__all__ = ["EDGE_SPACING", "limit_set_shapes"]

# Out-of-plane spacing between the edges' segments, as a fraction of the longest R drawn.
EDGE_SPACING = 0.02


def limit_set_shapes(ls: LimitSet, offset: float) -> list[Shape]:
    """Return each limit-set edge's R range and the trigger range as segments of the arm surface y = h."""
    ranges = ls.edge_radius_ranges
    reach = max([abs(v) for r in ranges.values() for v in r] + [abs(v) for v in ls.trigger or ()] + [1e-3])
    width = 0.01 * reach
    shapes = []
    for k, (edge, (low, high)) in enumerate(sorted(ranges.items())):
        z = EDGE_SPACING * reach * (k + 1)
        points = np.array([[low, offset, z], [high, offset, z]])
        shapes.append(Shape("line_strip", points, "limit_set", "ghost", width))
        shapes.append(
            Shape(
                "text",
                points[1:] + [0.0, 2 * width, 0.0],
                "limit_set_edges",
                "text",
                3 * width,
                f"edge {edge}",
            )
        )
    if ls.trigger is not None:
        low, high = ls.trigger
        points = np.array([[low, offset, 0.0], [high, offset, 0.0]])
        shapes.append(Shape("line_strip", points, "trigger_range", "sensor_on", 2 * width))
    return shapes
