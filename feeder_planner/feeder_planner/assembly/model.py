"""Assembly files (contract section 2): bodies as unions of boxes and convex polyhedra, in metres."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from feeder_planner.assembly.geometry import ConvexPiece, box_piece, faces_piece, hull_piece, overlap_depth
from feeder_planner.assembly.mesh_contacts import check_mesh_overlaps
from feeder_planner.assembly.meshes import MeshPart, mesh_parts, part_bounds
from feeder_planner.assembly.tolerances import PENETRATION_TOLERANCE, UNIT_NORMAL_TOLERANCE
from feeder_planner.errors import InputError
from feeder_planner.fields_io import (
    load_yaml_mapping,
    non_negative_number,
    optional,
    point_array,
    positive_number,
    required,
    short_string,
    yaml_mapping_from_text,
)
from feeder_planner.limits import (
    CONTACT_DISTANCE_TOLERANCE,
    MAX_ASSEMBLY_MESH_FACES,
    MAX_ASSEMBLY_PIECES,
    MAX_CONTACTS,
    MAX_CONVEX_VERTICES,
    MAX_DENSITY,
    MAX_LENGTH_M,
    check_count,
    check_length_scale,
    quote,
)
from feeder_planner.units import length_scale

__all__ = [
    "Assembly",
    "Body",
    "ExplicitContact",
    "assembly_from_document",
    "assembly_from_text",
    "load_assembly",
]


@dataclass(frozen=True)
class Body:
    """A rigid body: convex pieces (metres), mass (kg) and centre of mass; grounded bodies are held fixed."""

    name: str
    grounded: bool
    pieces: tuple[ConvexPiece, ...]
    mass: float
    center: np.ndarray
    density: float
    piece_fields: tuple[str, ...] = ()
    meshes: tuple[MeshPart, ...] = ()  # non-convex triangle surfaces (``meshes:``), see assembly.meshes

    @property
    def size(self) -> float:
        """Diagonal of the body's bounding box (m): the length scale of its torque equations."""
        lower, upper = part_bounds([*self.pieces, *self.meshes])
        return float(np.linalg.norm(upper - lower))


@dataclass(frozen=True)
class ExplicitContact:
    """A contact point given in the file: force on ``a`` along +normal (normal from b into a)."""

    a: str
    b: str
    point: np.ndarray
    normal: np.ndarray
    mu: float


@dataclass(frozen=True)
class Assembly:
    """Bodies, the default friction coefficient, and explicit contacts (None means 'auto')."""

    name: str
    bodies: tuple[Body, ...]
    mu: float
    explicit_contacts: tuple[ExplicitContact, ...] | None = None
    source: str = ""
    unit_scale: float = 1.0
    index: dict[str, int] = field(default_factory=dict)

    @property
    def size(self) -> float:
        """Diagonal of the assembly's bounding box (m): the length scale of the contact tolerances."""
        lower, upper = part_bounds([p for b in self.bodies for p in (*b.pieces, *b.meshes)])
        return float(np.linalg.norm(upper - lower))

    @property
    def free_bodies(self) -> list[int]:
        """Indices of the bodies that are not grounded (the ones with equilibrium equations)."""
        return [i for i, body in enumerate(self.bodies) if not body.grounded]


def load_assembly(path: str | Path) -> Assembly:
    """Read and validate an assembly file; every error names the file and the field."""
    document = load_yaml_mapping(path)
    try:
        return assembly_from_document(document, str(path), Path(path).parent)
    except InputError as error:
        raise error.with_source(str(path)) from None


def assembly_from_text(
    text: str, source: str = "assembly_yaml", base_dir: str | Path | None = None
) -> Assembly:
    """Parse an assembly given as YAML text (a service request field); mesh paths relative to ``base_dir``."""
    document = yaml_mapping_from_text(text, source)
    try:
        return assembly_from_document(document, source, base_dir)
    except InputError as error:
        raise error.with_source(source) from None


