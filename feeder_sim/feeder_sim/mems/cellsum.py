"""Exact force and torque of a cellwise-constant force field on a polygon from integrals along its edges.

Let F(x, y) = f_ij on cell (i, j) of the grid and 0 outside it. With H(x, y) = int_{-inf}^y F(x, t) dt
and K(x, y) = int_{-inf}^y t F(x, t) dt, Green's theorem gives
    int_P F dA = -oint H dx,   int_P x F dA = -oint x H dx,   int_P y F dA = -oint K dx,
which equal sum_ij f_ij * (area, Sx, Sy) of P within cell ij exactly (the sums of issue 3's model).
Inside one cell H is linear and K quadratic in y, so on each piece of an edge between two grid-line
crossings the integrands are polynomials of degree <= 2 along the edge: Simpson's rule is exact.
H and K are continuous in y, so a piece assigned to a neighbouring row by rounding costs only
rounding. The work is proportional to the cells the boundary crosses, not to the cells covered:
the column sums over fully covered cells come from prefix sums precomputed once per field.
Terms depending on x only (a column offset) integrate to zero around a closed loop, so the prefix
sums are taken relative to the row below the part, which keeps the cancellation small.
"""

from __future__ import annotations

import numpy as np

__all__ = ["CellForceSums"]


class CellForceSums:
    """Prefix sums of the cell forces ``forces[i, j]`` of one field on a grid.

    The grid has node coordinates ``x_nodes``, ``y_nodes``; ``wrench`` integrates the sums along a
    polygon's edges.
    """

    def __init__(self, forces: np.ndarray, x_nodes: np.ndarray, y_nodes: np.ndarray) -> None:
        nx, ny = forces.shape[:2]
        self.nx, self.ny = nx, ny
        self.x_nodes = np.asarray(x_nodes, float)
        self.y_nodes = np.asarray(y_nodes, float)
        # Simpson's rule on [0, 1]: exact for the quadratics each edge piece integrates (see above)
        self._simpson = np.array([1.0, 4.0, 1.0])[:, None] / 6.0
        # padded cells: index 0 lies left of / below the grid, n + 1 right of / above it (no force)
        f = np.zeros((nx + 2, ny + 2, 2))
        f[1:-1, 1:-1] = forces
        bottom = np.concatenate([self.y_nodes[:1], self.y_nodes])
        top = np.concatenate([self.y_nodes, self.y_nodes[-1:]])
        height = (top - bottom)[None, :, None]
        first = (0.5 * (top - bottom) * (top + bottom))[None, :, None]
        # exclusive prefix sums up each column: H and K at the bottom of every padded cell
        h = np.concatenate([np.zeros((nx + 2, 1, 2)), np.cumsum(f * height, axis=1)[:, :-1]], axis=1)
        k = np.concatenate([np.zeros((nx + 2, 1, 2)), np.cumsum(f * first, axis=1)[:, :-1]], axis=1)
        # per padded cell (flat index i * (ny + 2) + j): fx, fy, Hx, Hy, Kx at its bottom, its bottom y
        table = np.concatenate(
            [f, h, k[..., :1], np.broadcast_to(bottom[None, :, None], (nx + 2, ny + 2, 1))], axis=2
        )
        self._fields_by_column = np.ascontiguousarray(np.moveaxis(table, 2, 0))
        self._fields = self._fields_by_column.reshape(6, -1)
        self._next: dict[tuple[int, ...], np.ndarray] = {}

    def _successors(self, sizes: tuple[int, ...]) -> np.ndarray:
        """Return the index of the end vertex of every edge of stacked loops of these sizes (cached)."""
        nxt = self._next.get(sizes)
        if nxt is None:
            parts, offset = [], 0
            for n in sizes:
                parts.append(np.roll(np.arange(offset, offset + n), -1))
                offset += n
            nxt = self._next[sizes] = np.concatenate(parts)
        return nxt

    def wrench(self, loops: tuple[np.ndarray, ...], about: np.ndarray) -> np.ndarray:
        """Return (Fx, Fy, torque about ``about``): sum over cells of f_ij times the exact covered moments.

        The covered area and first moments are those of the region bounded by ``loops`` (outer
        counter-clockwise, holes clockwise) within each cell.
        """
        xn, yn = self.x_nodes, self.y_nodes
        start = np.concatenate(loops) if len(loops) > 1 else loops[0]
        d = start[self._successors(tuple(len(loop) for loop in loops))] - start
        lo = start.min(axis=0)
        hi = start.max(axis=0)
        keep = d[:, 0] != 0.0  # vertical edges add nothing to oint ... dx
        start, d = start[keep], d[keep]
        # grid lines strictly inside the part's bounding box
        i0, i1 = xn.searchsorted((lo[0], hi[0]), side="right")
        j0, j1 = yn.searchsorted((lo[1], hi[1]), side="right")
        # crossing parameters of every edge with every line; lines missing the edge clip to 0 or 1
        # (zero-length pieces); horizontal edges get t = 0 for every y-line (dy -> inf)
        dy = d[:, 1].copy()
        dy[dy == 0.0] = np.inf
        n_edges = len(d)
        t = np.concatenate(
            [
                np.zeros((n_edges, 1)),
                np.ones((n_edges, 1)),
                (xn[i0:i1] - start[:, :1]) / d[:, :1],
                (yn[j0:j1] - start[:, 1:]) / dy[:, None],
            ],
            axis=1,
        )
        np.maximum(t, 0.0, out=t)
        np.minimum(t, 1.0, out=t)
        t.sort(axis=1)
        width = t.shape[1]
        # the pieces of positive length, flat: piece q of edge e runs from t[e, c] to t[e, c + 1]
        q = np.flatnonzero(t[:, 1:] > t[:, :-1])
        e = q // (width - 1)
        tf = t.ravel()
        ta, tb = tf[q + e], tf[q + e + 1]
        sx, sy, ex, ey = np.concatenate([start.T, d.T])[:, e]
        tt = np.concatenate([ta[None], (0.5 * (ta + tb))[None], tb[None]])
        x = sx + tt * ex
        y = sy + tt * ey
        # each piece's padded cell from its midpoint (searchsorted is exact against the nodes)
        i = xn.searchsorted(x[1], side="right")
        j = yn.searchsorted(y[1], side="right")
        cell = self._fields[:, i * (self.ny + 2) + j]
        # prefix sums relative to the row of the part's lowest point (a column offset: oint = 0)
        ref = self._fields_by_column[:, :, j0][:, i]
        fx, fy, bottom = cell[0], cell[1], cell[5]
        hx, hy = cell[2] - ref[2], cell[3] - ref[3]
        ax, ay = float(about[0]), float(about[1])
        u = y - bottom  # y above the cell bottom at the Simpson nodes
        w = (self._simpson * ((tb - ta) * ex)).ravel()  # signed dx times Simpson weights
        gx = hx + fx * u  # H at the nodes
        gy = hy + fy * u
        # K - ay H = (Kb - ay Hb) + fx u (u/2 + bottom - ay): only its x component is needed
        kk = (cell[4] - ref[4] - ay * hx) + fx * u * (0.5 * u + (bottom - ay))
        torque = (x - ax) * gy - kk
        return -np.array([w @ gx.ravel(), w @ gy.ravel(), w @ torque.ravel()])
