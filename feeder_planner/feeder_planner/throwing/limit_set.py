"""Iterating the throw map: R_flip and R_max (Prop. IV.4), forward limit sets from a grid of starts, cycles."""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from feeder_planner.errors import InputError, SolverError
from feeder_planner.throwing.geometry import ArmPart
from feeder_planner.throwing.grasp import grasp_radii
from feeder_planner.throwing.sensor import trigger_range
from feeder_planner.throwing.throw_map import GRASP_TOL, ThrowParams, lowest_radius, throw_batch

SCAN_POINTS = 400  # resolution of the R_flip scan and of the invariant-set check, per edge
MAX_SCAN_RADII = 1000  # give up looking for a flip beyond this many part radii past R_grasp


@dataclass
class Trajectories:
    """States after each throw: edge[b, n], radius[b, n], jog[b, n] (jog[:, 0] is meaningless), escaped[b]."""

    edge: np.ndarray
    radius: np.ndarray
    jog: np.ndarray
    escaped: np.ndarray


def iterate(
    part: ArmPart, params: ThrowParams, edges: np.ndarray, radii: np.ndarray, throws: int
) -> Trajectories:
    """f^N from every start at once; a state outside the domain (unstable edge, R < R_grasp) stops its row."""
    low = np.full(part.n, np.inf)
    for i in part.stable_edges:
        low[i] = lowest_radius(part, i, params)
    starts = len(edges)
    edge = np.zeros((starts, throws + 1), dtype=int)
    radius = np.full((starts, throws + 1), np.nan)
    jog = np.zeros((starts, throws + 1), dtype=bool)
    edge[:, 0], radius[:, 0] = edges, radii
    alive = np.arange(starts)
    escaped = np.zeros(starts, dtype=bool)
    for n in range(1, throws + 1):
        if alive.size == 0:
            break
        out = throw_batch(part, edge[alive, n - 1], radius[alive, n - 1], params)
        edge[alive, n], radius[alive, n] = out.edge, out.radius
        jog[alive, n] = out.is_jog(edge[alive, n - 1])
        ok = out.radius >= low[out.edge] - GRASP_TOL * np.abs(low[out.edge])
        escaped[alive[~ok]] = True
        alive = alive[ok]
    return Trajectories(edge, radius, jog, escaped)


@dataclass
class EdgeBounds:
    """Per stable edge: R_grasp, the lowest throwable R, R_flip, R_max (Prop. IV.4), and whether jogs go outward."""

    grasp: dict[int, float]
    low: dict[int, float]
    flip: dict[int, float]
    max: dict[int, float]
    jogs_outward: dict[int, bool]
    invariant: bool  # f maps Z = U_i (i, [low_i, R_max_i]) into itself on the sampled grid


def edge_bounds(part: ArmPart, params: ThrowParams, points: int = SCAN_POINTS) -> EdgeBounds:
    """R_flip^i: the first flip on a grid of R from the lowest throwable R; R_max^i: grown until f(Z) lies in Z.

    Sampled on ``points`` radii per edge (resolution stated by the grid); raises SolverError if some edge
    never flips within MAX_SCAN_RADII part radii.
    """
    grasp = grasp_radii(part, params.offset, params.mu)
    low = {i: lowest_radius(part, i, params) for i in part.stable_edges}
    flip: dict[int, float] = {}
    outward: dict[int, bool] = {}
    top: dict[int, float] = {}
    for i in part.stable_edges:
        span = 10 * part.radius
        while True:
            r = np.linspace(low[i], low[i] + span, points)
            out = throw_batch(part, np.full(points, i), r, params)
            flips = np.flatnonzero(~out.is_jog(np.full(points, i)))
            if flips.size:
                first = int(flips[0])
                flip[i] = (
                    _refine_flip(part, params, i, float(r[first - 1]), float(r[first]))
                    if first
                    else float(r[0])
                )
                outward[i] = bool(np.all(out.radius[:first] > r[:first]))
                top[i] = max(float(r[first]), float(out.radius[:first].max()) if first else float(r[first]))
                break
            span *= 4
            if span > MAX_SCAN_RADII * part.radius:
                raise SolverError(f"edge {i} never flips for R up to {low[i] + span / 4:.4g} m: no R_flip")
    invariant = True
    for _ in range(50):
        grown = False
        for i in part.stable_edges:
            r = np.linspace(low[i], top[i], points)
            out = throw_batch(part, np.full(points, i), r, params)
            for e, r1 in zip(out.edge, out.radius):
                e = int(e)
                if e not in low or r1 < low[e] * (1 - GRASP_TOL):
                    invariant = False
                    continue
                if r1 > top[e]:
                    top[e], grown = float(r1), True
        if not grown:
            break
    else:
        invariant = False
    return EdgeBounds(grasp, low, flip, top, outward, invariant)


def _refine_flip(part: ArmPart, params: ThrowParams, edge: int, jog_r: float, flip_r: float) -> float:
    """Bisect between the last jog and the first flip of the scan grid (to 1e-12 of the radius)."""
    one = np.array([edge])
    while flip_r - jog_r > 1e-12 * flip_r:
        mid = 0.5 * (jog_r + flip_r)
        if throw_batch(part, one, np.array([mid]), params).is_jog(one)[0]:
            jog_r = mid
        else:
            flip_r = mid
    return flip_r


