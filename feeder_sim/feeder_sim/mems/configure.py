"""The MEMS field array's scene built from its parameters, ROS-free: what configure loads and checks.

Every problem names the parameter (``parameter part_files[1]``), so that a bad file fails the lifecycle
configure transition with one line; the node only wires the result to its streams.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from feeder_planner.errors import InputError
from feeder_planner.fields_io import load_yaml_mapping
from feeder_planner.mems import CombinedField, ProgramStep, program_from_mapping
from feeder_planner.parts import Part, load_part, part_document
from feeder_sim.mems.bodies import Body
from feeder_sim.mems.parameters import MemsParameters
from feeder_sim.mems.scene import Scene, random_poses
from feeder_sim.mems.spawning import ArrayParts

__all__ = ["ConfiguredScene", "configure_scene"]


@dataclass
class ConfiguredScene:
    """The scene, its parts' names and part documents (for ~/parts), their initial poses and part files."""

    scene: Scene
    names: list[str]
    documents: list[dict[str, Any]]
    initial: np.ndarray
    sources: list[str] = field(default_factory=list)

    def parts(self) -> ArrayParts:
        """Return the array's parts as configured (what ~/spawn_part and ~/remove_part change)."""
        return ArrayParts(self.scene, self.names, self.documents, self.initial, self.sources)


def configure_scene(p: MemsParameters) -> ConfiguredScene:
    """Load the parts and the program named by the parameters ``p`` and build the scene.

    Raises InputError naming the parameter (part_files[i], initial_poses, program_file, friction).
    """
    parts: list[Part] = []
    documents: list[dict[str, Any]] = []
    sources: list[str] = []
    for index, path in enumerate(p.part_files):
        if not path:
            continue
        try:
            parts.append(load_part(path))
            documents.append(part_document(path))  # a CAD part's outline as read (what ~/parts publishes)
            sources.append(path)
        except InputError as error:
            raise InputError(f"parameter part_files[{index}]", str(error)) from None
    poses = list(p.initial_poses)
    if poses in ([], [0.0]):
        poses = random_poses(len(parts), p.placement_radius, p.seed).ravel().tolist()
    if len(poses) != 3 * len(parts) or not all(
        isinstance(v, (int, float)) and math.isfinite(v) for v in poses
    ):
        raise InputError(
            "parameter initial_poses",
            f"needs 3 finite numbers per part ({3 * len(parts)}), got {len(poses)}",
        )
    program: tuple[ProgramStep, ...]
    if p.program_file:
        try:
            program = program_from_mapping(load_yaml_mapping(p.program_file))
        except InputError as error:
            raise InputError("parameter program_file", str(error.with_source(p.program_file))) from None
    else:
        program = (ProgramStep(CombinedField(p.default_delta), math.inf),)
    if p.friction != 0.0 and p.fidelity != "dynamic":
        raise InputError(
            "parameter friction",
            f"Coulomb friction acts only in the dynamic fidelity; fidelity is {p.fidelity!r} "
            "(leave friction 0 or choose dynamic)",
        )
    initial = np.array(poses, float).reshape(-1, 3)
    nx, ny = p.array_size
    scene = Scene(
        [Body(part, pose.copy()) for part, pose in zip(parts, initial, strict=True)],
        program,
        p.fidelity,
        array=(nx, ny, p.pitch),
        directions=p.directions,
        damping=p.damping,
        friction=p.friction,
    )
    names = [
        doc["name"] if isinstance(doc.get("name"), str) else f"part{i}" for i, doc in enumerate(documents)
    ]
    return ConfiguredScene(scene, names, documents, initial, sources)
