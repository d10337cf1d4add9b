"""Exact lifted unit-radial potential V(X, Y) = int_S |(X, Y) + r| dA (eq. 4) and its derivatives.

Orders 0-2 are closed forms of boundary integrals (divergence theorem: V = 1/3 oint |r| (r.n) ds,
grad V = oint |r| n ds (eqs. 5-6), Hess V = oint (r/|r|) n^T ds (eqs. 7-9)); every edge integral is
elementary (sqrt and asinh). Orders >= 3 use d^{k}V = oint d^{k-1}|r| n ds, the (k-1)-th derivatives
of |r| obtained exactly by the Leibniz recursion of |r|*|r| = xi^2 + eta^2 and integrated by
Gauss-Legendre on pieces graded geometrically away from the foot of the origin on each edge line, so
that every piece sees the integrand's complex singularities (foot +- i h) at least one piece length
away: 24 nodes then leave only rounding (relative error < 1e-12, tested). Valid while the origin is
not on the boundary (Prop. 2).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property, lru_cache
from math import comb

import numpy as np

from feeder_planner.errors import InputError
from feeder_planner.mems.tolerances import (
    GAUSS_NODES,
    GRADING_EXTRA_LEVELS,
    GRADING_MAX_LEVELS,
    ON_BOUNDARY,
    ROUNDING_BOUND,
)
from feeder_planner.parts import Part

__all__ = [
    "Edges",
    "edge_endpoints",
    "loop_edges",
    "part_edges",
    "potential",
    "gradient",
    "point_gradient",
    "value_gradient_hessian",
    "value_gradient_hessian_noise",
    "derivatives",
]


# The smallest |h| divided by: h A is below 1e-297 there, where it is taken as its limit 0.
_H_FLOOR = 1e-300


@dataclass(frozen=True)
class Edges:
    """All boundary edges of a part (outer counter-clockwise, holes clockwise) as arrays."""

    start: np.ndarray  # (E, 2) in the part frame
    direction: np.ndarray  # (E, 2) unit tangent
    normal: np.ndarray  # (E, 2) unit outward normal of the area
    length: np.ndarray  # (E,)
    scale: float  # part radius, the length scale of tolerances

    @cached_property
    def lines(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return (P, o, M): o + P z = (s0, s1, h, h) (4E,) and M = (-n; n) (2E, 2).

        o + P z are the edges' terms translated by z, M the normals signed for the ends (s0; s1).
        s0, s1 are the arc-length coordinates of an edge's ends from the foot of the origin on its line and
        h its signed distance (``_edge_terms``): affine in the translation, so fixed edges need them once.
        h comes twice, beside the two ends, so that both ends' terms are one operation each; an edge's
        integral, end term minus start term, times its normal is then one product with M.
        """
        s0 = (self.start * self.direction).sum(axis=1)
        h = (self.start * self.normal).sum(axis=1)
        projection = np.vstack([self.direction, self.direction, self.normal, self.normal])
        return (
            projection,
            np.concatenate([s0, s0 + self.length, h, h]),
            np.vstack([-self.normal, self.normal]),
        )


def edge_endpoints(loops: tuple[np.ndarray, ...]) -> tuple[np.ndarray, np.ndarray]:
    """Return the start and end points (E, 2) of every edge of the loops, stacked loop after loop.

    Edge i of a loop joins its vertex i to vertex i + 1, the last one closing the loop.
    """
    start = np.vstack(loops)
    end = np.vstack([np.roll(loop, -1, axis=0) for loop in loops])
    return start, end


def loop_edges(loops: tuple[np.ndarray, ...], scale: float | None = None) -> Edges:
    """Return the Edges of loops oriented so the area lies on their left (outer ccw, holes cw).

    ``scale`` is the length scale of the tolerances (the part radius); by default the largest
    coordinate of the loops, which is what placed loops in the plane frame offer.
    """
    a, b = edge_endpoints(loops)
    d = b - a
    length = np.hypot(d[:, 0], d[:, 1])
    u = d / length[:, None]
    n = np.column_stack([u[:, 1], -u[:, 0]])
    return Edges(a, u, n, length, float(np.abs(a).max()) if scale is None else scale)


def part_edges(part: Part) -> Edges:
    """Return the Edges of the part's loops in the part frame, with the part radius as scale."""
    return loop_edges(part.loops(), part.radius)


def _edge_terms(edges: Edges, z: np.ndarray) -> tuple[np.ndarray, ...]:
    """Return per-edge (s0, s1, h, rho0, rho1, h*A) with A = int ds/|r| along the translated edge."""
    a = edges.start + z[..., None, :]  # (..., E, 2)
    s0 = np.einsum("...ek,ek->...e", a, edges.direction)
    h = np.einsum("...ek,ek->...e", a, edges.normal)
    return _line_terms(np.concatenate([s0, s0 + edges.length], axis=-1), np.concatenate([h, h], axis=-1))


