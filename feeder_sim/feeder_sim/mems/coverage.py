"""Exact area and first moments of a polygon inside every cell of an axis-aligned grid."""

from __future__ import annotations

# Q(X, Y) = integrals of (1, x, y) over P and {x < X, y < Y} follow from Green's theorem as
# -oint 1[x < X] G(x, y) dx with dG/dy = (1, x, y) clipped at Y; on each edge piece where
# min(y, Y) is one polynomial the integrand has degree <= 2, integrated in closed form from its end values. Cell
# moments are second differences of Q at the grid nodes (only nodes around the part are evaluated).

import numpy as np


def _piece(x0: np.ndarray, y0: np.ndarray, slope: np.ndarray, a: np.ndarray, b: np.ndarray,
           cap: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Exact int_a^b (m, x m, m^2/2) dx with m = min(y(x), cap), y linear; min is one line on [a, b]."""
    ma = np.minimum(y0 + slope * (a - x0), cap)
    mb = np.minimum(y0 + slope * (b - x0), cap)
    w = b - a
    return (0.5 * w * (ma + mb), w * (2 * a * ma + a * mb + b * ma + 2 * b * mb) / 6.0,
            w * (ma * ma + ma * mb + mb * mb) / 6.0)


def quadrant_moments(loops: tuple[np.ndarray, ...], xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """(3, len(xs), len(ys)): area, Sx, Sy of the loops' region within {x < X_i, y < Y_j}."""
    start = np.vstack(loops)
    end = np.vstack([np.roll(loop, -1, axis=0) for loop in loops])
    keep = start[:, 0] != end[:, 0]              # vertical edges contribute nothing to oint ... dx
    start, end = start[keep], end[keep]
    x0, y0, x1, y1 = start[:, 0], start[:, 1], end[:, 0], end[:, 1]
    slope = (y1 - y0) / (x1 - x0)
    sign = np.sign(x1 - x0)
    lo, hi = np.minimum(x0, x1), np.maximum(x0, x1)
    e = (slice(None), None, None)
    big_x = xs[None, :, None]
    cap = ys[None, None, :]
    top = np.minimum(hi[e], big_x)
    top = np.maximum(top, lo[e])                 # empty range when X <= lo
    with np.errstate(divide="ignore", invalid="ignore"):
        cross = x0[e] + (cap - y0[e]) / slope[e]
    cross = np.where(np.isfinite(cross), cross, lo[e])
    t = np.clip(cross, lo[e], top)
    shape = np.broadcast_shapes(top.shape, cap.shape)
    args = [np.broadcast_to(v, shape) for v in (x0[e], y0[e], slope[e])]
    lo_b, t_b, top_b, cap_b = (np.broadcast_to(v, shape) for v in (lo[e], t, top, cap))
    first = _piece(*args, lo_b, t_b, cap_b)
    second = _piece(*args, t_b, top_b, cap_b)
    sg = sign[:, None, None]
    return -np.stack([((u + v) * sg).sum(axis=0) for u, v in zip(first, second)])


class Grid:
    """An nx x ny array of square cells of side ``pitch`` centred on the plane origin."""

    def __init__(self, nx: int, ny: int, pitch: float) -> None:
        self.nx, self.ny, self.pitch = int(nx), int(ny), float(pitch)
        self.x_nodes = (np.arange(self.nx + 1) - 0.5 * self.nx) * self.pitch
        self.y_nodes = (np.arange(self.ny + 1) - 0.5 * self.ny) * self.pitch

    def centers(self) -> np.ndarray:
        """(nx, ny, 2) cell centres."""
        cx = 0.5 * (self.x_nodes[:-1] + self.x_nodes[1:])
        cy = 0.5 * (self.y_nodes[:-1] + self.y_nodes[1:])
        return np.stack(np.meshgrid(cx, cy, indexing="ij"), axis=-1)

    def cell_moments(self, loops: tuple[np.ndarray, ...]) -> tuple[slice, slice, np.ndarray]:
        """Cells around the part (index slices) and their (3, ni, nj) area, Sx, Sy, exact."""
        pts = np.vstack(loops)
        i0 = int(np.clip(np.floor((pts[:, 0].min() - self.x_nodes[0]) / self.pitch), 0, self.nx))
        i1 = int(np.clip(np.ceil((pts[:, 0].max() - self.x_nodes[0]) / self.pitch), 0, self.nx))
        j0 = int(np.clip(np.floor((pts[:, 1].min() - self.y_nodes[0]) / self.pitch), 0, self.ny))
        j1 = int(np.clip(np.ceil((pts[:, 1].max() - self.y_nodes[0]) / self.pitch), 0, self.ny))
        if i1 <= i0 or j1 <= j0:
            return slice(0, 0), slice(0, 0), np.zeros((3, 0, 0))
        q = quadrant_moments(loops, self.x_nodes[i0:i1 + 1], self.y_nodes[j0:j1 + 1])
        cells = q[:, 1:, 1:] - q[:, :-1, 1:] - q[:, 1:, :-1] + q[:, :-1, :-1]
        return slice(i0, i1), slice(j0, j1), cells
