"""Generated assembly documents (random towers on a grounded base, brick walls) for tests and benchmarks."""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["brick_wall", "random_assembly"]


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
