"""The one-bit proximity sensor: which arm positions a part covers, and the trigger radius range (contract 3)."""

from __future__ import annotations

import numpy as np

from feeder_planner.throwing.geometry import ArmPart, rotate

Intervals = list[tuple[float, float]]


def merge(intervals: Intervals) -> Intervals:
    """Union of closed intervals, sorted and disjoint."""
    out: Intervals = []
    for lo, hi in sorted(intervals):
        if out and lo <= out[-1][1]:
            out[-1] = (out[-1][0], max(out[-1][1], hi))
        else:
            out.append((lo, hi))
    return out


def intersect(a: Intervals, b: Intervals) -> Intervals:
    out: Intervals = []
    i = j = 0
    while i < len(a) and j < len(b):
        lo, hi = max(a[i][0], b[j][0]), min(a[i][1], b[j][1])
        if lo <= hi:
            out.append((lo, hi))
        if a[i][1] < b[j][1]:
            i += 1
        else:
            j += 1
    return out


def subtract(a: Intervals, b: Intervals) -> Intervals:
    """A minus the open interiors of b (a sensor exactly on a forbidden state's border is refused too)."""
    out: Intervals = []
    for lo, hi in a:
        pieces = [(lo, hi)]
        for blo, bhi in b:
            nxt: Intervals = []
            for plo, phi in pieces:
                if bhi < plo or blo > phi:
                    nxt.append((plo, phi))
                    continue
                if plo < blo:
                    nxt.append((plo, blo))
                if bhi < phi:
                    nxt.append((bhi, phi))
            pieces = nxt
        out.extend(pieces)
    return [(lo, hi) for lo, hi in out if hi > lo]


def covered(loops: tuple[np.ndarray, ...], base: float, height: float) -> Intervals:
    """The x positions where the vertical segment {x} x [base, base + height] meets the polygon with these loops."""
    top = base + height
    scale = max(float(np.abs(loop).max()) for loop in loops)
    eps = 1e-12 * scale
    pieces: Intervals = []
    for loop in loops:
        p, q = loop, np.roll(loop, -1, axis=0)
        for (x0, y0), (x1, y1) in zip(p, q):
            # Clip the boundary segment to the slab.
            t0, t1 = 0.0, 1.0
            dy = y1 - y0
            if abs(dy) < 1e-300:
                if not (base - eps <= y0 <= top + eps):
                    continue
            else:
                ta, tb = (base - eps - y0) / dy, (top + eps - y0) / dy
                t0, t1 = max(t0, min(ta, tb)), min(t1, max(ta, tb))
                if t0 > t1:
                    continue
            xa, xb = x0 + t0 * (x1 - x0), x0 + t1 * (x1 - x0)
            pieces.append((min(xa, xb), max(xa, xb)))
    # Chords of the part along the slab's top line (where the part spans the slab wider than its boundary shows).
    for level in (top, base):
        xs = []
        for loop in loops:
            p, q = loop, np.roll(loop, -1, axis=0)
            for (x0, y0), (x1, y1) in zip(p, q):
                if (y0 > level) != (y1 > level):
                    xs.append(x0 + (level - y0) * (x1 - x0) / (y1 - y0))
        xs.sort()
        pieces.extend((xs[i], xs[i + 1]) for i in range(0, len(xs) - 1, 2))
    return merge(pieces)


def resting_cover(part: ArmPart, edge: int, height: float) -> Intervals:
    """Covered x positions, relative to the centre of mass, of the part resting on ``edge`` (its loops, not its hull)."""
    angle = -float(part.edge_angle[edge])
    loops = tuple(rotate(loop, angle) for loop in part.part.loops())
    return covered(loops, -float(part.d[edge]), height)


def reads(part: ArmPart, edge: int, radius: float, sensor_radius: float, height: float) -> bool:
    """Sensor value with the part at rest on ``edge`` at R = ``radius``."""
    return any(lo <= sensor_radius - radius <= hi for lo, hi in resting_cover(part, edge, height))


def reads_pose(
    part: ArmPart, x: float, y: float, theta: float, arm_y: float, sensor_radius: float, height: float
) -> bool:
    """Sensor value for a part at any pose (x, y, theta) in the arm frame, arm surface at y = arm_y."""
    loops = part.part.placed(x, y, theta)
    return any(lo <= sensor_radius <= hi for lo, hi in covered(loops, arm_y, height))


def trigger_range(
    part: ArmPart, goal: int, height: float, states: list[list[tuple[int, float]]]
) -> tuple[float, float] | None:
    """Widest sensor radius interval that reads true at rest in every visit to ``goal`` and never elsewhere.

    ``states`` holds, per start, the resting states (edge, R) of its trajectory inside the limit set.
    """
    covers = {e: resting_cover(part, e, height) for e in {e for run in states for e, _ in run}}
    forbidden: Intervals = []
    allowed: Intervals | None = None
    for run in states:
        visit: Intervals = []
        for index, (edge, radius) in enumerate(run):
            shifted = [(lo + radius, hi + radius) for lo, hi in covers[edge]]
            if edge == goal:
                visit.extend(shifted)
                last = index + 1 == len(run) or run[index + 1][0] != goal
                # Only whole visits count: a visit cut by the window's ends may be incomplete.
                if last and index + 1 < len(run) and _starts_inside(run, index, goal):
                    allowed = merge(visit) if allowed is None else intersect(allowed, merge(visit))
                if last:
                    visit = []
            else:
                forbidden.extend(shifted)
    if allowed is None:
        return None
    free = subtract(allowed, merge(forbidden))
    if not free:
        return None
    lo, hi = max(free, key=lambda iv: iv[1] - iv[0])
    return (lo, hi)


def _starts_inside(run: list[tuple[int, float]], end: int, goal: int) -> bool:
    """Whether the goal visit ending at ``end`` began after the window's first state."""
    start = end
    while start > 0 and run[start - 1][0] == goal:
        start -= 1
    return start > 0
