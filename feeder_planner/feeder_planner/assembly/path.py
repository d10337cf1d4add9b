"""Safe reorientation paths: Property 2's great arc between two stable directions, every sample certified."""

from __future__ import annotations

import math

import numpy as np

from feeder_planner.assembly.region import StableRegion
from feeder_planner.assembly.stability import StabilityChecker, unit_gravity
from feeder_planner.assembly.tolerances import (
    ANTIPODAL_ANGLE,
    ANTIPODAL_COSINE,
    DEFAULT_PATH_STEP,
    MIDPOINT_MIN_NORM,
    SAME_POINT_ANGLE,
)
from feeder_planner.errors import InputError, SolverError

__all__ = ["great_arc", "safe_path"]


def great_arc(g1: np.ndarray, g2: np.ndarray, step: float) -> np.ndarray:
    """Return points of the shorter great arc from g1 to g2 (eq. 11, by angle), at most ``step`` apart."""
    g1, g2 = unit_gravity(g1, "from"), unit_gravity(g2, "to")
    angle = math.acos(float(np.clip(g1 @ g2, -1.0, 1.0)))
    if angle < SAME_POINT_ANGLE:
        return g1[None, :]
    if math.pi - angle < ANTIPODAL_ANGLE:
        raise InputError("to", "is antipodal to 'from': the great arc between them is not unique")
    count = max(1, math.ceil(angle / step))
    t = np.linspace(0.0, 1.0, count + 1)
    # Spherical linear interpolation: equal angular steps along the arc of eq. (11).
    s = math.sin(angle)
    points = (np.sin((1 - t) * angle)[:, None] * g1 + np.sin(t * angle)[:, None] * g2) / s
    return points / np.linalg.norm(points, axis=1, keepdims=True)


def safe_path(
    region: StableRegion,
    checker: StabilityChecker,
    g1: np.ndarray,
    g2: np.ndarray,
    step: float = DEFAULT_PATH_STEP,
) -> np.ndarray:
    """Return a sampled great-arc path from g1 to g2 whose every sample the stability LP certifies stable.

    Property 2: for two stable, non-antipodal directions the arc lies in the region. Antipodal ends (possible
    only for the sphere, a great circle or a hemisphere's rim) go through a stable midpoint first.
    """
    if not (isinstance(step, (int, float)) and math.isfinite(step) and 0 < step <= math.pi / 2):
        raise InputError("step", f"must be in (0, pi/2] rad, got {step!r}")
    g1, g2 = unit_gravity(g1, "from"), unit_gravity(g2, "to")
    for name, g in (("from", g1), ("to", g2)):
        verdict = checker(g)
        if not verdict.stable:
            raise InputError(name, f"direction {np.round(g, 9).tolist()} is not stable")
    waypoints = [g1, g2]
    if g1 @ g2 < -1 + ANTIPODAL_COSINE:
        waypoints = [g1, _antipodal_midpoint(region, g1), g2]
    samples = [great_arc(a, b, step) for a, b in zip(waypoints, waypoints[1:], strict=False)]
    path = np.vstack([samples[0]] + [s[1:] for s in samples[1:]])
    for index, g in enumerate(path):
        if not checker(g).stable:
            raise SolverError(f"path sample {index} ({np.round(g, 9).tolist()}) failed the stability LP")
    return path


def _antipodal_midpoint(region: StableRegion, g: np.ndarray) -> np.ndarray:
    """Return a stable direction 90 degrees from g, joining g and -g by two great arcs (sphere, circle...)."""
    if region.kind in ("sphere", "hemisphere"):
        candidates = [-n for n in region.normals] or [
            np.cross(g, [1.0, 0.0, 0.0]),
            np.cross(g, [0.0, 1.0, 0.0]),
        ]
    elif region.kind == "great_circle":
        candidates = [np.cross(region.equalities[0], g)]
    else:
        raise InputError(
            "to", f"is antipodal to 'from' and the region is a {region.kind}: no stable arc joins them"
        )
    for c in candidates:
        c = c - (c @ g) * g
        if np.linalg.norm(c) > MIDPOINT_MIN_NORM:
            return c / np.linalg.norm(c)
    raise SolverError("no midpoint found between antipodal directions")
