"""Generated assembly documents (random towers, brick walls, mesh assemblies) for tests and benchmarks."""

from __future__ import annotations

from pathlib import Path
from typing import Any, cast

import numpy as np

__all__ = [
    "box_profile",
    "brick_wall",
    "dovetail_joint",
    "extruded_prism",
    "mesh_brick_wall",
    "mesh_pallet",
    "random_assembly",
    "stepped_stack",
    "write_mesh",
]


def random_assembly(
    seed: int, contact_faces: int, mu: float = 0.3, walls: bool = True, scale: float = 1.0
) -> dict[str, Any]:
    """Return an assembly document with about ``contact_faces`` touching face pairs (4 contact points each).

    Towers of boxes stand on a grounded base; each box is shifted at random but keeps overlapping the one
    below, so every contact is a generic rectangle. With ``walls`` a grounded wall touches the side of some
    towers.
    """
    rng = np.random.default_rng(seed)
    towers = max(1, int(np.sqrt(contact_faces / 2)))
    jitter = 0.3 / np.sqrt(max(1, contact_faces // towers))
    height = max(1, contact_faces // towers)
    bodies: list[dict[str, Any]] = []
    base = {
        "name": "base",
        "grounded": True,
        "boxes": [{"min": [-1.0, -1.0, -1.0], "max": [3.0 * towers + 1.0, 3.0, 0.0]}],
    }
    bodies.append(base)
    for t in range(towers):
        x0, y0, z = 3.0 * t + 0.5, 0.5, 0.0
        for level in range(height):
            w, d, h = rng.uniform(0.8, 1.2), rng.uniform(0.8, 1.2), rng.uniform(0.4, 1.0)
            x = x0 + rng.uniform(-jitter, jitter)
            y = y0 + rng.uniform(-jitter, jitter)
            bodies.append(
                {
                    "name": f"t{t}_{level}",
                    "density": float(rng.uniform(0.5, 2.0)),
                    "boxes": [{"min": [x, y, z], "max": [x + w, y + d, z + h]}],
                }
            )
            z += h
            if walls and level == 0 and t % 2 == 0:
                # A grounded wall flush with the first box's -x face.
                bodies.append(
                    {
                        "name": f"wall{t}",
                        "grounded": True,
                        "boxes": [{"min": [x - 0.2, y - 0.2, 0.0], "max": [x, y + d + 0.2, h]}],
                    }
                )
    for body in bodies:
        for box in body["boxes"]:
            box["min"] = [float(v * scale) for v in box["min"]]
            box["max"] = [float(v * scale) for v in box["max"]]
    return {
        "name": f"random_{seed}",
        "length_unit": "m",
        "mu": float(mu),
        "bodies": bodies,
        "contacts": "auto",
    }


def brick_wall(rows: int, columns: int, mu: float = 0.6) -> dict[str, Any]:
    """Return a running-bond wall of 2 x 1 x 1 bricks on a grounded footing: one connected sub-assembly.

    Each brick rests on two bricks of the row below (half offset) and touches its neighbours in its row, so
    there are about (3 rows x columns) contact faces of 4 points each.
    """
    bodies: list[dict[str, Any]] = [
        {
            "name": "footing",
            "grounded": True,
            "boxes": [{"min": [-1.0, -1.0, -1.0], "max": [2.0 * columns + 2.0, 2.0, 0.0]}],
        }
    ]
    for row in range(rows):
        offset = 0.0 if row % 2 == 0 else 1.0
        count = columns if row % 2 == 0 else columns - 1
        for column in range(count):
            x = offset + 2.0 * column
            bodies.append(
                {
                    "name": f"b{row}_{column}",
                    "boxes": [{"min": [x, 0.0, float(row)], "max": [x + 2.0, 1.0, float(row + 1)]}],
                }
            )
    return {
        "name": f"wall_{rows}x{columns}",
        "length_unit": "m",
        "mu": float(mu),
        "bodies": bodies,
        "contacts": "auto",
    }


def extruded_prism(profile: list[tuple[float, float]], y0: float, y1: float) -> tuple[np.ndarray, np.ndarray]:
    """Return (vertices, triangles) of a simple polygon in the x-z plane extruded from y = y0 to y = y1.

    The profile (x, z) may be non-convex; it is made counter-clockwise, its caps are ear-clipped, and the
    triangles are oriented outward: a closed, consistently oriented surface (what ``meshes:`` requires).
    """
    points = np.asarray(profile, float)
    if _signed_area(points) < 0:
        points = points[::-1]
    n = len(points)
    # Vertex k at y0 is k, at y1 is n + k. x cross z = -y: a profile CCW in (x, z) has its right-hand normal
    # along -y, so the y0 cap keeps the ear order and the y1 cap reverses it.
    vertices = np.vstack(
        [
            np.column_stack([points[:, 0], np.full(n, y0), points[:, 1]]),
            np.column_stack([points[:, 0], np.full(n, y1), points[:, 1]]),
        ]
    )
    faces: list[tuple[int, int, int]] = []
    for a, b, c in _ear_clip(points):
        faces.append((a, b, c))  # y0 cap, outward -y
        faces.append((n + a, n + c, n + b))  # y1 cap, outward +y
    for k in range(n):
        m = (k + 1) % n
        faces.append((k, n + m, m))
        faces.append((k, n + k, n + m))
    return vertices, np.asarray(faces, dtype=np.int64)


def _signed_area(points: np.ndarray) -> float:
    """Shoelace area of a 2-D polygon: > 0 counter-clockwise."""
    x, y = points[:, 0], points[:, 1]
    return float(0.5 * (x @ np.roll(y, -1) - y @ np.roll(x, -1)))


def _ear_clip(points: np.ndarray) -> list[tuple[int, int, int]]:
    """Triangulate a simple counter-clockwise polygon by ear clipping (small profiles: O(n^3) is fine)."""
    remaining = list(range(len(points)))
    triangles = []
    while len(remaining) > 3:
        for index in range(len(remaining)):
            a, b, c = remaining[index - 1], remaining[index], remaining[(index + 1) % len(remaining)]
            pa, pb, pc = points[a], points[b], points[c]
            cross = (pb[0] - pa[0]) * (pc[1] - pa[1]) - (pb[1] - pa[1]) * (pc[0] - pa[0])
            if cross <= 1e-12:
                continue  # reflex or flat corner: not an ear
            others = [points[k] for k in remaining if k not in (a, b, c)]
            if any(_in_triangle(p, pa, pb, pc) for p in others):
                continue
            triangles.append((a, b, c))
            remaining.pop(index)
            break
        else:
            raise ValueError("profile is not a simple polygon (no ear found)")
    triangles.append((remaining[0], remaining[1], remaining[2]))
    return triangles


def _in_triangle(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> bool:
    """Whether p lies inside or on the counter-clockwise triangle abc."""

    def side(u: np.ndarray, v: np.ndarray) -> float:
        return float((v[0] - u[0]) * (p[1] - u[1]) - (v[1] - u[1]) * (p[0] - u[0]))

    return side(a, b) >= 0 and side(b, c) >= 0 and side(c, a) >= 0


def box_profile(x0: float, z0: float, x1: float, z1: float) -> list[tuple[float, float]]:
    """Return the rectangle [x0, x1] x [z0, z1] as an (x, z) profile."""
    return [(x0, z0), (x1, z0), (x1, z1), (x0, z1)]


def write_mesh(path: str | Path, vertices: np.ndarray, faces: np.ndarray) -> None:
    """Write a triangle mesh by trimesh in the format of the file's ending (.stl binary, .obj, .ply)."""
    import trimesh

    path = Path(path)
    file_type = {".stl": "stl", ".obj": "obj", ".ply": "ply"}[path.suffix.lower()]
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    # stl, obj and ply export as bytes or text (trimesh returns a dict only for its dict formats)
    data = cast("bytes | str", mesh.export(file_type=file_type))
    path.write_bytes(data if isinstance(data, bytes) else data.encode())


def dovetail_joint(directory: str | Path, mu: float = 0.0) -> dict[str, Any]:
    """Write the meshes of an interlocking dovetail joint into ``directory`` and return its assembly document.

    A grounded base with a dovetail slot along y (binary STL) holds a tail piece whose tenon fills the slot
    and whose cap rests on the base's top (OBJ); both bodies are non-convex. The tail cannot lift out, only
    slide along the slot: with mu = 0 the region is the great circle of directions across the slot; with
    friction the wedge can clamp the tail (rigid bodies, unbounded squeeze) and every direction is stable.
    """
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    base = [
        (-2.0, 0.0),
        (2.0, 0.0),
        (2.0, 1.5),
        (0.5, 1.5),
        (0.8, 0.75),
        (-0.8, 0.75),
        (-0.5, 1.5),
        (-2.0, 1.5),
    ]
    tail = [
        (-0.8, 0.75),
        (0.8, 0.75),
        (0.5, 1.5),
        (1.5, 1.5),
        (1.5, 2.0),
        (-1.5, 2.0),
        (-1.5, 1.5),
        (-0.5, 1.5),
    ]
    write_mesh(directory / "dovetail_base.stl", *extruded_prism(base, 0.0, 3.0))
    write_mesh(directory / "dovetail_tail.obj", *extruded_prism(tail, 0.5, 2.5))
    return {
        "name": "dovetail_joint",
        "length_unit": "cm",
        "mu": float(mu),
        "bodies": [
            # The meshes are drawn in decimetres: scale 10 makes them centimetres, the file's unit.
            {
                "name": "base",
                "grounded": True,
                "meshes": [{"file": f"{directory.name}/dovetail_base.stl", "scale": 10.0}],
            },
            {
                "name": "tail",
                "density": 0.8,
                "meshes": [{"file": f"{directory.name}/dovetail_tail.obj", "scale": 10.0}],
            },
        ],
        "contacts": "auto",
    }


def mesh_pallet(directory: str | Path, columns: int = 3, rows: int = 2, mu: float = 0.4) -> dict[str, Any]:
    """Write a pallet of parts into ``directory`` and return its assembly document.

    A grounded pallet deck (box mesh, PLY) carries ``columns`` x ``rows`` L-brackets (binary STL, one file
    placed by rigid transforms) with a block in each bracket's corner (PLY); every body is a mesh.
    """
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    pitch = 3.0
    deck_x, deck_y = pitch * columns, pitch * rows
    write_mesh(
        directory / "pallet_deck.ply", *extruded_prism(box_profile(0.0, -0.5, deck_x, 0.0), 0.0, deck_y)
    )
    bracket = [(0.0, 0.0), (2.0, 0.0), (2.0, 0.4), (0.4, 0.4), (0.4, 1.6), (0.0, 1.6)]
    write_mesh(directory / "l_bracket.stl", *extruded_prism(bracket, 0.0, 2.0))
    write_mesh(directory / "block.ply", *extruded_prism(box_profile(0.4, 0.4, 1.2, 1.0), 0.3, 1.5))
    bodies: list[dict[str, Any]] = [
        {
            "name": "deck",
            "grounded": True,
            "meshes": [{"file": f"{directory.name}/pallet_deck.ply", "scale": 10.0}],
        }
    ]
    for column in range(columns):
        for row in range(rows):
            x, y = 0.5 + pitch * column, 0.5 + pitch * row
            # Translations are in the file's unit (cm); the meshes are drawn in dm (scale 10).
            move = [
                [1.0, 0.0, 0.0, 10 * x],
                [0.0, 1.0, 0.0, 10 * y],
                [0.0, 0.0, 1.0, 0.0],
                [0.0, 0.0, 0.0, 1.0],
            ]
            bodies.append(
                {
                    "name": f"bracket_{column}_{row}",
                    "density": 2.7,
                    "meshes": [{"file": f"{directory.name}/l_bracket.stl", "scale": 10.0, "transform": move}],
                }
            )
            bodies.append(
                {
                    "name": f"block_{column}_{row}",
                    "density": 1.2,
                    "meshes": [{"file": f"{directory.name}/block.ply", "scale": 10.0, "transform": move}],
                }
            )
    return {
        "name": f"mesh_pallet_{columns}x{rows}",
        "length_unit": "cm",
        "mu": float(mu),
        "bodies": bodies,
        "contacts": "auto",
    }


def stepped_stack(directory: str | Path | None = None, mu: float = 0.5) -> dict[str, Any]:
    """Return a stack with a non-convex L-shaped body, as boxes (``directory`` None) or as meshes.

    On a grounded floor stands an L (two boxes, or one extruded L mesh), a block on its low step against
    its riser, and a bar across the top of both. Written as meshes (into ``directory``) every body is one
    mesh file (STL, OBJ, PLY mixed); the two documents describe the same solids, so they have the same
    stable region (the L's merged bottom face gives other contact points than its two boxes, spanning
    the same wrench cone).
    """
    solids: dict[str, list[list[list[float]]]] = {
        "floor": [[[-1.0, -1.0, -1.0], [4.0, 2.0, 0.0]]],
        "l_shape": [[[0.0, 0.0, 0.0], [2.0, 1.0, 1.0]], [[0.0, 0.0, 1.0], [1.0, 1.0, 2.0]]],
        "block": [[[1.0, 0.0, 1.0], [2.0, 1.0, 2.0]]],
        "bar": [[[0.0, 0.0, 2.0], [2.5, 1.0, 2.5]]],
    }
    density = {"floor": 1.0, "l_shape": 1.0, "block": 2.0, "bar": 0.5}
    bodies: list[dict[str, Any]] = []
    for name, boxes in solids.items():
        body: dict[str, Any] = {"name": name, "density": density[name]}
        if name == "floor":
            body["grounded"] = True
        if directory is None:
            body["boxes"] = [{"min": lo, "max": hi} for lo, hi in boxes]
        else:
            folder = Path(directory)
            folder.mkdir(parents=True, exist_ok=True)
            if name == "l_shape":
                profile = [(0.0, 0.0), (2.0, 0.0), (2.0, 1.0), (1.0, 1.0), (1.0, 2.0), (0.0, 2.0)]
                vertices, faces = extruded_prism(profile, 0.0, 1.0)
            else:
                (x0, y0, z0), (x1, y1, z1) = boxes[0]
                vertices, faces = extruded_prism(box_profile(x0, z0, x1, z1), y0, y1)
            ending = {"floor": "ply", "l_shape": "stl", "block": "obj", "bar": "stl"}[name]
            write_mesh(folder / f"steps_{name}.{ending}", vertices, faces)
            body["meshes"] = [{"file": f"{folder.name}/steps_{name}.{ending}"}]
        bodies.append(body)
    return {
        "name": "stepped_stack" if directory is None else "stepped_stack_meshes",
        "length_unit": "m",
        "mu": float(mu),
        "bodies": bodies,
        "contacts": "auto",
    }


def mesh_brick_wall(directory: str | Path, rows: int, columns: int, mu: float = 0.6) -> dict[str, Any]:
    """Return ``brick_wall(rows, columns)`` with every body a mesh: one brick and one footing file, moved.

    The solids are those of the box wall, so the stable region is the same; it measures the mesh route
    (reading, planar regions, intersections) on a large connected assembly. Paths are relative to the
    parent of ``directory``.
    """
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    boxes = brick_wall(rows, columns, mu)
    brick = directory / "wall_brick.stl"
    write_mesh(brick, *extruded_prism(box_profile(0.0, 0.0, 2.0, 1.0), 0.0, 1.0))
    footing = boxes["bodies"][0]["boxes"][0]
    (x0, y0, z0), (x1, y1, z1) = footing["min"], footing["max"]
    write_mesh(directory / "wall_footing.stl", *extruded_prism(box_profile(x0, z0, x1, z1), y0, y1))
    bodies: list[dict[str, Any]] = [
        {"name": "footing", "grounded": True, "meshes": [{"file": f"{directory.name}/wall_footing.stl"}]}
    ]
    for body in boxes["bodies"][1:]:
        x, y, z = body["boxes"][0]["min"]
        move = [[1.0, 0.0, 0.0, x], [0.0, 1.0, 0.0, y], [0.0, 0.0, 1.0, z], [0.0, 0.0, 0.0, 1.0]]
        bodies.append(
            {
                "name": body["name"],
                "meshes": [{"file": f"{directory.name}/wall_brick.stl", "transform": move}],
            }
        )
    return {**boxes, "name": f"mesh_wall_{rows}x{columns}", "bodies": bodies}
