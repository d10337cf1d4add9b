"""Contacts and interpenetration for mesh bodies (sec. II-B, Fig. 7, for non-convex triangle surfaces).

A mesh's triangles are grouped by plane (same outward normal and offset, to the contact tolerances) and each
group merged into one planar region (shapely: possibly non-convex, with holes). Two parts of different bodies
touch where a region of one and a region of the other lie in the same plane with opposite normals; their
intersection is the contact polygon, and as in Fig. 7 the vertices of its convex hull (per connected piece)
are the contact points: forces spread over a planar patch generate the same wrench cone as forces at the
corners of its hull. Convex pieces (boxes, ``convex``) take part through their faces, so a mesh can rest on a
box. Interpenetration is measured on sample points (vertices, edge midpoints, face centroids) of each part
inside the other: a lower bound of the depth, exact where a corner or an edge pokes in.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
import shapely  # type: ignore[import-untyped]
from shapely.geometry import MultiPolygon, Polygon  # type: ignore[import-untyped]
from shapely.geometry.base import BaseGeometry  # type: ignore[import-untyped]

from feeder_planner.assembly.geometry import ConvexPiece, tangent_basis
from feeder_planner.assembly.meshes import BodyParts, MeshPart
from feeder_planner.assembly.tolerances import ANGLE_TOLERANCE, AREA_TOLERANCE, NORMAL_KEY_SCALE

__all__ = ["PlanarRegion", "check_mesh_overlaps", "part_regions", "penetration_depth", "region_contacts"]

Part = ConvexPiece | MeshPart


@dataclass(frozen=True)
class PlanarRegion:
    """One plane of a part's surface: canonical axis a, level a.x, outward side (+1: along a), 2-D region."""

    axis: np.ndarray
    level: float
    side: float
    normal: np.ndarray  # outward unit normal (side * axis)
    region: Polygon | MultiPolygon  # in the axis's tangent basis
    u: np.ndarray
    v: np.ndarray


def _canonical(normal: np.ndarray) -> tuple[np.ndarray, float]:
    """Return the axis of a normal's line (first non-zero component positive) and the normal's side on it."""
    index = int(np.argmax(np.abs(normal) > 1e-12))
    side = 1.0 if normal[index] > 0 else -1.0
    return normal * side, side


def _region_of(axis: np.ndarray, side: float, level: float, polygons: Sequence[np.ndarray]) -> PlanarRegion:
    """Merge coplanar 3-D polygons into one planar region in the axis's fixed tangent basis."""
    u, v = tangent_basis(axis)
    shapes = [Polygon(np.column_stack([p @ u, p @ v])) for p in polygons]
    merged = shapely.union_all([s if s.is_valid else s.buffer(0) for s in shapes])
    return PlanarRegion(axis, level, side, axis * side, merged, u, v)


def part_regions(part: Part, distance_tol: float) -> list[PlanarRegion]:
    """Return the planar regions of a part's surface: faces of a convex piece, merged triangles of a mesh."""
    if isinstance(part, ConvexPiece):
        regions = []
        for face in part.faces:
            axis, side = _canonical(face.normal)
            regions.append(_region_of(axis, side, float(face.polygon.mean(axis=0) @ axis), [face.polygon]))
        return regions
    triangles = part.triangles
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    groups: dict[tuple[int, ...], list[int]] = {}
    for index, normal in enumerate(normals):
        axis, side = _canonical(normal)
        level = float(triangles[index].mean(axis=0) @ axis)
        # Rounded keys group a plane's triangles; a plane split by a rounding boundary only gives two regions,
        # whose contact points span the same wrench cone as one.
        key = (
            *np.round(axis * NORMAL_KEY_SCALE).astype(np.int64).tolist(),
            int(side),
            int(np.round(level / distance_tol)),
        )
        groups.setdefault(key, []).append(index)
    regions = []
    for members in groups.values():
        axis, side = _canonical(normals[members].mean(axis=0) / np.linalg.norm(normals[members].mean(axis=0)))
        level = float(np.mean(triangles[members].reshape(-1, 3) @ axis))
        regions.append(_region_of(axis, side, level, list(triangles[members])))
    return regions


