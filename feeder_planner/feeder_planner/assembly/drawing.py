"""What a viewer draws of a stable region: the sphere of gravity directions, the region, its centre, a path.

ROS-free shapes in the assembly frame, on a sphere of radius ``radius`` about its origin (a direction g is
the point radius * g). The region's boundary is drawn from its own inequalities: of each bounding great
circle n . g = 0, the samples that satisfy every other inequality, so the drawing is the region the
planner certifies, whatever the order of its vertices.
"""

from __future__ import annotations

import numpy as np

from feeder_planner.assembly.region import StableRegion
from feeder_planner.drawing import Shape

__all__ = ["BOUNDARY_SAMPLES", "great_circle", "boundary_points", "region_shapes", "path_shape"]

# Samples per bounding great circle: a 1 degree step.
BOUNDARY_SAMPLES = 360
# A boundary sample may violate another inequality by this much (unit vectors): the region's corners.
BOUNDARY_SLACK = 1e-9


def great_circle(normal: np.ndarray, points: int) -> np.ndarray:
    """Return ``points`` unit vectors evenly around the great circle n . g = 0, the first repeated last."""
    n = np.asarray(normal, float)
    n = n / np.linalg.norm(n)
    u = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    angles = np.linspace(0.0, 2 * np.pi, points)
    return np.outer(np.cos(angles), u) + np.outer(np.sin(angles), np.cross(n, u))


def boundary_points(region: StableRegion, samples: int = BOUNDARY_SAMPLES) -> list[np.ndarray]:
    """Return, per bounding great circle, its points in the region as (k, 2, 3) unit segments.

    The circles are those of the inequalities (n . g = 0, the edges of a 2-D region) and of the equalities
    (e . g = 0: an arc or a great circle is a piece of one); a sample is kept when it satisfies every
    other constraint.
    """
    normals = np.asarray(region.normals, float).reshape(-1, 3)
    equalities = np.asarray(region.equalities, float).reshape(-1, 3)
    circles = [*normals, *equalities]
    arcs = []
    for index, n in enumerate(circles):
        circle = great_circle(n, samples + 1)
        inside = np.ones(len(circle), bool)
        for other, m in enumerate(circles):
            if other == index:
                continue
            value = circle @ m
            inside &= value <= BOUNDARY_SLACK if other < len(normals) else np.abs(value) <= BOUNDARY_SLACK
        keep = inside[:-1] & inside[1:]
        arcs.append(np.stack([circle[:-1][keep], circle[1:][keep]], axis=1))
    return arcs


def region_shapes(region: StableRegion, radius: float) -> list[Shape]:
    """Return the sphere, the region's boundary arcs, its vertices and its centre (with an arrow to it)."""
    shapes = [Shape("sphere", np.zeros((1, 3)), "sphere", "sphere", 2.0 * radius)]
    segments = [arc for arc in boundary_points(region) if len(arc)]
    if segments:
        points = np.concatenate(segments).reshape(-1, 3) * radius
        shapes.append(Shape("line_list", points, "region", "region", 0.01 * radius))
    vertices = np.asarray(region.vertices, float).reshape(-1, 3)
    if len(vertices):
        shapes.append(Shape("points", vertices * radius, "region_vertices", "region", 0.04 * radius))
    if region.center is not None:
        c = np.asarray(region.center, float) * radius
        shapes.append(Shape("sphere", c[None, :], "center", "center", 0.06 * radius))
        shapes.append(Shape("arrow", np.array([np.zeros(3), c]), "center_arrow", "center", 0.01 * radius))
    return shapes


def path_shape(path: np.ndarray, radius: float) -> Shape:
    """Return a path of unit gravity directions as a polyline on the sphere."""
    points = np.asarray(path, float).reshape(-1, 3)
    points = points / np.linalg.norm(points, axis=1, keepdims=True) * radius
    return Shape("line_strip", points, "safe_path", "path", 0.015 * radius)
