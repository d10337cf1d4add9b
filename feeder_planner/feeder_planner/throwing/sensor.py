"""The one-bit proximity sensor: the arm positions a part covers and the trigger radius range (contract 3)."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from feeder_planner.errors import InputError
from feeder_planner.throwing.geometry import ArmPart, rotate
from feeder_planner.throwing.tolerances import HORIZONTAL_EDGE, SENSING_HEIGHT_FRACTION, SLAB_SLACK

__all__ = [
    "Intervals",
    "check_sensing_height",
    "sensing_height_or_default",
    "merge",
    "intersect",
    "subtract",
    "covered",
    "resting_cover",
    "reads",
    "reads_pose",
    "trigger_range",
    "TriggerReading",
    "read_trigger",
]

Intervals = list[tuple[float, float]]


def check_sensing_height(value: float, field: str = "sensing_height") -> float:
    """Return ``value`` if it is a finite sensing height >= 0, else raise InputError naming ``field``."""
    if not math.isfinite(value):
        raise InputError(field, f"must be finite, got {value!r}")
    if value < 0:
        raise InputError(field, f"must be >= 0, got {value}")
    return value


def sensing_height_or_default(part: ArmPart, height: float | None) -> float:
    """Return ``height`` checked, or when None the default: SENSING_HEIGHT_FRACTION of the part radius."""
    return SENSING_HEIGHT_FRACTION * part.radius if height is None else check_sensing_height(height)


def merge(intervals: Intervals) -> Intervals:
    """Return the union of closed intervals, sorted and disjoint."""
    out: Intervals = []
    for lo, hi in sorted(intervals):
        if out and lo <= out[-1][1]:
            out[-1] = (out[-1][0], max(out[-1][1], hi))
        else:
            out.append((lo, hi))
    return out


def intersect(a: Intervals, b: Intervals) -> Intervals:
    """Return the intersection of two sorted, disjoint unions of closed intervals."""
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
    """Return a minus the open interiors of b (a sensor exactly on a forbidden border is refused too)."""
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
    """Return the x where the vertical segment {x} x [base, base + height] meets the polygon of ``loops``."""
    top = base + height
    scale = max(float(np.abs(loop).max()) for loop in loops)
    eps = SLAB_SLACK * scale
    pieces: Intervals = []
    for loop in loops:
        p, q = loop, np.roll(loop, -1, axis=0)
        for (x0, y0), (x1, y1) in zip(p, q, strict=True):
            # Clip the boundary segment to the slab.
            t0, t1 = 0.0, 1.0
            dy = y1 - y0
            if abs(dy) < HORIZONTAL_EDGE:
                if not (base - eps <= y0 <= top + eps):
                    continue
            else:
                ta, tb = (base - eps - y0) / dy, (top + eps - y0) / dy
                t0, t1 = max(t0, min(ta, tb)), min(t1, max(ta, tb))
                if t0 > t1:
                    continue
            xa, xb = x0 + t0 * (x1 - x0), x0 + t1 * (x1 - x0)
            pieces.append((min(xa, xb), max(xa, xb)))
    # Chords along the slab's top and bottom lines: where the part spans the slab wider than its boundary.
    for level in (top, base):
        xs = []
        for loop in loops:
            p, q = loop, np.roll(loop, -1, axis=0)
            for (x0, y0), (x1, y1) in zip(p, q, strict=True):
                if (y0 > level) != (y1 > level):
                    xs.append(x0 + (level - y0) * (x1 - x0) / (y1 - y0))
        xs.sort()
        pieces.extend((xs[i], xs[i + 1]) for i in range(0, len(xs) - 1, 2))
    return merge(pieces)


def resting_cover(part: ArmPart, edge: int, height: float) -> Intervals:
    """Return the covered x, relative to the centre of mass, of the part resting on ``edge``.

    The part's own loops count, not its hull (contract 3).
    """
    angle = -float(part.edge_angle[edge])
    loops = tuple(rotate(loop, angle) for loop in part.part.loops())
    return covered(loops, -float(part.d[edge]), height)


def reads(part: ArmPart, edge: int, radius: float, sensor_radius: float, height: float) -> bool:
    """Return the sensor value with the part at rest on ``edge`` at R = ``radius``."""
    return any(lo <= sensor_radius - radius <= hi for lo, hi in resting_cover(part, edge, height))


def reads_pose(
    part: ArmPart, x: float, y: float, theta: float, arm_y: float, sensor_radius: float, height: float
) -> bool:
    """Return the sensor value for a part at a pose (x, y, theta) in the arm frame, arm surface y = arm_y."""
    loops = part.part.placed(x, y, theta)
    return any(lo <= sensor_radius <= hi for lo, hi in covered(loops, arm_y, height))


def _merged(low: np.ndarray, high: np.ndarray) -> Intervals:
    """Return the union of closed intervals [low[k], high[k]], sorted and disjoint (``merge``, vectorized)."""
    if low.size == 0:
        return []
    order = np.lexsort((high, low))
    low, high = low[order], high[order]
    top = np.maximum.accumulate(high)
    starts = np.flatnonzero(np.concatenate([[True], low[1:] > top[:-1]]))
    ends = np.concatenate([starts[1:], [low.size]]) - 1
    return [(float(low[a]), float(top[b])) for a, b in zip(starts, ends, strict=True)]


def _goal_and_others(
    part: ArmPart, goal: int, height: float, states: list[list[tuple[int, float]]]
) -> tuple[Intervals | None, dict[int, Intervals]]:
    """Return the sensor radii covered in every complete visit to ``goal``, and those of each other edge.

    The first is None when no visit to ``goal`` is complete; the second maps each other edge to the
    radii covered while the part rests on it. A visit is a run of states on ``goal``; only whole visits
    count (a visit cut by the stretch's ends may be incomplete).
    """
    covers = {
        e: np.array(resting_cover(part, e, height), dtype=float).reshape(-1, 2)
        for e in {e for run in states for e, _ in run}
    }
    goal_cover = [(float(lo), float(hi)) for lo, hi in covers.get(goal, np.zeros((0, 2)))]
    low: dict[int, list[np.ndarray]] = {}
    high: dict[int, list[np.ndarray]] = {}
    allowed: Intervals | None = None
    for run in states:
        if not run:
            continue
        edge = np.array([e for e, _ in run])
        radius = np.array([r for _, r in run])
        on = edge == goal
        for other in dict.fromkeys(int(e) for e in edge[~on]):
            r = radius[edge == other][:, None]
            low.setdefault(other, []).append((covers[other][:, 0][None, :] + r).ravel())
            high.setdefault(other, []).append((covers[other][:, 1][None, :] + r).ravel())
        steps = np.diff(np.concatenate([[0], on.astype(np.int8), [0]]))
        for a, b in zip(np.flatnonzero(steps == 1), np.flatnonzero(steps == -1), strict=True):
            if a == 0 or b == len(run):
                continue
            # A visit holds a few states: plain Python merges them faster than numpy would.
            visit = merge([(lo + r, hi + r) for _, r in run[a:b] for lo, hi in goal_cover])
            allowed = visit if allowed is None else intersect(allowed, visit)
    return allowed, {e: _merged(np.concatenate(low[e]), np.concatenate(high[e])) for e in low}


def trigger_range(
    part: ArmPart, goal: int, height: float, states: list[list[tuple[int, float]]]
) -> tuple[float, float] | None:
    """Return the widest sensor radius range reading true at rest in every visit to ``goal``, never elsewhere.

    ``states`` holds, per start, the resting states (edge, R) of its trajectory inside the limit set.
    """
    allowed, others = _goal_and_others(part, goal, height, states)
    if allowed is None:
        return None
    free = subtract(allowed, merge([iv for v in others.values() for iv in v]))
    if not free:
        return None
    lo, hi = max(free, key=lambda iv: iv[1] - iv[0])
    return (lo, hi)


def _length(intervals: Intervals) -> float:
    """Return the total length of sorted, disjoint intervals."""
    return sum(hi - lo for lo, hi in intervals)


@dataclass(frozen=True)
class TriggerReading:
    """The trigger range of a set of attractors and, when there is none, why.

    ``trigger``: the widest sensor radius range reading true in every complete visit to the goal edge
    and in no resting state elsewhere (None: none). ``allowed``: the radii covered in every complete goal
    visit (None: no complete visit; empty: the visits share none). ``blockers``: per (attractor, other
    edge) whose resting states cover some of ``allowed``, the part covered, the most first. ``alone``:
    the attractors whose own goal visits share no radius. ``free``: every sensor radius range that reads
    true in every goal visit and never elsewhere, ``trigger`` the widest of them.
    """

    trigger: tuple[float, float] | None
    allowed: Intervals | None
    blockers: list[tuple[int, int, Intervals]]
    alone: list[int]
    free: Intervals = dataclasses.field(default_factory=list)


def read_trigger(
    part: ArmPart, goal: int, height: float, groups: list[list[list[tuple[int, float]]]]
) -> TriggerReading:
    """Return the trigger range over the attractors' states and what rules one out, in one pass.

    ``groups`` holds the states of each attractor, as ``trigger_range`` takes them.
    """
    per_group = [_goal_and_others(part, goal, height, g) for g in groups]
    allowed: Intervals | None = None
    for own, _ in per_group:
        if own is not None:
            allowed = own if allowed is None else intersect(allowed, own)
    alone = [k for k, (own, _) in enumerate(per_group) if own is not None and not own]
    if not allowed:
        return TriggerReading(None, allowed, [], alone)
    found: list[tuple[int, int, Intervals]] = []
    for k, (_, others) in enumerate(per_group):
        for edge, cover in others.items():
            hit = intersect(allowed, cover)
            if _length(hit) > 0:
                found.append((k, edge, hit))
    found.sort(key=lambda f: -_length(f[2]))
    free = subtract(allowed, merge([iv for _, others in per_group for v in others.values() for iv in v]))
    trigger = max(free, key=lambda iv: iv[1] - iv[0]) if free else None
    return TriggerReading(trigger, allowed, found, alone, free)


def _starts_inside(run: list[tuple[int, float]], end: int, goal: int) -> bool:
    """Return whether the goal visit ending at ``end`` began after the window's first state."""
    start = end
    while start > 0 and run[start - 1][0] == goal:
        start -= 1
    return start > 0