@dataclass
class Cycle:
    edges: list[int]
    throws_per_cycle: float
    throws_range: tuple[int, int]


def find_cycle(edge_row: np.ndarray, jog_row: np.ndarray) -> Cycle | None:
    """Shortest period of the sequence of visited edges (a visit starts at each flip), canonically rotated."""
    visits: list[int] = []
    lengths: list[int] = []
    for n in range(len(edge_row)):
        if n == 0 or not jog_row[n]:
            visits.append(int(edge_row[n]))
            lengths.append(1)
        else:
            lengths[-1] += 1
    # Drop the first and last visits: the window cuts them.
    visits, lengths = visits[1:-1], lengths[1:-1]
    total = len(visits)
    for p in range(1, total // 2 + 1):
        if all(visits[i] == visits[i + p] for i in range(total - p)):
            break
    else:
        return None
    if total < 2 * p:
        return None
    dwell = Counter()
    for v, n in zip(visits, lengths):
        dwell[v] += n
    period = visits[:p]
    # Start the cycle at the visit with the longest stay (ties: smallest edge), as the paper tells its cycles.
    start = max(range(p), key=lambda j: (sum(n for v, n in zip(visits[j::p], lengths[j::p])), -period[j]))
    canonical = period[start:] + period[:start]
    per_cycle = [sum(lengths[c : c + p]) for c in range(0, total - p + 1, p)]
    return Cycle(canonical, float(np.mean(per_cycle)), (min(per_cycle), max(per_cycle)))


@dataclass
class LimitSet:
    bounds: EdgeBounds
    cycle: Cycle | None
    unique: bool
    edge_radius_ranges: dict[int, tuple[float, float]]
    trigger: tuple[float, float] | None
    goal_edge: int | None
    starts: int
    throws: int
    escaped: int
    cycles_by_start: list[list[int] | None] = field(default_factory=list)
    trajectories: Trajectories | None = None


def limit_set(
    part: ArmPart,
    params: ThrowParams,
    goal_edge: int | None = None,
    starts_per_edge: int = 25,
    throws: int = 300,
    burn_in: int = 100,
    sensing_height: float | None = None,
    keep_trajectories: bool = False,
) -> LimitSet:
    """Forward limit set from a grid of starts over Z (as Figs. 7, 8), its cycle and the sensor trigger range.

    Every start of the grid (``starts_per_edge`` radii in [low_i, R_max_i] on each stable edge) is thrown
    ``throws`` times; states after ``burn_in`` throws are taken as the limit set. The cycle is unique when
    every start's visit sequence has the same period.
    """
    if goal_edge is not None and goal_edge not in part.stable_edges:
        raise InputError("goal_edge", f"edge {goal_edge} is not a stable edge (stable: {part.stable_edges})")
    bounds = edge_bounds(part, params)
    edges, radii = [], []
    for i in part.stable_edges:
        edges += [i] * starts_per_edge
        # Cell centres: the ends of [low_i, R_max_i] are degenerate (at low_i the left vertex barely lifts).
        step = (bounds.max[i] - bounds.low[i]) / starts_per_edge
        radii += list(bounds.low[i] + step * (0.5 + np.arange(starts_per_edge)))
    traj = iterate(part, params, np.array(edges), np.array(radii), throws)
    if traj.escaped.any():
        bad = int(np.flatnonzero(traj.escaped)[0])
        raise SolverError(
            f"{int(traj.escaped.sum())} start(s) leave the throw map's domain (a throw lands below "
            f"R_grasp or on no stable edge), e.g. from edge {edges[bad]} at R = {radii[bad]:.4g} m: "
            "this design has no invariant set (Prop. IV.4)"
        )
    tail_e, tail_r, tail_j = traj.edge[:, burn_in:], traj.radius[:, burn_in:], traj.jog[:, burn_in:]
    cycles = [find_cycle(e, j) for e, j in zip(tail_e, tail_j)]
    names = [c.edges if c else None for c in cycles]
    unique = all(n is not None for n in names) and all(n == names[0] for n in names)
    ranges = {}
    for e in sorted(set(int(v) for v in tail_e.ravel())):
        values = tail_r[tail_e == e]
        ranges[e] = (float(values.min()), float(values.max()))
    cycle = None
    if unique:
        counts = [c.throws_per_cycle for c in cycles if c]
        lo = min(c.throws_range[0] for c in cycles if c)
        hi = max(c.throws_range[1] for c in cycles if c)
        cycle = Cycle(names[0], float(np.mean(counts)), (lo, hi))
    trigger = None
    if goal_edge is not None:
        height = 0.01 * part.radius if sensing_height is None else sensing_height
        runs = [list(zip((int(v) for v in e), (float(r) for r in rr))) for e, rr in zip(tail_e, tail_r)]
        trigger = trigger_range(part, goal_edge, height, runs)
    return LimitSet(
        bounds,
        cycle,
        unique,
        ranges,
        trigger,
        goal_edge,
        len(edges),
        throws,
        0,
        names,
        traj if keep_trajectories else None,
    )
