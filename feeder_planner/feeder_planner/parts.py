"""Planar parts (polygons with holes) as the contract's part files describe them."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from feeder_planner import cad, polygon
from feeder_planner.errors import InputError
from feeder_planner.fields_io import (
    load_yaml_mapping,
    optional,
    point_array,
    positive_number,
    required,
    short_string,
)
from feeder_planner.limits import MAX_DENSITY, MAX_PART_VERTICES, check_count, check_length_scale
from feeder_planner.units import length_scale

# Contract section 2: a part file without `density` has uniform areal density 1 kg/m^2.
DEFAULT_DENSITY = 1.0


@dataclass(frozen=True)
class Part:
    """A rigid planar part in its own frame: centroid at the origin, lengths in metres.

    ``outer`` is counter-clockwise, every hole clockwise, so that boundary integrals
    over ``loops()`` are integrals over the part's area. ``file_vertices`` keeps the
    outer boundary in the file's order (and frame, in metres), which the throwing
    arm's hull numbering follows.
    """

    name: str
    outer: np.ndarray
    holes: tuple[np.ndarray, ...]
    density: float
    area: float
    offset: np.ndarray  # centroid of the file's frame, in metres: part frame = file frame - offset
    file_vertices: np.ndarray  # outer boundary as given (metres, file frame, file order)
    unit_scale: float = 1.0  # metres per length unit of the file
    second_moment: tuple[float, float, float] = field(default=(0.0, 0.0, 0.0))  # Ixx, Iyy, Ixy about centroid

    @property
    def mass(self) -> float:
        """Mass (kg): areal density times area."""
        return self.density * self.area

    @property
    def polar_moment(self) -> float:
        """Integral of |r|^2 over the part about its centroid (m^4)."""
        return self.second_moment[0] + self.second_moment[1]

    @property
    def radius(self) -> float:
        """Largest distance from the centroid to a vertex (m)."""
        return float(np.hypot(self.outer[:, 0], self.outer[:, 1]).max())

    def loops(self) -> tuple[np.ndarray, ...]:
        """Outer loop and holes, oriented so the area is to the left of every edge."""
        return (self.outer, *self.holes)

    def placed(self, x: float, y: float, theta: float) -> tuple[np.ndarray, ...]:
        """Return the part's loops in the plane frame at configuration (x, y, theta)."""
        c, s = np.cos(theta), np.sin(theta)
        rotation = np.array([[c, -s], [s, c]])
        return tuple(loop @ rotation.T + np.array([x, y]) for loop in self.loops())


def make_part(
    vertices: object,
    holes: object = (),
    density: float = DEFAULT_DENSITY,
    name: str = "part",
    unit_scale: float = 1.0,
    field_prefix: str = "",
) -> Part:
    """Validate and build a Part; vertices are in units of ``unit_scale`` metres.

    Limits (``feeder_planner.limits``): at most MAX_PART_VERTICES vertices (outer and holes), a length
    scale within [MIN_LENGTH_M, MAX_LENGTH_M], a density of at most MAX_DENSITY, a short one-line name.
    Memory is linear in the vertices: every intersection test is one sweep (``polygon.loop_contacts``).
    """
    outer_field = f"{field_prefix}vertices"
    if isinstance(vertices, (list, tuple)):
        check_count(len(vertices), MAX_PART_VERTICES, outer_field, "vertices")
    outer = point_array(vertices, outer_field, 2, min_points=3) * unit_scale
    _check_scale(outer, outer_field)
    polygon.check_simple(outer, outer_field)
    if not isinstance(holes, (list, tuple)):
        raise InputError(f"{field_prefix}holes", f"expected a list of polygons, got {type(holes).__name__}")
    total = len(outer)
    hole_loops: list[np.ndarray] = []
    for index, hole in enumerate(holes):
        hole_field = f"{field_prefix}holes[{index}]"
        if isinstance(hole, (list, tuple)):
            total += len(hole)
            check_count(total, MAX_PART_VERTICES, hole_field, "vertices of the part (outer and holes)")
        loop = point_array(hole, hole_field, 2, min_points=3) * unit_scale
        _check_scale(loop, hole_field)
        polygon.check_simple(loop, hole_field)
        hole_loops.append(loop)
    _check_holes(outer, hole_loops, field_prefix)
    density_value = positive_number(density, f"{field_prefix}density")
    if density_value > MAX_DENSITY:
        raise InputError(
            f"{field_prefix}density", f"{density_value:.3g} exceeds the limit of {MAX_DENSITY:g}"
        )
    name = short_string(name, f"{field_prefix}name")

    ccw_outer = outer if polygon.signed_area(outer) > 0 else outer[::-1]
    cw_holes = [h if polygon.signed_area(h) < 0 else h[::-1] for h in hole_loops]
    area, sx, sy = 0.0, 0.0, 0.0
    for loop in (ccw_outer, *cw_holes):
        a, mx, my = polygon.first_moments(loop)
        area, sx, sy = area + a, sx + mx, sy + my
    offset = np.array([sx / area, sy / area])
    centred = [loop - offset for loop in (ccw_outer, *cw_holes)]
    moments = np.zeros(3)
    for loop in centred:
        moments += np.array(polygon.second_moments(loop))
    return Part(
        name=name,
        outer=centred[0],
        holes=tuple(centred[1:]),
        density=density_value,
        area=area,
        offset=offset,
        file_vertices=outer,
        unit_scale=unit_scale,
        second_moment=(float(moments[0]), float(moments[1]), float(moments[2])),
    )