def assembly_from_document(
    document: dict[str, Any], source: str = "", base_dir: str | Path | None = None
) -> Assembly:
    """Validate a parsed assembly mapping and build the bodies; mesh paths are relative to ``base_dir``."""
    scale = length_scale(optional(document, "length_unit", "m"))
    mu = non_negative_number(optional(document, "mu", 0.0), "mu")
    raw_bodies = required(document, "bodies")
    if not isinstance(raw_bodies, list) or not raw_bodies:
        raise InputError("bodies", "expected a non-empty list of bodies")
    _check_piece_count(raw_bodies)
    bodies = []
    faces = 0
    for i, raw in enumerate(raw_bodies):
        bodies.append(_body(raw, f"bodies[{i}]", scale, base_dir))
        # Counted as the meshes are read, so memory stays within the limit plus one mesh.
        faces += sum(len(mesh.faces) for mesh in bodies[-1].meshes)
        check_count(faces, MAX_ASSEMBLY_MESH_FACES, f"bodies[{i}].meshes", "mesh triangles in all")
    lower, upper = part_bounds([p for b in bodies for p in (*b.pieces, *b.meshes)])
    check_length_scale(
        float(max(np.abs(lower).max(), np.abs(upper).max())), float((upper - lower).max()), "bodies"
    )
    names = [b.name for b in bodies]
    for i, name in enumerate(names):
        if names.index(name) != i:
            raise InputError(f"bodies[{i}].name", f"duplicate body name {name!r}")
    if not any(b.grounded for b in bodies):
        raise InputError("bodies", "no grounded body: at least one body needs 'grounded: true'")
    assembly = Assembly(
        short_string(optional(document, "name", "assembly"), "name"),
        tuple(bodies),
        mu,
        None,
        source,
        scale,
        {b.name: i for i, b in enumerate(bodies)},
    )
    _check_interpenetration(assembly)
    check_mesh_overlaps(assembly.bodies, PENETRATION_TOLERANCE * assembly.size)
    contacts = optional(document, "contacts", "auto")
    if contacts != "auto":
        explicit = _explicit_contacts(contacts, assembly, scale)
        assembly = Assembly(assembly.name, assembly.bodies, mu, explicit, source, scale, assembly.index)
    return assembly


def _body(raw: Any, field_name: str, scale: float, base_dir: str | Path | None = None) -> Body:
    """Read one body of the file: name, grounded flag, density and pieces, with its mass properties."""
    if not isinstance(raw, dict):
        raise InputError(field_name, f"expected a mapping, got {type(raw).__name__}")
    name = short_string(required(raw, "name", f"{field_name}.name"), f"{field_name}.name", "a body name")
    grounded = optional(raw, "grounded", False)
    if not isinstance(grounded, bool):
        raise InputError(f"{field_name}.grounded", f"expected true or false, got {quote(grounded)}")
    density = positive_number(optional(raw, "density", 1.0), f"{field_name}.density")
    if density > MAX_DENSITY:
        raise InputError(f"{field_name}.density", f"{density:.3g} exceeds the limit of {MAX_DENSITY:g}")
    named = _box_pieces(raw, field_name, scale) + _convex_pieces(raw, field_name, scale)
    pieces = [piece for _, piece in named]
    fields = [item for item, _ in named]
    meshes = [part for _, part in mesh_parts(raw, field_name, scale, base_dir)]
    if not pieces and not meshes:
        raise InputError(field_name, "a body needs at least one box, convex polyhedron or mesh")
    mass, center = _mass_properties(pieces, fields, density, field_name) if pieces else (0.0, np.zeros(3))
    if meshes:
        # Meshes add their enclosed volumes (check_mesh_overlaps refuses overlaps within the body).
        volume = float(sum(m.volume for m in meshes))
        moment = sum((m.volume * m.centroid for m in meshes), start=np.zeros(3))
        total = mass + density * volume
        center = (mass * center + density * moment) / total
        mass = total
    return Body(name, grounded, tuple(pieces), mass, center, density, tuple(fields), tuple(meshes))


