"""ROS 2 node: the throwing-arm planner (grasp radii, throw map, limit set, trigger radii, design search)."""

from __future__ import annotations

import json
import math
from typing import Protocol

import numpy as np
from rclpy.node import Node

from feeder_msgs.msg import DesignCandidate, LimitAttractor, LimitEdgeRange
from feeder_msgs.msg import Part as PartMsg
from feeder_msgs.srv import DesignSearch, GraspRadii, LimitSetCompute, SensorTriggerRadii, ThrowCompute
from feeder_planner.errors import InputError
from feeder_planner.node_kit import (
    ParameterSpec,
    declare_parameters,
    integer_at_least,
    run_node,
    service_guard,
)
from feeder_planner.node_kit.msg_parts import part_from_msg
from feeder_planner.node_kit.request_limits import (
    LENGTH_RANGE_M,
    MAX_DESIGNS,
    MAX_SPEED,
    MAX_STARTS_PER_EDGE,
    MAX_THROW_WORK,
    MAX_THROWS,
    MIN_THROWS,
    check_count,
    check_design,
    check_magnitude,
    check_part_size,
)
from feeder_planner.node_kit.services import REQUEST_QUEUE_PARAMETER, serve
from feeder_planner.node_kit.tf import namespaced_frame
from feeder_planner.node_kit.viz import ResultMarkers
from feeder_planner.throwing import (
    DEFAULT_STARTS_PER_EDGE,
    DEFAULT_THROWS,
    DesignRow,
    LimitSet,
    ThrowParams,
    arm_part,
    check_grasp_parameters,
    check_sensing_height,
    grasp_radii,
    limit_set,
    search,
    throw,
)
from feeder_planner.throwing.attractors import Attractor
from feeder_planner.throwing.drawing import limit_set_shapes

__all__ = ["PARAMETERS", "ThrowPlanner", "main"]

PARAMETERS = (
    ParameterSpec(
        "default_starts_per_edge",
        DEFAULT_STARTS_PER_EDGE,
        "grid starts per stable edge when a request leaves it 0",
        integer_at_least(1),
        read_only=True,  # read once at start-up: declared so, never accepted and ignored
    ),
    ParameterSpec(
        "default_throws",
        DEFAULT_THROWS,
        "throws per start when a request leaves it 0",
        integer_at_least(MIN_THROWS),
        read_only=True,
    ),
    REQUEST_QUEUE_PARAMETER,
    ParameterSpec(
        "frame_id",
        "",
        "frame of ~/markers (the arm frame); empty: arm_pivot under the node's namespace, the arm's default",
        read_only=True,
    ),
)

# One thread per service and one for the rest: a long limit set occupies its service's thread only.
THREADS = 6


class _ThrowRequest(Protocol):
    """The design fields every throw_planner request carries (SI)."""

    offset: float
    release_speed: float
    gravity: float
    mu: float


class _LimitRequest(_ThrowRequest, Protocol):
    """The fields of a limit-set or trigger-radii request besides the design."""

    part: PartMsg
    sensing_height: float


def _params(request: _ThrowRequest) -> ThrowParams:
    """Return the request's design parameters, checked (errors name the request field)."""
    check_design(
        {
            "offset": request.offset,
            "release_speed": request.release_speed,
            "gravity": request.gravity,
            "mu": request.mu,
        }
    )
    return ThrowParams(request.offset, request.release_speed, request.gravity, request.mu)


def _height(value: float) -> float | None:
    """Return a request's sensing height: negative means the default (None); NaN or inf is refused."""
    if math.isfinite(value) and value < 0:
        return None
    return check_sensing_height(check_magnitude(value, LENGTH_RANGE_M[1], "sensing_height", "m"))


