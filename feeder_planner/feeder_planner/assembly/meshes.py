"""Mesh bodies of an assembly file (``meshes:``): STL, OBJ and PLY surfaces read with trimesh, checked.

A mesh is a closed, consistently oriented triangle surface; its body may be non-convex. Each mesh entry is
``{file: PATH, scale: S, transform: 4x4}``: a file vertex x becomes T (S x) in the file's length unit (then
metres), T a rigid motion (rotation and translation; a reflection would turn the surface inside out). Mass
and centre of mass come from the enclosed volume (divergence theorem, exact for the polyhedron) and the
body's density. The contact side (coplanar faces merged into planar polygons) is ``mesh_contacts``.
"""

from __future__ import annotations

import functools
import os
import struct
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from feeder_planner.assembly.geometry import BoundedByVertices, ConvexPiece
from feeder_planner.errors import InputError
from feeder_planner.fields_io import finite_number, optional, positive_number, required

__all__ = [
    "BodyParts",
    "MAX_MESH_BYTES",
    "MAX_MESH_FACES",
    "MESH_SUFFIXES",
    "MeshPart",
    "body_surface",
    "checked_mesh",
    "load_mesh_part",
    "mesh_parts",
    "part_bounds",
    "resolve_mesh_path",
    "rigid_transform",
]

MESH_SUFFIXES = {".stl": "stl", ".obj": "obj", ".ply": "ply", ".step": "step", ".stp": "step"}
"""File name endings read as meshes, and trimesh's name of their format (STEP: OpenCASCADE, tessellated)."""
# STEP solids are tessellated with chords within this fraction of the file's bounding-box diagonal (the
# planar parts' chord tolerance, feeder_planner.cad.options.CHORD_TOLERANCE): boxes and planar faces are
# exact, a cylinder of the assembly's size gets about 160 chords around.
STEP_TESSELLATION = 1e-4
# A mesh beyond these is refused before trimesh parses it: 200,000 triangles load and are checked in about a
# second and 100 MB here; a 2-million-face CAD export would take tens of seconds and gigabytes, and contact
# finding needs only the planar faces, which a decimated export keeps.
MAX_MESH_FACES = 200_000
MAX_MESH_BYTES = 64 * 1024 * 1024
# Relative to the mesh's bounding-box diagonal: a rotation's columns orthonormal to this, a triangle's area
# below this times diagonal^2 counts as degenerate, an enclosed volume below this times diagonal^3 as zero.
RIGID_TOLERANCE = 1e-9
DEGENERATE_AREA = 1e-12
ZERO_VOLUME = 1e-12


@dataclass(frozen=True)
class MeshPart(BoundedByVertices):
    """One checked mesh of a body, in metres (assembly frame): triangles, volume and centroid."""

    field: str
    path: str
    vertices: np.ndarray  # (n, 3)
    faces: np.ndarray  # (m, 3) vertex indices, counter-clockwise seen from outside
    volume: float
    centroid: np.ndarray

    @property
    def triangles(self) -> np.ndarray:
        """The (m, 3, 3) corner coordinates of every face."""
        return self.vertices[self.faces]

    def surface_distance(self, point: np.ndarray) -> float:
        """Return the exact distance (m) from ``point`` to the nearest face of the mesh.

        Per triangle: the distance to its plane where the foot of the perpendicular lies inside it
        (barycentric coordinates all >= 0), else the distance to the nearest of its three edges.
        """
        corners = self.triangles
        a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
        normal = np.cross(b - a, c - a)
        area2 = np.einsum("ij,ij->i", normal, normal)  # > 0: degenerate faces are refused when read
        offset = point - a
        height = np.einsum("ij,ij->i", offset, normal) / area2
        foot = point - height[:, None] * normal
        inside = np.ones(len(corners), dtype=bool)
        for start, end in ((a, b), (b, c), (c, a)):
            inside &= np.einsum("ij,ij->i", np.cross(end - start, foot - start), normal) >= 0.0
        plane = np.abs(height) * np.sqrt(area2)
        edges = np.full(len(corners), np.inf)
        for start, end in ((a, b), (b, c), (c, a)):
            direction = end - start
            along = np.clip(
                np.einsum("ij,ij->i", point - start, direction) / np.einsum("ij,ij->i", direction, direction),
                0.0,
                1.0,
            )
            edges = np.minimum(edges, np.linalg.norm(start + along[:, None] * direction - point, axis=1))
        return float(np.min(np.where(inside, plane, edges)))


