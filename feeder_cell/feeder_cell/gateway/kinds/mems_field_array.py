"""The MEMS field array as the gateway shows it: its parts, its methods and its counters.

Methods: RunProgram (~/run_program), LoadProgram (~/set_program), PlaceParts (~/place_parts: a new batch).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from feeder_cell.gateway.arguments import ArgumentError, check_count, read_number, read_string
from feeder_cell.gateway.spec import (
    ActionLink,
    Argument,
    ArgumentSpec,
    KindProfile,
    MethodSpec,
    ServiceLink,
    StreamLink,
    Values,
    VariableSpec,
)
from feeder_msgs.action import RunProgram
from feeder_msgs.msg import FieldProgram, FieldSpec, MemsPartStates
from feeder_msgs.srv import FieldSetProgram, MemsPlaceParts
from feeder_planner.errors import InputError
from feeder_planner.fields_io import load_yaml_mapping, yaml_mapping_from_text
from feeder_planner.mems import ProgramStep, program_from_mapping
from feeder_planner.node_kit.msg_fields import fill_field_spec
from feeder_planner.node_kit.request_limits import MAX_YAML_CHARS
from feeder_sim.mems.counters import COUNTERS

__all__ = ["PROFILE", "RunProgramGoal", "check_run_program", "check_load_program", "resolve_program"]


@dataclass(frozen=True)
class RunProgramGoal:
    """A checked RunProgram call: the program's steps (validated by the mechanics) and the limits."""

    name: str
    steps: tuple[ProgramStep, ...]
    timeout: float
    tolerance: float
    dwell: float

    def message(self) -> Any:
        """Return the ~/run_program goal."""
        program = FieldProgram(name=self.name, steps=[fill_field_spec(FieldSpec(), s) for s in self.steps])
        return RunProgram.Goal(
            program=program, timeout=self.timeout, tolerance=self.tolerance, dwell=self.dwell
        )


@dataclass(frozen=True)
class LoadProgramCall:
    """A checked LoadProgram call: the program the array runs from now on (no goal watches it)."""

    name: str
    steps: tuple[ProgramStep, ...]

    def message(self) -> Any:
        """Return the ~/set_program request."""
        steps = [fill_field_spec(FieldSpec(), s) for s in self.steps]
        return FieldSetProgram.Request(program=FieldProgram(name=self.name, steps=steps))


def check_load_program(spec: MethodSpec, args: list[Argument], program_dir: str) -> LoadProgramCall:
    """Check LoadProgram(Program): a program file of program_dir by name, or inline YAML."""
    check_count(spec, args)
    try:
        name, steps = resolve_program(read_string(args[0], 0, "Program"), program_dir)
    except InputError as error:
        raise ArgumentError("BadInvalidArgument", 0, str(error)) from None
    return LoadProgramCall(name, steps)


@dataclass(frozen=True)
class NewBatchCall:
    """PlaceParts: every part back to its initial pose (a new batch arrives on the array)."""

    def message(self) -> Any:
        """Return the ~/place_parts request."""
        return MemsPlaceParts.Request(reset=True)


def _check_new_batch(spec: MethodSpec, args: list[Argument]) -> NewBatchCall:
    check_count(spec, args)
    return NewBatchCall()


def resolve_program(text: str, program_dir: str) -> tuple[str, tuple[ProgramStep, ...]]:
    """Return (name, steps) of a Program argument: an inline YAML program or a file of ``program_dir``.

    A file name may not leave ``program_dir`` (no absolute paths, no ``..``): a PLC names programs, it
    does not read the gateway's file system.
    """
    field = "Program"
    stripped = text.strip()
    if not stripped:
        raise InputError(
            field, "is empty: name a program file of program_dir or give an inline '{steps: [...]}'"
        )
    if stripped.startswith("{"):
        # A PLC string is unbounded: the request layer's size, alias and depth bounds apply to it too.
        if len(stripped) > MAX_YAML_CHARS:
            raise InputError(field, f"inline program: {len(stripped)} characters, at most {MAX_YAML_CHARS}")
        try:
            document = yaml_mapping_from_text(stripped, "inline program", field)
        except InputError as error:
            raise InputError(field, f"inline program: {error.problem}") from None
        return "inline", program_from_mapping(document, field)
    if not program_dir:
        raise InputError(field, f"names a file ({stripped!r}), but the gateway's program_dir is empty")
    relative = Path(stripped)
    if relative.is_absolute() or ".." in relative.parts:
        raise InputError(field, f"must be a file name inside program_dir, got {stripped!r}")
    path = Path(program_dir) / relative
    if not path.suffix:
        path = path.with_suffix(".yaml")
    if not path.is_file():
        raise InputError(field, f"no program {relative.as_posix()!r} in program_dir {program_dir}")
    try:
        steps = program_from_mapping(load_yaml_mapping(path), field)
    except InputError as error:
        raise InputError(field, str(error.with_source(relative.as_posix()))) from None
    return relative.as_posix(), steps


