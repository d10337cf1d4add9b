"""What a viewer draws of a device or a planner's result: ROS-free shapes in the device's own frame.

A ``Shape`` is a list of 3-D points (metres, the device's frame), a kind that says how the points are
joined, a namespace (what the shape shows, e.g. ``parts``) and a style (a named colour, defined once in
``node_kit.msg_markers``). The node kit turns shapes into visualization_msgs markers; the mechanics'
modules (``feeder_sim.*.drawing``, ``feeder_planner.*.drawing``) build them from their own models, so
what is drawn is the model's geometry, not a second copy of it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, Sequence

import numpy as np
import shapely  # type: ignore[import-untyped]

from feeder_planner.parts import Part

__all__ = [
    "ShapeKind",
    "Shape",
    "lift",
    "loop_strip",
    "triangulate_loops",
    "part_shapes",
    "rotation_z",
]

ShapeKind = Literal["triangles", "line_strip", "line_list", "arrow", "sphere", "points", "text"]


@dataclass(frozen=True)
class Shape:
    """Points in the device frame joined as ``kind``; ``size`` is the line width or diameter (m).

    ``triangles``: every three points a triangle; ``line_strip``: a polyline (closed when its last point
    repeats its first); ``line_list``: every two points a segment; ``arrow``: from points[0] to points[1];
    ``sphere``: centred at points[0], diameter ``size``; ``points``: one dot per point; ``text``: ``text``
    at points[0].
    """

    kind: ShapeKind
    points: np.ndarray  # (n, 3)
    namespace: str
    style: str
    size: float = 0.0
    text: str = ""


def lift(points: np.ndarray, z: float = 0.0) -> np.ndarray:
    """Return (n, 2) planar points as (n, 3) points at height ``z``."""
    points = np.asarray(points, float).reshape(-1, 2)
    return np.column_stack([points, np.full(len(points), float(z))])


def loop_strip(loop: np.ndarray, z: float = 0.0) -> np.ndarray:
    """Return a closed polyline of a planar loop: its vertices in order, then the first again."""
    loop = np.asarray(loop, float)
    return lift(np.vstack([loop, loop[:1]]), z)


def rotation_z(theta: float) -> np.ndarray:
    """Return the 2 x 2 rotation by ``theta`` (rad), counter-clockwise."""
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s], [s, c]])


def triangulate_loops(loops: Sequence[np.ndarray]) -> np.ndarray:
    """Return (m, 3, 2) triangles covering the polygon of ``loops`` (outer first, then holes) exactly.

    A constrained Delaunay triangulation keeps every boundary edge, so no triangle crosses a hole; the
    triangles' areas sum to the polygon's area.
    """
    outer, *holes = (np.asarray(loop, float) for loop in loops)
    polygon = shapely.Polygon(outer, [hole for hole in holes])
    collection = shapely.constrained_delaunay_triangles(polygon)
    triangles = [np.asarray(t.exterior.coords)[:3] for t in shapely.get_parts(collection)]
    if not triangles:
        return np.zeros((0, 3, 2))
    return np.array(triangles, float)


def part_shapes(
    part: Part,
    pose: Sequence[float] | np.ndarray,
    namespace: str,
    style: str,
    *,
    triangles: np.ndarray | None = None,
    z: float = 0.0,
    outline_width: float = 0.0,
) -> list[Shape]:
    """Return a part at planar pose (x, y, theta): a filled triangle list and a closed strip per loop.

    The outline's vertices are exactly ``part.placed(x, y, theta)`` (the model's own placement);
    ``triangles`` (in the part frame, from ``triangulate_loops(part.loops())``) may be passed in so that
    a node triangulates each part once, not at every update.
    """
    x, y, theta = (float(v) for v in pose)
    if triangles is None:
        triangles = triangulate_loops(part.loops())
    placed_triangles = triangles.reshape(-1, 2) @ rotation_z(theta).T + np.array([x, y])
    width = outline_width or part.radius * 0.02
    shapes = [Shape("triangles", lift(placed_triangles, z), namespace, style)]
    shapes += [
        Shape("line_strip", loop_strip(loop, z), f"{namespace}_outline", "outline", width)
        for loop in part.placed(x, y, theta)
    ]
    return shapes
