"""Planar parts from STL solids: the outline the solid rests on, or its section by a plane.

The mesh is read and checked (closed, oriented, no degenerate faces) by the assembly's mesh reader. Resting
on ``face`` (default ``-z``: the solid lies on its lowest z face, seen from +z) the outline is the
solid's silhouette along that axis: the union of its projected triangles (shapely), so a through hole is a
hole and a blind pocket is not. With ``section`` the outline is instead the cut by the plane across
``face``'s axis at that coordinate (file unit): the cut's segments chained as any drawing's. The frame
(u, v) of each face: -z (x, y), +z (x, -y), -x (y, z), +x (-y, z), -y (-x, z), +y (x, z); each seen from
outside the face, so that the part is not mirrored.

STL has no unit: ``unit`` must be given, else the units are missing and the file is refused.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from feeder_planner import polygon
from feeder_planner.cad.options import CadOptions, unit_scale
from feeder_planner.cad.outline import Loop, Outline, Piece, assemble_outline
from feeder_planner.errors import InputError

__all__ = ["read_stl", "solid_outline"]

# Face -> (axis along which the solid is seen, index of u, sign of u, index of v, sign of v).
_FRAMES = {
    "-z": (2, 0, 1.0, 1, 1.0),
    "+z": (2, 0, 1.0, 1, -1.0),
    "-x": (0, 1, 1.0, 2, 1.0),
    "+x": (0, 1, -1.0, 2, 1.0),
    "-y": (1, 0, -1.0, 2, 1.0),
    "+y": (1, 0, 1.0, 2, 1.0),
}


def read_stl(path: str | Path, options: CadOptions) -> Outline:
    """Read an STL solid's resting outline (or section) with its holes; InputError naming the problem."""
    from feeder_planner.assembly.meshes import load_mesh_part

    if options.unit is None:
        raise InputError(
            "<unit>",
            "units missing: STL has none; give unit: (m, cm, mm, in...) in the part YAML's cad: mapping",
        )
    scale = unit_scale(options.unit, "cad.unit")
    mesh = load_mesh_part(Path(path), "solid", 1.0, np.eye(4))  # checks closed, oriented, non-degenerate
    return solid_outline(mesh.triangles, options, scale, f"{options.unit} (given by unit)")


def solid_outline(triangles: np.ndarray, options: CadOptions, scale: float, unit_name: str) -> Outline:
    """Return the outline of a checked solid's triangles (m, 3, 3), resting on ``face`` or in ``section``."""
    along, iu, su, iv, sv = _FRAMES[options.face or "-z"]
    flat = np.stack([triangles[:, :, iu] * su, triangles[:, :, iv] * sv], axis=2)
    if options.section is None:
        pieces = _silhouette(flat)
    else:
        pieces = _section(triangles, flat, along, options.section)
    choose = "choose another face: or section:, or export one part per file"
    outer, holes = assemble_outline(pieces, choose)
    how = (
        f"section at {options.section:g} across {options.face or '-z'}" if options.section is not None else ""
    )
    notes = (how,) if how else ()
    # What the drawing shows under the outline: the solid's triangles as seen from the face.
    seen = tuple(Piece(corners, True, f"triangle {k}") for k, corners in enumerate(flat))
    return Outline(_canonical(outer), holes, scale, unit_name, seen + tuple(pieces), notes)


def _canonical(loop: Loop) -> Loop:
    """Return the loop counter-clockwise from its lowest (then leftmost) vertex.

    A solid has no vertex order of its own, and the throwing arm numbers hull edges in the outline's
    order: this rule makes the numbering the file's (a YAML part drawn the same way numbers alike).
    """
    points = loop.points if polygon.signed_area(loop.points) > 0 else loop.points[::-1]
    first = int(np.lexsort((points[:, 0], points[:, 1]))[0])
    return Loop(np.roll(points, -first, axis=0), loop.labels)


def _silhouette(flat: np.ndarray) -> list[Piece]:
    """Return the union of the projected triangles as closed pieces (outline and holes)."""
    import shapely  # type: ignore[import-untyped]

    areas = 0.5 * np.abs(
        (flat[:, 1, 0] - flat[:, 0, 0]) * (flat[:, 2, 1] - flat[:, 0, 1])
        - (flat[:, 2, 0] - flat[:, 0, 0]) * (flat[:, 1, 1] - flat[:, 0, 1])
    )
    seen = flat[
        areas > 1e-12 * float(np.ptp(flat.reshape(-1, 2), axis=0).max()) ** 2
    ]  # side faces project to lines
    union = shapely.union_all(shapely.polygons(np.concatenate([seen, seen[:, :1]], axis=1)))
    union = shapely.simplify(union, 0.0)  # drops the collinear vertices where triangles met
    polygons = list(getattr(union, "geoms", [union]))
    pieces = []
    for k, shape in enumerate(polygons):
        pieces.append(Piece(np.asarray(shape.exterior.coords)[:-1], True, f"silhouette outline {k}"))
        for j, ring in enumerate(shape.interiors):
            pieces.append(Piece(np.asarray(ring.coords)[:-1], True, f"silhouette hole {j} of outline {k}"))
    return pieces


def _section(triangles: np.ndarray, flat: np.ndarray, along: int, level: float) -> list[Piece]:
    """Return the segments where the plane ``coordinate[along] == level`` cuts the triangles."""
    height = triangles[:, :, along] - level
    pieces = []
    for k in range(len(triangles)):
        h = height[k]
        if h.min() >= 0 or h.max() <= 0:
            continue  # the plane misses the face or only touches it: pick a level between vertices
        points = []
        for a, b in ((0, 1), (1, 2), (2, 0)):
            if (h[a] < 0) != (h[b] < 0):
                t = h[a] / (h[a] - h[b])
                points.append(flat[k, a] + t * (flat[k, b] - flat[k, a]))
        if len(points) == 2:
            pieces.append(Piece(np.array(points), False, f"section of face {k}"))
    if not pieces:
        raise InputError("cad.section", f"the plane at {level:g} misses the solid; choose a level inside it")
    return pieces
