"""Convex polyhedral pieces (boxes and hulls): faces, volume, centroid, and overlap depth."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from feeder_planner.assembly.tolerances import (
    FLAT_TOLERANCE,
    ON_PLANE_FACTOR,
    PARALLEL_EDGES,
    PLANE_MATCH_TOLERANCE,
    SAME_EDGE_DIRECTION,
)
from feeder_planner.errors import InputError
from feeder_planner.limits import quote

__all__ = [
    "ConvexPiece",
    "Face",
    "box_piece",
    "faces_piece",
    "hull_piece",
    "overlap_depth",
    "tangent_basis",
]


@dataclass(frozen=True)
class Face:
    """A planar convex face: outward unit normal, offset (normal . x = offset), CCW polygon about normal."""

    normal: np.ndarray
    offset: float
    polygon: np.ndarray  # (k, 3), counter-clockwise seen from outside


class BoundedByVertices:
    """The axis-aligned bounding box of a shape's ``vertices`` (m): a convex piece's or a mesh's."""

    vertices: np.ndarray

    @property
    def lower(self) -> np.ndarray:
        """Lower corner of the axis-aligned bounding box (m)."""
        return self.vertices.min(axis=0)

    @property
    def upper(self) -> np.ndarray:
        """Upper corner of the axis-aligned bounding box (m)."""
        return self.vertices.max(axis=0)

    @property
    def size(self) -> float:
        """Diagonal of the bounding box (m): the length scale of the shape's tolerances."""
        return float(np.linalg.norm(self.upper - self.lower))


@dataclass(frozen=True)
class ConvexPiece(BoundedByVertices):
    """A convex polyhedron in metres (assembly frame) with its faces, volume and centroid."""

    vertices: np.ndarray
    faces: tuple[Face, ...]
    volume: float
    centroid: np.ndarray
    is_box: bool = False

    def edge_directions(self) -> np.ndarray:
        """Return the unit directions of the edges of all faces (duplicates allowed)."""
        directions = []
        for face in self.faces:
            loop = face.polygon
            d = np.roll(loop, -1, axis=0) - loop
            directions.append(d / np.linalg.norm(d, axis=1, keepdims=True))
        return np.vstack(directions)


def box_piece(lower: np.ndarray, upper: np.ndarray, field: str) -> ConvexPiece:
    """Build an axis-aligned box; refuses max <= min on any axis."""
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    for axis, name in enumerate("xyz"):
        if not upper[axis] > lower[axis]:
            raise InputError(
                field,
                f"degenerate box: max.{name} = {upper[axis]!r} is not greater than min.{name} = "
                f"{lower[axis]!r}",
            )
    corners = np.array(
        [[x, y, z] for x in (lower[0], upper[0]) for y in (lower[1], upper[1]) for z in (lower[2], upper[2])]
    )
    faces = []
    for axis in range(3):
        for sign, value in ((-1.0, lower[axis]), (1.0, upper[axis])):
            normal = np.zeros(3)
            normal[axis] = sign
            on_face = corners[np.isclose(corners[:, axis], value)]
            faces.append(Face(normal, sign * value, _ccw(on_face, normal)))
    extent = upper - lower
    return ConvexPiece(corners, tuple(faces), float(np.prod(extent)), (lower + upper) / 2.0, is_box=True)


def hull_piece(points: np.ndarray, field: str) -> ConvexPiece:
    """Build the convex polyhedron whose vertices are ``points``; every point must be a hull vertex."""
    points = np.asarray(points, float)
    if len(points) < 4:
        raise InputError(field, f"degenerate polyhedron: needs at least 4 vertices, got {len(points)}")
    size = float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))
    centered = points - points.mean(axis=0)
    if size == 0.0 or np.linalg.matrix_rank(centered, tol=FLAT_TOLERANCE * size) < 3:
        raise InputError(field, "degenerate polyhedron: its vertices are coplanar (zero volume)")
    from scipy.spatial import ConvexHull, QhullError  # here: a scene without an assembly skips scipy.spatial

    try:
        hull = ConvexHull(points)
    except QhullError as exc:
        raise InputError(field, f"degenerate polyhedron: {str(exc).splitlines()[0]}") from None
    outside = sorted(set(range(len(points))) - set(hull.vertices.tolist()))
    if outside:
        raise InputError(
            f"{field}[{outside[0]}]",
            "is not a vertex of the convex hull (not a convex polyhedron, or a repeated point)",
        )
    return _piece_from_planes(points, hull.equations, size, field)


