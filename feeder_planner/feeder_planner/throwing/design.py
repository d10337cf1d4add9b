"""Design search over offset h and release speed: a unique limit set from all starts and the widest trigger range."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from feeder_planner.errors import FeederError, InputError
from feeder_planner.throwing.geometry import ArmPart
from feeder_planner.throwing.limit_set import limit_set
from feeder_planner.throwing.throw_map import ThrowParams


@dataclass(frozen=True)
class DesignRow:
    offset: float
    speed: float
    unique: bool
    cycle: list[int] | None
    trigger: tuple[float, float] | None
    note: str

    @property
    def width(self) -> float:
        return 0.0 if self.trigger is None else self.trigger[1] - self.trigger[0]


def search(
    part: ArmPart,
    goal_edge: int,
    offsets: np.ndarray,
    speeds: np.ndarray,
    gravity: float,
    mu: float,
    sensing_height: float | None = None,
    starts_per_edge: int = 10,
    throws: int = 200,
) -> tuple[DesignRow | None, list[DesignRow]]:
    """Try every (h, W) of the grid; the best design has a unique cycle through the goal edge and the widest range."""
    if goal_edge not in part.stable_edges:
        raise InputError("goal_edge", f"edge {goal_edge} is not a stable edge (stable: {part.stable_edges})")
    if len(offsets) == 0 or len(speeds) == 0:
        raise InputError("offsets" if len(offsets) == 0 else "release_speeds", "needs at least one value")
    rows: list[DesignRow] = []
    for h in offsets:
        for w in speeds:
            params = ThrowParams(float(h), float(w), gravity, mu)  # validates every value
            try:
                ls = limit_set(part, params, goal_edge, starts_per_edge, throws, throws // 3, sensing_height)
            except FeederError as error:
                rows.append(DesignRow(float(h), float(w), False, None, None, str(error)[:160]))
                continue
            note = "" if ls.unique else "starts reach different cycles (or none)"
            if ls.unique and goal_edge not in ls.cycle.edges:
                note = "goal edge is not in the cycle"
            rows.append(
                DesignRow(
                    float(h),
                    float(w),
                    ls.unique,
                    ls.cycle.edges if ls.cycle else None,
                    ls.trigger if ls.unique else None,
                    note,
                )
            )
    good = [r for r in rows if r.unique and r.trigger is not None]
    best = max(good, key=lambda r: r.width) if good else None
    return best, rows
