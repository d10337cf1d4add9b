"""One STEP solid as a planar part: its outline resting on a face, or its section by a plane.

Apart from ``cad.step`` (which reads and tessellates a STEP file's solids, for assemblies too): this module
uses the mesh path (``assembly.meshes``) and the solid outlines of ``cad.stl``, which ``assembly.meshes``
must not see in turn.
"""

from __future__ import annotations

from pathlib import Path

from feeder_planner.cad.options import CadOptions, unit_scale
from feeder_planner.cad.outline import Outline
from feeder_planner.cad.step import read_step_solids
from feeder_planner.errors import InputError

__all__ = ["read_step_part"]


def read_step_part(path: str | Path, options: CadOptions) -> Outline:
    """Read the outline of one STEP solid (``body``, or the only one), resting on ``face`` or in section."""
    from feeder_planner.assembly.meshes import checked_mesh  # imported here: trimesh's cost
    from feeder_planner.cad.stl import solid_outline

    unit = unit_scale(options.unit, "cad.unit") if options.unit is not None else None
    solids, scale, unit_name = read_step_solids(path, options.chord_tolerance, unit)
    if options.body is None and len(solids) > 1:
        raise InputError(
            "<file>",
            f"{len(solids)} solids and no choice made; choose one with body: (1 to {len(solids)}) in the "
            "part YAML's cad: mapping",
        )
    number = options.body or 1
    if number > len(solids):
        raise InputError("cad.body", f"the file has {len(solids)} solid(s), not {number}")
    solid = solids[number - 1]
    mesh = checked_mesh(Path(path), solid.label, solid.vertices, solid.faces)
    return solid_outline(mesh.triangles, options, scale, unit_name)