def mesh_parts(
    raw: dict[str, Any], field_name: str, scale: float, base_dir: str | Path | None
) -> list[tuple[str, MeshPart]]:
    """Read a body's ``meshes`` list (paths relative to ``base_dir``) as checked parts, with their fields."""
    meshes = optional(raw, "meshes", [])
    if not isinstance(meshes, list):
        raise InputError(f"{field_name}.meshes", "expected a list of {file, scale, transform} meshes")
    parts = []
    for j, entry in enumerate(meshes):
        item = f"{field_name}.meshes[{j}]"
        if not isinstance(entry, dict):
            raise InputError(item, "expected a mapping with file (and optional scale, transform)")
        unknown = sorted(set(entry) - {"file", "scale", "transform", "body"})
        if unknown:
            raise InputError(f"{item}.{unknown[0]}", "unknown key (a mesh has file, scale, transform, body)")
        name = required(entry, "file", f"{item}.file")
        if not isinstance(name, str) or not name:
            raise InputError(f"{item}.file", f"expected a file path (a string), got {name!r}")
        factor = positive_number(optional(entry, "scale", 1.0), f"{item}.scale")
        transform = rigid_transform(optional(entry, "transform", None), f"{item}.transform")
        path = resolve_mesh_path(name, base_dir, f"{item}.file")
        body = _step_body(entry, path, item)
        parts.append((item, load_mesh_part(path, item, factor * scale, transform, scale, body)))
    return parts


def _step_body(entry: dict[str, Any], path: Path, item: str) -> int | None:
    """Return a STEP mesh's ``body`` (its solid's number, default 1); refuse ``body`` for other meshes."""
    is_step = MESH_SUFFIXES[path.suffix.lower()] == "step"
    if "body" not in entry:
        return 1 if is_step else None
    body = entry["body"]
    if not is_step:
        raise InputError(f"{item}.body", "only a STEP file has bodies; remove body")
    if isinstance(body, bool) or not isinstance(body, int) or body < 1:
        raise InputError(f"{item}.body", f"expected a solid's number 1, 2, ..., got {body!r}"[:200])
    return body


def resolve_mesh_path(name: str, base_dir: str | Path | None, field: str) -> Path:
    """Return the mesh file ``name`` (absolute, or relative to ``base_dir``); InputError naming ``field``."""
    path = Path(name).expanduser()
    if not path.is_absolute():
        if base_dir is None:
            raise InputError(field, f"relative mesh path {name!r} needs a base directory (none is known)")
        path = Path(base_dir) / path
    if path.suffix.lower() not in MESH_SUFFIXES:
        raise InputError(
            field,
            f"{str(path)!r}: unknown mesh format {path.suffix!r} (expected .stl, .obj, .ply, .step or .stp)",
        )
    if not path.is_file():
        raise InputError(field, f"mesh file {str(path)!r} does not exist (or is not a file)")
    if not os.access(path, os.R_OK):
        raise InputError(field, f"mesh file {str(path)!r} is not readable")
    return path


