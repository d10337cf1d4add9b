"""Iterating the throw map: R_flip, R_max (Prop. IV.4), forward limit sets from a grid of starts, cycles."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from feeder_planner.errors import InputError, SolverError
from feeder_planner.throwing.attractors import (
    Attractor,
    Rows,
    Search,
    group_attractors,
    iterate_to_attractor,
)
from feeder_planner.throwing.geometry import ArmPart
from feeder_planner.throwing.grasp import grasp_radii
from feeder_planner.throwing.sensor import TriggerReading, read_trigger, sensing_height_or_default
from feeder_planner.throwing.throw_map import ThrowParams, lowest_radius, radius_in_domain, throw_batch
from feeder_planner.throwing.tolerances import (
    BURN_IN_CAP,
    BURN_IN_DIVISOR,
    DEFAULT_STARTS_PER_EDGE,
    DEFAULT_THROWS,
    FIRST_SCAN_RADII,
    FLIP_REFINE,
    MAX_GROWTH_ROUNDS,
    MAX_SCAN_RADII,
    RESOLUTION_CELLS,
    SCAN_GROWTH,
    SCAN_POINTS,
)

__all__ = [
    "Trajectories",
    "iterate",
    "EdgeBounds",
    "edge_bounds",
    "Cycle",
    "LimitSet",
    "default_burn_in",
    "OffsetBelowDMinError",
    "check_limit_offset",
    "limit_set",
    "single_design_rows",
    "read_limit_set",
    "escape_error",
    "not_converged_error",
    "trigger_note",
    "sensed_states",
]


@dataclass(frozen=True)
class Trajectories:
    """States after each throw: edge[b, n], radius[b, n], jog[b, n] (jog[:, 0] is meaningless), escaped[b].

    From the attractor search also ``tail[b]``..``tail_end[b]``, row b's confirmed tail (-1: none), and
    ``sensed[b]``..``tail_end[b]``, the states the trigger range is read on (``sensed_states``).
    """

    edge: np.ndarray
    radius: np.ndarray
    jog: np.ndarray
    escaped: np.ndarray
    tail: np.ndarray | None = None
    tail_end: np.ndarray | None = None
    sensed: np.ndarray | None = None


def iterate(
    part: ArmPart, params: ThrowParams, edges: np.ndarray, radii: np.ndarray, throws: int
) -> Trajectories:
    """Return f^N from every start at once; a state outside the domain (R < lowest R) stops its row."""
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
        ok = radius_in_domain(out.radius, low[out.edge])
        escaped[alive[~ok]] = True
        alive = alive[ok]
    return Trajectories(edge, radius, jog, escaped)


def _by_edge(values: dict[int, Any]) -> dict[str, Any]:
    """Return a per-edge mapping with the contract's JSON keys (edge numbers as strings)."""
    return {str(i): v for i, v in values.items()}


@dataclass(frozen=True)
class EdgeBounds:
    """Per stable edge: R_grasp, the lowest throwable R, R_flip, R_max (Prop. IV.4), if jogs go outward."""

    grasp: dict[int, float]
    low: dict[int, float]
    flip: dict[int, float]
    max: dict[int, float]
    jogs_outward: dict[int, bool]
    invariant: bool  # f maps Z = U_i (i, [low_i, R_max_i]) into itself on the sampled grid


