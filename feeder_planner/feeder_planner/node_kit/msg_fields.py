"""Conversions between feeder_msgs field programs (FieldProgram, FieldSpec) and the mechanics.

A FieldSpec message carries every parameter of every field type; which ones a type reads is the
mechanics' one definition (``field_parameters``), and each parameter maps to its message fields
below, in both directions.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any, Protocol, TypeAlias, TypeVar, cast

from feeder_planner.errors import InputError
from feeder_planner.mems.fields import ProgramStep, check_field_type, field_from_mapping, field_parameters
from feeder_planner.node_kit.request_limits import MAX_PROGRAM_STEPS, check_count

__all__ = [
    "FieldSpecLike",
    "FieldProgramLike",
    "field_spec_to_mapping",
    "program_from_msg",
    "fill_field_spec",
]


class FieldSpecLike(Protocol):
    """The fields of feeder_msgs/FieldSpec this module reads and writes (lengths in m, angles in rad)."""

    type: str
    delta: float
    center_x: float
    center_y: float
    strength: float
    angle: float
    k1: float
    k2: float
    force_x: float
    force_y: float
    duration: float  # s; 0 or inf: forever


class FieldProgramLike(Protocol):
    """The field of feeder_msgs/FieldProgram this module reads."""

    @property
    def steps(self) -> Sequence[FieldSpecLike]:
        """Return the program's steps in order."""
        ...


Spec = TypeVar("Spec", bound=FieldSpecLike)


# A field parameter's value: a number, or a pair ([x, y] in a mapping, a tuple in a Field).
FieldValue: TypeAlias = float | Sequence[float]


def _pair(value: FieldValue) -> tuple[float, float]:
    """Return a two-element parameter (center, force, k: the name says which) as two floats."""
    pair = cast(Sequence[float], value)
    return float(pair[0]), float(pair[1])


def _number(value: FieldValue) -> float:
    """Return a one-number parameter (strength, delta, angle: the name says which) as a float."""
    return float(cast(float, value))


# Parameter name (as in the field mapping) -> its value read from a message.
_READ: dict[str, Callable[[FieldSpecLike], FieldValue]] = {
    "center": lambda s: [s.center_x, s.center_y],
    # a message leaves strength 0 when it does not set it: the default strength 1
    "strength": lambda s: s.strength if s.strength != 0.0 else 1.0,
    "force": lambda s: [s.force_x, s.force_y],
    "delta": lambda s: s.delta,
    "angle": lambda s: s.angle,
    "k": lambda s: [s.k1, s.k2],
}


def _write(spec: FieldSpecLike, name: str, value: FieldValue) -> None:
    """Write one field parameter into its message fields."""
    if name == "center":
        spec.center_x, spec.center_y = _pair(value)
    elif name == "force":
        spec.force_x, spec.force_y = _pair(value)
    elif name == "k":
        spec.k1, spec.k2 = _pair(value)
    elif name == "strength":
        spec.strength = _number(value)
    elif name == "delta":
        spec.delta = _number(value)
    elif name == "angle":
        spec.angle = _number(value)
    else:  # pragma: no cover - a field parameter without message fields is a programming error
        raise KeyError(name)


def field_spec_to_mapping(spec: FieldSpecLike) -> dict[str, Any]:
    """Return the parameters a FieldSpec message carries for its type, as a field mapping.

    An unknown type gives just {'type': ...}, which ``field_from_mapping`` refuses naming the type.
    """
    try:
        kind = check_field_type(spec.type)
    except InputError:
        return {"type": spec.type}
    return {"type": kind, **{name: _READ[name](spec) for name in field_parameters(kind)}}


def program_from_msg(msg: FieldProgramLike, field: str = "program") -> tuple[ProgramStep, ...]:
    """Return the program of a FieldProgram message, validated.

    Errors name the step and parameter, e.g. ``program.steps[1].delta``.
    """
    if len(msg.steps) == 0:
        raise InputError(f"{field}.steps", "a field program needs at least one step")
    check_count(len(msg.steps), MAX_PROGRAM_STEPS, f"{field}.steps", "steps")
    steps = []
    for i, spec in enumerate(msg.steps):
        where = f"{field}.steps[{i}]"
        duration = spec.duration
        if math.isnan(duration) or duration < 0:
            raise InputError(f"{where}.duration", f"must be >= 0 (0 or inf: forever), got {duration!r}")
        built = field_from_mapping(field_spec_to_mapping(spec), where)
        steps.append(ProgramStep(built, math.inf if duration == 0 else float(duration)))
    return tuple(steps)


def fill_field_spec(spec: Spec, step: ProgramStep) -> Spec:
    """Write a ProgramStep into a FieldSpec message and return it (inverse of program_from_msg)."""
    f = step.field
    spec.type = f.kind
    for name in field_parameters(f.kind):
        _write(spec, name, getattr(f, name))
    spec.duration = 0.0 if math.isinf(step.duration) else float(step.duration)
    return spec