def rigid_transform(value: Any, field: str) -> np.ndarray:
    """Return a 4x4 rigid transform (identity for None): rotation with det +1 and last row (0, 0, 0, 1)."""
    if value is None:
        return np.eye(4)
    if not isinstance(value, list) or len(value) != 4 or not all(isinstance(r, list) for r in value):
        raise InputError(field, "expected a 4x4 matrix (a list of 4 rows of 4 numbers)")
    rows = []
    for i, row in enumerate(value):
        if len(row) != 4:
            raise InputError(f"{field}[{i}]", f"expected 4 numbers, got {len(row)}")
        rows.append([finite_number(x, f"{field}[{i}][{k}]") for k, x in enumerate(row)])
    matrix = np.array(rows)
    if np.abs(matrix[3] - [0.0, 0.0, 0.0, 1.0]).max() > RIGID_TOLERANCE:
        raise InputError(f"{field}[3]", f"the last row must be [0, 0, 0, 1], got {matrix[3].tolist()}")
    rotation = matrix[:3, :3]
    error = float(np.abs(rotation.T @ rotation - np.eye(3)).max())
    if error > RIGID_TOLERANCE:
        raise InputError(
            field,
            f"not a rigid transform: the 3x3 block is not a rotation (R^T R differs from I by {error:.3g}; "
            "scale goes in 'scale')",
        )
    if np.linalg.det(rotation) < 0:
        raise InputError(field, "not a rigid transform: it is a reflection (determinant -1)")
    return matrix


def load_mesh_part(
    path: Path,
    field: str,
    factor: float,
    transform: np.ndarray,
    unit_scale: float = 1.0,
    body: int | None = None,
) -> MeshPart:
    """Read and check one mesh file: size limits, finite vertices, closed, oriented, no degenerate faces.

    ``factor`` (mesh scale times the file's unit) scales the file's vertices, ``transform`` (translation in
    the file's unit, ``unit_scale`` metres each) then moves them rigidly. A STEP file carries its own unit,
    which replaces the assembly's in ``factor``; ``body`` is its solid, placed as the file places it.
    """
    where = f"{field}.file"
    if body is not None:
        if path.stat().st_size > MAX_MESH_BYTES:
            raise InputError(where, f"{str(path)!r}: more than the {MAX_MESH_BYTES} byte limit")
        stat = path.stat()
        try:
            vertices, faces, metres = _step_mesh(str(path), body, stat.st_size, stat.st_mtime_ns)
        except InputError as error:
            raise InputError(
                f"{where} solid {body}", f"{str(path)!r}: {error.field}: {error.problem}"
            ) from None
        vertices = vertices * (metres * factor / unit_scale)
        vertices = vertices @ transform[:3, :3].T + transform[:3, 3] * unit_scale
        return checked_mesh(path, field, vertices, faces)
    size = path.stat().st_size
    # The declared face count first (binary STL, PLY headers; text files up to the byte limit are counted):
    # a 2-million-face export is refused for its faces, before the byte limit.
    faces_hint = _face_count_hint(path) if size <= MAX_MESH_BYTES or _has_header(path) else None
    if faces_hint is not None and faces_hint > MAX_MESH_FACES:
        raise InputError(
            where,
            f"{str(path)!r}: {faces_hint} faces is more than the limit of {MAX_MESH_FACES} "
            "(decimate the mesh: contacts need only its planar faces)",
        )
    if size > MAX_MESH_BYTES:
        raise InputError(where, f"{str(path)!r}: {size} bytes is more than the {MAX_MESH_BYTES} byte limit")
    stat = path.stat()
    try:
        vertices, faces = _file_mesh(str(path), stat.st_size, stat.st_mtime_ns)
    except _MeshFileError as error:
        raise InputError(where, f"{str(path)!r}: {error}") from None
    vertices = vertices * factor
    vertices = vertices @ transform[:3, :3].T + transform[:3, 3] * unit_scale
    return checked_mesh(path, field, vertices, faces)


@functools.lru_cache(maxsize=32)
def _step_mesh(path: str, body: int, size: int, mtime_ns: int) -> tuple[np.ndarray, np.ndarray, float]:
    """Tessellate solid ``body`` of a STEP file: vertices (file numbers), faces, metres per number; cached."""
    from feeder_planner.cad.step import read_step_solids

    del size, mtime_ns  # only part of the cache key
    solids, metres, _unit = read_step_solids(path, STEP_TESSELLATION)
    if body > len(solids):
        raise InputError("body", f"the file has {len(solids)} solid(s), not {body}")
    solid = solids[body - 1]
    if len(solid.faces) > MAX_MESH_FACES:
        raise InputError("body", f"{len(solid.faces)} faces after tessellation, more than {MAX_MESH_FACES}")
    return solid.vertices, solid.faces, metres


