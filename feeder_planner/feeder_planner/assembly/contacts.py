"""Contact points of an assembly: vertices of the polygons where opposite faces touch (sec. II-B, Fig. 7)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from feeder_planner.assembly.broad_phase import touching_pairs
from feeder_planner.assembly.geometry import ConvexPiece, Face, tangent_basis
from feeder_planner.assembly.mesh_contacts import PlanarRegion, part_regions, region_contacts
from feeder_planner.assembly.meshes import MeshPart
from feeder_planner.assembly.model import Assembly
from feeder_planner.assembly.tolerances import (
    ANGLE_TOLERANCE,
    AREA_TOLERANCE,
    DISTANCE_TOLERANCE,
    NORM_FLOOR,
    NORMAL_KEY_SCALE,
    POLYGON_DEDUPE,
)

__all__ = ["Contact", "assembly_contacts", "auto_contacts", "clip_convex", "polygon_area"]


@dataclass(frozen=True)
class Contact:
    """One contact point between bodies ``a`` and ``b`` (indices): force on a along +normal (b into a)."""

    a: int
    b: int
    point: np.ndarray
    normal: np.ndarray
    mu: float


def assembly_contacts(assembly: Assembly, mu: float | None = None) -> list[Contact]:
    """Explicit contacts of the file, or the automatic ones; ``mu`` overrides every coefficient when given."""
    if assembly.explicit_contacts is not None:
        contacts = [
            Contact(assembly.index[c.a], assembly.index[c.b], c.point, c.normal, c.mu)
            for c in assembly.explicit_contacts
        ]
    else:
        contacts = auto_contacts(assembly)
    if mu is not None:
        contacts = [Contact(c.a, c.b, c.point, c.normal, mu) for c in contacts]
    # Contacts between two grounded bodies carry no unknowns that matter.
    return [c for c in contacts if not (assembly.bodies[c.a].grounded and assembly.bodies[c.b].grounded)]


def auto_contacts(assembly: Assembly) -> list[Contact]:
    """Every pair of touching opposite faces of different bodies gives its contact polygon's vertices.

    Candidate part pairs come from the broad phase (bounding boxes within the distance tolerance), in the
    order of a double loop over parts; mesh parts take the planar-region route of ``mesh_contacts``.
    """
    distance_tol = DISTANCE_TOLERANCE * assembly.size
    entries: list[tuple[int, ConvexPiece | MeshPart]] = []
    for bi, body in enumerate(assembly.bodies):
        entries += [(bi, piece) for piece in body.pieces] + [(bi, mesh) for mesh in body.meshes]
    lower = np.array([e[1].lower for e in entries]).reshape(-1, 3)
    upper = np.array([e[1].upper for e in entries]).reshape(-1, 3)
    owner = np.array([e[0] for e in entries], dtype=int)
    grounded = np.array([assembly.bodies[e[0]].grounded for e in entries], dtype=bool)
    pairs = touching_pairs(lower, upper, distance_tol)
    if len(pairs):
        i, j = pairs[:, 0], pairs[:, 1]
        pairs = pairs[(owner[i] != owner[j]) & ~(grounded[i] & grounded[j])]
    regions: dict[int, list[PlanarRegion]] = {}
    contacts: list[Contact] = []
    seen: set[tuple[int, ...]] = set()
    for k, m in pairs.tolist():
        (bi, piece), (bj, other) = entries[k], entries[m]
        if isinstance(piece, ConvexPiece) and isinstance(other, ConvexPiece):
            found = _piece_contacts(bi, piece, bj, other, distance_tol, assembly)
        else:
            for index in (k, m):
                if index not in regions:
                    regions[index] = part_regions(entries[index][1], distance_tol)
            found = _region_pair_contacts(bi, regions[k], bj, regions[m], distance_tol, assembly)
        for contact in found:
            key = (
                contact.a,
                contact.b,
                *np.round(contact.point / distance_tol).astype(np.int64),
                *np.round(contact.normal * NORMAL_KEY_SCALE).astype(np.int64),
            )
            if key not in seen:
                seen.add(key)
                contacts.append(contact)
    return contacts


def _region_pair_contacts(
    bi: int,
    first: list[PlanarRegion],
    bj: int,
    second: list[PlanarRegion],
    tol: float,
    assembly: Assembly,
) -> list[Contact]:
    """Contacts of two parts given as planar regions (at least one a mesh), oriented as for faces."""
    found = []
    for point, outward in region_contacts(first, second, tol):
        # outward is the first part's normal, into the second: the force on the second part is along it.
        if assembly.bodies[bi].grounded:
            found.append(Contact(bj, bi, point, outward, assembly.mu))
        else:
            found.append(Contact(bi, bj, point, -outward, assembly.mu))
    return found


def _piece_contacts(
    bi: int, p: ConvexPiece, bj: int, q: ConvexPiece, tol: float, assembly: Assembly
) -> list[Contact]:
    """Return the contacts of piece p (body bi) and q (body bj): vertices of touching face pairs' polygons."""
    if p.is_box and q.is_box:
        return _box_contacts(bi, p, bj, q, tol, assembly)
    found: list[Contact] = []
    cos_tol = np.cos(ANGLE_TOLERANCE)
    for fp in p.faces:
        for fq in q.faces:
            if np.dot(fp.normal, fq.normal) > -cos_tol:
                continue
            if (
                np.max(np.abs(fp.polygon @ fq.normal - fq.offset)) > tol
                or np.max(np.abs(fq.polygon @ fp.normal - fp.offset)) > tol
            ):
                continue
            polygon = _face_intersection(fp, fq)
            if polygon is None:
                continue
            # Orient so the grounded body (if any) is b: the force on a is along +normal.
            if assembly.bodies[bi].grounded:
                a, b, normal = bj, bi, fp.normal
            else:
                a, b, normal = bi, bj, fq.normal
            mu = assembly.mu
            found.extend(Contact(a, b, point, normal.copy(), mu) for point in polygon)
    return found


