"""ROS 2 node: the stable-region planner of an assembly (region, single-direction check, safe great-arc path)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from geometry_msgs.msg import Point, Vector3
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from feeder_msgs.msg import ContactForce, StabilityRegion
from feeder_msgs.srv import StabilityCheck, StablePath, StableRegion
from feeder_planner.assembly.default import DEFAULT_ASSEMBLY_YAML
from feeder_planner.assembly.model import Assembly, assembly_from_text, load_assembly
from feeder_planner.assembly.planner import PreparedAssembly, check_result, path_result, prepare
from feeder_planner.assembly.region import StableRegion as Region
from feeder_planner.errors import InputError
from feeder_planner.nodes.ros_common import ParameterSpec, declare_parameters, run_node, service_guard

PARAMETERS = (
    ParameterSpec("assembly_file", "", "assembly YAML file (contract section 2); empty = the built-in block in an "
                                       "L bracket (paper Figs. 12/14, mu 0.3)"),
    ParameterSpec("override_mu", False, "use the parameter mu for every contact instead of the file's coefficients"),
    ParameterSpec("mu", 0.0, "Coulomb friction coefficient (>= 0) used when override_mu is true",
                  lambda v: None if isinstance(v, float) and math.isfinite(v) and v >= 0
                  else f"must be a finite number >= 0, got {v!r}"),
    ParameterSpec("facets", 4, "facets K >= 3 of the friction pyramid (4 is the paper's)",
                  lambda v: None if isinstance(v, int) and v >= 3 else f"must be an integer >= 3, got {v!r}"),
)

LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)


def vec(v: Any) -> Vector3:
    return Vector3(x=float(v[0]), y=float(v[1]), z=float(v[2]))


def from_vec(msg: Vector3, field: str) -> np.ndarray:
    g = np.array([msg.x, msg.y, msg.z], dtype=float)
    if not np.all(np.isfinite(g)):
        raise InputError(field, f"must be finite, got {g.tolist()}")
    if np.linalg.norm(g) < 1e-12:
        raise InputError(field, "must be a non-zero direction")
    return g


def region_msg(region: Region, contacts: int) -> StabilityRegion:
    return StabilityRegion(kind=region.kind, normals=[vec(n) for n in region.normals],
                           equalities=[vec(e) for e in region.equalities],
                           vertices=[vec(v) for v in region.vertices], area_sr=region.area_sr,
                           has_center=region.center is not None,
                           center=vec(region.center) if region.center is not None else Vector3(),
                           facets=region.facets, contacts=contacts, lp_count=region.lp_count)


def force_msgs(result: dict) -> list[ContactForce]:
    return [ContactForce(body_a=f["a"], body_b=f["b"], point=Point(x=f["point"][0], y=f["point"][1], z=f["point"][2]),
                         normal=vec(f["normal"]), force=vec(f["force"])) for f in result.get("forces", [])]


class StableRegionPlanner(Node):
    """Services under /stable_region_planner/; the default assembly's region is latched on ~/region."""

    def __init__(self) -> None:
        super().__init__("stable_region_planner")
        self.p = declare_parameters(self, PARAMETERS)
        self.assembly = self._load(self.p["assembly_file"])
        self.prepared = prepare(self.assembly, self.p["mu"] if self.p["override_mu"] else None, self.p["facets"])
        guard = service_guard(self)
        self.create_service(StableRegion, "~/stable_region", guard(self.on_region))
        self.create_service(StabilityCheck, "~/check_stability", guard(self.on_check))
        self.create_service(StablePath, "~/safe_path", guard(self.on_path))
        self.region_pub = self.create_publisher(StabilityRegion, "~/region", LATCHED)
        self.region_pub.publish(region_msg(self.prepared.region, len(self.prepared.contacts)))
        self.get_logger().info(f"{self.assembly.name}: stable region is {self.prepared.region.kind} "
                               f"({len(self.prepared.contacts)} contact points)")

    @staticmethod
    def _load(path: str) -> Assembly:
        if not path:
            return assembly_from_text(DEFAULT_ASSEMBLY_YAML, "built-in assembly")
        try:
            return load_assembly(path)
        except InputError as error:
            raise InputError(f"parameter assembly_file ({error.field})", error.problem, error.source) from None

    def _prepared(self, request: Any) -> PreparedAssembly:
        """The node's prepared assembly, or the request's own assembly / mu / K (validated, naming the field)."""
        if request.override_mu and not (math.isfinite(request.mu) and request.mu >= 0):
            raise InputError("mu", f"must be a finite number >= 0, got {request.mu!r}")
        if request.facets != 0 and request.facets < 3:
            raise InputError("facets", f"must be 0 (node default) or >= 3, got {request.facets}")
        if not request.assembly_yaml and not request.override_mu and request.facets in (0, self.prepared.facets):
            return self.prepared
        assembly = assembly_from_text(request.assembly_yaml, "assembly_yaml") if request.assembly_yaml \
            else self.assembly
        mu = request.mu if request.override_mu else (self.prepared.mu if not request.assembly_yaml else None)
        return prepare(assembly, mu, request.facets or self.prepared.facets)

    def on_region(self, request: Any, response: Any) -> Any:
        prepared = self._prepared(request)
        response.region = region_msg(prepared.region, len(prepared.contacts))
        return response

    def on_check(self, request: Any, response: Any) -> Any:
        g = from_vec(request.gravity, "gravity")
        prepared = self._prepared(request)
        result = check_result(prepared, g)
        response.stable = result["stable"]
        response.margin = result["margin_rad"]
        response.unbalanced_bodies = result["unbalanced_bodies"]
        response.forces = force_msgs(result)
        return response

    def on_path(self, request: Any, response: Any) -> Any:
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