def _scan_flip(
    part: ArmPart, params: ThrowParams, edge: int, low: float, points: int
) -> tuple[float, bool, float]:
    """Return (R_flip, whether every jog below it moves outward, first R_max guess) of one edge.

    Scans ``points`` radii from ``low`` over FIRST_SCAN_RADII part radii, growing the span by SCAN_GROWTH
    until a throw flips (Prop. IV.4, property 1); raises SolverError past MAX_SCAN_RADII part radii.
    """
    span = FIRST_SCAN_RADII * part.radius
    while True:
        r = np.linspace(low, low + span, points)
        out = throw_batch(part, np.full(points, edge), r, params)
        flips = np.flatnonzero(~out.is_jog(np.full(points, edge)))
        if flips.size:
            first = int(flips[0])
            flip = (
                _refine_flip(part, params, edge, float(r[first - 1]), float(r[first]))
                if first
                else float(r[0])
            )
            outward = bool(np.all(out.radius[:first] > r[:first]))
            top = max(float(r[first]), float(out.radius[:first].max()) if first else float(r[first]))
            return flip, outward, top
        span *= SCAN_GROWTH
        if span > MAX_SCAN_RADII * part.radius:
            raise SolverError(
                f"edge {edge} never flips for R up to {low + span / SCAN_GROWTH:.4g} m: no R_flip"
            )


def _grow_max(
    part: ArmPart, params: ThrowParams, low: dict[int, float], top: dict[int, float], points: int
) -> bool:
    """Grow ``top`` (R_max per edge, in place) until f maps Z = U_i (i, [low_i, top_i]) into itself.

    Returns whether Z is invariant on the sampled grid (Prop. IV.4, property 2): no image below its
    edge's lowest R or on an unstable edge, and the growth ends within MAX_GROWTH_ROUNDS rounds.
    """
    invariant = True
    for _ in range(MAX_GROWTH_ROUNDS):
        grown = False
        for i in part.stable_edges:
            r = np.linspace(low[i], top[i], points)
            out = throw_batch(part, np.full(points, i), r, params)
            for e, r1 in zip(out.edge, out.radius, strict=True):
                e = int(e)
                if e not in low or not radius_in_domain(r1, low[e]):
                    invariant = False
                    continue
                if r1 > top[e]:
                    top[e], grown = float(r1), True
        if not grown:
            return invariant
    return False


def edge_bounds(part: ArmPart, params: ThrowParams, points: int = SCAN_POINTS) -> EdgeBounds:
    """Return the edge bounds: R_flip^i and R_max^i of every stable edge (Prop. IV.4).

    R_flip^i is the first flip on a grid of R from the lowest throwable R (``_scan_flip``); R_max^i is
    grown until f(Z) lies in Z (``_grow_max``). Sampled on ``points`` radii per edge (resolution stated
    by the grid); raises SolverError if some edge never flips within MAX_SCAN_RADII part radii.
    """
    grasp = grasp_radii(part, params.offset, params.mu)
    low = {i: lowest_radius(part, i, params) for i in part.stable_edges}
    flip: dict[int, float] = {}
    outward: dict[int, bool] = {}
    top: dict[int, float] = {}
    for i in part.stable_edges:
        flip[i], outward[i], top[i] = _scan_flip(part, params, i, low[i], points)
    invariant = _grow_max(part, params, low, top, points)
    return EdgeBounds(grasp, low, flip, top, outward, invariant)


def _refine_flip(part: ArmPart, params: ThrowParams, edge: int, jog_r: float, flip_r: float) -> float:
    """Bisect between the last jog and the first flip of the scan grid (to FLIP_REFINE of the radius)."""
    one = np.array([edge])
    while flip_r - jog_r > FLIP_REFINE * flip_r:
        mid = 0.5 * (jog_r + flip_r)
        if throw_batch(part, one, np.array([mid]), params).is_jog(one)[0]:
            jog_r = mid
        else:
            flip_r = mid
    return flip_r


@dataclass(frozen=True)
class Cycle:
    """A cycle of the limit set: the edges of one period, and the throws one period takes (mean, range)."""

    edges: list[int]
    throws_per_cycle: float
    throws_range: tuple[int, int]

    def to_json(self) -> dict[str, Any]:
        """Return the contract's `cycle` object."""
        return {
            "edges": self.edges,
            "throws_per_cycle": self.throws_per_cycle,
            "throws_range": list(self.throws_range),
        }


