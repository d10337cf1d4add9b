"""ROS 2 node: the stable-region planner of an assembly (region, one-direction check, safe great-arc path)."""

from __future__ import annotations

import math
import os

import numpy as np
from rclpy.node import Node

from feeder_msgs.msg import StabilityRegion
from feeder_msgs.srv import StabilityCheck, StablePath, StableRegion
from feeder_planner.assembly import (
    DEFAULT_PATH_STEP,
    MIN_FACETS,
    Assembly,
    PreparedAssembly,
    assembly_from_document,
    check_result,
    path_result,
    prepare,
    region_result,
    validate_mu,
)
from feeder_planner.assembly.drawing import path_shape, region_shapes
from feeder_planner.errors import InputError
from feeder_planner.node_kit import (
    LATCHED,
    ParameterSpec,
    declare_parameters,
    from_vec,
    positive,
    run_node,
    service_guard,
    vec,
)
from feeder_planner.node_kit.msg_assembly import (
    ASSEMBLY_PARAMETERS,
    force_msgs,
    load_assembly_parameter,
    region_msg,
)
from feeder_planner.node_kit.request_limits import (
    MAX_FACETS,
    MAX_PATH_SAMPLES,
    bounded_yaml_mapping,
    check_count,
)
from feeder_planner.node_kit.services import REQUEST_QUEUE_PARAMETER, serve
from feeder_planner.node_kit.tf import namespaced_frame
from feeder_planner.node_kit.viz import ResultMarkers

__all__ = ["PARAMETERS", "StableRegionPlanner", "main"]

# One thread per service and one for the rest: a long path occupies its service's thread only.
THREADS = 4

PARAMETERS = (
    *ASSEMBLY_PARAMETERS,
    ParameterSpec(
        "frame_id",
        "",
        "frame of ~/markers (the assembly frame); empty: assembly under the node's namespace, the "
        "fixture's default frame beside it",
        read_only=True,
    ),
    ParameterSpec(
        "mesh_base_dir",
        "",
        "directory relative mesh paths of a request's assembly_yaml resolve against (meshes: [{file}]); "
        "empty: the directory of assembly_file, and with no assembly_file only absolute paths",
        read_only=True,
    ),
    ParameterSpec(
        "sphere_radius",
        0.1,
        "radius (m) of the sphere of gravity directions ~/markers draws the region on",
        positive,
        read_only=True,
    ),
)


class StableRegionPlanner(Node):
    """Serve ~/stable_region, ~/check_stability and ~/safe_path; latch its assembly's region on ~/region.

    All names are private, so the planner moves whole with its namespace; it reads no device topic (requests
    carry the gravity directions), so it needs no ``device`` parameter.
    """

    def __init__(self) -> None:
        super().__init__("stable_region_planner")
        self.p = declare_parameters(self, (*PARAMETERS, REQUEST_QUEUE_PARAMETER))
        self.assembly = load_assembly_parameter(self.p["assembly_file"])
        self.prepared = prepare(
            self.assembly, self.p["mu"] if self.p["override_mu"] else None, self.p["facets"]
        )
        guard = service_guard(self)
        serve(self, StableRegion, "~/stable_region", guard(self.on_region), own_group=True)
        serve(self, StabilityCheck, "~/check_stability", guard(self.on_check), own_group=True)
        serve(self, StablePath, "~/safe_path", guard(self.on_path), own_group=True)
        self.region_pub = self.create_publisher(StabilityRegion, "~/region", LATCHED)
        self.region_pub.publish(region_msg(region_result(self.prepared)))
        self.frame_id = self.p["frame_id"] or namespaced_frame(self, "assembly")
        self.markers = ResultMarkers(self)  # the node's region, and the last safe path it planned
        self.markers.publish(region_shapes(self.prepared.region, self.p["sphere_radius"]), self.frame_id)
        self.get_logger().info(
            f"{self.assembly.name}: stable region is {self.prepared.region.kind} "
            f"({len(self.prepared.contacts)} contact points)"
        )

    def _prepared(
        self, request: StableRegion.Request | StabilityCheck.Request | StablePath.Request
    ) -> PreparedAssembly:
        """Return the node's prepared assembly, or the request's own assembly / mu / K (fields validated)."""
        if request.override_mu or not math.isfinite(request.mu):  # NaN is refused even when unused
            validate_mu(request.mu, "mu")
        if request.facets != 0 and request.facets < MIN_FACETS:
            raise InputError("facets", f"must be 0 (node default) or >= {MIN_FACETS}, got {request.facets}")
        check_count(request.facets, MAX_FACETS, "facets", "friction-pyramid facets")
        if (
            not request.assembly_yaml
            and not request.override_mu
            and request.facets in (0, self.prepared.facets)
        ):
            return self.prepared
        base = self.p["mesh_base_dir"] or (os.path.dirname(self.p["assembly_file"]) or None)
        assembly = _request_assembly(request.assembly_yaml, base) if request.assembly_yaml else self.assembly
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
        step = request.step or DEFAULT_PATH_STEP
        arc = math.acos(
            float(np.clip(float(start @ goal) / (np.linalg.norm(start) * np.linalg.norm(goal)), -1.0, 1.0))
        )
        samples = math.ceil(arc / step) + 1
        if samples > MAX_PATH_SAMPLES:
            raise InputError(
                "step",
                f"{step:.3g} rad over the {arc:.3g} rad arc is {samples} samples; the limit per request is "
                f"{MAX_PATH_SAMPLES} (a step of at least {arc / (MAX_PATH_SAMPLES - 1):.3g} rad)",
            )
        prepared = self._prepared(request)
        result = path_result(prepared, start, goal, request.step or DEFAULT_PATH_STEP)
        response.path = [vec(g) for g in result.path]
        if prepared is self.prepared:  # the node's own assembly: its region and this path
            radius = self.p["sphere_radius"]
            shapes = [*region_shapes(self.prepared.region, radius), path_shape(result.path, radius)]
            self.markers.publish(shapes, self.frame_id)
        response.min_margin = result.min_margin_rad
        return response


def _request_assembly(text: str, mesh_base_dir: str | None = None) -> Assembly:
    """Parse a request's ``assembly_yaml`` (size, aliases, nesting bounded; meshes relative to the base)."""
    document = bounded_yaml_mapping(text, "assembly_yaml")
    try:
        return assembly_from_document(document, "assembly_yaml", mesh_base_dir)
    except InputError as error:
        raise InputError(f"assembly_yaml ({error.field})", error.problem) from None


# What a cell host builds (feeder_cell.host) when a scene asks for it: there its services share the host's
# one thread, so a long request holds the host's other nodes (alone, THREADS serve beside each other).
NODE = StableRegionPlanner


def main(args: list[str] | None = None) -> None:
    """Run the node until shutdown."""
    run_node(StableRegionPlanner, "stable_region_planner", args, threads=THREADS)


if __name__ == "__main__":
    main()
