"""Pivot point (Prop. 3) and the equilibrium curve (X*, Y*)(theta, delta), eqs. (12-14), by Newton on convex U."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from feeder_planner.errors import SolverError
from feeder_planner.mems.lifted import Edges, potential, value_gradient_hessian_noise

# Newton stops when the step is below this fraction of the part radius; V is strictly convex
# (Prop. 3 (i)) so damped Newton converges from anywhere, and quadratically near the minimum.
STEP_TOL = 1e-14
MAX_ITER = 200


def _newton(edges: Edges, z: np.ndarray, tilt: np.ndarray) -> np.ndarray:
    """Minimise V(z) + tilt . z for every row of z (convex, so damped Newton is global)."""
    z = np.array(z, float, copy=True)
    active = np.ones(z.shape[:-1], bool)
    scale = edges.scale
    for _ in range(MAX_ITER):
        if not active.any():
            return z
        za, ta = z[active], tilt[active]
        value, grad, hess, gnoise = value_gradient_hessian_noise(edges, za)
        g = grad + ta
        step = -np.linalg.solve(hess, g[..., None])[..., 0]
        # Backtrack only where a long step might not decrease U; near the minimum Newton is safe.
        f0 = value + (ta * za).sum(-1)
        t = np.ones(len(za))
        long = np.hypot(step[:, 0], step[:, 1]) > 1e-3 * scale
        for _ in range(40):
            if not long.any():
                break
            trial = za[long] + t[long, None] * step[long]
            f1 = potential(edges, trial) + (ta[long] * trial).sum(-1)
            bad = np.zeros(len(za), bool)
            bad[long] = f1 > f0[long] + 1e-13 * np.abs(f0[long]) + 1e-300
            if not bad.any():
                break
            t = np.where(bad, 0.5 * t, t)
        za = za + t[:, None] * step
        z[active] = za
        # Stop at STEP_TOL, or at the rounding floor of the gradient mapped through Hess^-1.
        noise = (gnoise + 8 * np.finfo(float).eps * np.abs(ta).sum(-1)) / np.linalg.eigvalsh(hess)[:, 0]
        done = np.hypot(step[:, 0], step[:, 1]) * t <= np.maximum(STEP_TOL * scale, 4.0 * noise)
        idx = np.flatnonzero(active)
        active[idx[done]] = False
    raise SolverError("Newton on the lifted potential did not converge (equilibrium curve)")


def pivot_translation(edges: Edges) -> np.ndarray:
    """(X0, Y0), the unique minimum of V (Prop. 3 (ii)); the pivot point is (-X0, -Y0) in the part frame."""
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
    """Solve grad V(Z) + delta |S| (sin theta, cos theta) = 0 (the system before eq. 22) for each theta."""
    theta = np.asarray(theta, float)
    b = np.column_stack([np.sin(theta), np.cos(theta)])
    tilt = delta * area * b
    z0 = np.broadcast_to(start if start is not None else np.zeros(2), b.shape)
    z = _newton(edges, z0, tilt)
    _, grad, hess, gnoise = value_gradient_hessian_noise(edges, z)
    c, s = np.cos(theta), np.sin(theta)
    x = c * z[:, 0] - s * z[:, 1]
    y = s * z[:, 0] + c * z[:, 1]
    # Hess V dZ/dtheta = -delta |S| (cos theta, -sin theta)
    dz = -np.linalg.solve(hess, (delta * area * np.column_stack([c, -s]))[..., None])[..., 0]
    dx = -s * z[:, 0] - c * z[:, 1] + c * dz[:, 0] - s * dz[:, 1]
    error = 2.0 * (gnoise + 8 * np.finfo(float).eps * np.abs(tilt).sum(-1)) / np.linalg.eigvalsh(hess)[:, 0]
    return CurvePoints(theta, z, x, y, dx, hess, grad, error + STEP_TOL * edges.scale)


def hessian_xyt(grad: np.ndarray, hess: np.ndarray, z: np.ndarray, theta: float) -> np.ndarray:
    """Hessian of U(x, y, theta) = V(R(theta)^T (x, y)) + delta |S| y at a configuration (chain rule)."""
    c, s = np.cos(theta), np.sin(theta)
    r = np.array([[c, -s], [s, c]])
    dr = np.array([[-s, -c], [c, -s]])
    w = np.array([z[1], -z[0]])  # dZ/dtheta
    out = np.zeros((3, 3))
    out[:2, :2] = r @ hess @ r.T
    out[:2, 2] = out[2, :2] = dr @ grad + r @ hess @ w
    out[2, 2] = w @ hess @ w - z @ grad
    return out