def attractor_msg(a: Attractor, ls: LimitSet) -> LimitAttractor:
    """Return the LimitAttractor of one attractor of a limit set (NaN throws per round: none found)."""
    per = a.throws_per_round or (math.nan, math.nan, math.nan)
    pattern = a.pattern or []
    return LimitAttractor(
        edges=a.edges,
        ranges=[
            LimitEdgeRange(
                edge=e,
                grasp_radius=ls.bounds.grasp[e],
                flip_radius=ls.bounds.flip[e],
                max_radius=ls.bounds.max[e],
                in_limit_set=True,
                range_min=lo,
                range_max=hi,
            )
            for e, (lo, hi) in a.edge_radius_ranges.items()
        ],
        periodic=a.periodic,
        cycle=a.cycle or [],
        pattern_edge=[p[0] for p in pattern],
        pattern_min=[p[1] for p in pattern],
        pattern_max=[p[2] for p in pattern],
        throws_per_round_min=float(per[0]),
        throws_per_round_mean=float(per[1]),
        throws_per_round_max=float(per[2]),
        basin=a.basin,
        longest_transient=a.longest_transient,
        lift_off=a.violations["lift_off"],
        slip=a.violations["slip"],
        off_arm=a.violations["off_arm"],
    )


class ThrowPlanner(Node):
    """Private services (``~/throw``...: under the node's namespace and name); each response has ok and error.

    The planner has no device topics: every request carries the part and the design it is about.
    """

    def __init__(self) -> None:
        super().__init__("throw_planner")
        self.p = declare_parameters(self, PARAMETERS)
        guard = service_guard(self)
        serve(self, GraspRadii, "~/grasp_radii", guard(self.on_grasp), own_group=True)
        serve(self, ThrowCompute, "~/throw", guard(self.on_throw), own_group=True)
        serve(self, LimitSetCompute, "~/limit_set", guard(self.on_limit_set), own_group=True)
        serve(self, SensorTriggerRadii, "~/trigger_radii", guard(self.on_trigger), own_group=True)
        serve(self, DesignSearch, "~/design_search", guard(self.on_design), own_group=True)
        self.frame_id = self.p["frame_id"] or namespaced_frame(self, "arm_pivot")
        self.markers = ResultMarkers(self)  # the last limit set's R ranges and trigger range on the arm

    def on_grasp(self, request: GraspRadii.Request, response: GraspRadii.Response) -> GraspRadii.Response:
        """Answer R_grasp for every stable edge (eqs. 1-4)."""
        check_part_size(request.part)
        check_design({"offset": request.offset, "mu": request.mu})
        part = part_from_msg(request.part)
        check_grasp_parameters(request.offset, request.mu)
        radii = grasp_radii(arm_part(part), request.offset, request.mu)
        response.stable_edges = list(radii)
        response.grasp_radius = list(radii.values())
        return response

    def on_throw(
        self, request: ThrowCompute.Request, response: ThrowCompute.Response
    ) -> ThrowCompute.Response:
        """Answer one application of the throw map."""
        check_part_size(request.part)
        params = _params(request)
        check_design({"radius": request.radius}, radius="radius")
        part = part_from_msg(request.part)
        result = throw(arm_part(part), request.edge, request.radius, params)
        response.edge_after, response.radius_after = result.edge, result.radius
        response.kind, response.turns = result.kind, result.turns
        response.lift_off, response.slip = result.lift_off, result.slip
        response.off_arm, response.toe_stub = result.off_arm, result.toe_stub
        return response

    def _limit(self, request: _LimitRequest, goal: int | None, starts: int, throws: int) -> LimitSet:
        """Return the limit set a request asks for; 0 starts or throws mean the node's defaults."""
        check_part_size(request.part)
        params = _params(request)
        check_count(starts, MAX_STARTS_PER_EDGE, "starts_per_edge", "starts per edge")
        check_count(throws, MAX_THROWS, "throws", "throws per start")
        if 0 < throws < MIN_THROWS:
            raise InputError("throws", f"must be 0 (node default) or >= {MIN_THROWS}, got {throws}")
        starts = starts or self.p["default_starts_per_edge"]
        throws = throws or self.p["default_throws"]
        part = arm_part(part_from_msg(request.part))
        work = starts * throws * len(part.stable_edges)
        if work > MAX_THROW_WORK:
            raise InputError(
                "starts_per_edge, throws",
                f"{starts} starts x {throws} throws x {len(part.stable_edges)} stable edges = {work} "
                f"throw states; the limit per request is {MAX_THROW_WORK}",
            )
        return limit_set(part, params, goal, starts, throws, sensing_height=_height(request.sensing_height))

    def on_limit_set(
        self, request: LimitSetCompute.Request, response: LimitSetCompute.Response
    ) -> LimitSetCompute.Response:
        """Answer the limit set per edge, its cycle and trigger range, and the whole result as JSON."""
        goal = None if request.goal_edge < 0 else request.goal_edge
        ls = self._limit(request, goal, request.starts_per_edge, request.throws)
        response.stable_edges = ls.stable_edges
        for i in ls.stable_edges:
            rng = ls.edge_radius_ranges.get(i)
            response.edges.append(
                LimitEdgeRange(
                    edge=i,
                    grasp_radius=ls.bounds.grasp[i],
                    flip_radius=ls.bounds.flip[i],
                    max_radius=ls.bounds.max[i],
                    in_limit_set=rng is not None,
                    range_min=rng[0] if rng else math.nan,
                    range_max=rng[1] if rng else math.nan,
                )
            )
        response.unique = ls.unique
        if ls.cycle:
            response.cycle_edges, response.throws_per_cycle = ls.cycle.edges, ls.cycle.throws_per_cycle
        response.has_trigger = ls.trigger is not None
        if ls.trigger:
            response.trigger_min, response.trigger_max = ls.trigger
        response.attractors = [attractor_msg(a, ls) for a in ls.attractors]
        response.converged, response.trigger_note = ls.converged, ls.trigger_note or ""
        response.json = json.dumps(ls.to_json(), allow_nan=False)
        self.markers.publish(limit_set_shapes(ls, request.offset), self.frame_id)
        return response

    def on_trigger(
        self, request: SensorTriggerRadii.Request, response: SensorTriggerRadii.Response
    ) -> SensorTriggerRadii.Response:
        """Answer the sensor trigger radius range for the goal edge (with the node's default grid)."""
        if request.goal_edge < 0:
            raise InputError("goal_edge", f"must be a stable edge index, got {request.goal_edge}")
        ls = self._limit(request, request.goal_edge, 0, 0)
        response.has_trigger = ls.trigger is not None
        if ls.trigger:
            response.radius_min, response.radius_max = ls.trigger
        if ls.cycle:
            response.cycle_edges = ls.cycle.edges
        self.markers.publish(limit_set_shapes(ls, request.offset), self.frame_id)
        return response

    def on_design(
        self, request: DesignSearch.Request, response: DesignSearch.Response
    ) -> DesignSearch.Response:
        """Answer every design of the (h, W) grid and the best one."""
        check_part_size(request.part)
        offsets, speeds = list(request.offsets), list(request.release_speeds)
        # Counted before any list is read: 1e5 x 1e5 values must cost nothing.
        check_count(len(offsets), MAX_DESIGNS, "offsets", "values")
        check_count(len(speeds), MAX_DESIGNS, "release_speeds", "values")
        check_count(len(offsets) * len(speeds), MAX_DESIGNS, "offsets x release_speeds", "designs")
        for i, value in enumerate(offsets):
            check_magnitude(value, LENGTH_RANGE_M[1], f"offsets[{i}]", "m")
        for i, value in enumerate(speeds):
            check_magnitude(value, MAX_SPEED, f"release_speeds[{i}]", "rad/s")
        check_design({"gravity": request.gravity, "mu": request.mu})
        part = part_from_msg(request.part)
        found = search(
            arm_part(part),
            request.goal_edge,
            np.array(offsets),
            np.array(speeds),
            request.gravity,
            request.mu,
            _height(request.sensing_height),
        )
        response.designs = [_candidate(row) for row in found.designs]
        response.found = found.best is not None
        if found.best:
            response.best = _candidate(found.best)
        return response


def _candidate(row: DesignRow) -> DesignCandidate:
    """Return one design as a message."""
    tr = row.trigger
    return DesignCandidate(
        offset=row.offset,
        release_speed=row.speed,
        unique=row.unique,
        cycle_edges=row.cycle or [],
        has_trigger=tr is not None,
        trigger_min=tr[0] if tr else math.nan,
        trigger_max=tr[1] if tr else math.nan,
        note=row.note,
    )


# What a cell host builds (feeder_cell.host) when a scene asks for it: there its services share the host's
# one thread, so a long request holds the host's other nodes (alone, THREADS serve beside each other).
NODE = ThrowPlanner


def main(args: list[str] | None = None) -> None:
    """Run the throw_planner node."""
    run_node(ThrowPlanner, "throw_planner", args, threads=THREADS)


if __name__ == "__main__":
    main()
