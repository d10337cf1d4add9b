"""Property 1's degenerate kinds beyond the paper's figures: hemisphere, great circle; the deepest centre."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import random_directions


def _pocket(floor: bool) -> dict:
    """A unit block in a square pocket (walls on +-x and +-y), with or without a floor under it; mu = 0."""
    walls = [
        {"min": [0, 0, 0], "max": [1, 3, 3]},
        {"min": [2, 0, 0], "max": [3, 3, 3]},
        {"min": [0, 0, 0], "max": [3, 1, 3]},
        {"min": [0, 2, 0], "max": [3, 3, 3]},
    ]
    if floor:
        walls.append({"min": [0, 0, -1], "max": [3, 3, 0.5]})
    return {
        "name": "pocket",
        "mu": 0.0,
        "bodies": [
            {"name": "pocket", "grounded": True, "boxes": walls},
            {"name": "block", "boxes": [{"min": [1, 1, 0.5], "max": [2, 2, 1.5]}]},
        ],
    }


def test_block_in_a_pocket_with_a_floor_is_a_hemisphere(from_doc) -> None:
    region = from_doc(_pocket(floor=True)).region
    assert region.kind == "hemisphere"
    assert region.normals[0] == pytest.approx([0, 0, 1])
    assert region.area_sr == pytest.approx(2 * math.pi)
    assert region.center == pytest.approx([0, 0, -1])


def test_block_in_a_bottomless_pocket_is_a_great_circle(from_doc) -> None:
    prepared = from_doc(_pocket(floor=False))
    region = prepared.region
    assert region.kind == "great_circle"
    assert abs(region.equalities[0] @ [0, 0, 1]) == pytest.approx(1.0)
    for angle in np.linspace(0, 2 * math.pi, 9):
        g = np.array([math.cos(angle), math.sin(angle), 0.0])
        assert region.contains(g) and prepared.check(g).stable
    assert not prepared.check(np.array([0.0, 0.1, -1.0])).stable


def test_centre_is_the_deepest_direction(example) -> None:
    region = example("block_in_l_bracket", mu=0.4).region
    depth = lambda g: float(np.min(-(region.normals @ g)))  # noqa: E731  sine of the angle to the nearest edge
    best = depth(region.center)
    # No direction, random or near the centre, is deeper than the centre.
    near = region.center + 0.2 * np.random.default_rng(1).normal(size=(20000, 3))
    candidates = np.vstack([random_directions(20000, 2), near / np.linalg.norm(near, axis=1, keepdims=True)])
    assert max(depth(g) for g in candidates) <= best + 1e-12
    assert region.margin(region.center) == pytest.approx(math.asin(best))