def _line_terms(ends: np.ndarray, h2: np.ndarray) -> tuple[np.ndarray, ...]:
    """Return (s0, s1, h, rho0, rho1, h*A) from the edges' ends and their distances, both (..., 2E).

    ``ends`` are (s0, s1), the ends' coordinates on the edges' lines, ``h2`` the distances h twice.
    A = asinh(s1/|h|) - asinh(s0/|h|). Where the two nearly cancel (an edge far along its line), |h| is
    small against s and h A enters V and its derivatives times h, below the rounding of the s rho terms.
    """
    count = ends.shape[-1] // 2
    rho = np.hypot(ends, h2)
    asinh = _asinh_of_ends(ends, h2)
    h = h2[..., :count]
    h_a = h * (asinh[..., count:] - asinh[..., :count])
    return ends[..., :count], ends[..., count:], h, rho[..., :count], rho[..., count:], h_a


def _asinh_of_ends(ends: np.ndarray, h2: np.ndarray) -> np.ndarray:
    """Return asinh(s/|h|) at every end.

    h A -> 0 with h (as h log|h|), so a floor on |h| keeps the quotients finite without changing it:
    hypot(h, floor) is |h| to the bit for |h| above about 1e-292, and the floor at h = 0.
    """
    return np.arcsinh(ends / np.hypot(h2, _H_FLOOR))


def _abs_r_integrals(terms: tuple[np.ndarray, ...]) -> np.ndarray:
    """Return int |r| ds along every edge: [s rho + h^2 asinh(s/|h|)]/2 between the edge's ends."""
    s0, s1, h, rho0, rho1, h_a = terms
    return 0.5 * (s1 * rho1 - s0 * rho0 + h * h_a)


def _noise_of(terms: tuple[np.ndarray, ...]) -> np.ndarray:
    """Return the rounding bound of the gradient's sum: ROUNDING_BOUND times the sum of |its terms|."""
    s0, s1, h, rho0, rho1, h_a = terms
    magnitudes = 0.5 * (np.abs(s1 * rho1) + np.abs(s0 * rho0) + np.abs(h * h_a))
    return ROUNDING_BOUND * magnitudes.sum(axis=-1)


def potential(edges: Edges, z: np.ndarray) -> np.ndarray:
    """Return V at translations z (..., 2), eq. (4) as 1/3 sum_e h_e int |r| ds."""
    terms = _edge_terms(edges, np.asarray(z, float))
    return (terms[2] * _abs_r_integrals(terms)).sum(axis=-1) / 3.0


def gradient(edges: Edges, z: np.ndarray) -> np.ndarray:
    """Return (dV/dX, dV/dY) at translations z (..., 2), eqs. (5-6) as oint |r| n ds."""
    terms = _edge_terms(edges, np.asarray(z, float))
    return np.einsum("...e,ek->...k", _abs_r_integrals(terms), edges.normal)


def point_gradient(edges: Edges, z: tuple[float, float]) -> tuple[float, float]:
    """Return (dV/dX, dV/dY) at one translation z, eqs. (5-6): ``gradient`` without rebuilding the terms.

    The edges' projections (``Edges.lines``) are kept, so a part's fixed edges cost one product per call,
    and every edge's int |r| ds is the difference of its antiderivative s rho + h^2 asinh(s/|h|) (twice
    ``_abs_r_integrals``) at its two ends, taken for all ends at once. ndarray.dot: the @ operator costs
    twice as much on arrays this small.
    """
    projection, offset, signed_normals = edges.lines
    count = 2 * len(edges.length)
    ends_h = offset + projection.dot(np.array(z, float))
    ends, h2 = ends_h[:count], ends_h[count:]
    antiderivative = ends * np.hypot(ends, h2) + h2 * h2 * _asinh_of_ends(ends, h2)
    gx, gy = antiderivative.dot(signed_normals).tolist()
    return 0.5 * gx, 0.5 * gy