def faces_piece(points: np.ndarray, faces: list[list[int]], field: str) -> ConvexPiece:
    """Build a convex polyhedron given by vertices and faces: checks closedness, planarity and convexity."""
    points = np.asarray(points, float)
    edge_count: dict[tuple[int, int], int] = {}
    for f_index, face in enumerate(faces):
        if len(face) < 3:
            raise InputError(
                f"{field}.faces[{f_index}]", f"a face needs at least 3 vertices, got {len(face)}"
            )
        for index in face:
            if not isinstance(index, int) or isinstance(index, bool) or not 0 <= index < len(points):
                raise InputError(f"{field}.faces[{f_index}]", f"vertex index {quote(index)} out of range")
        for a, b in zip(face, face[1:] + face[:1], strict=True):
            key = (min(a, b), max(a, b))
            edge_count[key] = edge_count.get(key, 0) + 1
    for (a, b), count in sorted(edge_count.items()):
        if count != 2:
            raise InputError(
                f"{field}.faces",
                f"open polyhedron: edge ({a}, {b}) belongs to {count} face(s), "
                f"a closed surface needs exactly 2",
            )
    piece = hull_piece(points[sorted({i for face in faces for i in face})], f"{field}.vertices")
    if len(piece.faces) != len(faces):
        raise InputError(
            f"{field}.faces",
            f"the {len(faces)} faces do not bound a convex polyhedron "
            f"(its hull has {len(piece.faces)} faces)",
        )
    return piece


def _piece_from_planes(points: np.ndarray, equations: np.ndarray, size: float, field: str) -> ConvexPiece:
    """Build the piece bounded by qhull's plane equations, merging each plane's triangles into one face."""
    on_plane_tolerance = FLAT_TOLERANCE * size * ON_PLANE_FACTOR
    faces: list[Face] = []
    seen: list[np.ndarray] = []
    for equation in equations:
        normal, offset = equation[:3], -equation[3]
        if any(
            np.dot(normal, other[:3]) > 1.0 - PLANE_MATCH_TOLERANCE
            and abs(offset + other[3]) <= on_plane_tolerance
            for other in seen
        ):
            continue
        seen.append(equation)
        on_plane = points[np.abs(points @ normal - offset) <= on_plane_tolerance]
        faces.append(Face(normal / np.linalg.norm(normal), float(offset), _ccw(on_plane, normal)))
    volume, centroid = _volume_centroid(faces)
    if volume <= (FLAT_TOLERANCE * size) * size * size:
        raise InputError(field, "degenerate polyhedron: zero volume")
    return ConvexPiece(points, tuple(faces), volume, centroid)


def _ccw(points: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """Points of one face ordered counter-clockwise about ``normal`` (duplicates removed)."""
    center = points.mean(axis=0)
    u = _perpendicular(normal)
    v = np.cross(normal, u)
    angles = np.arctan2((points - center) @ v, (points - center) @ u)
    ordered = points[np.argsort(angles)]
    keep = [0] + [i for i in range(1, len(ordered)) if np.linalg.norm(ordered[i] - ordered[i - 1]) > 0.0]
    return ordered[keep]


def _perpendicular(normal: np.ndarray) -> np.ndarray:
    """Return a unit vector perpendicular to ``normal`` (chosen away from the smallest component)."""
    axis = np.zeros(3)
    axis[int(np.argmin(np.abs(normal)))] = 1.0
    u = _cross(normal, axis)
    return u / math.sqrt(u @ u)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    # np.cross costs ~20 us of axis bookkeeping per call; this is called once per contact and face.
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def tangent_basis(normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return two unit vectors u, v with u x v = normal (a right-handed frame of the tangent plane)."""
    u = _perpendicular(normal)
    return u, _cross(normal, u)


def _volume_centroid(faces: list[Face]) -> tuple[float, np.ndarray]:
    """Return volume and centroid: divergence theorem over fan triangles of each face, apex at a reference."""
    reference = np.mean([face.polygon.mean(axis=0) for face in faces], axis=0)
    volume, moment = 0.0, np.zeros(3)
    for face in faces:
        loop = face.polygon - reference
        for i in range(1, len(loop) - 1):
            a, b, c = loop[0], loop[i], loop[i + 1]
            tet = np.dot(a, np.cross(b, c)) / 6.0
            volume += tet
            moment += tet * (a + b + c) / 4.0
    return float(volume), reference + moment / volume


def overlap_depth(p: ConvexPiece, q: ConvexPiece) -> float:
    """Separating-axis overlap: > 0 is the penetration depth, <= 0 the gap (both in metres)."""
    if p.is_box and q.is_box:
        return float(np.min(np.minimum(p.upper, q.upper) - np.maximum(p.lower, q.lower)))
    axes = [face.normal for face in p.faces] + [face.normal for face in q.faces]
    for d in _unique_directions(p.edge_directions()):
        for e in _unique_directions(q.edge_directions()):
            cross = np.cross(d, e)
            norm = np.linalg.norm(cross)
            if norm > PARALLEL_EDGES:
                axes.append(cross / norm)
    axes_array = np.asarray(axes)
    pp, qq = p.vertices @ axes_array.T, q.vertices @ axes_array.T
    overlaps = np.minimum(pp.max(axis=0), qq.max(axis=0)) - np.maximum(pp.min(axis=0), qq.min(axis=0))
    return float(overlaps.min())


def _unique_directions(directions: np.ndarray) -> np.ndarray:
    """Drop repeated unit directions, up to sign (first occurrence kept)."""
    unique: list[np.ndarray] = []
    for d in directions:
        if not any(abs(np.dot(d, u)) > 1.0 - SAME_EDGE_DIRECTION for u in unique):
            unique.append(d)
    return np.asarray(unique)
