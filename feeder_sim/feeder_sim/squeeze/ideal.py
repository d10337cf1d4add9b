"""The ideal fidelity: Goldberg's quasi-static, frictionless squeeze, walked contact by contact.

This is the published model computed a second way, independent of the planner's breakpoint table
(``feeder_planner.squeeze``): from the part's orientation the walk finds, straight from the hull
vertices, the vertex pair touching the jaws just ahead in each direction, the one-sided slopes of the
jaw width, and moves the part the way the width falls, to the next orientation where another vertex
reaches a jaw. Within one contact pair the width D cos(theta - beta) is concave, so a fall never turns
into a rise before a contact change; the walk stops where neither direction falls, a minimum of the
diameter function (Goldberg 1993, section 3). A part exactly at a crest falls towards increasing theta,
the planner's convention.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from feeder_planner.errors import SolverError
from feeder_planner.squeeze import convex_hull

__all__ = ["IdealSqueeze", "ideal_squeeze"]

# Vertex x-coordinates equal within this fraction of the hull's size touch the same jaw together.
TIE_FRACTION = 1e-12


@dataclass(frozen=True)
class IdealSqueeze:
    """The outcome of one ideal squeeze: final orientation (rad), jaw width (m), contact changes."""

    orientation: float
    width: float
    contact_changes: int


def _pair(hull: np.ndarray, theta: float, direction: int, tie: float) -> tuple[int, int]:
    """Return the vertices on the jaws just ahead of ``theta`` in ``direction`` (+1 or -1): (max x, min x)."""
    c, s = math.cos(theta), math.sin(theta)
    xs = hull[:, 0] * c - hull[:, 1] * s
    # d x_i / d theta = -y_i: ahead of a tie, the vertex moving outward leads.
    slopes = -(hull[:, 0] * s + hull[:, 1] * c) * direction
    top = float(xs.max())
    bottom = float(xs.min())
    high = [i for i in range(len(hull)) if xs[i] >= top - tie]
    low = [i for i in range(len(hull)) if xs[i] <= bottom + tie]
    return max(high, key=lambda i: slopes[i]), min(low, key=lambda i: slopes[i])


def _slope(hull: np.ndarray, theta: float, a: int, b: int) -> float:
    """d(width)/d(theta) with vertices a and b on the jaws."""
    c, s = math.cos(theta), math.sin(theta)
    chord = hull[a] - hull[b]
    return float(-(chord[0] * s + chord[1] * c))


def _next_contact(hull: np.ndarray, theta: float, direction: int, a: int, b: int) -> float:
    """Return the smallest step (rad, > 0) in ``direction`` at which another vertex reaches a jaw."""
    best = math.inf
    for anchor in (a, b):
        for k in range(len(hull)):
            if k in (a, b):
                continue
            edge = hull[k] - hull[anchor]
            # (R(t) edge)_x = |edge| cos(t + arg edge) vanishes at t = pi/2 - arg edge (mod pi).
            root = math.pi / 2 - math.atan2(float(edge[1]), float(edge[0]))
            step = math.fmod((root - theta) * direction, math.pi)
            if step < 0:
                step += math.pi
            if 1e-13 < step < best:
                best = step
    return best


def ideal_squeeze(vertices: object, theta: float, field: str = "vertices") -> IdealSqueeze:
    """Squeeze the part (outline ``vertices``, metres) from orientation ``theta`` relative to the gripper."""
    hull = convex_hull(vertices, field)
    tie = TIE_FRACTION * float(np.abs(hull).max())
    changes = 0
    for _ in range(8 * len(hull) + 8):
        a, b = _pair(hull, theta, +1, tie)
        if _slope(hull, theta, a, b) < 0.0:
            direction = +1
        else:
            a, b = _pair(hull, theta, -1, tie)
            if _slope(hull, theta, a, b) > 0.0:
                direction = -1
            else:
                c, s = math.cos(theta), math.sin(theta)
                xs = hull[:, 0] * c - hull[:, 1] * s
                return IdealSqueeze(theta, float(xs.max() - xs.min()), changes)
        theta += direction * _next_contact(hull, theta, direction, a, b)
        changes += 1
    raise SolverError(f"the ideal squeeze did not settle within {8 * len(hull) + 8} contact changes")
