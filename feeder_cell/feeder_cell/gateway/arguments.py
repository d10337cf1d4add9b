"""Method arguments from OPC UA clients, checked before anything reaches a device; errors name the argument.

ROS-free: an argument arrives as its value and OPC UA built-in type name (``Argument``). This module holds
what every check shares: the count of arguments and the readers of one argument by its expected type.
Each kind's own check (``kinds.<kind>``, its profile's ``action.check``) reads its arguments with them and
returns the kind's goal, or raises ``ArgumentError`` with the OPC UA status code a PLC sees
(``BadArgumentsMissing``, ``BadTooManyArguments``, ``BadTypeMismatch``, ``BadInvalidArgument``), the
argument's index and a message naming it.

Types are matched exactly, everywhere: an argument's variant must have the built-in type its Argument
declares (a UInt32 argument takes a UInt32 variant, not an Int32 or Int64 one; a Double argument takes a
Double, whatever its value, 3.0 included, and no Float or integer), and an array argument an array of that
type. The one exception is an empty array argument, which may arrive as an empty (Null) variant. OPC 10000-4
(5.12.2.4, Call: inputArgumentResults) names Bad_TypeMismatch for an argument of the wrong data type;
the server reports it in the argument's result under Bad_InvalidArgument for the call.
"""

from __future__ import annotations

import math
from typing import cast

from feeder_cell.gateway.spec import Argument, MethodSpec
from feeder_planner.errors import FeederError

__all__ = [
    "Argument",
    "ArgumentError",
    "UINT32_MAX",
    "check_count",
    "read_integer",
    "read_number",
    "read_numbers",
    "read_string",
]

UINT32_MAX = 2**32 - 1


class ArgumentError(FeederError):
    """A method argument the gateway refuses: the status code, the argument (index, -1: the call) and why."""

    def __init__(self, status: str, index: int, message: str) -> None:
        self.status = status
        self.index = index
        self.message = message
        super().__init__(message)


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


def _scalar(arg: Argument, index: int, name: str) -> object:
    if arg.array or isinstance(arg.value, list):
        raise ArgumentError(
            "BadTypeMismatch", index, f"{name}: expected a scalar, got an array of {arg.type}"
        )
    return arg.value


def read_integer(arg: Argument, index: int, name: str, declared: str = "UInt32") -> int:
    """Read an integer argument of the declared built-in type; ``name`` and ``index`` go into the error."""
    value = _scalar(arg, index, name)
    if arg.type != declared or isinstance(value, bool) or not isinstance(value, int):
        raise ArgumentError(
            "BadTypeMismatch", index, f"{name}: expected a {declared}, got {arg.type} {value!r}"
        )
    return value


def read_number(arg: Argument, index: int, name: str) -> float:
    """Read a finite Double."""
    value = _scalar(arg, index, name)
    if arg.type != "Double" or isinstance(value, bool):
        raise ArgumentError("BadTypeMismatch", index, f"{name}: expected a Double, got {arg.type} {value!r}")
    number = float(cast(float, value))  # a Double variant holds a float
    if not math.isfinite(number):
        raise ArgumentError("BadInvalidArgument", index, f"{name}: must be finite, got {value!r}")
    return number


def read_numbers(arg: Argument, index: int, name: str) -> tuple[float, ...]:
    """Read an array of finite Doubles; an empty variant (Null) is the empty array."""
    if arg.type == "Null" or arg.value is None:
        return ()
    if not isinstance(arg.value, list) or arg.type != "Double":
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


def read_string(arg: Argument, index: int, name: str) -> str:
    """Read a String argument."""
    value = _scalar(arg, index, name)
    if arg.type != "String" or not isinstance(value, str):
        raise ArgumentError("BadTypeMismatch", index, f"{name}: expected a String, got {arg.type} {value!r}")
    return value
