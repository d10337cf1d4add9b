"""SI result dictionaries of the throwing planner, shared by the `feeder` CLI and the throw_planner node."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from feeder_planner.parts import Part
from feeder_planner.throwing.design import search
from feeder_planner.throwing.geometry import arm_part
from feeder_planner.throwing.grasp import grasp_radii
from feeder_planner.throwing.limit_set import limit_set
from feeder_planner.throwing.throw_map import ThrowParams, throw


def geometry_dict(part: Part) -> dict[str, Any]:
    arm = arm_part(part)
    return {
        "hull": arm.hull.tolist(),
        "hull_file_index": list(arm.file_index),
        "stable_edges": arm.stable_edges,
        "d": arm.d.tolist(),
        "u_left": arm.u_left.tolist(),
        "u_right": arm.u_right.tolist(),
        "mass": arm.mass,
        "rho": arm.rho,
        "part_radius": arm.radius,
        "d_min": arm.d_min,
    }


def throw_dict(part: Part, edge: int, radius: float, params: ThrowParams) -> dict[str, Any]:
    res = throw(arm_part(part), edge, radius, params)
    return {
        "edge": res.edge,
        "radius": res.radius,
        "kind": res.kind,
        "start_edge": edge,
        "start_radius": radius,
        "rotation": res.rotation,
        "turns": res.turns,
        "flight_time": res.flight_time,
        "impacts": res.impacts,
    }


def grasp_dict(part: Part, offset: float, mu: float) -> dict[str, Any]:
    arm = arm_part(part)
    return {
        "stable_edges": arm.stable_edges,
        "grasp_radius": {str(i): r for i, r in grasp_radii(arm, offset, mu).items()},
    }


def limit_set_dict(
    part: Part,
    params: ThrowParams,
    goal_edge: int | None,
    sensing_height: float | None,
    starts_per_edge: int = 25,
    throws: int = 300,
) -> dict[str, Any]:
    arm = arm_part(part)
    height = 0.01 * arm.radius if sensing_height is None else sensing_height
    ls = limit_set(arm, params, goal_edge, starts_per_edge, throws, min(100, throws // 3), height)
    b = ls.bounds
    return {
        "stable_edges": arm.stable_edges,
        "grasp_radius": {str(i): r for i, r in b.grasp.items()},
        "flip_radius": {str(i): r for i, r in b.flip.items()},
        "max_radius": {str(i): r for i, r in b.max.items()},
        "invariant": b.invariant,
        "cycle": None
        if ls.cycle is None
        else {
            "edges": ls.cycle.edges,
            "throws_per_cycle": ls.cycle.throws_per_cycle,
            "throws_range": list(ls.cycle.throws_range),
        },
        "unique": ls.unique,
        "edge_radius_ranges": {str(e): list(r) for e, r in ls.edge_radius_ranges.items()},
        "trigger": None
        if ls.trigger is None
        else {"goal_edge": goal_edge, "radius_range": list(ls.trigger), "sensing_height": height},
        "starts": ls.starts,
        "throws": ls.throws,
    }


def design_dict(
    part: Part,
    goal_edge: int,
    offsets: list[float],
    speeds: list[float],
    gravity: float,
    mu: float,
    sensing_height: float | None,
) -> dict[str, Any]:
    arm = arm_part(part)
    best, rows = search(arm, goal_edge, np.array(offsets), np.array(speeds), gravity, mu, sensing_height)

    def row(r: Any) -> dict[str, Any]:
        return {
            "offset": r.offset,
            "release_speed": r.speed,
            "unique": r.unique,
            "cycle": r.cycle,
            "trigger_range": None if r.trigger is None else list(r.trigger),
            "width": r.width,
            "note": r.note,
        }

    return {
        "goal_edge": goal_edge,
        "best": None if best is None else row(best),
        "designs": [row(r) for r in rows],
    }


def finite_all(result: Any) -> bool:
    """Whether every number in a result is finite (JSON output refuses NaN)."""
    if isinstance(result, dict):
        return all(finite_all(v) for v in result.values())
    if isinstance(result, (list, tuple)):
        return all(finite_all(v) for v in result)
    return not isinstance(result, float) or math.isfinite(result)