def _box_pieces(raw: dict[str, Any], field_name: str, scale: float) -> list[tuple[str, ConvexPiece]]:
    """Read the body's ``boxes`` ({min, max} in the file's unit) as pieces in metres, with their fields."""
    boxes = optional(raw, "boxes", [])
    if not isinstance(boxes, list):
        raise InputError(f"{field_name}.boxes", "expected a list of {min, max} boxes")
    pieces = []
    for j, box in enumerate(boxes):
        item = f"{field_name}.boxes[{j}]"
        if not isinstance(box, dict):
            raise InputError(item, "expected a mapping with min and max")
        lower = _coordinates([required(box, "min", f"{item}.min")], f"{item}.min", scale)[0]
        upper = _coordinates([required(box, "max", f"{item}.max")], f"{item}.max", scale)[0]
        pieces.append((item, box_piece(lower, upper, item)))
    return pieces


def _convex_pieces(raw: dict[str, Any], field_name: str, scale: float) -> list[tuple[str, ConvexPiece]]:
    """Read the body's ``convex`` polyhedra (vertex lists, or vertices and faces) as pieces, with fields."""
    convex = optional(raw, "convex", [])
    if not isinstance(convex, list):
        raise InputError(f"{field_name}.convex", "expected a list of convex polyhedra")
    pieces = []
    for j, poly in enumerate(convex):
        item = f"{field_name}.convex[{j}]"
        if isinstance(poly, dict):
            points = _coordinates(required(poly, "vertices", f"{item}.vertices"), f"{item}.vertices", scale)
            faces = required(poly, "faces", f"{item}.faces")
            if not isinstance(faces, list) or not all(isinstance(f, list) for f in faces):
                raise InputError(f"{item}.faces", "expected a list of vertex-index lists")
            used = {i for f in faces for i in f if isinstance(i, int) and not isinstance(i, bool)}
            unused = [i for i in range(len(points)) if i not in used]
            if unused and len(used) >= 3:
                raise InputError(
                    f"{item}.vertices[{unused[0]}]", "is in no face (a convex polyhedron's vertex)"
                )
            _check_convex_position(points, f"{item}.vertices")
            pieces.append((item, faces_piece(points, faces, item)))
        else:
            points = _coordinates(poly, item, scale)
            _check_convex_position(points, item)
            pieces.append((item, hull_piece(points, item)))
    return pieces


def _coordinates(value: Any, field: str, scale: float) -> np.ndarray:
    """Read 3-D points in the file's unit as metres; refuse more than MAX_CONVEX_VERTICES or past scale."""
    if isinstance(value, list):
        check_count(len(value), MAX_CONVEX_VERTICES, field, "points")
    points = point_array(value, field, 3) * scale
    magnitude = float(np.abs(points).max())
    if not magnitude <= MAX_LENGTH_M:
        check_length_scale(magnitude, 0.0, field)
    return points


def _check_convex_position(points: np.ndarray, field: str) -> None:
    """Refuse a point of a convex polyhedron inside the hull of the others, naming the first such point.

    A point is in convex position when it lies strictly outside the hull of the other points: beyond some
    face plane of the full hull it is a vertex of. qhull's own vertex list can keep a point that lies
    inside within its merging tolerance; here a point counts as inside when every hull plane through it
    (within FLAT tolerance x size) still has it on the boundary and it is not a hull vertex.
    """
    if len(points) < 4:
        return  # hull_piece names the degenerate polyhedron
    from scipy.spatial import ConvexHull, QhullError

    size = float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))
    try:
        hull = ConvexHull(points)
    except (QhullError, ValueError):
        return  # hull_piece names the degenerate polyhedron
    vertices = set(hull.vertices.tolist())
    for index in range(len(points)):
        if index not in vertices:
            depth = float(np.max(hull.equations[:, :3] @ points[index] + hull.equations[:, 3]))
            raise InputError(
                f"{field}[{index}]",
                f"is not in convex position: it lies {abs(depth):.3g} m inside the hull of the other points"
                if depth < -1e-12 * size
                else "is not in convex position: it lies on the hull of the other points (or repeats one)",
            )


def _check_piece_count(raw_bodies: list[Any]) -> None:
    """Refuse more than MAX_ASSEMBLY_PIECES boxes, polyhedra and meshes (all bodies) before reading them."""
    count = 0
    for raw in raw_bodies:
        if isinstance(raw, dict):
            for key in ("boxes", "convex", "meshes"):
                value = raw.get(key)
                count += len(value) if isinstance(value, list) else 0
    check_count(count, MAX_ASSEMBLY_PIECES, "bodies", "boxes, convex polyhedra and meshes")