@dataclass(frozen=True)
class LimitSet:
    """A forward limit set from a grid of starts: the edge bounds, its attractors, cycle and trigger range.

    ``to_json`` gives the `feeder limit-set --json` object (contract 3, SI units).
    """

    stable_edges: list[int]
    bounds: EdgeBounds
    cycle: Cycle | None
    unique: bool
    edge_radius_ranges: dict[int, tuple[float, float]]
    trigger: tuple[float, float] | None
    goal_edge: int | None
    sensing_height: float
    starts: int
    throws: int
    cycles_by_start: list[list[int] | None] = field(default_factory=list)
    trajectories: Trajectories | None = None
    attractors: list[Attractor] = field(default_factory=list)
    unconverged: int = 0
    trigger_note: str | None = None
    throws_used: int = 0
    growing: dict[int, list[int]] = field(default_factory=dict)

    @property
    def converged(self) -> bool:
        """Whether every start reached an attractor within the cap on throws."""
        return self.unconverged == 0

    @property
    def growing_edges(self) -> list[int]:
        """Return the edges whose radius range some start was still widening when the throws ran out.

        Such a start is unconverged (in ``unconverged``, in no attractor): its tail confirmed but for a
        range its recent states still widened (``attractors.widening``), so no range is read from it
        as it stands, and the answer asks for more throws (`feeder limit-set` exits 3).
        """
        return sorted({e for edges in self.growing.values() for e in edges})

    def to_json(self) -> dict[str, Any]:
        """Return the contract's limit-set object: bounds per edge, cycle, ranges, trigger, attractors."""
        b = self.bounds
        return {
            "stable_edges": self.stable_edges,
            "grasp_radius": _by_edge(b.grasp),
            "flip_radius": _by_edge(b.flip),
            "max_radius": _by_edge(b.max),
            "invariant": b.invariant,
            "cycle": None if self.cycle is None else self.cycle.to_json(),
            "unique": self.unique,
            "edge_radius_ranges": _by_edge({e: list(r) for e, r in self.edge_radius_ranges.items()}),
            "trigger": None
            if self.trigger is None
            else {
                "goal_edge": self.goal_edge,
                "radius_range": list(self.trigger),
                "sensing_height": self.sensing_height,
            },
            "starts": self.starts,
            "throws": self.throws,
            "attractors": [a.to_json() for a in self.attractors],
            "converged": self.converged,
            "unconverged_starts": self.unconverged,
            "trigger_note": self.trigger_note,
            "throws_used": self.throws_used,
        }


def _grid_starts(part: ArmPart, bounds: EdgeBounds, starts_per_edge: int) -> tuple[list[int], list[float]]:
    """Return the starts: ``starts_per_edge`` cell centres of [low_i, R_max_i] on each stable edge.

    Cell centres, because the ends of the interval are degenerate (at low_i the left vertex barely lifts).
    """
    edges: list[int] = []
    radii: list[float] = []
    for i in part.stable_edges:
        edges += [i] * starts_per_edge
        step = (bounds.max[i] - bounds.low[i]) / starts_per_edge
        radii += list(bounds.low[i] + step * (0.5 + np.arange(starts_per_edge)))
    return edges, radii


def _common_cycle(cycles: list[Cycle | None]) -> Cycle | None:
    """Return the cycle every start reached, its throws averaged over the starts; None if they differ."""
    names = [c.edges if c else None for c in cycles]
    if not (all(n is not None for n in names) and all(n == names[0] for n in names)):
        return None
    found = [c for c in cycles if c]
    lo = min(c.throws_range[0] for c in found)
    hi = max(c.throws_range[1] for c in found)
    return Cycle(found[0].edges, float(np.mean([c.throws_per_cycle for c in found])), (lo, hi))


def _edge_ranges(tail_e: np.ndarray, tail_r: np.ndarray) -> dict[int, tuple[float, float]]:
    """Return the (min, max) of R per edge over the limit set's states."""
    ranges = {}
    for e in sorted({int(v) for v in tail_e.ravel()}):
        values = tail_r[tail_e == e]
        ranges[e] = (float(values.min()), float(values.max()))
    return ranges


