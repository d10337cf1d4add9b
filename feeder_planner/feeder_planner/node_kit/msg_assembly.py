"""What the nodes that hold an assembly share: its parameters, its file, and its message conversions."""

from __future__ import annotations

from collections.abc import Sequence

from feeder_msgs.msg import ContactForce, StabilityRegion
from feeder_planner.assembly import (
    DEFAULT_ASSEMBLY_YAML,
    DEFAULT_FACETS,
    MIN_FACETS,
    Assembly,
    ContactLoad,
    RegionResult,
    assembly_from_text,
    load_assembly,
)
from feeder_planner.errors import InputError
from feeder_planner.node_kit.msg_geometry import point, vec
from feeder_planner.node_kit.parameters import ParameterSpec, integer_at_least, non_negative

__all__ = ["ASSEMBLY_PARAMETERS", "force_msgs", "load_assembly_parameter", "region_msg"]

ASSEMBLY_PARAMETERS = (
    ParameterSpec(
        "assembly_file",
        "",
        "assembly YAML file (contract section 2); empty = the built-in block in an L bracket "
        "(paper Figs. 12/14, mu 0.3)",
        read_only=True,
    ),
    ParameterSpec(
        "override_mu",
        False,
        "use the parameter mu for every contact instead of the file's coefficients",
        read_only=True,
    ),
    ParameterSpec(
        "mu",
        0.0,
        "Coulomb friction coefficient (>= 0) used when override_mu is true",
        non_negative,
        read_only=True,
    ),
    ParameterSpec(
        "facets",
        DEFAULT_FACETS,
        f"facets K >= {MIN_FACETS} of the friction pyramid ({DEFAULT_FACETS} is the paper's)",
        integer_at_least(MIN_FACETS),
        read_only=True,
    ),
)


def load_assembly_parameter(path: str) -> Assembly:
    """Load the assembly the ``assembly_file`` parameter names (built-in when empty); errors name it."""
    if not path:
        return assembly_from_text(DEFAULT_ASSEMBLY_YAML, "built-in assembly")
    try:
        return load_assembly(path)
    except InputError as error:
        raise InputError(f"parameter assembly_file ({error.field})", error.problem, error.source) from None


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