class _MeshFileError(Exception):
    """What is wrong with a mesh file itself (the caller adds the file and the field)."""


@functools.lru_cache(maxsize=32)
def _file_mesh(path: str, size: int, mtime_ns: int) -> tuple[np.ndarray, np.ndarray]:
    """Parse a file with trimesh and merge its coincident vertices; cached by path, size and time.

    A pallet or a wall places one file many times: parsing it once saves most of the reading time. The
    size and modification time in the key make an edited file be read again. No trimesh processing, so
    NaN vertices are seen, not dropped.
    """
    import trimesh  # imported here: trimesh costs about 0.3 s to import and most assemblies have no mesh

    del size, mtime_ns  # only part of the cache key
    try:
        mesh = trimesh.load(
            path, file_type=MESH_SUFFIXES[Path(path).suffix.lower()], force="mesh", process=False
        )
    except Exception as exc:  # trimesh raises many kinds (ValueError, struct.error, KeyError...) on bad files
        raise _MeshFileError(f"cannot read the mesh ({type(exc).__name__}: {exc})") from None
    vertices = np.asarray(getattr(mesh, "vertices", np.zeros((0, 3))), dtype=float).reshape(-1, 3)
    faces = np.asarray(getattr(mesh, "faces", np.zeros((0, 3))), dtype=np.int64).reshape(-1, 3)
    if len(faces) == 0:
        raise _MeshFileError("the file holds no triangles")
    if len(faces) > MAX_MESH_FACES:
        raise _MeshFileError(f"{len(faces)} faces is more than the limit of {MAX_MESH_FACES}")
    if len(faces) and (faces.min() < 0 or faces.max() >= len(vertices)):
        raise _MeshFileError("a face refers to a vertex the file does not have")
    bad = np.nonzero(~np.isfinite(vertices).all(axis=1))[0]
    if len(bad):
        raise _MeshFileError(f"vertex {int(bad[0])} is not finite ({len(bad)} such vertices)")
    vertices, faces = _merge_vertices(vertices, faces)
    vertices.flags.writeable = False  # shared by every body that places this file
    faces.flags.writeable = False
    return vertices, faces


def checked_mesh(path: Path, field: str, vertices: np.ndarray, faces: np.ndarray) -> MeshPart:
    """Refuse open, inconsistently oriented, degenerate or empty meshes (vertices already merged)."""
    where = f"{field}.file"
    name = repr(str(path))
    diagonal = float(np.linalg.norm(vertices.max(axis=0) - vertices.min(axis=0)))
    if diagonal == 0.0:
        raise InputError(where, f"{name}: zero volume (all vertices coincide)")
    corners = vertices[faces]
    areas = 0.5 * np.linalg.norm(
        np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1
    )
    degenerate = np.nonzero(areas <= DEGENERATE_AREA * diagonal * diagonal)[0]
    if len(degenerate):
        raise InputError(
            where,
            f"{name}: {len(degenerate)} degenerate face(s) of zero area (first: face {int(degenerate[0])})",
        )
    _check_closed_and_oriented(faces, where, name)
    volume, centroid = _volume_centroid(corners)
    if abs(volume) <= ZERO_VOLUME * diagonal**3:
        raise InputError(where, f"{name}: zero volume (a flat or empty surface)")
    if volume < 0:
        raise InputError(where, f"{name}: the faces point inward (negative enclosed volume {volume:.3g})")
    return MeshPart(field, str(path), vertices, faces, float(volume), centroid)


