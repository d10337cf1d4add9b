"""What a viewer draws of the MEMS array: its surface and outline, the cell force vectors, the parts.

ROS-free shapes in the array (plane) frame: the grid is the model's own ``Grid`` (centred on the origin),
a part is drawn where ``Part.placed`` puts it. ``feeder_sim.nodes.mems_field_array`` publishes them.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from feeder_planner.drawing import Shape, lift, part_shapes, triangulate_loops
from feeder_planner.parts import Part
from feeder_sim.mems.coverage import Grid
from feeder_sim.mems.scene import Scene

__all__ = ["array_shapes", "force_shapes", "parts_shapes", "ArrayDrawing", "Layout"]

# What the array's static shapes are drawn for: (nx, ny, pitch, force arrow stride).
Layout = tuple[int, int, float, int]

# The surface sits this fraction of the pitch below the plane, so the parts drawn at z = 0 are on top.
SURFACE_DEPTH = 0.05
# The longest force arrow is this fraction of the spacing of the arrows drawn (no arrow reaches the next).
ARROW_FILL = 0.8
# Arrow heads: length as a fraction of the arrow, half-angle (rad).
HEAD_FRACTION, HEAD_ANGLE = 0.3, 0.45


def array_shapes(grid: Grid) -> list[Shape]:
    """Return the array's surface (two triangles) and its closed outline, at the grid's true extent."""
    x0, x1 = float(grid.x_nodes[0]), float(grid.x_nodes[-1])
    y0, y1 = float(grid.y_nodes[0]), float(grid.y_nodes[-1])
    corners = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
    z = -SURFACE_DEPTH * grid.pitch
    surface = lift(corners[[0, 1, 2, 0, 2, 3]], z)
    outline = lift(corners[[0, 1, 2, 3, 0]], 0.0)
    return [
        Shape("triangles", surface, "array", "device"),
        Shape("line_strip", outline, "array_outline", "outline", 0.5 * grid.pitch),
    ]


def force_shapes(grid: Grid, forces: np.ndarray, stride: int) -> list[Shape]:
    """Return every ``stride``-th cell's force as an arrow (segments of one line list), longest scaled.

    ``forces`` is (nx, ny, 2), as the model's cells push. Arrows start at the cell centres; directions
    are exact, lengths are relative (the largest is ``ARROW_FILL`` of the spacing). No cell pushing (a
    power loss) draws nothing.
    """
    if stride <= 0:
        return []
    centers = grid.centers()[::stride, ::stride].reshape(-1, 2)
    vectors = np.asarray(forces, float)[::stride, ::stride].reshape(-1, 2)
    largest = float(np.hypot(vectors[:, 0], vectors[:, 1]).max()) if len(vectors) else 0.0
    if largest <= 0:
        return []
    tips = centers + vectors * (ARROW_FILL * stride * grid.pitch / largest)
    back = centers - tips
    segments = [centers, tips]
    for angle in (HEAD_ANGLE, -HEAD_ANGLE):
        c, s = np.cos(angle), np.sin(angle)
        head = back @ np.array([[c, s], [-s, c]]) * HEAD_FRACTION
        segments += [tips, tips + head]
    starts, ends = np.concatenate(segments[0::2]), np.concatenate(segments[1::2])
    points = np.stack([starts, ends], axis=1).reshape(-1, 2)
    return [Shape("line_list", lift(points, 0.0), "cell_forces", "force", 0.1 * stride * grid.pitch)]


def parts_shapes(
    parts: Sequence[Part],
    poses: Sequence[Sequence[float] | np.ndarray],
    triangles: Sequence[np.ndarray] | None = None,
    namespace: str = "parts",
    style: str = "part",
) -> list[Shape]:
    """Return every part at its pose (x, y, theta) on the array: filled, with its outer and hole outlines."""
    shapes: list[Shape] = []
    for index, (part, pose) in enumerate(zip(parts, poses, strict=True)):
        tri = triangles[index] if triangles is not None else None
        shapes += part_shapes(part, pose, namespace, style, triangles=tri)
    return shapes


class ArrayDrawing:
    """The array's shapes as a viewer gets them, each rebuilt only when what it shows changed."""

    def __init__(self) -> None:
        # Parts are triangulated once per part (the parts a scene holds change with spawns and removals)
        # and placed at every update.
        self.part_triangles: tuple[list[Part], list[np.ndarray]] = ([], [])
        # The cells' forces and layout the static shapes were drawn for (() before the first), and those.
        self.array: tuple[np.ndarray | None, Layout | tuple[()], list[Shape]] = (None, (), [])

    def shapes(self, scene: Scene, forces: np.ndarray, layout: Layout) -> tuple[list[Shape], list[Shape]]:
        """Return (static, dynamic): the array and its force arrows, the parts at their poses.

        The array and its force arrows change only with the cells' forces (a new array each time they
        change) or the layout: built then, not at every update (thousands of arrows on a large array).
        """
        parts = [b.part for b in scene.bodies]
        drawn_parts, triangles = self.part_triangles
        if len(parts) != len(drawn_parts) or any(a is not b for a, b in zip(parts, drawn_parts, strict=True)):
            known = {id(part): tri for part, tri in zip(drawn_parts, triangles, strict=True)}
            triangles = [
                known[id(part)] if id(part) in known else triangulate_loops(part.loops()) for part in parts
            ]
            self.part_triangles = (parts, triangles)
        drawn, drawn_layout, static = self.array
        if drawn is not forces or drawn_layout != layout:
            grid = Grid(layout[0], layout[1], layout[2])
            static = array_shapes(grid) + force_shapes(grid, forces, layout[3])
            self.array = (forces, layout, static)
        shapes = parts_shapes(parts, [b.pose for b in scene.bodies], self.part_triangles[1])
        return static, shapes
