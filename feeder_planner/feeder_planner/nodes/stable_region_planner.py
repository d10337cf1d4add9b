"""ROS 2 node: the stable-region planner of an assembly (region, one-direction check, safe great-arc path)."""

from __future__ import annotations

import math

from rclpy.node import Node

from feeder_msgs.msg import StabilityRegion
from feeder_msgs.srv import StabilityCheck, StablePath, StableRegion
from feeder_planner.assembly import (
    DEFAULT_PATH_STEP,
    MIN_FACETS,
    PreparedAssembly,
    assembly_from_text,
    check_result,
    path_result,
    prepare,
    region_result,
    validate_mu,
)
from feeder_planner.errors import InputError
from feeder_planner.node_kit import LATCHED, declare_parameters, from_vec, run_node, service_guard, vec
from feeder_planner.node_kit.msg_assembly import (
    ASSEMBLY_PARAMETERS,
    force_msgs,
    load_assembly_parameter,
    region_msg,
)

__all__ = ["PARAMETERS", "StableRegionPlanner", "main"]

PARAMETERS = ASSEMBLY_PARAMETERS


class StableRegionPlanner(Node):
    """Serve ~/stable_region, ~/check_stability and ~/safe_path; latch its assembly's region on ~/region.

    All names are private, so the planner moves whole with its namespace; it reads no device topic (requests
    carry the gravity directions), so it needs no ``device`` parameter.
    """

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
        self.region_pub.publish(region_msg(region_result(self.prepared)))
        self.get_logger().info(
            f"{self.assembly.name}: stable region is {self.prepared.region.kind} "
            f"({len(self.prepared.contacts)} contact points)"
        )

    def _prepared(
        self, request: StableRegion.Request | StabilityCheck.Request | StablePath.Request
    ) -> PreparedAssembly:
        """Return the node's prepared assembly, or the request's own assembly / mu / K (fields validated)."""
        if request.override_mu:
            validate_mu(request.mu, "mu")
        if request.facets != 0 and request.facets < MIN_FACETS:
            raise InputError("facets", f"must be 0 (node default) or >= {MIN_FACETS}, got {request.facets}")
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
        """Serve ~/stable_region: the region of the node's or the request's assembly."""
        response.region = region_msg(region_result(self._prepared(request)))
        return response

    def on_check(
        self, request: StabilityCheck.Request, response: StabilityCheck.Response
    ) -> StabilityCheck.Response:
        """Serve ~/check_stability: one direction's verdict, margin, unbalanced bodies and contact forces."""
        g = from_vec(request.gravity, "gravity")
        result = check_result(self._prepared(request), g)
        response.stable = result.stable
        response.margin = result.margin_rad
        response.unbalanced_bodies = list(result.unbalanced_bodies)
        response.forces = force_msgs(result.forces)
        return response

    def on_path(self, request: StablePath.Request, response: StablePath.Response) -> StablePath.Response:
        """Serve ~/safe_path: a certified great arc (step 0 means the default 1 degree)."""
        start, goal = from_vec(request.start, "start"), from_vec(request.goal, "goal")
        if not math.isfinite(request.step) or request.step < 0:
            raise InputError("step", f"must be 0 (1 degree) or a positive angle in rad, got {request.step!r}")
        result = path_result(self._prepared(request), start, goal, request.step or DEFAULT_PATH_STEP)
        response.path = [vec(g) for g in result.path]
        response.min_margin = result.min_margin_rad
        return response


def main(args: list[str] | None = None) -> None:
    """Run the node until shutdown."""
    run_node(StableRegionPlanner, "stable_region_planner", args)


if __name__ == "__main__":
    main()
