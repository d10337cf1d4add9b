"""What the nodes that hold an assembly share: its parameters, its file, and its message conversions."""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from feeder_msgs.msg import ContactForce, StabilityRegion
from feeder_planner.assembly.default import DEFAULT_ASSEMBLY_YAML
from feeder_planner.assembly.model import Assembly, assembly_from_text, load_assembly
from feeder_planner.assembly.planner import PreparedAssembly
from feeder_planner.assembly.region import StableRegion
from feeder_planner.errors import InputError
from feeder_planner.node_kit.msg_geometry import point, vec
from feeder_planner.node_kit.parameters import ParameterSpec, integer_at_least, non_negative

__all__ = ["ASSEMBLY_PARAMETERS", "load_assembly_parameter", "region_msg", "force_msgs", "contact_force_msgs"]

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
        4,
        "facets K >= 3 of the friction pyramid (4 is the paper's)",
        integer_at_least(3),
        read_only=True,
    ),
)


def load_assembly_parameter(path: str) -> Assembly:
    """The assembly the ``assembly_file`` parameter names (the built-in one when empty); errors name it."""
    if not path:
        return assembly_from_text(DEFAULT_ASSEMBLY_YAML, "built-in assembly")
    try:
        return load_assembly(path)
    except InputError as error:
        raise InputError(f"parameter assembly_file ({error.field})", error.problem, error.source) from None


def region_msg(region: StableRegion, contacts: int) -> StabilityRegion:
    """A feeder_msgs/StabilityRegion of a computed region."""
    return StabilityRegion(
        kind=region.kind,
        normals=[vec(n) for n in region.normals],
        equalities=[vec(e) for e in region.equalities],
        vertices=[vec(v) for v in region.vertices],
        area_sr=region.area_sr,
        has_center=region.center is not None,
        center=vec(region.center) if region.center is not None else vec((0.0, 0.0, 0.0)),
        facets=region.facets,
        contacts=contacts,
        lp_count=region.lp_count,
    )


def force_msgs(forces: Sequence[dict[str, Any]]) -> list[ContactForce]:
    """ContactForce messages from the ``forces`` rows of a check result (body names, point, normal, force)."""
    return [
        ContactForce(
            body_a=f["a"],
            body_b=f["b"],
            point=point(f["point"]),
            normal=vec(f["normal"]),
            force=vec(f["force"]),
        )
        for f in forces
    ]


def contact_force_msgs(prepared: PreparedAssembly, forces: np.ndarray) -> list[ContactForce]:
    """ContactForce messages for a certified LP solution: one row of ``forces`` per prepared contact."""
    bodies = prepared.assembly.bodies
    return [
        ContactForce(
            body_a=bodies[c.a].name,
            body_b=bodies[c.b].name,
            point=point(c.point),
            normal=vec(c.normal),
            force=vec(f),
        )
        for c, f in zip(prepared.contacts, forces, strict=True)
    ]