def check_run_program(spec: MethodSpec, args: list[Argument], program_dir: str) -> RunProgramGoal:
    """Check RunProgram(Program, Timeout, Tolerance, Dwell); the program is parsed and validated here."""
    check_count(spec, args)
    text = read_string(args[0], 0, "Program")
    try:
        name, steps = resolve_program(text, program_dir)
    except InputError as error:
        raise ArgumentError("BadInvalidArgument", 0, str(error)) from None
    timeout = read_number(args[1], 1, "Timeout")
    if timeout <= 0:
        raise ArgumentError("BadInvalidArgument", 1, f"Timeout: must be > 0 s, got {timeout!r}")
    tolerance = read_number(args[2], 2, "Tolerance")
    if tolerance < 0:
        raise ArgumentError(
            "BadInvalidArgument", 2, f"Tolerance: must be >= 0 (0: device default), got {tolerance!r}"
        )
    dwell = read_number(args[3], 3, "Dwell")
    if dwell < 0:
        raise ArgumentError(
            "BadInvalidArgument", 3, f"Dwell: must be >= 0 s (0: device default), got {dwell!r}"
        )
    return RunProgramGoal(name, steps, timeout, tolerance, dwell)


def _parts(msg: Any) -> Values:
    return {
        "Signals.PartNames": [p.name for p in msg.parts],
        "Signals.PartOrientations": [float(p.theta) for p in msg.parts],
        "Signals.PartPositions": [
            float(c) for p in msg.parts for c in (p.pose.position.x, p.pose.position.y)
        ],
    }


def _feedback(fb: Any) -> Values:
    return {
        "Command.Feedback.Time": float(fb.time),
        "Command.Feedback.Settled": [bool(s) for s in fb.settled],
        "Command.Feedback.EquilibriumDistance": [float(d) for d in fb.equilibrium_distance],
    }


def _result(result: Any) -> Values:
    return {
        "Command.Result.Settled": bool(result.settled),
        "Command.Result.Equilibrium": [int(e) for e in result.equilibrium],
        "Command.Result.EquilibriumDistance": [float(d) for d in result.equilibrium_distance],
    }


PROFILE = KindProfile(
    counters=COUNTERS,
    signals=(
        VariableSpec("Signals.PartNames", "String", "parts on the array (~/part_states)", array=True),
        VariableSpec(
            "Signals.PartOrientations",
            "Double",
            "orientation theta of each part, rad in [0, 2 pi)",
            array=True,
            unit="C81",
        ),
        VariableSpec(
            "Signals.PartPositions",
            "Double",
            "centroid (x, y) of each part, m, flattened pairs",
            array=True,
            unit="MTR",
        ),
    ),
    streams=(StreamLink("part_states", MemsPartStates, _parts),),
    action=ActionLink(
        method=MethodSpec(
            "RunProgram",
            "start ~/run_program: run a field program until every part settled or Timeout",
            (
                ArgumentSpec(
                    "Program",
                    "String",
                    "a program file name in the gateway's program_dir, or an inline YAML program "
                    "starting with '{' (e.g. {steps: [{field: {type: radial, center: [0, 0]}}]})",
                ),
                ArgumentSpec("Timeout", "Double", "s of the device's clock, > 0"),
                ArgumentSpec(
                    "Tolerance", "Double", "settled below this change (m and rad), >= 0 (0: device default)"
                ),
                ArgumentSpec(
                    "Dwell", "Double", "s the change must stay below Tolerance, >= 0 (0: device default)"
                ),
            ),
        ),
        check=lambda spec, args, context: check_run_program(spec, args, context.program_dir),
        action_type=RunProgram,
        action_name="run_program",
        feedback=(
            VariableSpec(
                "Command.Feedback.Time", "Double", "s of node clock since the program started", unit="SEC"
            ),
            VariableSpec("Command.Feedback.Settled", "Boolean", "per part: settled", array=True),
            VariableSpec(
                "Command.Feedback.EquilibriumDistance",
                "Double",
                "per part: rad to the nearest predicted equilibrium",
                array=True,
                unit="C81",
            ),
        ),
        result=(
            VariableSpec("Command.Result.Settled", "Boolean", "every part settled"),
            VariableSpec(
                "Command.Result.Equilibrium",
                "Int32",
                "per part: predicted equilibrium reached (-1 none)",
                array=True,
            ),
            VariableSpec(
                "Command.Result.EquilibriumDistance",
                "Double",
                "per part: rad to that equilibrium",
                array=True,
                unit="C81",
            ),
        ),
        feedback_values=_feedback,
        result_values=_result,
    ),
    services=(
        ServiceLink(
            MethodSpec(
                "PlaceParts",
                "infeed: a new batch, every part back to its initial pose (~/place_parts reset)",
            ),
            lambda spec, args, _context: _check_new_batch(spec, args),
            MemsPlaceParts,
            "place_parts",
        ),
        ServiceLink(
            MethodSpec(
                "LoadProgram",
                "load a field program by name (a file in program_dir) or inline YAML; it runs from now "
                "on, no goal watches it (~/set_program); RunProgram runs one and waits for the parts",
                (ArgumentSpec("Program", "String", "a file in program_dir, or inline YAML starting with {"),),
            ),
            lambda spec, args, context: check_load_program(spec, args, context.program_dir),
            FieldSetProgram,
            "set_program",
        ),
    ),
)
