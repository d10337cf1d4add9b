"""Design search over offset h and release speed W: a unique limit set and the widest trigger range.

Every design of the grid is evaluated in one batch (issue 14 item 5): the edge bounds of all designs
are scanned, refined and grown together, and all designs' starts are iterated together with
``throw_rows`` (one row per start per design), so the cost per throw is that of a large batch however
many designs there are. ``search_loop`` keeps the former one-limit-set-per-design loop, for comparison.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from feeder_planner.errors import FeederError, InputError
from feeder_planner.throwing.attractors import Rows, iterate_to_attractor
from feeder_planner.throwing.geometry import ArmPart
from feeder_planner.throwing.grasp import grasp_radius
from feeder_planner.throwing.limit_set import (
    check_limit_offset,
    limit_set,
    read_limit_set,
)
from feeder_planner.throwing.sensor import check_sensing_height, sensing_height_or_default
from feeder_planner.throwing.throw_map import ThrowParams, radius_in_domain, throw_rows
from feeder_planner.throwing.tolerances import (
    FIRST_SCAN_RADII,
    FLIP_REFINE,
    MAX_GROWTH_ROUNDS,
    MAX_SCAN_RADII,
    MIN_WINDOW,
    RESOLUTION_CELLS,
    SCAN_GROWTH,
)

__all__ = ["DesignRow", "DesignSearch", "Design", "evaluate", "search", "search_loop", "MAX_DESIGNS"]

# A design whose limit set cannot be computed keeps the start of the error as its note: long enough for
# the reason and the example start, short enough for one row of the `feeder throw-design` table.
NOTE_CHARS = 160
# A coarser grid than `feeder limit-set` (4 starts per edge, at most 300 throws): the search computes
# one limit set per (h, W), and the chosen design can be re-checked on a finer grid with `limit-set`.
SEARCH_STARTS_PER_EDGE = 4
SEARCH_THROWS = 300
# Radii per edge in the batched R_flip scan and R_max growth of a search: a quarter of `limit-set`'s
# SCAN_POINTS, since the bounds only place the starts (a finer re-check is one `limit-set` away).
SEARCH_SCAN_POINTS = 50
# Throws per recurrence window of a search: four cycles of the paper's triangle (13 throws per cycle), so
# a design's starts can be judged after 100 throws instead of 400.
SEARCH_WINDOW = 50
# Designs of one search at most (issue 16 item 2): 10^4 designs x 10 starts per edge of a 12-edge part
# is 1.2 million rows of about 200 throws, hours of work and gigabytes of trajectories; a study that big
# is split into several runs (or run on a cluster with --robust).
MAX_DESIGNS = 10_000
# Designs evaluated per batch: bounds the trajectory memory (rows x throws x 26 bytes, about 60 MB for
# 100 designs of a 12-edge part) and sets how often progress is reported and Ctrl-C is seen.
DESIGNS_PER_BATCH = 100


@dataclass(frozen=True)
class Design:
    """One design to evaluate: offset h (m), release speed W (rad/s), friction mu."""

    offset: float
    speed: float
    mu: float


@dataclass(frozen=True)
class DesignRow:
    """One design (h, W) of the grid: whether its limit set is unique, its cycle and trigger range."""

    offset: float
    speed: float
    unique: bool
    cycle: list[int] | None
    trigger: tuple[float, float] | None
    note: str
    mu: float = math.nan
    attractors: int = 0
    periodic: bool | None = None
    edges: list[int] | None = None

    @property
    def width(self) -> float:
        """Width of the trigger range (m); 0 without one."""
        return 0.0 if self.trigger is None else self.trigger[1] - self.trigger[0]

    def to_json(self) -> dict[str, Any]:
        """Return one row of the `feeder throw-design --json` table (SI)."""
        return {
            "offset": self.offset,
            "release_speed": self.speed,
            "unique": self.unique,
            "cycle": self.cycle,
            "trigger_range": None if self.trigger is None else [float(v) for v in self.trigger],
            "width": self.width,
            "note": self.note,
            "attractors": self.attractors,
            "periodic": self.periodic,
            "edges": self.edges,
        }


@dataclass(frozen=True)
class DesignSearch:
    """Every design of the grid and the best: a unique attractor through the goal edge, widest range."""

    goal_edge: int
    best: DesignRow | None
    designs: list[DesignRow]

    def to_json(self) -> dict[str, Any]:
        """Return the `feeder throw-design --json` object."""
        return {
            "goal_edge": self.goal_edge,
            "best": None if self.best is None else self.best.to_json(),
            "designs": [r.to_json() for r in self.designs],
        }


def _bounds_many(
    part: ArmPart, designs: list[Design], gravity: float, points: int
) -> tuple[np.ndarray, np.ndarray, list[str | None]]:
    """Return (low[d, e], R_max[d, e], failure note per design) of every design at once.

    The batched form of ``edge_bounds`` (Prop. IV.4): a scan of ``points`` radii per stable edge from
    the lowest throwable R, growing the span by SCAN_GROWTH until a throw flips; then R_max grown
    until f maps Z into itself. R_flip itself is not needed to place the starts, so it is not refined.
    Unstable edges have low = R_max = inf.
    """
    count, n = len(designs), part.n
    stable = part.stable_edges
    low = np.full((count, n), np.inf)
    top = np.full((count, n), np.inf)
    notes: list[str | None] = [None] * count
    for d, design in enumerate(designs):
        for i in stable:
            low[d, i] = max(grasp_radius(part, i, design.offset, design.mu), -float(part.u_left[i]))
    h = np.array([x.offset for x in designs])
    w = np.array([x.speed for x in designs])
    mu = np.array([x.mu for x in designs])
    pairs = [(d, i) for d in range(count) for i in stable]
    span = {pair: FIRST_SCAN_RADII * part.radius for pair in pairs}
    todo = list(pairs)
    while todo:
        dd = np.repeat([d for d, _ in todo], points)
        ee = np.repeat([i for _, i in todo], points)
        rr = np.concatenate([np.linspace(low[d, i], low[d, i] + span[(d, i)], points) for d, i in todo])
        out = throw_rows(part, ee, rr, h[dd], w[dd], gravity, mu[dd])
        jog = out.is_jog(ee).reshape(len(todo), points)
        r1 = out.radius.reshape(len(todo), points)
        r0 = rr.reshape(len(todo), points)
        again = []
        for row, (d, i) in enumerate(todo):
            flips = np.flatnonzero(~jog[row])
            if flips.size:
                first = int(flips[0])
                top[d, i] = max(float(r0[row, first]), float(r1[row, :first].max()) if first else -np.inf)
                continue
            span[(d, i)] *= SCAN_GROWTH
            if span[(d, i)] > MAX_SCAN_RADII * part.radius:
                notes[d] = notes[d] or (
                    f"edge {i} never flips for R up to "
                    f"{low[d, i] + span[(d, i)] / SCAN_GROWTH:.4g} m: no R_flip"
                )
            else:
                again.append((d, i))
        todo = again
    live = [d for d in range(count) if notes[d] is None]
    for _ in range(MAX_GROWTH_ROUNDS):
        if not live:
            break
        dd = np.repeat([d for d in live for _ in stable], points)
        ee = np.repeat([i for _ in live for i in stable], points)
        rr = np.concatenate([np.linspace(low[d, i], top[d, i], points) for d in live for i in stable])
        out = throw_rows(part, ee, rr, h[dd], w[dd], gravity, mu[dd])
        landed = np.maximum(out.edge, 0)
        ok = (out.edge >= 0) & radius_in_domain(out.radius, low[dd, landed])
        grown_to = top.copy()
        np.maximum.at(grown_to, (dd[ok], landed[ok]), out.radius[ok])
        # A throw landing outside the domain is not growth; the iteration will see that start escape.
        grew = set(int(d) for d in np.flatnonzero((grown_to > top).any(axis=1)))
        top = np.where(np.isfinite(low), grown_to, top)
        live = [d for d in live if d in grew and notes[d] is None]
    return low, top, notes


def evaluate(
    part: ArmPart,
    goal_edge: int,
    designs: list[Design],
    gravity: float,
    sensing_height: float | None = None,
    starts_per_edge: int = SEARCH_STARTS_PER_EDGE,
    throws: int = SEARCH_THROWS,
    points: int = SEARCH_SCAN_POINTS,
    window: int = SEARCH_WINDOW,
) -> list[DesignRow]:
    """Return the row of every design, all designs' throws batched together (issue 14 item 5).

    Per design: the edge bounds (``_bounds_many``), a grid of ``starts_per_edge`` starts per stable edge
    over [low_i, R_max_i], thrown until the design's tails confirm (``iterate_to_attractor``, at most
    ``throws``), read as attractors and a trigger range (``read_limit_set``). A design's row only depends
    on the design, not on the others in the batch, so any split of a study into batches gives the same
    rows.
    """
    height = sensing_height_or_default(part, sensing_height)
    low, top, notes = _bounds_many(part, designs, gravity, points)
    owner, edges, radii = [], [], []
    for d in range(len(designs)):
        if notes[d] is not None:
            continue
        for i in part.stable_edges:
            step = (top[d, i] - low[d, i]) / starts_per_edge
            owner += [d] * starts_per_edge
            edges += [i] * starts_per_edge
            radii += list(low[d, i] + step * (0.5 + np.arange(starts_per_edge)))
    rows_out: list[DesignRow] = []
    if not owner:
        return [_failed(x, notes[k] or "") for k, x in enumerate(designs)]
    own = np.array(owner)
    # One resolution unit per design for all its edges: its widest edge span over RESOLUTION_CELLS, as
    # ``single_design_rows`` (a row's tail does not depend on the other designs of the batch).
    finite = np.isfinite(low)
    span = (np.where(finite, top, 0.0) - np.where(finite, low, 0.0)).max(axis=1)
    ceiling = np.where(np.isfinite(top), top, 0.0).max(axis=1)
    width = np.tile(np.maximum(span / RESOLUTION_CELLS, FLIP_REFINE * ceiling)[:, None], (1, part.n))
    rows = Rows(np.array(edges), np.array(radii), low[own], width[own])
    h = np.array([x.offset for x in designs])[own]
    w = np.array([x.speed for x in designs])[own]
    mu = np.array([x.mu for x in designs])[own]
    search_ = iterate_to_attractor(
        rows,
        lambda idx, e, r: throw_rows(part, e, r, h[idx], w[idx], gravity, mu[idx]),
        throws,
        max(MIN_WINDOW, min(window, throws // 3)),
        design=own,
    )
    for d, design in enumerate(designs):
        if notes[d] is not None:
            rows_out.append(_failed(design, notes[d] or ""))
            continue
        members = np.flatnonzero(own == d)
        rows_out.append(_read(part, goal_edge, design, search_, members, height, throws))
    return rows_out


def _failed(design: Design, note: str) -> DesignRow:
    """Return the row of a design without a limit set."""
    return DesignRow(design.offset, design.speed, False, None, None, note[:NOTE_CHARS], design.mu)


def _read(
    part: ArmPart,
    goal_edge: int,
    design: Design,
    search_: Any,
    members: np.ndarray,
    height: float,
    throws: int,
) -> DesignRow:
    """Return one design's row from its rows of the batched search."""
    if search_.escaped[members].any():
        return _failed(
            design, "some start leaves the throw map's domain: this design has no invariant set (Prop. IV.4)"
        )
    done = search_.tail[members] >= 0
    if not done.any():
        return _failed(design, f"the attractor search did not converge within {throws} throws")
    attractors, trigger, note, _ = read_limit_set(part, search_, members, goal_edge, height, True)
    unique = bool(done.all()) and len(attractors) == 1
    only = attractors[0] if unique else None
    if not done.all():
        note = f"{int((~done).sum())} start(s) did not converge within {throws} throws"
    elif not unique:
        note = f"starts reach {len(attractors)} different attractors"
    cycle = only.cycle if only is not None and only.periodic else None
    return DesignRow(
        design.offset,
        design.speed,
        unique,
        cycle,
        trigger if unique else None,
        (note or "")[:NOTE_CHARS],
        design.mu,
        len(attractors),
        None if only is None else only.periodic,
        None if only is None else only.edges,
    )


