"""The controller's file parameters, read at start: a bad file is named by its parameter before any cycle.

``p`` is the node's parameter dictionary (``feeder_cell.controller.parameters.PARAMETERS``). Every error is
an InputError naming the parameter (``parameter orient_program_file``...), which exits 2.
"""

from __future__ import annotations

from typing import Any, Callable, TypeVar

from feeder_cell.controller.fault_schedule import FaultSchedule
from feeder_cell.experiment.arrivals import ArrivalStream, scene_arrivals, scene_seed
from feeder_cell.experiment.faults_process import scene_faults
from feeder_msgs.msg import FieldProgram, FieldSpec
from feeder_msgs.msg import Part as PartMsg
from feeder_planner.errors import InputError
from feeder_planner.fields_io import load_yaml_mapping
from feeder_planner.mems import program_from_mapping
from feeder_planner.node_kit.msg_fields import fill_field_spec
from feeder_planner.node_kit.msg_parts import part_to_msg
from feeder_planner.parts import load_part

__all__ = ["arrival_stream", "fault_schedule", "field_program", "squeeze_part"]

T = TypeVar("T")


def field_program(p: dict[str, Any]) -> FieldProgram:
    """Return the program ORIENT runs: the file's, or one combined field (orient_delta) forever."""
    program = FieldProgram(name="cell_controller")
    path = p["orient_program_file"]
    if not path:
        program.steps = [FieldSpec(type="combined", delta=p["orient_delta"], strength=1.0)]
        return program
    try:
        steps = program_from_mapping(load_yaml_mapping(path), "program")
    except InputError as error:
        raise InputError("parameter orient_program_file", str(error)) from None
    program.steps = [fill_field_spec(FieldSpec(), step) for step in steps]
    return program


def squeeze_part(p: dict[str, Any]) -> PartMsg:
    """Return the part ``squeeze_part_file`` names, for the squeeze planner's ~/plan."""
    path = p["squeeze_part_file"]
    if not path:
        raise InputError(
            "parameter squeeze_part_file", "is required with orienter squeeze (the gripper's part_file)"
        )
    try:
        load_part(path)  # checked here: a bad part is named at start, not at the first cycle
        return part_to_msg(load_yaml_mapping(path))
    except InputError as error:
        raise InputError("parameter squeeze_part_file", str(error)) from None


def arrival_stream(p: dict[str, Any], orienter: str) -> ArrivalStream | None:
    """Return the arrivals ``arrivals_file`` names (its arrivals: section and seed), or None."""
    path = p["arrivals_file"]
    if not path:
        return None
    arrivals, seed = _section(path, "arrivals_file", "arrivals", scene_arrivals)
    if arrivals.mems is not None and orienter != "mems":
        raise InputError(
            "parameter arrivals_file",
            f"arrivals.mems places parts on the MEMS array, but the orienter is {orienter}",
        )
    return ArrivalStream(arrivals, seed, p["replication"])


def fault_schedule(p: dict[str, Any]) -> FaultSchedule:
    """Return the fault processes ``faults_file`` names (its faults: section and seed); none if empty."""
    path = p["faults_file"]
    if not path:
        return FaultSchedule(())
    specs, seed = _section(path, "faults_file", "faults", scene_faults)
    return FaultSchedule(specs, seed, p["replication"])


def _section(
    path: str, parameter: str, section: str, read: Callable[[dict[str, Any]], T | None]
) -> tuple[T, int]:
    """Return a scene file's ``section:`` (``read`` validates it) and its seed; errors name ``parameter``."""
    try:
        document = load_yaml_mapping(path)
        value = read(document)
        if value is None:
            raise InputError(section, f"is missing: the file has no {section}: section")
        return value, scene_seed(document)
    except InputError as error:
        raise InputError(f"parameter {parameter}", str(error)) from None
