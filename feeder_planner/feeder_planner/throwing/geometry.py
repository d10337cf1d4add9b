"""Hull numbering, stable edges, d^i, contact vertices, rho and d_min of a part on the arm (section II)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from feeder_planner import polygon
from feeder_planner.parts import Part

__all__ = ["ArmPart", "rotate", "arm_part"]


@dataclass(frozen=True)
class ArmPart:
    """A part as the throwing arm sees it: its convex hull in the part frame (centroid at origin, metres).

    Hull vertex 0 is the first vertex of the part file that lies on the hull; vertices run
    counter-clockwise; edge i joins vertex i to vertex i+1 (contract section 3).
    """

    part: Part
    hull: np.ndarray  # (n, 2) hull vertices, part frame
    file_index: tuple[int, ...]  # index in the file's vertex list of each hull vertex
    edge_angle: np.ndarray  # alpha_i: direction angle of edge i in the part frame
    exterior: np.ndarray  # exterior angle at vertex k (turn from edge k-1 to edge k), in (0, pi)
    d: np.ndarray  # d^i: distance from the centre of mass to the line of edge i
    u_left: np.ndarray  # u_l^i, in frame F^i
    u_right: np.ndarray  # u_r^i, in frame F^i
    stable: np.ndarray  # bool, E^i stable (u_l < 0 < u_r)
    rho: float  # radius of gyration about the centre of mass
    mass: float

    @property
    def n(self) -> int:
        """Number of hull vertices (and edges)."""
        return len(self.hull)

    @property
    def radius(self) -> float:
        """Part radius r: largest distance from the centre of mass to a vertex."""
        return float(np.hypot(self.hull[:, 0], self.hull[:, 1]).max())

    @property
    def stable_edges(self) -> list[int]:
        """The stable edges E^i (u_l < 0 < u_r), in edge order."""
        return [int(i) for i in np.flatnonzero(self.stable)]

    @property
    def d_min(self) -> float:
        """d^min = min over stable edges of d^i (paper section II)."""
        return float(self.d[self.stable].min())

    def frame_vertices(self, edge: int) -> np.ndarray:
        """Return all hull vertices in the frame F^i of the part resting on ``edge`` (v^i up)."""
        return rotate(self.hull, -float(self.edge_angle[edge]))

    def contact_vertices(self, edge: int) -> tuple[tuple[float, float], tuple[float, float]]:
        """Return ((u_l, v_l), (u_r, v_r)) of edge i in F^i; v_l = v_r = -d^i."""
        return (
            (float(self.u_left[edge]), -float(self.d[edge])),
            (float(self.u_right[edge]), -float(self.d[edge])),
        )


def rotate(points: np.ndarray, angle: float) -> np.ndarray:
    """Return the rows of ``points`` rotated counter-clockwise by ``angle`` about the origin."""
    c, s = math.cos(angle), math.sin(angle)
    return points @ np.array([[c, s], [-s, c]])


def arm_part(part: Part) -> ArmPart:
    """Return the arm's view of ``part`` (convex hull numbered from the file's first hull vertex)."""
    file_pts = part.file_vertices - part.offset  # file order, part frame
    hull_idx = polygon.convex_hull_indices(file_pts)  # counter-clockwise
    start = min(hull_idx)  # first vertex of the file that lies on the hull
    k = hull_idx.index(start)
    hull_idx = hull_idx[k:] + hull_idx[:k]
    hull = file_pts[hull_idx]
    edges = np.roll(hull, -1, axis=0) - hull
    alpha = np.arctan2(edges[:, 1], edges[:, 0])
    exterior = np.mod(alpha - np.roll(alpha, 1), 2 * math.pi)
    n = len(hull)
    d = np.empty(n)
    ul = np.empty(n)
    ur = np.empty(n)
    for i in range(n):
        local = rotate(hull[[i, (i + 1) % n]], -float(alpha[i]))
        d[i] = -local[0, 1]
        ul[i], ur[i] = local[0, 0], local[1, 0]
    rho = math.sqrt(part.polar_moment / part.area)
    return ArmPart(
        part=part,
        hull=hull,
        file_index=tuple(int(i) for i in hull_idx),
        edge_angle=alpha,
        exterior=exterior,
        d=d,
        u_left=ul,
        u_right=ur,
        stable=(ul < 0) & (ur > 0),
        rho=rho,
        mass=part.mass,
    )
