"""Pivot point (Prop. 3) and the equilibrium curve (X*, Y*)(theta, delta), eqs. (12-14), by Newton.

U_{theta,delta}(X, Y) = V(X, Y) + delta |S| (sin theta X + cos theta Y) (eq. 12) has Hess U = Hess V,
positive definite (Prop. 3), so damped Newton converges from anywhere to its unique minimum.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import overload

import numpy as np

from feeder_planner.errors import SolverError
from feeder_planner.mems.lifted import Edges, potential, value_gradient_hessian_noise
from feeder_planner.mems.tolerances import (
    CURVE_ERROR_FACTOR,
    NEWTON_DECREASE_FLOOR,
    NEWTON_DECREASE_SLACK,
    NEWTON_LONG_STEP,
    NEWTON_MAX_BACKTRACKS,
    NEWTON_MAX_ITER,
    NEWTON_NOISE_FACTOR,
    NEWTON_STEP_TOL,
    ROUNDING_BOUND,
)

__all__ = ["CurvePoints", "plane_coordinates", "pivot_translation", "pivot_point", "curve", "hessian_xyt"]


@overload
def plane_coordinates(cos: float, sin: float, big_x: float, big_y: float) -> tuple[float, float]: ...


@overload
def plane_coordinates(
    cos: np.ndarray, sin: np.ndarray, big_x: np.ndarray | float, big_y: np.ndarray | float
) -> tuple[np.ndarray, np.ndarray]: ...


def plane_coordinates(
    cos: float | np.ndarray, sin: float | np.ndarray, big_x: float | np.ndarray, big_y: float | np.ndarray
) -> tuple[float | np.ndarray, float | np.ndarray]:
    """Return (x, y) = R(theta) (X, Y), eqs. (13-14), from cos theta and sin theta (floats or arrays)."""
    return cos * big_x - sin * big_y, sin * big_x + cos * big_y


def _rounding_floor(gnoise: np.ndarray, tilt: np.ndarray, hess: np.ndarray) -> np.ndarray:
    """Return the rounding floor of grad U = grad V + tilt mapped through Hess^-1 (a length per row)."""
    return (gnoise + ROUNDING_BOUND * np.abs(tilt).sum(-1)) / np.linalg.eigvalsh(hess)[:, 0]


def _backtrack(
    edges: Edges, z: np.ndarray, tilt: np.ndarray, value: np.ndarray, step: np.ndarray
) -> np.ndarray:
    """Return the step fraction per row: 1, halved while a long step would increase U = V + tilt . z.

    Only steps longer than NEWTON_LONG_STEP part radii are checked; near the minimum Newton is safe.
    """
    f0 = value + (tilt * z).sum(-1)
    t = np.ones(len(z))
    long = np.hypot(step[:, 0], step[:, 1]) > NEWTON_LONG_STEP * edges.scale
    for _ in range(NEWTON_MAX_BACKTRACKS):
        if not long.any():
            break
        trial = z[long] + t[long, None] * step[long]
        f1 = potential(edges, trial) + (tilt[long] * trial).sum(-1)
        bad = np.zeros(len(z), bool)
        bad[long] = f1 > f0[long] + NEWTON_DECREASE_SLACK * np.abs(f0[long]) + NEWTON_DECREASE_FLOOR
        if not bad.any():
            break
        t = np.where(bad, 0.5 * t, t)
    return t


def _newton(edges: Edges, z: np.ndarray, tilt: np.ndarray) -> np.ndarray:
    """Minimise V(z) + tilt . z for every row of z (convex, so damped Newton is global)."""
    z = np.array(z, float, copy=True)
    active = np.ones(z.shape[:-1], bool)
    scale = edges.scale
    for _ in range(NEWTON_MAX_ITER):
        if not active.any():
            return z
        za, ta = z[active], tilt[active]
        value, grad, hess, gnoise = value_gradient_hessian_noise(edges, za)
        g = grad + ta
        step = -np.linalg.solve(hess, g[..., None])[..., 0]
        t = _backtrack(edges, za, ta, value, step)
        za = za + t[:, None] * step
        z[active] = za
        # Stop at NEWTON_STEP_TOL, or at the rounding floor of the gradient mapped through Hess^-1.
        noise = _rounding_floor(gnoise, ta, hess)
        done = np.hypot(step[:, 0], step[:, 1]) * t <= np.maximum(
            NEWTON_STEP_TOL * scale, NEWTON_NOISE_FACTOR * noise
        )
        idx = np.flatnonzero(active)
        active[idx[done]] = False
    raise SolverError("Newton on the lifted potential did not converge (equilibrium curve)")


def pivot_point(z0: np.ndarray) -> tuple[float, float]:
    """Return the pivot point (part frame) from the minimum (X0, Y0) of V: (-X0, -Y0) (Prop. 3)."""
    return float(-z0[0]), float(-z0[1])


def pivot_translation(edges: Edges) -> np.ndarray:
    """Return (X0, Y0), the unique minimum of V (Prop. 3 (ii)); the pivot point is (-X0, -Y0), part frame."""
    return _newton(edges, np.zeros((1, 2)), np.zeros((1, 2)))[0]


@dataclass(frozen=True)
class CurvePoints:
    """The equilibrium curve sampled at angles theta for one delta."""

    theta: np.ndarray
    z: np.ndarray  # (N, 2): (X*, Y*)
    x: np.ndarray  # x*(theta, delta), eq. (13)
    y: np.ndarray  # y*(theta, delta), eq. (14)
    dx: np.ndarray  # d x* / d theta, by implicit differentiation of grad U = 0
    hess: np.ndarray  # Hess V at (X*, Y*)
    grad: np.ndarray  # grad V at (X*, Y*)
    error: np.ndarray  # bound on the rounding error of (X*, Y*) (and so of x*, y*), metres


def curve(
    edges: Edges, area: float, delta: float, theta: np.ndarray, start: np.ndarray | None = None
) -> CurvePoints:
    """Solve grad V(Z) + delta |S| (sin theta, cos theta) = 0 (the system before eq. 22) for each theta.

    The minimum of U_{theta,delta} (eq. 12) in the part's (X, Y) coordinates, with x*, y* by eqs.
    (13-14) and dx*/dtheta by implicit differentiation of grad U = 0.
    """
    theta = np.asarray(theta, float)
    b = np.column_stack([np.sin(theta), np.cos(theta)])
    tilt = delta * area * b
    z0 = np.broadcast_to(start if start is not None else np.zeros(2), b.shape)
    z = _newton(edges, z0, tilt)
    _, grad, hess, gnoise = value_gradient_hessian_noise(edges, z)
    c, s = np.cos(theta), np.sin(theta)
    x, y = plane_coordinates(c, s, z[:, 0], z[:, 1])
    # Hess V dZ/dtheta = -delta |S| (cos theta, -sin theta)
    dz = -np.linalg.solve(hess, (delta * area * np.column_stack([c, -s]))[..., None])[..., 0]
    dx = -s * z[:, 0] - c * z[:, 1] + c * dz[:, 0] - s * dz[:, 1]
    error = CURVE_ERROR_FACTOR * _rounding_floor(gnoise, tilt, hess)
    return CurvePoints(theta, z, x, y, dx, hess, grad, error + NEWTON_STEP_TOL * edges.scale)


def hessian_xyt(grad: np.ndarray, hess: np.ndarray, z: np.ndarray, theta: float) -> np.ndarray:
    """Return the Hessian of U(x, y, theta) = V(R(theta)^T (x, y)) + delta |S| y (chain rule on eq. 12)."""
    c, s = np.cos(theta), np.sin(theta)
    r = np.array([[c, -s], [s, c]])
    dr = np.array([[-s, -c], [c, -s]])
    w = np.array([z[1], -z[0]])  # dZ/dtheta
    out = np.zeros((3, 3))
    out[:2, :2] = r @ hess @ r.T
    out[:2, 2] = out[2, :2] = dr @ grad + r @ hess @ w
    out[2, 2] = w @ hess @ w - z @ grad
    return out