def value_gradient_hessian(edges: Edges, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return V, grad V and Hess V (eqs. 4-9) at translations z (..., 2), all closed forms."""
    return value_gradient_hessian_noise(edges, z)[:3]


def value_gradient_hessian_noise(
    edges: Edges, z: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Return V, grad V, Hess V and a bound on the rounding error of grad V, from one evaluation.

    The bound is ROUNDING_BOUND times the sum of the magnitudes of grad V's edge terms.
    """
    terms = _edge_terms(edges, np.asarray(z, float))
    s0, s1, h, rho0, rho1, h_a = terms
    noise = _noise_of(terms)
    i0 = _abs_r_integrals(terms)
    value = (h * i0).sum(axis=-1) / 3.0
    grad = np.einsum("...e,ek->...k", i0, edges.normal)
    # int r/|r| ds = u [rho] + n h A; Hess_ij = sum_e (int r_i/|r| ds) n_j (eqs. 7-9), symmetric in
    # exact arithmetic.
    w = (rho1 - rho0)[..., None] * edges.direction + h_a[..., None] * edges.normal
    hess = np.einsum("...ei,ej->...ij", w, edges.normal)
    hess = 0.5 * (hess + np.swapaxes(hess, -1, -2))
    return value, grad, hess, noise


def _rho_derivatives(xi: np.ndarray, eta: np.ndarray, order: int) -> dict[tuple[int, int], np.ndarray]:
    """Return every d^{i+j}|r| / dxi^i deta^j for i + j <= order, by Leibniz on |r|^2 = xi^2 + eta^2."""
    rho = np.hypot(xi, eta)
    d: dict[tuple[int, int], np.ndarray] = {(0, 0): rho}
    square = {(1, 0): 2 * xi, (0, 1): 2 * eta, (2, 0): 2.0, (0, 2): 2.0}
    for total in range(1, order + 1):
        for i in range(total, -1, -1):
            j = total - i
            acc = np.asarray(square.get((i, j), 0.0), float) * np.ones_like(rho)
            for bi in range(i + 1):
                for bj in range(j + 1):
                    if (bi, bj) in ((0, 0), (i, j)):
                        continue
                    acc = acc - comb(i, bi) * comb(j, bj) * d[(bi, bj)] * d[(i - bi, j - bj)]
            d[(i, j)] = acc / (2.0 * rho)
    return d


@lru_cache(maxsize=8)
def _gauss(nodes: int) -> tuple[np.ndarray, np.ndarray]:
    """Return Gauss-Legendre nodes and weights on [0, 1]."""
    x, w = np.polynomial.legendre.leggauss(nodes)
    return 0.5 * (x + 1.0), 0.5 * w


def _pieces(edges: Edges, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return breakpoints on every translated edge, graded geometrically about the foot of the origin."""
    a = edges.start + z
    s0 = -(a * edges.direction).sum(axis=1)  # foot of the origin, arc length from the edge start
    h = np.abs((a * edges.normal).sum(axis=1))
    length = edges.length
    outside = np.maximum(np.maximum(-s0, s0 - length), 0.0)  # distance from the foot to the segment
    r0 = np.maximum(h, 0.5 * outside)
    if np.any(r0 <= ON_BOUNDARY * edges.scale):
        raise InputError("field centre", "lies on the part boundary: V is not differentiable there (Prop. 2)")
    reach = np.ceil(np.log2((length.max() + np.abs(s0).max()) / r0.min()))
    levels = int(np.clip(reach + GRADING_EXTRA_LEVELS, 1, GRADING_MAX_LEVELS))
    k = r0[:, None] * 2.0 ** np.arange(levels)[None, :]
    cuts = np.concatenate(
        [np.zeros((len(s0), 1)), length[:, None], s0[:, None], s0[:, None] + k, s0[:, None] - k], axis=1
    )
    cuts = np.sort(np.clip(cuts, 0.0, length[:, None]), axis=1)
    return a, cuts[:, :-1], cuts[:, 1:]


def derivatives(
    part_or_edges: Part | Edges, z: np.ndarray, order: int, nodes: int = GAUSS_NODES
) -> dict[tuple[int, int], float]:
    """Return every V_{i,j} = d^{i+j}V / dX^i dY^j at z for 1 <= i + j <= order (Table 1's input).

    Orders <= 2 come from the closed forms (eqs. 5-9); higher ones from the graded boundary
    quadrature. Raises InputError when the field centre lies on the part boundary (V is only C^2
    there, Prop. 2).
    """
    edges = part_or_edges if isinstance(part_or_edges, Edges) else part_edges(part_or_edges)
    z = np.asarray(z, float)
    _, grad, hess = value_gradient_hessian(edges, z)
    out: dict[tuple[int, int], float] = {
        (1, 0): float(grad[0]),
        (0, 1): float(grad[1]),
        (2, 0): float(hess[0, 0]),
        (1, 1): float(hess[0, 1]),
        (0, 2): float(hess[1, 1]),
    }
    if order <= 2:
        return {key: value for key, value in out.items() if sum(key) <= order}
    a, lo, hi = _pieces(edges, z)
    keep = hi > lo  # clipping leaves many empty pieces; drop them
    edge_index = np.broadcast_to(np.arange(len(lo))[:, None], lo.shape)[keep]
    lo, hi = lo[keep], hi[keep]
    t, w = _gauss(nodes)
    s = lo[:, None] + (hi - lo)[:, None] * t  # (pieces, G)
    weight = (hi - lo)[:, None] * w
    points = a[edge_index][:, None, :] + s[..., None] * edges.direction[edge_index][:, None, :]
    d = _rho_derivatives(points[..., 0], points[..., 1], order - 1)
    nx = edges.normal[edge_index, 0][:, None]
    ny = edges.normal[edge_index, 1][:, None]
    for total in range(3, order + 1):
        for i in range(total, -1, -1):
            j = total - i
            # Peel one derivative off onto the boundary normal: d_X^i d_Y^j V = oint d^{i-1,j}|r| n_x ds.
            integrand = d[(i - 1, j)] * nx if i > 0 else d[(i, j - 1)] * ny
            out[(i, j)] = float((integrand * weight).sum())
    return out
