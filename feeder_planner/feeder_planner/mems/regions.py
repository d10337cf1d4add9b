"""Exact area moments of placed polygon loops, whole or clipped by a half-plane (Green's theorem)."""

from __future__ import annotations

import numpy as np

from feeder_planner import polygon

__all__ = ["area_moments", "moments", "clip_half_plane", "half_plane_moments"]


def area_moments(loops: tuple[np.ndarray, ...]) -> np.ndarray:
    """Return (A, Sx, Sy): area and first moments about the origin (signed loops).

    What the constant field needs (force times area at the centroid), without the second moments: it is
    evaluated twice per simulated step of the ideal array, where the second moments cost as much again.
    """
    out = np.zeros(3)
    for loop in loops:
        if len(loop) >= 3:
            out += polygon.first_moments(loop)
    return out


def moments(loops: tuple[np.ndarray, ...]) -> np.ndarray:
    """Return (A, Sx, Sy, Ixx, Iyy, Ixy): area, first and second moments about the origin (signed loops)."""
    out = np.zeros(6)
    for loop in loops:
        if len(loop) < 3:
            continue
        out[:3] += polygon.first_moments(loop)
        out[3:] += polygon.second_moments(loop)
    return out


def clip_half_plane(loop: np.ndarray, normal: np.ndarray, offset: float) -> np.ndarray:
    """Return the part of a loop with normal . r >= offset (Sutherland-Hodgman).

    For a non-convex loop the output may contain zero-width bridges along the cut line; they carry
    no area, so every Green's-theorem moment of the result is exact.
    """
    d = loop @ normal - offset
    out = []
    n = len(loop)
    for i in range(n):
        j = (i + 1) % n
        if d[i] >= 0:
            out.append(loop[i])
        if (d[i] >= 0) != (d[j] >= 0):
            t = d[i] / (d[i] - d[j])
            out.append(loop[i] + t * (loop[j] - loop[i]))
    return np.array(out).reshape(-1, 2)


def half_plane_moments(loops: tuple[np.ndarray, ...], normal: np.ndarray, offset: float) -> np.ndarray:
    """Return moments() of the loops' region with normal . r >= offset."""
    return moments(tuple(clip_half_plane(loop, normal, offset) for loop in loops))
