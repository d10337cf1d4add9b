"""ROS parameters as the Foxglove protocol names and carries them.

A parameter is named ``/namespace/node.parameter`` (the node's fully qualified name, a dot, the
parameter's name), as the ROS foxglove_bridge names them; node names cannot hold a dot, so the first dot
splits. Values travel as JSON: doubles with the type hint ``float64`` (so 2.0 stays a double in a
JavaScript client), double arrays with ``float64_array``, byte arrays base64 with ``byte_array``.
A value a client sets is converted to the type the node declared the parameter with (a JSON 5 for a
double parameter is 5.0), so the node judges the value, not a JSON accident of its type.
"""

from __future__ import annotations

import base64
import binascii
import math
from typing import Callable, TypeGuard, TypeVar

from rcl_interfaces.msg import ParameterType, ParameterValue

from feeder_cell.bridge.protocol import ParameterEntry

__all__ = ["split_name", "to_json", "from_json", "TYPE_NAMES"]

Element = TypeVar("Element")

TYPE_NAMES = {
    ParameterType.PARAMETER_NOT_SET: "not set",
    ParameterType.PARAMETER_BOOL: "bool",
    ParameterType.PARAMETER_INTEGER: "integer",
    ParameterType.PARAMETER_DOUBLE: "double",
    ParameterType.PARAMETER_STRING: "string",
    ParameterType.PARAMETER_BYTE_ARRAY: "byte array",
    ParameterType.PARAMETER_BOOL_ARRAY: "bool array",
    ParameterType.PARAMETER_INTEGER_ARRAY: "integer array",
    ParameterType.PARAMETER_DOUBLE_ARRAY: "double array",
    ParameterType.PARAMETER_STRING_ARRAY: "string array",
}
INT64 = (-(2**63), 2**63 - 1)


def split_name(name: str) -> tuple[str, str] | None:
    """Return (node, parameter) of ``/ns/node.param``, or None when the name is not of that form."""
    node, dot, parameter = name.partition(".")
    if not dot or not parameter or not node.startswith("/") or node.endswith("/") or len(node) < 2:
        return None
    return node, parameter


def to_json(name: str, value: ParameterValue) -> ParameterEntry:
    """Return the protocol's parameter entry of a ROS parameter value (no ``value`` when not set)."""
    kind = value.type
    entry: ParameterEntry = {"name": name}
    if kind == ParameterType.PARAMETER_BOOL:
        entry["value"] = bool(value.bool_value)
    elif kind == ParameterType.PARAMETER_INTEGER:
        entry["value"] = int(value.integer_value)
    elif kind == ParameterType.PARAMETER_DOUBLE:
        entry["value"], entry["type"] = float(value.double_value), "float64"
    elif kind == ParameterType.PARAMETER_STRING:
        entry["value"] = value.string_value
    elif kind == ParameterType.PARAMETER_BYTE_ARRAY:
        raw = b"".join(bytes(b) if isinstance(b, bytes) else bytes([b]) for b in value.byte_array_value)
        entry["value"], entry["type"] = base64.b64encode(raw).decode(), "byte_array"
    elif kind == ParameterType.PARAMETER_BOOL_ARRAY:
        entry["value"] = [bool(v) for v in value.bool_array_value]
    elif kind == ParameterType.PARAMETER_INTEGER_ARRAY:
        entry["value"] = [int(v) for v in value.integer_array_value]
    elif kind == ParameterType.PARAMETER_DOUBLE_ARRAY:
        entry["value"], entry["type"] = [float(v) for v in value.double_array_value], "float64_array"
    elif kind == ParameterType.PARAMETER_STRING_ARRAY:
        entry["value"] = list(value.string_array_value)
    return entry


def _is_int(value: object) -> TypeGuard[int]:
    return isinstance(value, int) and not isinstance(value, bool)


def _is_number(value: object) -> TypeGuard[int | float]:
    return (_is_int(value) or isinstance(value, float)) and not isinstance(value, bool)


def _integer(value: object) -> int:
    """Return a JSON number that is a whole number within int64 (JavaScript may send 3 as 3.0)."""
    if isinstance(value, float) and math.isfinite(value) and value == int(value):
        value = int(value)
    if not _is_int(value) or not INT64[0] <= value <= INT64[1]:
        raise ValueError(f"must be a whole number within int64, got {value!r}")
    return int(value)


def _double(value: object) -> float:
    if not _is_number(value):
        raise ValueError(f"must be a number, got {value!r}")
    return float(value)


