"""Design search over offset h and release speed W: a unique limit set and the widest trigger range."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from feeder_planner.errors import FeederError, InputError
from feeder_planner.throwing.geometry import ArmPart
from feeder_planner.throwing.limit_set import check_limit_offset, limit_set
from feeder_planner.throwing.sensor import check_sensing_height
from feeder_planner.throwing.throw_map import ThrowParams

__all__ = ["DesignRow", "DesignSearch", "search"]

# A design whose limit set cannot be computed keeps the start of the error as its note: long enough for
# the reason and the example start, short enough for one row of the `feeder throw-design` table.
NOTE_CHARS = 160
# A coarser grid than `feeder limit-set` (10 starts per edge, 200 throws): the search runs one limit set
# per (h, W), and the chosen design can be re-checked on a finer grid.
SEARCH_STARTS_PER_EDGE = 10
SEARCH_THROWS = 200


@dataclass(frozen=True)
class DesignRow:
    """One design (h, W) of the grid: whether its limit set is unique, its cycle and trigger range."""

    offset: float
    speed: float
    unique: bool
    cycle: list[int] | None
    trigger: tuple[float, float] | None
    note: str

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
            "trigger_range": None if self.trigger is None else list(self.trigger),
            "width": self.width,
            "note": self.note,
        }


@dataclass(frozen=True)
class DesignSearch:
    """Every design of the grid and the best: a unique cycle through the goal edge, widest trigger range."""

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


def _design(
    part: ArmPart,
    goal_edge: int,
    params: ThrowParams,
    sensing_height: float | None,
    starts_per_edge: int,
    throws: int,
) -> DesignRow:
    """Return the row of one design: its limit set's cycle and trigger range, or why there is none."""
    h, w = params.offset, params.speed
    try:
        ls = limit_set(part, params, goal_edge, starts_per_edge, throws, sensing_height=sensing_height)
    except FeederError as error:
        return DesignRow(h, w, False, None, None, str(error)[:NOTE_CHARS])
    note = "" if ls.unique else "starts reach different cycles (or none)"
    if ls.cycle is not None and goal_edge not in ls.cycle.edges:
        note = "goal edge is not in the cycle"
    return DesignRow(
        h, w, ls.unique, ls.cycle.edges if ls.cycle else None, ls.trigger if ls.unique else None, note
    )


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
) -> DesignSearch:
    """Return every (h, W) of the grid tried; the best: a unique cycle through the goal edge, widest range."""
    if goal_edge not in part.stable_edges:
        raise InputError("goal_edge", f"edge {goal_edge} is not a stable edge (stable: {part.stable_edges})")
    if len(offsets) == 0 or len(speeds) == 0:
        raise InputError("offsets" if len(offsets) == 0 else "release_speeds", "needs at least one value")
    if sensing_height is not None:
        check_sensing_height(sensing_height)
    for h in offsets:  # before any work: an offset with no limit set is bad input, not a row's note
        check_limit_offset(part, float(h), "offsets")
    rows = [
        _design(
            part,
            goal_edge,
            ThrowParams(float(h), float(w), gravity, mu),  # validates every value
            sensing_height,
            starts_per_edge,
            throws,
        )
        for h in offsets
        for w in speeds
    ]
    good = [r for r in rows if r.unique and r.trigger is not None]
    best = max(good, key=lambda r: r.width) if good else None
    return DesignSearch(goal_edge, best, rows)
