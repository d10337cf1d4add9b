"""ROS 2 node: the throwing-arm planner (grasp radii, throw map, limit set, trigger radii, design search)."""

from __future__ import annotations

import json
import math
from typing import Any

from rclpy.node import Node

from feeder_msgs.msg import DesignCandidate, LimitEdgeRange
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
from feeder_planner.throwing import api
from feeder_planner.throwing.throw_map import ThrowParams

PARAMETERS = (
    ParameterSpec(
        "default_starts_per_edge",
        25,
        "grid starts per stable edge when a request leaves it 0",
        integer_at_least(1),
    ),
    ParameterSpec(
        "default_throws",
        300,
        "throws per start when a request leaves it 0",
        integer_at_least(3),
    ),
)


def _params(request: Any) -> ThrowParams:
    return ThrowParams(request.offset, request.release_speed, request.gravity, request.mu)


def _height(value: float) -> float | None:
    if not math.isfinite(value):
        raise InputError("sensing_height", f"must be finite, got {value!r}")
    return None if value < 0 else value


class ThrowPlanner(Node):
    """Services under /throw_planner/; every response carries ok and error."""

    def __init__(self) -> None:
        super().__init__("throw_planner")
        self.p = declare_parameters(self, PARAMETERS)
        guard = service_guard(self)
        self.create_service(GraspRadii, "/throw_planner/grasp_radii", guard(self.on_grasp))
        self.create_service(ThrowCompute, "/throw_planner/throw", guard(self.on_throw))
        self.create_service(LimitSetCompute, "/throw_planner/limit_set", guard(self.on_limit_set))
        self.create_service(SensorTriggerRadii, "/throw_planner/trigger_radii", guard(self.on_trigger))
        self.create_service(DesignSearch, "/throw_planner/design_search", guard(self.on_design))

    def on_grasp(self, request: GraspRadii.Request, response: GraspRadii.Response) -> GraspRadii.Response:
        part = part_from_msg(request.part)
        ThrowParams(request.offset, 1.0, -1.0, request.mu)  # validates offset and mu, naming the field
        result = api.grasp_dict(part, request.offset, request.mu)
        response.stable_edges = result["stable_edges"]
        response.grasp_radius = [result["grasp_radius"][str(i)] for i in result["stable_edges"]]
        return response

    def on_throw(
        self, request: ThrowCompute.Request, response: ThrowCompute.Response
    ) -> ThrowCompute.Response:
        part = part_from_msg(request.part)
        result = api.throw_dict(part, request.edge, request.radius, _params(request))
        response.edge_after, response.radius_after = result["edge"], result["radius"]
        response.kind, response.turns = result["kind"], result["turns"]
        return response

    def _limit(self, request: Any, goal: int | None, starts: int, throws: int) -> dict[str, Any]:
        part = part_from_msg(request.part)
        return api.limit_set_dict(
            part,
            _params(request),
            goal,
            _height(request.sensing_height),
            starts or self.p["default_starts_per_edge"],
            throws or self.p["default_throws"],
        )

    def on_limit_set(
        self, request: LimitSetCompute.Request, response: LimitSetCompute.Response
    ) -> LimitSetCompute.Response:
        goal = None if request.goal_edge < 0 else request.goal_edge
        r = self._limit(request, goal, request.starts_per_edge, request.throws)
        response.stable_edges = r["stable_edges"]
        for i in r["stable_edges"]:
            key = str(i)
            rng = r["edge_radius_ranges"].get(key)
            response.edges.append(
                LimitEdgeRange(
                    edge=i,
                    grasp_radius=r["grasp_radius"][key],
                    flip_radius=r["flip_radius"][key],
                    max_radius=r["max_radius"][key],
                    in_limit_set=rng is not None,
                    range_min=rng[0] if rng else math.nan,
                    range_max=rng[1] if rng else math.nan,
                )
            )
        response.unique = r["unique"]
        if r["cycle"]:
            response.cycle_edges, response.throws_per_cycle = (
                r["cycle"]["edges"],
                r["cycle"]["throws_per_cycle"],
            )
        response.has_trigger = r["trigger"] is not None
        if r["trigger"]:
            response.trigger_min, response.trigger_max = r["trigger"]["radius_range"]
        response.json = json.dumps(r, allow_nan=False)
        return response

    def on_trigger(
        self, request: SensorTriggerRadii.Request, response: SensorTriggerRadii.Response
    ) -> SensorTriggerRadii.Response:
        if request.goal_edge < 0:
            raise InputError("goal_edge", f"must be a stable edge index, got {request.goal_edge}")
        r = self._limit(request, request.goal_edge, 0, 0)
        response.has_trigger = r["trigger"] is not None
        if r["trigger"]:
            response.radius_min, response.radius_max = r["trigger"]["radius_range"]
        if r["cycle"]:
            response.cycle_edges = r["cycle"]["edges"]
        return response

    def on_design(
        self, request: DesignSearch.Request, response: DesignSearch.Response
    ) -> DesignSearch.Response:
        part = part_from_msg(request.part)
        r = api.design_dict(
            part,
            request.goal_edge,
            list(request.offsets),
            list(request.release_speeds),
            request.gravity,
            request.mu,
            _height(request.sensing_height),
        )

        def candidate(row: dict[str, Any]) -> DesignCandidate:
            tr = row["trigger_range"]
            return DesignCandidate(
                offset=row["offset"],
                release_speed=row["release_speed"],
                unique=row["unique"],
                cycle_edges=row["cycle"] or [],
                has_trigger=tr is not None,
                trigger_min=tr[0] if tr else math.nan,
                trigger_max=tr[1] if tr else math.nan,
                note=row["note"],
            )

        response.designs = [candidate(row) for row in r["designs"]]
        response.found = r["best"] is not None
        if r["best"]:
            response.best = candidate(r["best"])
        return response


def main(args: list[str] | None = None) -> None:
    run_node(ThrowPlanner, "throw_planner", args)


if __name__ == "__main__":
    main()