def check_grid(part: ArmPart, goal_edge: int, offsets: np.ndarray, speeds: np.ndarray) -> None:
    """Refuse a design grid before any work: bad goal edge, empty or too large lists, bad offsets."""
    if goal_edge not in part.stable_edges:
        raise InputError("goal_edge", f"edge {goal_edge} is not a stable edge (stable: {part.stable_edges})")
    if len(offsets) == 0 or len(speeds) == 0:
        raise InputError("offsets" if len(offsets) == 0 else "release_speeds", "needs at least one value")
    if len(offsets) * len(speeds) > MAX_DESIGNS:
        raise InputError(
            "offsets",
            f"{len(offsets)} offsets x {len(speeds)} speeds = {len(offsets) * len(speeds)} designs, "
            f"more than the {MAX_DESIGNS} one search takes: split the grid",
        )
    for h in offsets:  # before any work: an offset with no limit set is bad input, not a row's note
        check_limit_offset(part, float(h), "offsets")


def search(
    part: ArmPart,
    goal_edge: int,
    offsets: np.ndarray,
    speeds: np.ndarray,
    gravity: float,
    mu: float,
    sensing_height: float | None = None,
    starts_per_edge: int = SEARCH_STARTS_PER_EDGE,
    throws: int = SEARCH_THROWS,
    progress: Callable[[int, int], None] | None = None,
) -> DesignSearch:
    """Return every (h, W) of the grid tried; the best: a unique attractor through the goal edge.

    Designs are evaluated in batches of DESIGNS_PER_BATCH (``evaluate``); ``progress(done, total)`` is
    told after each batch. The best design has a unique attractor and the widest trigger range.
    """
    check_grid(part, goal_edge, offsets, speeds)
    if sensing_height is not None:
        check_sensing_height(sensing_height)
    designs = []
    for h in offsets:
        for w in speeds:
            ThrowParams(float(h), float(w), gravity, mu)  # validates every value
            designs.append(Design(float(h), float(w), float(mu)))
    rows: list[DesignRow] = []
    for start in range(0, len(designs), DESIGNS_PER_BATCH):
        chunk = designs[start : start + DESIGNS_PER_BATCH]
        rows += evaluate(part, goal_edge, chunk, gravity, sensing_height, starts_per_edge, throws)
        if progress is not None:
            progress(len(rows), len(designs))
    return _best(goal_edge, rows)