def region_contacts(
    first: Iterable[PlanarRegion], second: Iterable[PlanarRegion], distance_tol: float
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Return (point, normal of the first part's region) for every touching opposite pair of regions.

    Regions touch when their axes agree to ANGLE_TOLERANCE, their sides are opposite and their levels agree
    to ``distance_tol``; the points are the hull vertices of each piece of the common area, on the mid-plane.
    """
    cos_tol = np.cos(ANGLE_TOLERANCE)
    second = list(second)
    found: list[tuple[np.ndarray, np.ndarray]] = []
    for p in first:
        for q in second:
            if p.side == q.side or float(p.axis @ q.axis) < cos_tol or abs(p.level - q.level) > distance_tol:
                continue
            common = p.region.intersection(q.region)
            if common.is_empty:
                continue
            smaller = min(_diameter(p.region), _diameter(q.region))
            level = (p.level + q.level) / 2.0
            for piece in _polygons(common):
                if piece.area <= AREA_TOLERANCE * smaller * smaller:
                    continue
                hull = shapely.convex_hull(piece).simplify(0.0)
                if not isinstance(hull, Polygon):
                    continue
                corners = np.asarray(hull.exterior.coords)[:-1]
                for x, y in corners:
                    found.append((x * p.u + y * p.v + level * p.axis, p.normal.copy()))
    return found


def _polygons(geometry: BaseGeometry) -> list[Polygon]:
    """Return the polygons of a shapely intersection (lines and points of mere edge contact dropped)."""
    if isinstance(geometry, Polygon):
        return [geometry]
    if isinstance(geometry, MultiPolygon):
        return list(geometry.geoms)
    return [g for g in getattr(geometry, "geoms", []) if isinstance(g, Polygon)]


def _diameter(geometry: BaseGeometry) -> float:
    """Largest side of a region's bounding rectangle: the length scale of its area tolerance."""
    x0, y0, x1, y1 = geometry.bounds
    return float(max(x1 - x0, y1 - y0))


def _samples(part: Part) -> np.ndarray:
    """Points of a part's surface that poke into an overlapping part: vertices, edge midpoints, centroids."""
    if isinstance(part, ConvexPiece):
        loops = [face.polygon for face in part.faces]
        mids = [(loop + np.roll(loop, -1, axis=0)) / 2.0 for loop in loops]
        centres = [loop.mean(axis=0, keepdims=True) for loop in loops]
        return np.vstack([part.vertices, *mids, *centres])
    t = part.triangles
    return np.vstack(
        [
            part.vertices,
            (t[:, 0] + t[:, 1]) / 2,
            (t[:, 1] + t[:, 2]) / 2,
            (t[:, 2] + t[:, 0]) / 2,
            t.mean(axis=1),
        ]
    )


def _depth_inside(container: Part, points: np.ndarray) -> float:
    """Largest depth of ``points`` inside ``container`` (m; <= 0 when none is inside)."""
    if len(points) == 0:
        return 0.0
    if isinstance(container, ConvexPiece):
        normals = np.array([f.normal for f in container.faces])
        offsets = np.array([f.offset for f in container.faces])
        return float(np.max(np.min(offsets[None, :] - points @ normals.T, axis=1)))
    lower, upper = container.lower, container.upper
    inside_box = np.all((points > lower) & (points < upper), axis=1)
    if not inside_box.any():
        return 0.0
    import trimesh  # imported on first use: most assemblies have no mesh

    mesh = trimesh.Trimesh(container.vertices, container.faces, process=False)
    depths = trimesh.proximity.signed_distance(mesh, points[inside_box])
    return float(np.max(depths))


def penetration_depth(p: Part, q: Part) -> float:
    """Return how deep two parts interpenetrate (m, > 0), from each part's sample points inside the other."""
    return max(_depth_inside(q, _samples(p)), _depth_inside(p, _samples(q)))


def check_mesh_overlaps(bodies: Sequence[BodyParts], tolerance: float) -> None:
    """Refuse a mesh overlapping another part deeper than ``tolerance`` (m), naming the pair and the depth.

    Parts of different bodies must not interpenetrate; within a body a mesh must not overlap another part
    either (their volumes are added for the mass). Only pairs with a mesh are checked here: convex pieces
    among themselves are the model's own check.
    """
    from feeder_planner.assembly.broad_phase import touching_pairs
    from feeder_planner.errors import InputError

    entries = [
        (bi, field, part)
        for bi, body in enumerate(bodies)
        for field, part in (
            *zip(body.piece_fields, body.pieces, strict=True),
            *((m.field, m) for m in body.meshes),
        )
    ]
    if not any(isinstance(part, MeshPart) for _, _, part in entries):
        return
    lower = np.array([e[2].lower for e in entries])
    upper = np.array([e[2].upper for e in entries])
    for k, m in touching_pairs(lower, upper, -tolerance).tolist():
        (bi, field_p, p), (bj, field_q, q) = entries[k], entries[m]
        if not (isinstance(p, MeshPart) or isinstance(q, MeshPart)):
            continue
        depth = penetration_depth(p, q)
        if depth <= tolerance:
            continue
        if bi == bj:
            raise InputError(field_q, f"overlaps {field_p} of the same body by {depth:.3g} m")
        a, b = bodies[bi], bodies[bj]
        raise InputError(
            "bodies",
            f"bodies {a.name!r} ({field_p}) and {b.name!r} ({field_q}) interpenetrate by {depth:.3g} m",
        )
