"""What the nodes that hold an assembly share: its parameters, its file, and its message conversions."""

from __future__ import annotations

from collections.abc import Sequence

from feeder_msgs.msg import ContactForce, StabilityRegion
from feeder_planner.assembly import ContactLoad, RegionResult
from feeder_planner.assembly.parameters import ASSEMBLY_PARAMETERS, load_assembly_parameter
from feeder_planner.node_kit.msg_geometry import point, vec

__all__ = ["ASSEMBLY_PARAMETERS", "force_msgs", "load_assembly_parameter", "region_msg"]


def region_msg(result: RegionResult) -> StabilityRegion:
    """Build the feeder_msgs/StabilityRegion of a computed region and its contact count."""
    region = result.region
    return StabilityRegion(
        kind=region.kind,
        normals=[vec(n) for n in region.normals],
        equalities=[vec(e) for e in region.equalities],
        vertices=[vec(v) for v in region.vertices],
        area_sr=region.area_sr,
        has_center=region.center is not None,
        center=vec(region.center) if region.center is not None else vec((0.0, 0.0, 0.0)),
        facets=region.facets,
        contacts=result.contacts,
        lp_count=region.lp_count,
    )


def force_msgs(loads: Sequence[ContactLoad] | None) -> list[ContactForce]:
    """Build the ContactForce messages of a check result's contact loads (none when unstable)."""
    return [
        ContactForce(
            body_a=load.a,
            body_b=load.b,
            point=point(load.point),
            normal=vec(load.normal),
            force=vec(load.force),
        )
        for load in loads or ()
    ]