def _merge_vertices(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Merge bit-identical vertex positions (STL repeats every corner), dropping unused vertices."""
    unique, inverse = np.unique(vertices, axis=0, return_inverse=True)
    faces = inverse.reshape(-1)[faces]
    used, remap = np.unique(faces, return_inverse=True)
    return unique[used], remap.reshape(-1, 3)


def _check_closed_and_oriented(faces: np.ndarray, where: str, name: str) -> None:
    """Refuse a surface unless every edge is in two faces, traversed once each way (closed, oriented)."""
    directed = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    undirected = np.sort(directed, axis=1)
    _, counts = np.unique(undirected, axis=0, return_counts=True)
    open_edges = int(np.sum(counts == 1))
    shared = int(np.sum(counts > 2))
    if open_edges:
        raise InputError(where, f"{name}: not watertight: {open_edges} open edge(s) (in only one face)")
    if shared:
        raise InputError(
            where, f"{name}: not a manifold surface: {shared} edge(s) shared by more than two faces"
        )
    _, directed_counts = np.unique(directed, axis=0, return_counts=True)
    flipped = int(np.sum(directed_counts > 1))
    if flipped:
        raise InputError(
            where, f"{name}: inconsistently oriented: {flipped} edge(s) traversed the same way by both faces"
        )


def _volume_centroid(corners: np.ndarray) -> tuple[float, np.ndarray]:
    """Volume and centroid of a closed oriented surface: signed tetrahedra to a reference point."""
    reference = corners.reshape(-1, 3).mean(axis=0)
    a, b, c = (corners[:, k] - reference for k in range(3))
    tets = np.einsum("ij,ij->i", a, np.cross(b, c)) / 6.0
    volume = float(tets.sum())
    if volume == 0.0:
        return 0.0, reference
    return volume, reference + (tets[:, None] * (a + b + c)).sum(axis=0) / (4.0 * volume)


def _has_header(path: Path) -> bool:
    """Whether the file declares its face count in a header (binary STL or PLY): read in O(1)."""
    with path.open("rb") as handle:
        head = handle.read(5)
    suffix = path.suffix.lower()
    return (suffix == ".stl" and not head.lower().startswith(b"solid")) or (
        suffix == ".ply" and head.startswith(b"ply")
    )


def _face_count_hint(path: Path) -> int | None:
    """Return the face count a file declares, read without parsing it (binary STL, PLY header) or None."""
    suffix = path.suffix.lower()
    with path.open("rb") as handle:
        head = handle.read(4096)
    if suffix == ".stl" and not head.lstrip().lower().startswith(b"solid") and len(head) >= 84:
        return int(struct.unpack("<I", head[80:84])[0])
    if suffix == ".ply" and head.startswith(b"ply"):
        for line in head.split(b"\n"):
            words = line.split()
            if len(words) == 3 and words[0] == b"element" and words[1] == b"face":
                try:
                    return int(words[2])
                except ValueError:
                    return None
            if line.strip() == b"end_header":
                break
        return None
    if suffix in (".obj", ".stl"):
        # Text formats: a face is a line starting 'f ' (OBJ) or 'facet' (ASCII STL); counting is one read.
        marker = b"\nf " if suffix == ".obj" else b"facet"
        count = 0
        with path.open("rb") as handle:
            tail = b""
            while chunk := handle.read(1 << 20):
                block = tail + chunk
                count += block.count(marker) - tail.count(marker)
                tail = block[-8:]
        return count
    return None


class BodyParts(Protocol):
    """The parts of a body (``model.Body``, which imports this module): its convex pieces and its meshes."""

    @property
    def pieces(self) -> Sequence[ConvexPiece]:
        """The body's convex pieces."""
        ...

    @property
    def piece_fields(self) -> Sequence[str]:
        """The file field of each piece, in the pieces' order."""
        ...

    @property
    def meshes(self) -> Sequence[MeshPart]:
        """The body's meshes."""
        ...


def part_bounds(parts: Sequence[BoundedByVertices]) -> tuple[np.ndarray, np.ndarray]:
    """Return the lower and upper corners of the bounding box of parts (convex pieces or meshes)."""
    return np.min([p.lower for p in parts], axis=0), np.max([p.upper for p in parts], axis=0)


def body_surface(body: BodyParts) -> list[np.ndarray]:
    """Return a body's surface as 3-D polygons (m): its pieces' faces, then its meshes' triangles.

    For drawings and markers, which until meshes knew only ``body.pieces``: one list covers both.
    """
    polygons = [face.polygon for piece in body.pieces for face in piece.faces]
    for mesh in body.meshes:
        polygons.extend(mesh.triangles)
    return polygons
