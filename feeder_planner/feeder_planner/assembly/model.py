"""Assembly files (contract section 2): bodies as unions of boxes and convex polyhedra, in metres."""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from feeder_planner.assembly.geometry import ConvexPiece, box_piece, faces_piece, hull_piece, overlap_depth
from feeder_planner.assembly.tolerances import PENETRATION_TOLERANCE, UNIT_NORMAL_TOLERANCE
from feeder_planner.errors import InputError
from feeder_planner.fields_io import (
    load_yaml_mapping,
    non_negative_number,
    optional,
    point_array,
    positive_number,
    required,
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

    @property
    def size(self) -> float:
        """Diagonal of the body's bounding box (m): the length scale of its torque equations."""
        lower = np.min([p.lower for p in self.pieces], axis=0)
        upper = np.max([p.upper for p in self.pieces], axis=0)
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
        lower = np.min([p.lower for b in self.bodies for p in b.pieces], axis=0)
        upper = np.max([p.upper for b in self.bodies for p in b.pieces], axis=0)
        return float(np.linalg.norm(upper - lower))

    @property
    def free_bodies(self) -> list[int]:
        """Indices of the bodies that are not grounded (the ones with equilibrium equations)."""
        return [i for i, body in enumerate(self.bodies) if not body.grounded]


def load_assembly(path: str | Path) -> Assembly:
    """Read and validate an assembly file; every error names the file and the field."""
    document = load_yaml_mapping(path)
    try:
        return assembly_from_document(document, str(path))
    except InputError as error:
        raise error.with_source(str(path)) from None


def assembly_from_text(text: str, source: str = "assembly_yaml") -> Assembly:
    """Parse an assembly given as YAML text (a service request field)."""
    try:
        document = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        raise InputError(
            "<yaml>", f"not valid YAML{f' at line {mark.line + 1}' if mark else ''}", source
        ) from None
    if not isinstance(document, dict):
        raise InputError("<top level>", "expected a mapping of fields", source)
    try:
        return assembly_from_document(document, source)
    except InputError as error:
        raise error.with_source(source) from None


def assembly_from_document(document: dict[str, Any], source: str = "") -> Assembly:
    """Validate a parsed assembly mapping and build the bodies with their mass properties."""
    scale = length_scale(optional(document, "length_unit", "m"))
    mu = non_negative_number(optional(document, "mu", 0.0), "mu")
    raw_bodies = required(document, "bodies")
    if not isinstance(raw_bodies, list) or not raw_bodies:
        raise InputError("bodies", "expected a non-empty list of bodies")
    bodies = [_body(raw, f"bodies[{i}]", scale) for i, raw in enumerate(raw_bodies)]
    names = [b.name for b in bodies]
    for i, name in enumerate(names):
        if names.index(name) != i:
            raise InputError(f"bodies[{i}].name", f"duplicate body name {name!r}")
    if not any(b.grounded for b in bodies):
        raise InputError("bodies", "no grounded body: at least one body needs 'grounded: true'")
    assembly = Assembly(
        str(optional(document, "name", "assembly")),
        tuple(bodies),
        mu,
        None,
        source,
        scale,
        {b.name: i for i, b in enumerate(bodies)},
    )
    _check_interpenetration(assembly)
    contacts = optional(document, "contacts", "auto")
    if contacts != "auto":
        explicit = _explicit_contacts(contacts, assembly, scale)
        assembly = Assembly(assembly.name, assembly.bodies, mu, explicit, source, scale, assembly.index)
    return assembly


def _body(raw: Any, field_name: str, scale: float) -> Body:
    """Read one body of the file: name, grounded flag, density and pieces, with its mass properties."""
    if not isinstance(raw, dict):
        raise InputError(field_name, f"expected a mapping, got {type(raw).__name__}")
    name = raw.get("name")
    if not isinstance(name, str) or not name:
        raise InputError(f"{field_name}.name", "is required: a non-empty string")
    grounded = optional(raw, "grounded", False)
    if not isinstance(grounded, bool):
        raise InputError(f"{field_name}.grounded", f"expected true or false, got {grounded!r}")
    density = positive_number(optional(raw, "density", 1.0), f"{field_name}.density")
    named = _box_pieces(raw, field_name, scale) + _convex_pieces(raw, field_name, scale)
    pieces = [piece for _, piece in named]
    fields = [item for item, _ in named]
    if not pieces:
        raise InputError(field_name, "a body needs at least one box or convex polyhedron")
    mass, center = _mass_properties(pieces, fields, density, field_name)
    return Body(name, grounded, tuple(pieces), mass, center, density, tuple(fields))


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
        lower = point_array([required(box, "min", f"{item}.min")], f"{item}.min", 3)[0] * scale
        upper = point_array([required(box, "max", f"{item}.max")], f"{item}.max", 3)[0] * scale
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
            points = (
                point_array(required(poly, "vertices", f"{item}.vertices"), f"{item}.vertices", 3) * scale
            )
            faces = required(poly, "faces", f"{item}.faces")
            if not isinstance(faces, list) or not all(isinstance(f, list) for f in faces):
                raise InputError(f"{item}.faces", "expected a list of vertex-index lists")
            pieces.append((item, faces_piece(points, faces, item)))
        else:
            pieces.append((item, hull_piece(point_array(poly, item, 3) * scale, item)))
    return pieces


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
    """Exact volume and centroid of a union of axis-aligned boxes (grid of all box planes)."""
    grids = [np.unique(np.concatenate([[b.lower[a], b.upper[a]] for b in boxes])) for a in range(3)]
    cells = np.zeros(tuple(len(g) - 1 for g in grids), dtype=bool)
    for b in boxes:
        slices = tuple(
            slice(np.searchsorted(grids[a], b.lower[a]), np.searchsorted(grids[a], b.upper[a]))
            for a in range(3)
        )
        cells[slices] = True
    widths = [np.diff(g) for g in grids]
    mids = [(g[1:] + g[:-1]) / 2 for g in grids]
    cell_volume = widths[0][:, None, None] * widths[1][None, :, None] * widths[2][None, None, :]
    filled = np.where(cells, cell_volume, 0.0)
    volume = float(filled.sum())
    center = (
        np.array(
            [
                (filled.sum(axis=(1, 2)) * mids[0]).sum(),
                (filled.sum(axis=(0, 2)) * mids[1]).sum(),
                (filled.sum(axis=(0, 1)) * mids[2]).sum(),
            ]
        )
        / volume
    )
    return volume, center


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


def _explicit_contacts(raw: Any, assembly: Assembly, scale: float) -> tuple[ExplicitContact, ...]:
    """Read the file's ``contacts`` list: bodies by name, point in metres, unit normal from b into a, mu."""
    if not isinstance(raw, list):
        raise InputError("contacts", "expected 'auto' or a list of {a, b, point, normal, mu} contacts")
    contacts = []
    for i, item in enumerate(raw):
        where = f"contacts[{i}]"
        if not isinstance(item, dict):
            raise InputError(where, "expected a mapping with a, b, point, normal")
        names = []
        for key in ("a", "b"):
            name = required(item, key, f"{where}.{key}")
            if name not in assembly.index:
                raise InputError(f"{where}.{key}", f"unknown body {name!r}")
            names.append(name)
        if names[0] == names[1]:
            raise InputError(f"{where}.b", "a contact joins two different bodies")
        point = point_array([required(item, "point", f"{where}.point")], f"{where}.point", 3)[0] * scale
        normal = point_array([required(item, "normal", f"{where}.normal")], f"{where}.normal", 3)[0]
        length = float(np.linalg.norm(normal))
        if abs(length - 1.0) > UNIT_NORMAL_TOLERANCE:
            raise InputError(f"{where}.normal", f"must be a unit vector, has length {length:.9g}")
        mu = non_negative_number(optional(item, "mu", assembly.mu), f"{where}.mu")
        contacts.append(ExplicitContact(names[0], names[1], point, normal / length, mu))
    return tuple(contacts)
