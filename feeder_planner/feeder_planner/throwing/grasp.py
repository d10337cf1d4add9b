"""Dynamic grasp: the wrench-cone test (III-A.1), its impulsive limit, eqs. (1)-(4), R_grasp (Prop. III.3)."""

from __future__ import annotations

import math

import numpy as np

from feeder_planner.errors import InputError
from feeder_planner.throwing.geometry import ArmPart

__all__ = [
    "cone_edges",
    "required_wrench",
    "in_cone",
    "carry_in_grasp",
    "impulse_in_grasp",
    "grasp_bounds",
    "grasp_radius",
    "grasp_radii",
]


def cone_edges(part: ArmPart, edge: int, mu: float) -> np.ndarray:
    """Return the four contact wrenches w_1..w_4 of edge i in F^i (rows), as in section III-A.1."""
    (ul, vl), (ur, vr) = part.contact_vertices(edge)
    return np.array(
        [[-mu, 1.0, ul + mu * vl], [mu, 1.0, ul - mu * vl], [mu, 1.0, ur - mu * vr], [-mu, 1.0, ur + mu * vr]]
    )


def required_wrench(
    part: ArmPart,
    edge: int,
    radius: float,
    offset: float,
    gravity: float,
    theta: float,
    theta_dot: float,
    theta_ddot: float,
) -> np.ndarray:
    """Return the wrench (f_u, f_v, tau) that carries the part rigidly (section III-A.1), per unit mass."""
    a = offset + float(part.d[edge])
    return (
        theta_ddot * np.array([-a, radius, part.rho**2])
        + theta_dot**2 * np.array([-radius, -a, 0.0])
        + np.array([-gravity * math.sin(theta), -gravity * math.cos(theta), 0.0])
    )


def in_cone(wrench: np.ndarray, cone: np.ndarray, tol: float = 0.0) -> bool:
    """Return whether w lies in the cone W^i: w . (w_j x w_k) <= 0 for (j, k) = (1,2), (2,3), (3,4), (4,1)."""
    scale = float(np.abs(wrench).max()) or 1.0
    for j in range(4):
        normal = np.cross(cone[j], cone[(j + 1) % 4])
        if float(wrench @ normal) > tol * scale * float(np.abs(normal).max()):
            return False
    return True


def carry_in_grasp(
    part: ArmPart,
    edge: int,
    radius: float,
    offset: float,
    gravity: float,
    mu: float,
    theta: float,
    theta_dot: float,
    theta_ddot: float,
) -> bool:
    """Return the necessary condition for a dynamic grasp at one arm state of a carry (wrench-cone test)."""
    return in_cone(
        required_wrench(part, edge, radius, offset, gravity, theta, theta_dot, theta_ddot),
        cone_edges(part, edge, mu),
    )


def impulse_in_grasp(part: ArmPart, edge: int, radius: float, offset: float, mu: float) -> bool:
    """Return whether the impulse p = W (-(h+d), R, rho^2) lies in the impulse cone (independent of W > 0)."""
    a = offset + float(part.d[edge])
    return in_cone(np.array([-a, radius, part.rho**2]), cone_edges(part, edge, mu))


def grasp_bounds(part: ArmPart, edge: int, offset: float, mu: float) -> tuple[float, float, float, float]:
    """Return the four lower bounds on R of eqs. (1)-(4) for a stable edge."""
    if not part.stable[edge]:
        raise InputError("edge", f"edge {edge} is not a stable edge (stable edges: {part.stable_edges})")
    (ul, vl), (ur, vr) = part.contact_vertices(edge)
    a = offset + float(part.d[edge])
    rho2 = part.rho**2
    return ((rho2 - vl * a) / ul, -a / mu, (rho2 - vr * a) / ur, a / mu)


def grasp_radius(part: ArmPart, edge: int, offset: float, mu: float) -> float:
    """Return R_grasp^i, the largest of the bounds (1)-(4) (Proposition III.3)."""
    return max(grasp_bounds(part, edge, offset, mu))


def grasp_radii(part: ArmPart, offset: float, mu: float) -> dict[int, float]:
    """Return R_grasp^i for every stable edge, in edge order."""
    return {i: grasp_radius(part, i, offset, mu) for i in part.stable_edges}
