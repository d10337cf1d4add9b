"""Throwing-arm mechanics (Lynch, Northrop, Pan: stable limit sets): grasp, flight, impact, throw map.

The public surface the `feeder` command, the throw_planner node, the simulator and the tests use; each
module's own ``__all__`` lists the rest. Results are frozen dataclasses with ``to_json()`` for the
contract's JSON objects (SI units); numerical tolerances and model constants live in ``tolerances``.
"""

from feeder_planner.throwing.attractors import Attractor
from feeder_planner.throwing.design import DesignRow, DesignSearch, search
from feeder_planner.throwing.flight import earliest_impact, flight_state, rest_pose, vertex_positions
from feeder_planner.throwing.geometry import ArmPart, arm_part
from feeder_planner.throwing.grasp import carry_in_grasp, grasp_radii, grasp_radius, impulse_in_grasp
from feeder_planner.throwing.limit_set import (
    Cycle,
    EdgeBounds,
    LimitSet,
    OffsetBelowDMinError,
    Trajectories,
    edge_bounds,
    iterate,
    limit_set,
)
from feeder_planner.throwing.sensor import (
    check_sensing_height,
    reads,
    reads_pose,
    resting_cover,
    sensing_height_or_default,
    trigger_range,
)
from feeder_planner.throwing.studies import RobustPoint, RobustStudy, robust_study
from feeder_planner.throwing.throw_map import (
    THROW_KINDS,
    BelowGraspError,
    ThrowBatch,
    ThrowKind,
    ThrowParams,
    ThrowResult,
    check_grasp_parameters,
    check_start,
    is_jog,
    lowest_radius,
    throw,
    throw_batch,
    throw_kind,
    whole_turns,
)
from feeder_planner.throwing.tolerances import DEFAULT_STARTS_PER_EDGE, DEFAULT_THROWS

__all__ = [
    "ArmPart",
    "arm_part",
    "carry_in_grasp",
    "grasp_radii",
    "grasp_radius",
    "impulse_in_grasp",
    "rest_pose",
    "flight_state",
    "vertex_positions",
    "earliest_impact",
    "ThrowKind",
    "THROW_KINDS",
    "ThrowParams",
    "BelowGraspError",
    "check_grasp_parameters",
    "check_start",
    "lowest_radius",
    "whole_turns",
    "is_jog",
    "throw_kind",
    "ThrowBatch",
    "throw_batch",
    "ThrowResult",
    "throw",
    "Trajectories",
    "iterate",
    "EdgeBounds",
    "edge_bounds",
    "Cycle",
    "LimitSet",
    "OffsetBelowDMinError",
    "limit_set",
    "DEFAULT_STARTS_PER_EDGE",
    "DEFAULT_THROWS",
    "check_sensing_height",
    "sensing_height_or_default",
    "reads",
    "reads_pose",
    "resting_cover",
    "trigger_range",
    "DesignRow",
    "DesignSearch",
    "search",
    "Attractor",
    "RobustPoint",
    "RobustStudy",
    "robust_study",
]