def _box_contacts(
    bi: int, p: ConvexPiece, bj: int, q: ConvexPiece, tol: float, assembly: Assembly
) -> list[Contact]:
    """Axis-aligned boxes: the same face-pair rule, with the common rectangle computed directly."""
    for axis in range(3):
        for sign, gap in ((1.0, q.lower[axis] - p.upper[axis]), (-1.0, p.lower[axis] - q.upper[axis])):
            if abs(gap) > tol:
                continue
            others = [k for k in range(3) if k != axis]
            lo = np.maximum(p.lower[others], q.lower[others])
            hi = np.minimum(p.upper[others], q.upper[others])
            extent = hi - lo
            smaller = min(
                np.linalg.norm((p.upper - p.lower)[others]), np.linalg.norm((q.upper - q.lower)[others])
            )
            if np.any(extent <= 0) or extent[0] * extent[1] <= AREA_TOLERANCE * smaller * smaller:
                continue
            level = (p.upper[axis] + q.lower[axis]) / 2 if sign > 0 else (p.lower[axis] + q.upper[axis]) / 2
            normal_pq = np.zeros(3)
            normal_pq[axis] = sign  # from p into q
            if assembly.bodies[bi].grounded:
                a, b, normal = bj, bi, normal_pq
            else:
                a, b, normal = bi, bj, -normal_pq
            corners = []
            for u, v in ((lo[0], lo[1]), (hi[0], lo[1]), (hi[0], hi[1]), (lo[0], hi[1])):
                point = np.empty(3)
                point[axis], point[others[0]], point[others[1]] = level, u, v
                corners.append(Contact(a, b, point, normal.copy(), assembly.mu))
            return corners
    return []


def _face_intersection(fp: Face, fq: Face) -> np.ndarray | None:
    """Return the common polygon of two touching faces (3-D vertices on the mid-plane), None without area."""
    u, v = tangent_basis(fq.normal)
    origin = fq.polygon[0]
    q2 = np.column_stack([(fq.polygon - origin) @ u, (fq.polygon - origin) @ v])
    # fp is counter-clockwise about -normal, so reversed in this basis.
    p2 = np.column_stack([(fp.polygon - origin) @ u, (fp.polygon - origin) @ v])[::-1]
    clipped = clip_convex(p2, q2)
    if len(clipped) < 3:
        return None
    diameter = min(np.ptp(p2, axis=0).max(), np.ptp(q2, axis=0).max())
    if polygon_area(clipped) <= AREA_TOLERANCE * diameter * diameter:
        return None
    plane_shift = fq.normal * (np.mean(fp.polygon @ fq.normal) - fq.offset) / 2.0
    return origin + plane_shift + clipped[:, :1] * u + clipped[:, 1:] * v


def clip_convex(subject: np.ndarray, clip: np.ndarray) -> np.ndarray:
    """Sutherland-Hodgman: the intersection of two counter-clockwise convex polygons."""
    output = subject
    for i in range(len(clip)):
        if len(output) == 0:
            break
        a, b = clip[i], clip[(i + 1) % len(clip)]
        edge = b - a
        side = edge[0] * (output[:, 1] - a[1]) - edge[1] * (output[:, 0] - a[0])
        points = []
        for j in range(len(output)):
            current, following = output[j], output[(j + 1) % len(output)]
            s0, s1 = side[j], side[(j + 1) % len(output)]
            if s0 >= 0:
                points.append(current)
            if (s0 >= 0) != (s1 >= 0):
                t = s0 / (s0 - s1)
                points.append(current + t * (following - current))
        output = np.asarray(points).reshape(-1, 2)
    return _dedupe(output)


def _dedupe(polygon: np.ndarray) -> np.ndarray:
    """Drop repeated and collinear vertices of a polygon (relative to its extent)."""
    if len(polygon) == 0:
        return polygon
    scale = max(float(np.ptp(polygon, axis=0).max()), NORM_FLOOR)
    keep = []
    for i in range(len(polygon)):
        if np.linalg.norm(polygon[i] - polygon[(i + 1) % len(polygon)]) > POLYGON_DEDUPE * scale:
            keep.append(i)
    polygon = polygon[keep]
    # Drop collinear vertices: they add contact points without adding any force the others cannot make.
    keep = []
    for i in range(len(polygon)):
        a, b, c = polygon[i - 1], polygon[i], polygon[(i + 1) % len(polygon)]
        cross = (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0])
        if abs(cross) > POLYGON_DEDUPE * scale * scale:
            keep.append(i)
    return polygon[keep]


def polygon_area(polygon: np.ndarray) -> float:
    """Signed area of a planar polygon (rows x, y): positive when counter-clockwise (shoelace formula)."""
    x, y = polygon[:, 0], polygon[:, 1]
    return float(0.5 * (np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))
