"""Test parts for the MEMS tests (built here, not read from files)."""

from __future__ import annotations

import math

import numpy as np

from feeder_planner.parts import Part, make_part


def plus(a: float = 1.0, b: float = 3.0, scale: float = 1.0) -> Part:
    """A plus shape aligned with the axes, symmetric under rotation by pi/2 (like Figure 6)."""
    v = [
        [a, -a],
        [b, -a],
        [b, a],
        [a, a],
        [a, b],
        [-a, b],
        [-a, a],
        [-b, a],
        [-b, -a],
        [-a, -a],
        [-a, -b],
        [a, -b],
    ]
    return make_part(v, unit_scale=scale)


def square(half: float = 1.0) -> Part:
    return make_part([[-half, -half], [half, -half], [half, half], [-half, half]])


def bracket(scale: float = 1.0) -> Part:
    """A non-symmetric L bracket."""
    return make_part([[0, 0], [4, 0], [4, 1], [1, 1], [1, 3], [0, 3]], unit_scale=scale)


def regular(n: int, phase: float = 0.1) -> Part:
    return make_part(
        [[math.cos(phase + 2 * math.pi * k / n), math.sin(phase + 2 * math.pi * k / n)] for k in range(n)]
    )


def blob(n: int) -> Part:
    """A non-symmetric star-shaped polygon with n vertices."""
    t = 2 * math.pi * np.arange(n) / n
    r = 1 + 0.3 * np.sin(3 * t) + 0.1 * np.cos(5 * t)
    return make_part(np.c_[r * np.cos(t), r * np.sin(t)].tolist())


def washer() -> Part:
    """Non-convex with a hole."""
    return make_part([[0, 0], [5, 0], [5, 2], [3, 2], [3, 4], [0, 4]], [[[1, 1], [2, 1], [2, 3], [1, 3]]])