def _mass_properties(
    pieces: list[ConvexPiece], fields: list[str], density: float, field_name: str
) -> tuple[float, np.ndarray]:
    """Volume and centroid of the union: boxes exactly by coordinate compression; hulls must not overlap."""
    size = float(
        np.linalg.norm(np.max([p.upper for p in pieces], axis=0) - np.min([p.lower for p in pieces], axis=0))
    )
    for (i, p), (j, q) in itertools.combinations(enumerate(pieces), 2):
        if (p.is_box and q.is_box) or overlap_depth(p, q) <= PENETRATION_TOLERANCE * size:
            continue
        raise InputError(
            f"{fields[j]}", f"overlaps {fields[i]} of the same body; only boxes of one body may overlap"
        )
    boxes = [p for p in pieces if p.is_box]
    volume, moment = 0.0, np.zeros(3)
    if boxes:
        v, c = _box_union(boxes)
        volume, moment = v, v * c
    for piece in pieces:
        if not piece.is_box:
            volume += piece.volume
            moment += piece.volume * piece.centroid
    return density * volume, moment / volume


def _box_union(boxes: list[ConvexPiece]) -> tuple[float, np.ndarray]:
    """Exact volume and centroid of a union of axis-aligned boxes, in memory linear in the boxes.

    A sweep over x: between consecutive x planes of the boxes (a slab) the union is a prism over the 2-D
    union of the boxes spanning the slab, whose area and first moments come from the grid of those boxes'
    own y and z planes (at most (2k)^2 cells for k boxes in the slab, never the (2N)^3 grid of all planes).
    """
    lower = np.array([b.lower for b in boxes])
    upper = np.array([b.upper for b in boxes])
    planes = np.unique(np.concatenate((lower[:, 0], upper[:, 0])))
    volume, moment = 0.0, np.zeros(3)
    for x0, x1 in zip(planes[:-1], planes[1:], strict=True):
        active = np.flatnonzero((lower[:, 0] <= x0) & (upper[:, 0] >= x1))
        if not active.size:
            continue
        area, my, mz = _rectangle_union(lower[active, 1:], upper[active, 1:])
        width = float(x1 - x0)
        volume += width * area
        moment += width * np.array([area * 0.5 * float(x0 + x1), my, mz])
    return volume, moment / volume


def _rectangle_union(lower: np.ndarray, upper: np.ndarray) -> tuple[float, float, float]:
    """Area and first moments (integrals of y and z) of a union of axis-aligned rectangles (plane grid)."""
    grids = [np.unique(np.concatenate((lower[:, a], upper[:, a]))) for a in range(2)]
    # Coverage count of each cell by a 2-D difference array: +1 at a rectangle's low corner, -1 past it.
    i0, i1 = np.searchsorted(grids[0], lower[:, 0]), np.searchsorted(grids[0], upper[:, 0])
    j0, j1 = np.searchsorted(grids[1], lower[:, 1]), np.searchsorted(grids[1], upper[:, 1])
    marks = np.zeros((len(grids[0]), len(grids[1])), dtype=np.int64)
    np.add.at(marks, (i0, j0), 1)
    np.add.at(marks, (i1, j0), -1)
    np.add.at(marks, (i0, j1), -1)
    np.add.at(marks, (i1, j1), 1)
    cells = marks.cumsum(axis=0).cumsum(axis=1)[:-1, :-1] > 0
    widths = [np.diff(g) for g in grids]
    mids = [(g[1:] + g[:-1]) / 2 for g in grids]
    filled = np.where(cells, widths[0][:, None] * widths[1][None, :], 0.0)
    area = float(filled.sum())
    return area, float((filled.sum(axis=1) * mids[0]).sum()), float((filled.sum(axis=0) * mids[1]).sum())


