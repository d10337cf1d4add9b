"""Conversions between feeder_msgs field programs (FieldProgram, FieldSpec) and the mechanics."""

from __future__ import annotations

import math
from typing import Any

from feeder_planner.errors import InputError
from feeder_planner.mems.fields import (
    CombinedField,
    ConstantField,
    Field,
    ProgramStep,
    QuadraticField,
    RadialField,
    SqueezeField,
    field_from_mapping,
)


def field_spec_to_mapping(spec: Any) -> dict[str, Any]:
    """The parameters a FieldSpec message carries for its type, as a field mapping."""
    kind = spec.type
    center = [spec.center_x, spec.center_y]
    strength = spec.strength if spec.strength != 0.0 else 1.0
    if kind == "radial":
        return {"type": kind, "center": center, "strength": strength}
    if kind == "constant":
        return {"type": kind, "force": [spec.force_x, spec.force_y]}
    if kind == "combined":
        return {"type": kind, "delta": spec.delta, "center": center, "strength": strength}
    if kind == "squeeze":
        return {"type": kind, "center": center, "angle": spec.angle, "strength": strength}
    if kind == "quadratic":
        return {"type": kind, "center": center, "k": [spec.k1, spec.k2], "angle": spec.angle}
    return {"type": kind}


def program_from_msg(msg: Any, field: str = "program") -> tuple[ProgramStep, ...]:
    """Validate a FieldProgram message; errors name e.g. ``program.steps[1].delta``."""
    if len(msg.steps) == 0:
        raise InputError(f"{field}.steps", "a field program needs at least one step")
    steps = []
    for i, spec in enumerate(msg.steps):
        where = f"{field}.steps[{i}]"
        duration = spec.duration
        if math.isnan(duration) or duration < 0:
            raise InputError(f"{where}.duration", f"must be >= 0 (0 or inf: forever), got {duration!r}")
        try:
            built = field_from_mapping(field_spec_to_mapping(spec), where)
        except InputError as error:
            raise InputError(error.field, error.problem) from None
        steps.append(ProgramStep(built, math.inf if duration == 0 else float(duration)))
    return tuple(steps)


def fill_field_spec(spec: Any, step: ProgramStep) -> Any:
    """Write a ProgramStep into a FieldSpec message (inverse of program_from_msg)."""
    f: Field = step.field
    spec.type = f.to_dict()["type"]
    if isinstance(f, (RadialField, CombinedField, SqueezeField, QuadraticField)):
        spec.center_x, spec.center_y = float(f.center[0]), float(f.center[1])
    if isinstance(f, (RadialField, CombinedField, SqueezeField)):
        spec.strength = float(f.strength)
    if isinstance(f, CombinedField):
        spec.delta = float(f.delta)
    if isinstance(f, (SqueezeField, QuadraticField)):
        spec.angle = float(f.angle)
    if isinstance(f, QuadraticField):
        spec.k1, spec.k2 = float(f.k[0]), float(f.k[1])
    if isinstance(f, ConstantField):
        spec.force_x, spec.force_y = float(f.force[0]), float(f.force[1])
    spec.duration = 0.0 if math.isinf(step.duration) else float(step.duration)
    return spec
