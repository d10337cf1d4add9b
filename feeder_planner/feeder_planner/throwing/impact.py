"""The sticking impact of section III-B, eqs. (7)-(9): the impact vertex stops, the impulse acts on it."""

from __future__ import annotations

import numpy as np

__all__ = ["sticking_impact", "kinetic_energy"]


def sticking_impact(
    rx: np.ndarray, ry: np.ndarray, xdot: np.ndarray, ydot: np.ndarray, phidot: np.ndarray, rho: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return the post-impact (xdot+, ydot+, phidot+) of eqs. (7)-(9); (rx, ry): centre of mass to vertex.

    Substituting (7) xdot+ = ry phidot+ and (8) ydot+ = -rx phidot+ into (9) gives
    phidot+ (rho^2 + rx^2 + ry^2) = rho^2 phidot- + ry xdot- - rx ydot-
    (angular momentum about the impact vertex is conserved, so energy can only be lost).
    """
    rho2 = rho * rho
    phi_plus = (rho2 * phidot + ry * xdot - rx * ydot) / (rho2 + rx * rx + ry * ry)
    return ry * phi_plus, -rx * phi_plus, phi_plus


def kinetic_energy(xdot: np.ndarray, ydot: np.ndarray, phidot: np.ndarray, rho: float) -> np.ndarray:
    """Return the kinetic energy per unit mass."""
    return 0.5 * (xdot * xdot + ydot * ydot + rho * rho * phidot * phidot)