def _infer(value: object, hint: str | None) -> int:
    """Return the ROS type a JSON value means when the node declared none (an undeclared parameter)."""
    if hint == "byte_array":
        return ParameterType.PARAMETER_BYTE_ARRAY
    if hint == "float64":
        return ParameterType.PARAMETER_DOUBLE
    if hint == "float64_array":
        return ParameterType.PARAMETER_DOUBLE_ARRAY
    if isinstance(value, bool):
        return ParameterType.PARAMETER_BOOL
    if _is_int(value):
        return ParameterType.PARAMETER_INTEGER
    if isinstance(value, float):
        return ParameterType.PARAMETER_DOUBLE
    if isinstance(value, str):
        return ParameterType.PARAMETER_STRING
    if isinstance(value, list) and value:
        first = _infer(value[0], None)
        return {
            ParameterType.PARAMETER_BOOL: ParameterType.PARAMETER_BOOL_ARRAY,
            ParameterType.PARAMETER_INTEGER: ParameterType.PARAMETER_INTEGER_ARRAY,
            ParameterType.PARAMETER_DOUBLE: ParameterType.PARAMETER_DOUBLE_ARRAY,
            ParameterType.PARAMETER_STRING: ParameterType.PARAMETER_STRING_ARRAY,
        }.get(first, ParameterType.PARAMETER_NOT_SET)
    raise ValueError(f"cannot be a ROS parameter value: {value!r}")


def _array(value: object, element: Callable[[object], Element]) -> list[Element]:
    if not isinstance(value, list):
        raise ValueError(f"must be an array, got {value!r}")
    out: list[Element] = []
    for i, item in enumerate(value):
        try:
            out.append(element(item))
        except ValueError as error:
            raise ValueError(f"[{i}] {error}") from None
    return out


def _bool(value: object) -> bool:
    if not isinstance(value, bool):
        raise ValueError(f"must be true or false, got {value!r}")
    return value


def _str(value: object) -> str:
    if not isinstance(value, str):
        raise ValueError(f"must be a string, got {value!r}")
    return value


def _bytes(value: object) -> list[bytes]:
    if isinstance(value, str):
        try:
            raw = base64.b64decode(value, validate=True)
        except (binascii.Error, ValueError):
            raise ValueError("must be base64 (type byte_array)") from None
        return [bytes([b]) for b in raw]
    return [bytes([b]) for b in _array(value, _byte)]


def _byte(value: object) -> int:
    byte = _integer(value)
    if not 0 <= byte <= 255:
        raise ValueError(f"must be a byte (0 to 255), got {value!r}")
    return byte


def from_json(value: object, hint: str | None, declared: int) -> ParameterValue:
    """Return the ROS value of a JSON value for a parameter declared as ``declared`` (a ParameterType).

    ``value`` None (undefined in the client) is a value that is not set: the node decides whether the
    parameter may be unset. An undeclared parameter (``declared`` NOT_SET) takes the JSON value's type.

    Raises
    ------
    ValueError
        The value cannot be of the declared type; the text says why.
    """
    result = ParameterValue()
    if value is None:
        return result  # PARAMETER_NOT_SET
    kind = declared if declared != ParameterType.PARAMETER_NOT_SET else _infer(value, hint)
    result.type = kind
    if kind == ParameterType.PARAMETER_BOOL:
        result.bool_value = _bool(value)
    elif kind == ParameterType.PARAMETER_INTEGER:
        result.integer_value = _integer(value)
    elif kind == ParameterType.PARAMETER_DOUBLE:
        result.double_value = _double(value)
    elif kind == ParameterType.PARAMETER_STRING:
        result.string_value = _str(value)
    elif kind == ParameterType.PARAMETER_BYTE_ARRAY:
        result.byte_array_value = _bytes(value)
    elif kind == ParameterType.PARAMETER_BOOL_ARRAY:
        result.bool_array_value = _array(value, _bool)
    elif kind == ParameterType.PARAMETER_INTEGER_ARRAY:
        result.integer_array_value = _array(value, _integer)
    elif kind == ParameterType.PARAMETER_DOUBLE_ARRAY:
        result.double_array_value = _array(value, _double)
    elif kind == ParameterType.PARAMETER_STRING_ARRAY:
        result.string_array_value = _array(value, _str)
    else:
        raise ValueError(f"cannot be a ROS parameter value: {value!r}")
    return result