def _check_interpenetration(assembly: Assembly) -> None:
    """Refuse pieces of different bodies overlapping deeper than PENETRATION_TOLERANCE x assembly size."""
    tolerance = PENETRATION_TOLERANCE * assembly.size
    entries = [
        (bi, pi, piece) for bi, body in enumerate(assembly.bodies) for pi, piece in enumerate(body.pieces)
    ]
    lower = np.array([e[2].lower for e in entries])
    upper = np.array([e[2].upper for e in entries])
    owner = np.array([e[0] for e in entries])
    for k, (bi, pi, piece) in enumerate(entries):
        # Bounding-box prefilter: later pieces of other bodies whose boxes overlap beyond the tolerance.
        overlap = np.min(np.minimum(upper[k + 1 :], upper[k]) - np.maximum(lower[k + 1 :], lower[k]), axis=1)
        for offset in np.nonzero((overlap > tolerance) & (owner[k + 1 :] != bi))[0]:
            bj, pj, other = entries[k + 1 + offset]
            depth = overlap_depth(piece, other)
            if depth > tolerance:
                a, b = assembly.bodies[bi], assembly.bodies[bj]
                raise InputError(
                    "bodies",
                    f"bodies {a.name!r} ({a.piece_fields[pi]}) and {b.name!r} "
                    f"({b.piece_fields[pj]}) interpenetrate by {depth:.3g} m",
                )


def _surface_distance(body: Body, point: np.ndarray) -> float:
    """Return a lower bound of the distance (m) from ``point`` to the body's surface (exact for meshes).

    Per convex piece, the largest signed plane distance max(n . p - offset) is the distance to the
    boundary for a point inside, and at most the true distance for one outside (equal when the nearest
    point of the piece is on a face): a point refused by this bound is surely that far from the piece.
    """
    best = math.inf
    for piece in body.pieces:
        signed = max(float(face.normal @ point - face.offset) for face in piece.faces)
        best = min(best, abs(signed))
    for mesh in body.meshes:  # a non-convex surface: the exact distance to its nearest triangle
        best = min(best, mesh.surface_distance(point))
    return best


def _explicit_contacts(raw: Any, assembly: Assembly, scale: float) -> tuple[ExplicitContact, ...]:
    """Read the file's ``contacts`` list: bodies by name, point in metres, unit normal from b into a, mu."""
    if not isinstance(raw, list):
        raise InputError("contacts", "expected 'auto' or a list of {a, b, point, normal, mu} contacts")
    check_count(len(raw), MAX_CONTACTS, "contacts", "contacts")
    tolerance = CONTACT_DISTANCE_TOLERANCE * assembly.size
    contacts = []
    for i, item in enumerate(raw):
        where = f"contacts[{i}]"
        if not isinstance(item, dict):
            raise InputError(where, "expected a mapping with a, b, point, normal")
        names = []
        for key in ("a", "b"):
            name = short_string(required(item, key, f"{where}.{key}"), f"{where}.{key}", "a body name")
            if name not in assembly.index:
                raise InputError(f"{where}.{key}", f"unknown body {quote(name)}")
            names.append(name)
        if names[0] == names[1]:
            raise InputError(f"{where}.b", "a contact joins two different bodies")
        point = _coordinates([required(item, "point", f"{where}.point")], f"{where}.point", scale)[0]
        # A contact is where a body's surface is: a point off both surfaces is no contact (a typo, a unit).
        distances = [_surface_distance(assembly.bodies[assembly.index[name]], point) for name in names]
        if min(distances) > tolerance:
            raise InputError(
                f"{where}.point",
                f"is {distances[0]:.3g} m from the surface of body {names[0]!r} and {distances[1]:.3g} m "
                f"from that of {names[1]!r}: a contact point must be within {tolerance:.3g} m "
                f"({CONTACT_DISTANCE_TOLERANCE:g} x the assembly's size) of a body's surface",
            )
        normal = point_array([required(item, "normal", f"{where}.normal")], f"{where}.normal", 3)[0]
        length = float(np.linalg.norm(normal))
        if abs(length - 1.0) > UNIT_NORMAL_TOLERANCE:
            raise InputError(f"{where}.normal", f"must be a unit vector, has length {length:.9g}")
        mu = non_negative_number(optional(item, "mu", assembly.mu), f"{where}.mu")
        contacts.append(ExplicitContact(names[0], names[1], point, normal / length, mu))
    return tuple(contacts)
