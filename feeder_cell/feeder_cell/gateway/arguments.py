"""Method arguments from OPC UA clients, checked before anything reaches a device; errors name the argument.

ROS-free: an argument arrives as its value and OPC UA built-in type name; a check returns a plain goal
(``FeedPartGoal``, ``RunProgramGoal``, ``FollowPathGoal``) or raises ``ArgumentError`` with the OPC UA status
code a PLC sees (``BadArgumentsMissing``, ``BadTooManyArguments``, ``BadTypeMismatch``,
``BadInvalidArgument``), the argument's index and a message naming it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from feeder_cell.gateway.layout import MethodSpec
from feeder_planner.errors import FeederError, InputError
from feeder_planner.fields_io import load_yaml_mapping, yaml_mapping_from_text
from feeder_planner.mems import ProgramStep, program_from_mapping
from feeder_planner.node_kit.request_limits import MAX_YAML_CHARS

__all__ = [
    "Argument",
    "ArgumentError",
    "FeedPartGoal",
    "RunProgramGoal",
    "FollowPathGoal",
    "check_count",
    "check_feed_part",
    "check_run_program",
    "check_follow_path",
    "resolve_program",
]

INTEGER_TYPES = ("SByte", "Byte", "Int16", "UInt16", "Int32", "UInt32", "Int64", "UInt64")
FLOAT_TYPES = ("Float", "Double")
UINT32_MAX = 2**32 - 1


@dataclass(frozen=True)
class Argument:
    """One input argument as the client sent it: the value (a list for an array) and its built-in type."""

    value: Any
    type: str  # VariantType name, e.g. Double, UInt32, String; "Null" for an empty variant
    array: bool = False


class ArgumentError(FeederError):
    """A method argument the gateway refuses: the status code, the argument (index, -1: the call) and why."""

    def __init__(self, status: str, index: int, message: str) -> None:
        self.status = status
        self.index = index
        self.message = message
        super().__init__(message)


@dataclass(frozen=True)
class FeedPartGoal:
    """A checked FeedPart call."""

    max_throws: int
    timeout: float


@dataclass(frozen=True)
class RunProgramGoal:
    """A checked RunProgram call: the program's steps (validated by the mechanics) and the limits."""

    name: str
    steps: tuple[ProgramStep, ...]
    timeout: float
    tolerance: float
    dwell: float


@dataclass(frozen=True)
class FollowPathGoal:
    """A checked FollowPath call: exactly one of the waypoint lists is non-empty."""

    tilt: tuple[float, ...]  # flattened pairs
    gravity: tuple[tuple[float, float, float], ...]


def check_count(spec: MethodSpec, args: list[Argument]) -> None:
    """Refuse a call with fewer or more arguments than the method takes, naming them."""
    expected = ", ".join(f"{a.name} ({a.type}{'[]' if a.array else ''})" for a in spec.inputs) or "none"
    if len(args) < len(spec.inputs):
        missing = ", ".join(a.name for a in spec.inputs[len(args) :])
        raise ArgumentError("BadArgumentsMissing", -1, f"{spec.name}: missing {missing}; it takes {expected}")
    if len(args) > len(spec.inputs):
        raise ArgumentError(
            "BadTooManyArguments",
            len(spec.inputs),
            f"{spec.name}: {len(args)} arguments given; it takes {expected}",
        )


def _scalar(arg: Argument, index: int, name: str) -> Any:
    if arg.array or isinstance(arg.value, list):
        raise ArgumentError(
            "BadTypeMismatch", index, f"{name}: expected a scalar, got an array of {arg.type}"
        )
    return arg.value


def _integer(arg: Argument, index: int, name: str) -> int:
    value = _scalar(arg, index, name)
    if arg.type not in INTEGER_TYPES or isinstance(value, bool):
        raise ArgumentError(
            "BadTypeMismatch", index, f"{name}: expected an integer (UInt32), got {arg.type} {value!r}"
        )
    return int(value)


def _number(arg: Argument, index: int, name: str) -> float:
    value = _scalar(arg, index, name)
    if arg.type not in (*FLOAT_TYPES, *INTEGER_TYPES) or isinstance(value, bool):
        raise ArgumentError(
            "BadTypeMismatch", index, f"{name}: expected a number (Double), got {arg.type} {value!r}"
        )
    number = float(value)
    if not math.isfinite(number):
        raise ArgumentError("BadInvalidArgument", index, f"{name}: must be finite, got {value!r}")
    return number