def _check_scale(loop: np.ndarray, field: str) -> None:
    """Refuse a loop (metres) whose coordinates or span leave the models' length range."""
    check_length_scale(float(np.abs(loop).max()), float(np.ptp(loop, axis=0).max()), field)


def _check_holes(outer: np.ndarray, holes: list[np.ndarray], field_prefix: str) -> None:
    """Refuse a hole not strictly inside the outer boundary, or overlapping an earlier hole.

    One sweep finds every pair of loops whose boundaries touch (``polygon.loop_contacts``); loops whose
    boundaries are apart are nested or disjoint, which one vertex of each tells (even-odd rule).
    """
    if not holes:
        return
    contacts = polygon.loop_contacts([outer, *holes])  # loop 0 is the outer boundary, loop k+1 hole k
    touching = {(int(a), int(b)) for a, b in contacts}
    firsts = np.array([hole[0] for hole in holes])
    in_outer = polygon.points_in_polygon(firsts, outer)
    # overlap[k, l]: hole k's first vertex is inside hole l, or hole l's inside hole k, or they touch.
    nested = np.stack([polygon.points_in_polygon(firsts, hole) for hole in holes], axis=1)
    overlap = nested | nested.T
    for a, b in touching:
        if a > 0:
            overlap[a - 1, b - 1] = overlap[b - 1, a - 1] = True
    for k in range(len(holes)):
        hole_field = f"{field_prefix}holes[{k}]"
        if (0, k + 1) in touching or not in_outer[k]:
            raise InputError(hole_field, "hole is not strictly inside the outer boundary")
        earlier = np.flatnonzero(overlap[k, :k])
        if earlier.size:
            raise InputError(hole_field, f"hole overlaps holes[{int(earlier[0])}]")


def part_from_mapping(document: dict[str, Any]) -> Part:
    """Build a Part from a parsed part file (contract section 2)."""
    scale = length_scale(optional(document, "length_unit", "m"))
    return make_part(
        required(document, "vertices"),
        optional(document, "holes", []),
        optional(document, "density", DEFAULT_DENSITY),
        optional(document, "name", "part"),
        scale,
    )


def load_part(path: str | Path) -> Part:
    """Read and validate a part file; every error names the file and the field.

    A CAD file (``.dxf``...) is read by ``feeder_planner.cad``; so is the file a part YAML's ``cad:``
    mapping names (relative to the YAML), with that mapping's options and the YAML's name and density.
    """
    if cad.is_cad_file(path):
        return cad_part(path)
    document = load_yaml_mapping(path)
    try:
        if "cad" in document:
            return _cad_document_part(document, Path(path).parent)
        return part_from_mapping(document)
    except InputError as error:
        raise (error if error.source else error.with_source(str(path))) from None


def part_document(path: str | Path) -> dict[str, Any]:
    """Return the contract-section-2 document of any part file (a CAD part's as read, in metres).

    A plain part YAML is returned as written; a CAD part (a CAD file, or a YAML with ``cad:``) as its
    outline and holes as read, in metres and the file's frame. It is what a node publishes as its part
    (``~/part``), so that another node rebuilds the same part without the CAD file.
    """
    if not cad.is_cad_file(path):
        document = load_yaml_mapping(path)
        if "cad" not in document:
            return document
    part = load_part(path)
    return {
        "name": part.name,
        "length_unit": "m",
        "vertices": part.file_vertices.tolist(),
        "holes": [(hole + part.offset).tolist() for hole in part.holes],
        "density": part.density,
    }


def _cad_document_part(document: dict[str, Any], base: Path) -> Part:
    """Return the part a YAML's ``cad: {file: ..., options}`` names, with the YAML's name and density."""
    raw = document["cad"]
    if not isinstance(raw, dict):
        raise InputError("cad", "expected a mapping with file (and options: docs/cli.md, Importing parts)")
    extra = sorted(set(document) - {"cad", "name", "density"})
    if extra:
        raise InputError(
            extra[0], "a part with cad: takes its geometry and unit from the CAD file; remove it"
        )
    file = short_string(required(raw, "file", "cad.file"), "cad.file")
    target = Path(file).expanduser()
    target = target if target.is_absolute() else base / target
    if not cad.is_cad_file(target):
        raise InputError("cad.file", f"{file!r} is not a CAD file (expected {', '.join(cad.CAD_SUFFIXES)})")
    options = cad.options_from_mapping(raw, "cad")
    density = positive_number(optional(document, "density", DEFAULT_DENSITY), "density")
    name = optional(document, "name", None)
    return cad_part(target, options, None if name is None else short_string(name, "name"), density)


def cad_part(
    path: str | Path,
    options: cad.CadOptions | None = None,
    name: str | None = None,
    density: float = DEFAULT_DENSITY,
) -> Part:
    """Read a CAD file as a Part: its outline, holes and unit; the name defaults to the file's stem."""
    return part_from_outline(cad.read_outline(path, options), path, name, density)


def part_from_outline(
    outline: cad.Outline, path: str | Path, name: str | None = None, density: float = DEFAULT_DENSITY
) -> Part:
    """Make a read outline a Part (errors name ``path``); the name defaults to the file's stem."""
    try:
        return make_part(
            outline.outer.points.tolist(),
            [hole.points.tolist() for hole in outline.holes],
            density,
            name if name is not None else Path(path).stem[:256] or "part",
            outline.unit_scale,
        )
    except InputError as error:
        raise error.with_source(str(path)) from None
