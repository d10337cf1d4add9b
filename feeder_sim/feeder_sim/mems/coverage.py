"""Exact area and first moments of a polygon inside every cell of an axis-aligned grid.

Q(X, Y) = integrals of (1, x, y) over P and {x < X, y < Y} follow from Green's theorem as
-oint 1[x < X] G(x, y) dx with dG/dy = (1, x, y) clipped at Y; on each edge piece where min(y, Y) is
one polynomial the integrand has degree <= 2, integrated in closed form from its end values. Cell
moments are second differences of Q at the grid nodes (only nodes around the part are evaluated).
"""

from __future__ import annotations

import numpy as np

from feeder_planner.mems.lifted import edge_endpoints

__all__ = ["quadrant_moments", "Grid"]


def _piece(
    x0: np.ndarray, y0: np.ndarray, slope: np.ndarray, a: np.ndarray, b: np.ndarray, cap: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return int_a^b (m, x m, m^2/2) dx exactly, m = min(y(x), cap), y linear; min is one line on [a, b]."""
    ma = np.minimum(y0 + slope * (a - x0), cap)
    mb = np.minimum(y0 + slope * (b - x0), cap)
    w = b - a
    return (
        0.5 * w * (ma + mb),
        w * (2 * a * ma + a * mb + b * ma + 2 * b * mb) / 6.0,
        w * (ma * ma + ma * mb + mb * mb) / 6.0,
    )


def quadrant_moments(loops: tuple[np.ndarray, ...], xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """Return (3, len(xs), len(ys)): area, Sx, Sy of the loops' region within {x < X_i, y < Y_j}."""
    start, end = edge_endpoints(loops)
    keep = start[:, 0] != end[:, 0]  # vertical edges contribute nothing to oint ... dx
    start, end = start[keep], end[keep]
    x0, y0, x1, y1 = start[:, 0], start[:, 1], end[:, 0], end[:, 1]
    slope = (y1 - y0) / (x1 - x0)
    sign = np.sign(x1 - x0)
    lo, hi = np.minimum(x0, x1), np.maximum(x0, x1)
    # Each edge clipped to x < X_i is the segment [a, b] (empty when X_i <= lo).
    a = np.broadcast_to(lo[:, None], (len(lo), len(xs)))
    b = np.clip(xs[None, :], lo[:, None], hi[:, None])
    ya = y0[:, None] + slope[:, None] * (a - x0[:, None])
    yb = y0[:, None] + slope[:, None] * (b - x0[:, None])
    w = b - a
    cap = ys[None, None, :]
    # Rows above the clipped segment see min(y, Y) = y, rows below see Y: both in closed form.
    above = cap >= np.maximum(ya, yb)[..., None]
    whole = (
        0.5 * w * (ya + yb),
        w * (2 * a * ya + a * yb + b * ya + 2 * b * yb) / 6.0,
        w * (ya * ya + ya * yb + yb * yb) / 6.0,
    )
    flat = (cap * w[..., None], cap * (0.5 * (b * b - a * a))[..., None], 0.5 * cap * cap * w[..., None])
    out = np.stack([np.where(above, u[..., None], v) for u, v in zip(whole, flat, strict=True)])
    # Rows the segment crosses: split at the crossing, each side one line (only these cells pay).
    mid = ~above & (cap > np.minimum(ya, yb)[..., None])
    e, i, j = np.nonzero(mid)
    if e.size:
        cap_m = ys[j]
        cross = x0[e] + (cap_m - y0[e]) / slope[e]
        t = np.clip(cross, a[e, i], b[e, i])
        first = _piece(x0[e], y0[e], slope[e], a[e, i], t, cap_m)
        second = _piece(x0[e], y0[e], slope[e], t, b[e, i], cap_m)
        for k in range(3):
            out[k, e, i, j] = first[k] + second[k]
    return -(out * sign[None, :, None, None]).sum(axis=1)


class Grid:
    """An nx x ny array of square cells of side ``pitch`` centred on the plane origin."""

    def __init__(self, nx: int, ny: int, pitch: float) -> None:
        self.nx, self.ny, self.pitch = int(nx), int(ny), float(pitch)
        self.x_nodes = (np.arange(self.nx + 1) - 0.5 * self.nx) * self.pitch
        self.y_nodes = (np.arange(self.ny + 1) - 0.5 * self.ny) * self.pitch

    def centers(self) -> np.ndarray:
        """Return the (nx, ny, 2) cell centres."""
        cx = 0.5 * (self.x_nodes[:-1] + self.x_nodes[1:])
        cy = 0.5 * (self.y_nodes[:-1] + self.y_nodes[1:])
        return np.stack(np.meshgrid(cx, cy, indexing="ij"), axis=-1)

    def cell_moments(self, loops: tuple[np.ndarray, ...]) -> tuple[slice, slice, np.ndarray]:
        """Return the cells around the part (index slices) and their (3, ni, nj) area, Sx, Sy, exact."""
        pts = np.vstack(loops)
        i0 = int(np.clip(np.floor((pts[:, 0].min() - self.x_nodes[0]) / self.pitch), 0, self.nx))
        i1 = int(np.clip(np.ceil((pts[:, 0].max() - self.x_nodes[0]) / self.pitch), 0, self.nx))
        j0 = int(np.clip(np.floor((pts[:, 1].min() - self.y_nodes[0]) / self.pitch), 0, self.ny))
        j1 = int(np.clip(np.ceil((pts[:, 1].max() - self.y_nodes[0]) / self.pitch), 0, self.ny))
        if i1 <= i0 or j1 <= j0:
            return slice(0, 0), slice(0, 0), np.zeros((3, 0, 0))
        q = quadrant_moments(loops, self.x_nodes[i0 : i1 + 1], self.y_nodes[j0 : j1 + 1])
        cells = q[:, 1:, 1:] - q[:, :-1, 1:] - q[:, 1:, :-1] + q[:, :-1, :-1]
        return slice(i0, i1), slice(j0, j1), cells