def _best(goal_edge: int, rows: list[DesignRow]) -> DesignSearch:
    """Return the search result: the unique design with the widest trigger range is the best."""
    good = [r for r in rows if r.unique and r.trigger is not None]
    best = max(good, key=lambda r: r.width) if good else None
    return DesignSearch(goal_edge, best, rows)


def _design_loop_row(
    part: ArmPart,
    goal_edge: int,
    params: ThrowParams,
    sensing_height: float | None,
    starts_per_edge: int,
    throws: int,
) -> DesignRow:
    """Return the row of one design from its own `limit_set` (the per-design loop)."""
    h, w = params.offset, params.speed
    try:
        ls = limit_set(part, params, goal_edge, starts_per_edge, throws, sensing_height=sensing_height)
    except FeederError as error:
        return DesignRow(h, w, False, None, None, str(error)[:NOTE_CHARS], params.mu)
    note = "" if ls.unique else f"starts reach {len(ls.attractors)} attractor(s) (or none)"
    return DesignRow(
        h,
        w,
        ls.unique,
        ls.cycle.edges if ls.cycle else None,
        ls.trigger if ls.unique else None,
        ls.trigger_note or note if ls.unique else note,
        params.mu,
        len(ls.attractors),
        ls.attractors[0].periodic if ls.unique else None,
        ls.attractors[0].edges if ls.unique else None,
    )


def search_loop(
    part: ArmPart,
    goal_edge: int,
    offsets: np.ndarray,
    speeds: np.ndarray,
    gravity: float,
    mu: float,
    sensing_height: float | None = None,
    starts_per_edge: int = SEARCH_STARTS_PER_EDGE,
    throws: int = SEARCH_THROWS,
) -> DesignSearch:
    """Return the same search as ``search``, one full `limit_set` per design (the former loop; bench)."""
    check_grid(part, goal_edge, offsets, speeds)
    rows = [
        _design_loop_row(
            part,
            goal_edge,
            ThrowParams(float(h), float(w), gravity, mu),
            sensing_height,
            starts_per_edge,
            throws,
        )
        for h in offsets
        for w in speeds
    ]
    return _best(goal_edge, rows)
