"""Documented node parameters as data, ROS-free: what each parameter is and the checks that refuse values.

A spec holds the name, the default (whose type is the parameter's), the meaning, the check and the
mutability; each check names the value it refuses. A node's parameters are declared once, as a frozen
dataclass whose fields are ``param(...)``: the field's name and annotation are the parameter's name and
type, its metadata the rest; ``specs_of`` reads the specs off the class (for rclpy's declarations, the
scene validation and the docs' tables) and ``from_values`` builds the typed values the node reads.

The node kit declares them to rclpy (``node_kit.parameters.declare_parameters``); the scene validation and
the generated parameter tables read the same specs without ROS.
"""

from __future__ import annotations

import copy
import dataclasses
import math
from dataclasses import dataclass
from typing import Callable, Mapping, Sequence, TypeGuard, TypeVar

from feeder_planner.errors import InputError

__all__ = [
    "Check",
    "ParameterData",
    "ParameterSpec",
    "check_value",
    "param",
    "specs_of",
    "from_values",
    "finite",
    "positive",
    "non_negative",
    "negative",
    "integer",
    "integer_at_least",
    "one_of",
    "in_range",
    "non_empty_string",
]

# What a ROS parameter holds (rclpy may hand an array back as an array.array, a Sequence like the list).
ParameterData = bool | int | float | str | list[bool] | list[int] | list[float] | list[str]
# A check takes whatever value was given (a scene's YAML, a set_parameters request) and assumes nothing of
# it: it returns a problem description, or None if the value is fine.
Check = Callable[[object], "str | None"]


@dataclass(frozen=True)
class ParameterSpec:
    """A node parameter: name, default (whose type is the parameter's), meaning, check, mutability."""

    name: str
    default: ParameterData
    description: str
    check: Check | None = None
    read_only: bool = False


def check_value(spec: ParameterSpec, value: object) -> None:
    """Raise InputError naming the parameter when ``value`` fails the spec's check."""
    problem = spec.check(value) if spec.check else None
    if problem:
        raise InputError(f"parameter {spec.name}", problem)


Parameters = TypeVar("Parameters")
Default = TypeVar("Default", bound=ParameterData)


def param(
    default: Default, description: str, check: Check | None = None, *, read_only: bool = False
) -> Default:
    """Return a dataclass field that is a node parameter: its default, meaning, check and mutability.

    As ``dataclasses.field`` is, it is typed as its default, the value the field holds; a list default is
    copied for each instance.
    """
    metadata = {"description": description, "check": check, "read_only": read_only}
    if isinstance(default, list):
        return dataclasses.field(default_factory=lambda: copy.copy(default), metadata=metadata)
    return dataclasses.field(default=default, metadata=metadata)


def specs_of(cls: type) -> tuple[ParameterSpec, ...]:
    """Return the ParameterSpecs of a parameters dataclass, in field order (base classes first)."""
    specs = []
    for f in dataclasses.fields(cls):
        factory = f.default_factory
        default = f.default if factory is dataclasses.MISSING else factory()
        if default is dataclasses.MISSING:
            raise TypeError(f"{cls.__name__}.{f.name}: a parameter is a param() field, with a default")
        meta = f.metadata
        specs.append(ParameterSpec(f.name, default, meta["description"], meta["check"], meta["read_only"]))
    return tuple(specs)


def from_values(cls: type[Parameters], values: Mapping[str, object]) -> Parameters:
    """Return the typed parameters from declared values by name (a name the class lacks is ignored)."""
    names = {f.name for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
    return cls(**{name: value for name, value in values.items() if name in names})


def _is_number(value: object) -> TypeGuard[float]:
    # bool is an int subclass, but a parameter given as true is not a number.
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def finite(value: object) -> str | None:
    """Accept any finite number."""
    return None if _is_number(value) else f"must be a finite number, got {value!r}"


def positive(value: object) -> str | None:
    """Accept a finite number > 0."""
    return None if _is_number(value) and value > 0 else f"must be a finite number > 0, got {value!r}"


def non_negative(value: object) -> str | None:
    """Accept a finite number >= 0."""
    return None if _is_number(value) and value >= 0 else f"must be a finite number >= 0, got {value!r}"


def negative(value: object) -> str | None:
    """Accept a finite number < 0."""
    return None if _is_number(value) and value < 0 else f"must be a finite number < 0, got {value!r}"


def integer(value: object) -> str | None:
    """Accept any integer (not a bool)."""
    return (
        None
        if isinstance(value, int) and not isinstance(value, bool)
        else f"must be an integer, got {value!r}"
    )


def integer_at_least(low: int) -> Check:
    """Return a check for an integer >= ``low``."""

    def check(value: object) -> str | None:
        ok = isinstance(value, int) and not isinstance(value, bool) and value >= low
        return None if ok else f"must be an integer >= {low}, got {value!r}"

    return check


def one_of(choices: Sequence[str]) -> Check:
    """Return a check for one of a closed set of words."""

    def check(value: object) -> str | None:
        return None if value in choices else f"must be one of {', '.join(choices)}, got {value!r}"

    return check


def in_range(
    low: float, high: float, *, include_low: bool = True, include_high: bool = True, unit: str = ""
) -> Check:
    """Return a check for a finite number in an interval; the message states which bounds are open."""
    left, right = "[" if include_low else "(", "]" if include_high else ")"
    suffix = f" {unit}" if unit else ""

    def check(value: object) -> str | None:
        ok = (
            _is_number(value)
            and (value >= low if include_low else value > low)
            and (value <= high if include_high else value < high)
        )
        return (
            None
            if ok
            else f"must be a finite number in {left}{low:.6g}, {high:.6g}{right}{suffix}, got {value!r}"
        )

    return check


def non_empty_string(what: str) -> Check:
    """Return a check for a non-empty string; ``what`` says what it must name."""

    def check(value: object) -> str | None:
        return None if isinstance(value, str) and value else f"must name {what}"

    return check