def default_burn_in(throws: int) -> int:
    """Return the throws discarded as transient: a third of the run, at most BURN_IN_CAP."""
    return min(BURN_IN_CAP, throws // BURN_IN_DIVISOR)


class OffsetBelowDMinError(InputError):
    """An offset h <= -d_min: outside the regime in which the paper's limit sets exist (Prop. IV.4).

    With h + d^i <= 0 the centre of mass on edge i moves outward (or not inward) in flight,
    x' = -W (d^i + h) >= 0 (eq. 5), so nothing bounds R: iterating the map carries R off to infinity.
    Carries the values in metres so that a caller can restate them in its own length unit.
    """

    def __init__(
        self, offset: float, d_min: float, field: str = "offset", scale: float = 1.0, unit: str = "m"
    ) -> None:
        self.offset, self.d_min, self.scale, self.unit = offset, d_min, scale, unit
        super().__init__(
            field,
            f"h = {offset / scale:.6g} {unit} is at or below -d_min = {-d_min / scale:.6g} {unit}: on "
            "the edge of least d^i the centre of mass then moves outward in flight and nothing bounds R, "
            "so there is no limit set (Prop. IV.4 needs h > -d_min)",
        )

    def in_unit(self, scale: float, unit: str) -> OffsetBelowDMinError:
        """Return the same error with h and d_min stated in ``unit`` (``scale`` metres per unit)."""
        return OffsetBelowDMinError(self.offset, self.d_min, self.field, scale, unit)


def check_limit_offset(part: ArmPart, offset: float, field: str = "offset") -> None:
    """Refuse an offset h <= -d_min for iterating the map (Prop. IV.4: the limit set needs h > -d_min)."""
    if not math.isfinite(offset):
        raise InputError(field, f"must be a finite number, got {offset!r}")
    if not offset > -part.d_min:
        raise OffsetBelowDMinError(float(offset), part.d_min, field)


def single_design_rows(part: ArmPart, bounds: EdgeBounds, starts_per_edge: int) -> Rows:
    """Return the rows of one design's grid of starts, with the resolution unit of their radius ranges.

    One unit for every edge: the widest edge span max_i (R_max_i - low_i) over RESOLUTION_CELLS, so that
    it does not depend on the number of starts. An edge with a narrow range of R (the bracket's edge 1
    spans 3.7 mm) would otherwise get a resolution so fine that its ranges would take hundreds of cycles
    to agree between a tail's halves.
    """
    edges, radii = _grid_starts(part, bounds, starts_per_edge)
    low = np.full(part.n, np.inf)
    span = max(bounds.max[i] - bounds.low[i] for i in part.stable_edges)
    width = np.full(part.n, max(span / RESOLUTION_CELLS, FLIP_REFINE * max(bounds.max.values())))
    for i in part.stable_edges:
        low[i] = bounds.low[i]
    count = len(edges)
    return Rows(np.array(edges), np.array(radii), np.tile(low, (count, 1)), np.tile(width, (count, 1)))


def escape_error(search: Search, rows: Rows, length: float = 1.0, unit: str = "m") -> SolverError:
    """Return the error for starts that left the map's domain (no invariant set, Prop. IV.4)."""
    bad = int(np.flatnonzero(search.escaped)[0])
    return SolverError(
        f"{int(search.escaped.sum())} start(s) leave the throw map's domain (a throw lands below "
        f"R_grasp, on no stable edge or with a toe left of the pivot), e.g. from edge {int(rows.edge[bad])} "
        f"at R = {rows.radius[bad] / length:.4g} {unit}: this design has no invariant set (Prop. IV.4)"
    )


def not_converged_error(throws: int, window: int) -> SolverError:
    """Return the error for a search in which no start reached an attractor (issue 16 item 3, issue 25)."""
    return SolverError(
        f"the attractor search did not converge: no start's tail confirmed (the same edges, radius "
        f"ranges and cycle over its last n/4 throws as over its last n/2) within {throws} throws "
        f"(judged from {2 * window} throws on); raise --throws"
    )


def sensed_states(found: Search | Trajectories, b: int) -> list[tuple[int, float]]:
    """Return the resting states (edge, R) row b's trigger range is read on: its tail and more.

    From ``sensed[b]`` to the end of its confirmed tail (``attractors._trim_to_group``): the tail, and the
    older states of its stay that may be visits of the attractor, which the trigger range must hold in.
    ``found``: the search, or a limit set's kept trajectories.
    """
    assert found.sensed is not None and found.tail_end is not None
    sl = slice(int(found.sensed[b]), int(found.tail_end[b]) + 1)
    return list(
        zip((int(v) for v in found.edge[b, sl]), (float(r) for r in found.radius[b, sl]), strict=True)
    )


def _name(k: int, a: Attractor) -> str:
    """Return how a note names attractor k."""
    return f"attractor {k} (edges {a.edges})"


def trigger_note(attractors: list[Attractor], goal_edge: int, reading: TriggerReading | None) -> str:
    """Return why no sensor radius singles out ``goal_edge`` on the attractors: which attractor and edge.

    Either an attractor never visits the goal edge (``reading`` None), or the goal edge's visits share no
    covered radius, or other edges of named attractors cover every radius the goal edge's visits share
    (their resting states, in SI metres, from the states the trigger is read on, ``sensed_states``:
    the confirmed tails and the older states of their stays that may be visits; ``sensor.read_trigger``).
    """
    missing = [_name(k, a) for k, a in enumerate(attractors) if goal_edge not in a.edges]
    if missing or reading is None:
        return f"goal edge {goal_edge} is not visited by {', '.join(missing)}"
    if reading.allowed is None:
        return f"no complete visit to goal edge {goal_edge} in the attractors' tails"
    if not reading.allowed:
        named = [_name(k, attractors[k]) for k in reading.alone]
        where = f" ({', '.join(named)})" if named else " (each attractor alone has one: they differ)"
        return f"no sensor radius reads true in every visit to goal edge {goal_edge}{where}"

    def spans(intervals: list[tuple[float, float]]) -> str:
        return ", ".join(f"[{lo:.4g}, {hi:.4g}]" for lo, hi in intervals)

    covering = "; ".join(
        f"edge {e} of {_name(k, attractors[k])} covers {spans(hit)} m" for k, e, hit in reading.blockers[:3]
    )
    return (
        f"no sensor radius reads true in every visit to goal edge {goal_edge} and never elsewhere: every "
        f"visit to edge {goal_edge} covers R_s in {spans(reading.allowed)} m, but resting on {covering}"
    )


def read_limit_set(
    part: ArmPart,
    search: Search,
    members: np.ndarray,
    goal_edge: int | None,
    height: float,
    only_unique: bool = False,
) -> tuple[list[Attractor], tuple[float, float] | None, str | None, list[list[int] | None]]:
    """Return the attractors of ``members`` (rows of one design), its trigger range and why there is none.

    The attractors come from the rows' confirmed tails (the transients are not in them); the trigger
    range is read on those tails and the older states of their stays that may be visits
    (``sensed_states``), and is None with a note naming the attractor and edge that rule it out
    (``trigger_note``).
    ``only_unique`` (a design search): no trigger and no per-start cycles unless every start reached
    one attractor.
    """
    attractors = group_attractors(search, members)
    converged = [int(b) for b in members if search.tail[b] >= 0]
    if only_unique and (len(attractors) != 1 or len(converged) != len(members)):
        return attractors, None, None, []
    owner = {b: a for a in attractors for b in a.members}
    cycles: list[list[int] | None] = []
    for b in members:
        a = owner.get(int(b))
        cycles.append(a.cycle if a is not None and a.periodic else None)
    trigger, note = None, None
    if goal_edge is not None:
        reading = None
        if all(goal_edge in a.edges for a in attractors):
            groups = [[sensed_states(search, b) for b in a.members] for a in attractors]
            reading = read_trigger(part, goal_edge, height, groups)
            trigger = reading.trigger
        if trigger is None:
            note = trigger_note(attractors, goal_edge, reading)
    return attractors, trigger, note, cycles


def limit_set(
    part: ArmPart,
    params: ThrowParams,
    goal_edge: int | None = None,
    starts_per_edge: int = DEFAULT_STARTS_PER_EDGE,
    throws: int = DEFAULT_THROWS,
    sensing_height: float | None = None,
    keep_trajectories: bool = False,
    window: int | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> LimitSet:
    """Return the forward limit set from a grid of starts over Z (Figs. 7, 8): attractors, cycle, trigger.

    Every start of the grid (``starts_per_edge`` cell centres of [low_i, R_max_i] on each stable edge)
    is thrown until its tail confirms (``iterate_to_attractor``: the last n/2 throws show the same edges,
    radius ranges and cycle as the last n/4; at most ``throws`` throws, judged from two windows of
    ``window`` on); starts whose confirmed tails agree form one attractor (``group_attractors``), and
    a start that does not confirm is counted unconverged, in no attractor. ``unique``: every start
    reached the same attractor (Theorem IV.6 for a periodic one); ``cycle`` is filled when that
    attractor is periodic. The trigger range is read on the attractors' tails and the older states of
    their stays that may be visits (``sensed_states``); ``trigger_note``
    names the attractor and edge that rule it out. ``sensing_height`` None means the default
    (``sensing_height_or_default``). An offset at or below -d_min is refused (``check_limit_offset``).
    Raises SolverError when a start leaves the domain or no start converges.
    """
    if goal_edge is not None and goal_edge not in part.stable_edges:
        raise InputError("goal_edge", f"edge {goal_edge} is not a stable edge (stable: {part.stable_edges})")
    check_limit_offset(part, params.offset)
    height = sensing_height_or_default(part, sensing_height)
    bounds = edge_bounds(part, params)
    rows = single_design_rows(part, bounds, starts_per_edge)
    search = iterate_to_attractor(
        rows,
        lambda idx, e, r: throw_batch(part, e, r, params),
        throws,
        window,
        progress,
    )
    if search.escaped.any():
        raise escape_error(search, rows)
    if not search.converged.any():
        raise not_converged_error(throws, search.window)
    members = np.arange(len(rows.edge))
    attractors, trigger, note, cycles = read_limit_set(part, search, members, goal_edge, height)
    unconverged = int((~search.converged).sum())
    unique = unconverged == 0 and len(attractors) == 1
    only = attractors[0] if unique else None
    cycle = None
    if only is not None and only.periodic and only.cycle is not None and only.throws_per_round is not None:
        lo, mean, hi = only.throws_per_round
        cycle = Cycle(only.cycle, mean, (lo, hi))
    ranges: dict[int, tuple[float, float]] = {}
    for a in attractors:
        for e, (lo_r, hi_r) in a.edge_radius_ranges.items():
            old = ranges.get(e)
            ranges[e] = (lo_r, hi_r) if old is None else (min(old[0], lo_r), max(old[1], hi_r))
    traj = Trajectories(
        search.edge, search.radius, search.jog, search.escaped, search.tail, search.tail_end, search.sensed
    )
    return LimitSet(
        stable_edges=part.stable_edges,
        bounds=bounds,
        cycle=cycle,
        unique=unique,
        edge_radius_ranges=dict(sorted(ranges.items())),
        trigger=trigger,
        goal_edge=goal_edge,
        sensing_height=height,
        starts=len(rows.edge),
        throws=throws,
        cycles_by_start=cycles,
        trajectories=traj if keep_trajectories else None,
        attractors=attractors,
        unconverged=unconverged,
        trigger_note=note,
        throws_used=int(search.end.max()),
        growing=dict(search.growing),
    )