def _numbers(arg: Argument, index: int, name: str) -> tuple[float, ...]:
    if arg.type == "Null" or arg.value is None:
        return ()
    if not isinstance(arg.value, list) or arg.type not in (*FLOAT_TYPES, *INTEGER_TYPES):
        raise ArgumentError(
            "BadTypeMismatch", index, f"{name}: expected an array of Double, got {arg.type} {arg.value!r}"
        )
    out = []
    for i, value in enumerate(arg.value):
        number = float(value)
        if not math.isfinite(number):
            raise ArgumentError("BadInvalidArgument", index, f"{name}[{i}]: must be finite, got {value!r}")
        out.append(number)
    return tuple(out)


def _string(arg: Argument, index: int, name: str) -> str:
    value = _scalar(arg, index, name)
    if arg.type != "String" or not isinstance(value, str):
        raise ArgumentError("BadTypeMismatch", index, f"{name}: expected a String, got {arg.type} {value!r}")
    return value


def check_feed_part(spec: MethodSpec, args: list[Argument]) -> FeedPartGoal:
    """Check FeedPart(MaxThrows, Timeout)."""
    check_count(spec, args)
    max_throws = _integer(args[0], 0, "MaxThrows")
    if not 1 <= max_throws <= UINT32_MAX:
        raise ArgumentError("BadInvalidArgument", 0, f"MaxThrows: must be >= 1 (a UInt32), got {max_throws}")
    timeout = _number(args[1], 1, "Timeout")
    if timeout < 0:
        raise ArgumentError(
            "BadInvalidArgument", 1, f"Timeout: must be >= 0 s (0: no limit), got {timeout!r}"
        )
    return FeedPartGoal(max_throws, timeout)


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
    text = _string(args[0], 0, "Program")
    try:
        name, steps = resolve_program(text, program_dir)
    except InputError as error:
        raise ArgumentError("BadInvalidArgument", 0, str(error)) from None
    timeout = _number(args[1], 1, "Timeout")
    if timeout <= 0:
        raise ArgumentError("BadInvalidArgument", 1, f"Timeout: must be > 0 s, got {timeout!r}")
    tolerance = _number(args[2], 2, "Tolerance")
    if tolerance < 0:
        raise ArgumentError(
            "BadInvalidArgument", 2, f"Tolerance: must be >= 0 (0: device default), got {tolerance!r}"
        )
    dwell = _number(args[3], 3, "Dwell")
    if dwell < 0:
        raise ArgumentError(
            "BadInvalidArgument", 3, f"Dwell: must be >= 0 s (0: device default), got {dwell!r}"
        )
    return RunProgramGoal(name, steps, timeout, tolerance, dwell)


def check_follow_path(spec: MethodSpec, args: list[Argument]) -> FollowPathGoal:
    """Check FollowPath(TiltWaypoints, GravityWaypoints): one kind of waypoint, whole pairs or triples."""
    check_count(spec, args)
    tilt = _numbers(args[0], 0, "TiltWaypoints")
    flat = _numbers(args[1], 1, "GravityWaypoints")
    if bool(tilt) == bool(flat):
        which = "both are given" if tilt else "both are empty"
        raise ArgumentError(
            "BadInvalidArgument",
            0 if tilt else 1,
            f"TiltWaypoints, GravityWaypoints: give exactly one ({which})",
        )
    if tilt and len(tilt) % 2:
        raise ArgumentError(
            "BadInvalidArgument", 0, f"TiltWaypoints: must be (tilt_x, tilt_y) pairs, got {len(tilt)} numbers"
        )
    if flat and len(flat) % 3:
        raise ArgumentError(
            "BadInvalidArgument", 1, f"GravityWaypoints: must be (x, y, z) triples, got {len(flat)} numbers"
        )
    gravity = tuple((flat[i], flat[i + 1], flat[i + 2]) for i in range(0, len(flat), 3))
    for i, g in enumerate(gravity):
        if math.hypot(*g) == 0.0:
            raise ArgumentError(
                "BadInvalidArgument", 1, f"GravityWaypoints[{i}]: a zero vector has no direction"
            )
    return FollowPathGoal(tilt, gravity)
