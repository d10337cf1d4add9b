"""Exact planar polygon geometry: area, centroid, second moments, simplicity, convex hull."""

from __future__ import annotations

from typing import Callable, Iterator, Sequence

import numpy as np

from feeder_planner.errors import InputError

# Relative tolerance of every planar predicate here (orientation, coincidence, collinearity, zero area),
# as a fraction of the polygon's extent (lengths) or its square (areas, cross products). 1e-12 is about
# 4500 ulps of a double: far above the rounding of one cross product of coordinates of that extent, far
# below any feature a part file can mean (a part 1 m wide resolves 1 pm).
RELATIVE_TOLERANCE = 1e-12


def signed_area(vertices: np.ndarray) -> float:
    """Shoelace area; positive for counter-clockwise vertex order."""
    x, y = vertices[:, 0], vertices[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def _next(values: np.ndarray) -> np.ndarray:
    """Return each coordinate's successor around the loop: np.roll(values, -1) at a third of the cost."""
    return np.concatenate((values[1:], values[:1]))


def first_moments(vertices: np.ndarray) -> tuple[float, float, float]:
    """Return (A, Sx, Sy): the signed area and the integrals of x and y over the polygon (Green's theorem)."""
    x0, y0 = vertices[:, 0], vertices[:, 1]
    x1, y1 = _next(x0), _next(y0)
    cross = x0 * y1 - x1 * y0
    area = 0.5 * float(cross.sum())
    sx = float(((x0 + x1) * cross).sum()) / 6.0
    sy = float(((y0 + y1) * cross).sum()) / 6.0
    return area, sx, sy


def second_moments(vertices: np.ndarray) -> tuple[float, float, float]:
    """(Ixx, Iyy, Ixy) = integrals of x^2, y^2 and x*y over the polygon (signed like the area)."""
    x0, y0 = vertices[:, 0], vertices[:, 1]
    x1, y1 = _next(x0), _next(y0)
    cross = x0 * y1 - x1 * y0
    ixx = float(((x0 * x0 + x0 * x1 + x1 * x1) * cross).sum()) / 12.0
    iyy = float(((y0 * y0 + y0 * y1 + y1 * y1) * cross).sum()) / 12.0
    ixy = float(((x0 * y1 + 2 * x0 * y0 + 2 * x1 * y1 + x1 * y0) * cross).sum()) / 24.0
    return ixx, iyy, ixy


def _segments_cross(p: np.ndarray, q: np.ndarray, r: np.ndarray, s: np.ndarray, scale: float) -> np.ndarray:
    """Whether closed segments p-q and r-s intersect (vectorised over rows), with a relative tolerance."""
    eps = RELATIVE_TOLERANCE * scale * scale

    def orient(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
        value = (b[..., 0] - a[..., 0]) * (c[..., 1] - a[..., 1]) - (b[..., 1] - a[..., 1]) * (
            c[..., 0] - a[..., 0]
        )
        return np.where(np.abs(value) <= eps, 0.0, np.sign(value))

    def on_segment(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
        return (
            (np.minimum(a[..., 0], b[..., 0]) <= c[..., 0] + RELATIVE_TOLERANCE * scale)
            & (c[..., 0] <= np.maximum(a[..., 0], b[..., 0]) + RELATIVE_TOLERANCE * scale)
            & (np.minimum(a[..., 1], b[..., 1]) <= c[..., 1] + RELATIVE_TOLERANCE * scale)
            & (c[..., 1] <= np.maximum(a[..., 1], b[..., 1]) + RELATIVE_TOLERANCE * scale)
        )

    o1, o2, o3, o4 = orient(p, q, r), orient(p, q, s), orient(r, s, p), orient(r, s, q)
    proper = (o1 * o2 < 0) & (o3 * o4 < 0)
    touching = (
        ((o1 == 0) & on_segment(p, q, r))
        | ((o2 == 0) & on_segment(p, q, s))
        | ((o3 == 0) & on_segment(r, s, p))
        | ((o4 == 0) & on_segment(r, s, q))
    )
    return proper | touching


def check_simple(vertices: np.ndarray, field: str) -> None:
    """Raise InputError naming ``field`` unless the closed polygon is simple with non-zero area."""
    n = len(vertices)
    if n < 3:
        raise InputError(field, f"a polygon needs at least 3 vertices, got {n}")
    scale = float(np.ptp(vertices, axis=0).max())
    if scale <= 0.0:
        raise InputError(field, "degenerate polygon: all vertices coincide")
    edges = np.roll(vertices, -1, axis=0) - vertices
    lengths = np.hypot(edges[:, 0], edges[:, 1])
    short = np.flatnonzero(lengths <= RELATIVE_TOLERANCE * scale)
    if short.size:
        raise InputError(field, f"degenerate polygon: vertices {short[0]} and {(short[0] + 1) % n} coincide")
    # Every pair of non-adjacent edges must be disjoint; adjacent edges may only share their vertex.
    start, end = vertices, np.roll(vertices, -1, axis=0)
    hit = first_crossing(start, end, scale, lambda i, j: (j == i + 1) | ((i == 0) & (j == n - 1)))
    if hit is not None:
        raise InputError(field, f"self-intersecting polygon: edge {hit[0]} meets edge {hit[1]}")
    # Adjacent edges folding back on themselves overlap along a segment.
    prev_edge, next_edge = edges, np.roll(edges, -1, axis=0)
    cross = prev_edge[:, 0] * next_edge[:, 1] - prev_edge[:, 1] * next_edge[:, 0]
    dot = (prev_edge * next_edge).sum(axis=1)
    folded = np.flatnonzero((np.abs(cross) <= RELATIVE_TOLERANCE * scale * scale) & (dot < 0))
    if folded.size:
        raise InputError(field, f"self-intersecting polygon: edges fold back at vertex {(folded[0] + 1) % n}")
    if abs(signed_area(vertices)) <= RELATIVE_TOLERANCE * scale * scale:
        raise InputError(field, "degenerate polygon: zero area")


def point_in_polygon(point: np.ndarray, vertices: np.ndarray) -> bool:
    """Even-odd rule; points exactly on the boundary may go either way."""
    x, y = float(point[0]), float(point[1])
    xs, ys = vertices[:, 0], vertices[:, 1]
    xn, yn = np.roll(xs, -1), np.roll(ys, -1)
    straddle = (ys > y) != (yn > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        x_cross = xs + (y - ys) * (xn - xs) / (yn - ys)
    return bool(np.count_nonzero(straddle & (x < x_cross)) % 2)


def loop_contacts(loops: Sequence[np.ndarray]) -> np.ndarray:
    """Return the pairs (k, l), k < l, of loops whose boundaries touch or cross, as a (m, 2) int array.

    One sweep over the edges of every loop (``crossing_batches``): memory linear in the vertices.
    """
    starts = np.concatenate(loops)
    ends = np.concatenate([np.roll(loop, -1, axis=0) for loop in loops])
    owner = np.repeat(np.arange(len(loops)), [len(loop) for loop in loops])
    scale = float(max(np.ptp(loop, axis=0).max() for loop in loops))
    found = [np.empty((0, 2), dtype=np.int64)]
    for i, j in crossing_batches(starts, ends, scale, lambda i, j: owner[i] == owner[j]):
        found.append(np.unique(np.stack((owner[i], owner[j]), axis=1), axis=0))
    return np.unique(np.concatenate(found), axis=0)


def points_in_polygon(points: np.ndarray, vertices: np.ndarray) -> np.ndarray:
    """Even-odd rule for many points at once (as ``point_in_polygon``), in batches of bounded memory."""
    xs, ys = vertices[:, 0], vertices[:, 1]
    xn, yn = np.roll(xs, -1), np.roll(ys, -1)
    inside = np.zeros(len(points), dtype=bool)
    rows = max(1, SWEEP_BATCH_PAIRS // max(1, len(vertices)))
    for first in range(0, len(points), rows):
        x = points[first : first + rows, 0:1]
        y = points[first : first + rows, 1:2]
        straddle = (ys > y) != (yn > y)
        with np.errstate(divide="ignore", invalid="ignore"):
            x_cross = xs + (y - ys) * (xn - xs) / (yn - ys)
        inside[first : first + rows] = np.count_nonzero(straddle & (x < x_cross), axis=1) % 2 == 1
    return inside


# Candidate pairs compared per batch of the sweep: bounds the sweep's memory (about 100 bytes a pair)
# whatever the polygon, at no cost in speed for batches this large.
SWEEP_BATCH_PAIRS = 200_000


def first_crossing(
    start: np.ndarray,
    end: np.ndarray,
    scale: float,
    excluded: Callable[[np.ndarray, np.ndarray], np.ndarray],
) -> tuple[int, int] | None:
    """Return the least pair (i, j), i < j, of segments that cross, or None (``crossing_batches``)."""
    best: tuple[int, int] | None = None
    for i, j in crossing_batches(start, end, scale, excluded):
        k = int(np.lexsort((j, i))[0])
        candidate = (int(i[k]), int(j[k]))
        best = candidate if best is None else min(best, candidate)
    return best


def crossing_batches(
    start: np.ndarray,
    end: np.ndarray,
    scale: float,
    excluded: Callable[[np.ndarray, np.ndarray], np.ndarray],
) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """Yield the pairs (i, j), i < j, of segments start-end that cross, in batches; memory is linear.

    A sorted-bounds sweep: segments sorted by their lowest x; each is compared only with the segments
    whose lowest x falls in its own x range (every pair of overlapping x ranges is found that way, from
    the segment that starts first), then only where the y ranges overlap too. The ranges are widened by
    twice the tolerance of ``_segments_cross``, so no pair it would call crossing is skipped: the pairs
    are those of comparing every pair, found in batches of at most SWEEP_BATCH_PAIRS candidates.
    ``excluded(i, j)`` masks pairs never compared (adjacent edges of one loop, edges of one loop).
    """
    margin = 2.0 * RELATIVE_TOLERANCE * scale
    low = np.minimum(start, end) - margin
    high = np.maximum(start, end) + margin
    order = np.argsort(low[:, 0], kind="stable")
    sorted_low_x = low[order, 0]
    # Sorted positions p+1 .. reach[p]-1 start within segment order[p]'s x range.
    reach = np.searchsorted(sorted_low_x, high[order, 0], side="right")
    counts = np.maximum(reach - np.arange(len(order)) - 1, 0)
    cumulative = np.concatenate(([0], np.cumsum(counts)))
    position = 0
    while position < len(order):
        # A batch of sorted positions whose candidate pairs fit SWEEP_BATCH_PAIRS (at least one position).
        limit = cumulative[position] + SWEEP_BATCH_PAIRS
        stop = max(position + 1, int(np.searchsorted(cumulative, limit, side="right")) - 1)
        batch = np.arange(position, stop)
        position = stop
        repeats = counts[batch]
        total = int(repeats.sum())
        if not total:
            continue
        first = np.repeat(batch, repeats)
        offsets = np.arange(total) - np.repeat(np.cumsum(repeats) - repeats, repeats)
        second = first + 1 + offsets
        p, q = order[first], order[second]
        keep = (low[p, 1] <= high[q, 1]) & (low[q, 1] <= high[p, 1])
        i, j = np.minimum(p[keep], q[keep]), np.maximum(p[keep], q[keep])
        keep = ~excluded(i, j)
        i, j = i[keep], j[keep]
        if not i.size:
            continue
        hits = _segments_cross(start[i], end[i], start[j], end[j], scale)
        if hits.any():
            yield i[hits], j[hits]


def convex_hull_indices(points: np.ndarray) -> list[int]:
    """Return the convex hull's vertex indices, counter-clockwise, collinear points dropped.

    Andrew's monotone chain.
    """
    order = sorted(range(len(points)), key=lambda k: (points[k, 0], points[k, 1]))
    scale = float(np.ptp(points, axis=0).max()) or 1.0
    eps = RELATIVE_TOLERANCE * scale * scale

    def cross(o: int, a: int, b: int) -> float:
        return float(
            (points[a, 0] - points[o, 0]) * (points[b, 1] - points[o, 1])
            - (points[a, 1] - points[o, 1]) * (points[b, 0] - points[o, 0])
        )

    lower: list[int] = []
    for k in order:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], k) <= eps:
            lower.pop()
        lower.append(k)
    upper: list[int] = []
    for k in reversed(order):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], k) <= eps:
            upper.pop()
        upper.append(k)
    return lower[:-1] + upper[:-1]
