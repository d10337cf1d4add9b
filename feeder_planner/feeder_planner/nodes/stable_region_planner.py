"""ROS 2 node: the stable-region planner of an assembly (region, single-direction check, safe great-arc path)."""

from __future__ import annotations

import math

from rclpy.node import Node

from feeder_msgs.msg import StabilityRegion
from feeder_msgs.srv import StabilityCheck, StablePath, StableRegion
from feeder_planner.assembly.model import assembly_from_text
from feeder_planner.assembly.planner import PreparedAssembly, check_result, path_result, prepare
from feeder_planner.errors import InputError
from feeder_planner.node_kit import LATCHED, declare_parameters, from_vec, run_node, service_guard, vec
from feeder_planner.node_kit.msg_assembly import (
    ASSEMBLY_PARAMETERS,
    force_msgs,
    load_assembly_parameter,
    region_msg,
)

PARAMETERS = ASSEMBLY_PARAMETERS


class StableRegionPlanner(Node):
    """Services under /stable_region_planner/; the default assembly's region is latched on ~/region."""

    def __init__(self) -> None:
        super().__init__("stable_region_planner")
        self.p = declare_parameters(self, PARAMETERS)
        self.assembly = load_assembly_parameter(self.p["assembly_file"])
        self.prepared = prepare(
            self.assembly, self.p["mu"] if self.p["override_mu"] else None, self.p["facets"]
        )
        guard = service_guard(self)
        self.create_service(StableRegion, "~/stable_region", guard(self.on_region))
        self.create_service(StabilityCheck, "~/check_stability", guard(self.on_check))
        self.create_service(StablePath, "~/safe_path", guard(self.on_path))
        self.region_pub = self.create_publisher(StabilityRegion, "~/region", LATCHED)
        self.region_pub.publish(region_msg(self.prepared.region, len(self.prepared.contacts)))
        self.get_logger().info(
            f"{self.assembly.name}: stable region is {self.prepared.region.kind} "
            f"({len(self.prepared.contacts)} contact points)"
        )

    def _prepared(
        self, request: StableRegion.Request | StabilityCheck.Request | StablePath.Request
    ) -> PreparedAssembly:
        """The node's prepared assembly, or the request's own assembly / mu / K (validated, naming the field)."""
        if request.override_mu and not (math.isfinite(request.mu) and request.mu >= 0):
            raise InputError("mu", f"must be a finite number >= 0, got {request.mu!r}")
        if request.facets != 0 and request.facets < 3:
            raise InputError("facets", f"must be 0 (node default) or >= 3, got {request.facets}")
        if (
            not request.assembly_yaml
            and not request.override_mu
            and request.facets in (0, self.prepared.facets)
        ):
            return self.prepared
        assembly = (
            assembly_from_text(request.assembly_yaml, "assembly_yaml")
            if request.assembly_yaml
            else self.assembly
        )
        mu = request.mu if request.override_mu else (self.prepared.mu if not request.assembly_yaml else None)
        return prepare(assembly, mu, request.facets or self.prepared.facets)

    def on_region(
        self, request: StableRegion.Request, response: StableRegion.Response
    ) -> StableRegion.Response:
        prepared = self._prepared(request)
        response.region = region_msg(prepared.region, len(prepared.contacts))
        return response

    def on_check(
        self, request: StabilityCheck.Request, response: StabilityCheck.Response
    ) -> StabilityCheck.Response:
        g = from_vec(request.gravity, "gravity")
        prepared = self._prepared(request)
        result = check_result(prepared, g)
        response.stable = result["stable"]
        response.margin = result["margin_rad"]
        response.unbalanced_bodies = result["unbalanced_bodies"]
        response.forces = force_msgs(result.get("forces", []))
        return response

    def on_path(self, request: StablePath.Request, response: StablePath.Response) -> StablePath.Response:
        start, goal = from_vec(request.start, "start"), from_vec(request.goal, "goal")
        if not math.isfinite(request.step) or request.step < 0:
            raise InputError("step", f"must be 0 (1 degree) or a positive angle in rad, got {request.step!r}")
        prepared = self._prepared(request)
        result = path_result(prepared, start, goal, request.step or math.radians(1.0))
        response.path = [vec(g) for g in result["path"]]
        response.min_margin = result["min_margin_rad"]
        return response


def main(args: list[str] | None = None) -> None:
    run_node(StableRegionPlanner, "stable_region_planner", args)


if __name__ == "__main__":
    main()
