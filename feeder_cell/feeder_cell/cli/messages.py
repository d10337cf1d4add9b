"""ROS messages from YAML and back, for ``feeder call`` and ``feeder send-goal``.

What ``ros2 service call`` and ``ros2 action send_goal`` do with ``rosidl_runtime_py``, which the
registry's wheels lack.

Every problem is an InputError naming the field (``VALUES.names[2]``): an unknown type, a field the
message does not have, a value rclpy's setters refuse.
"""

from __future__ import annotations

import importlib
import re
from typing import Any

from feeder_planner.errors import InputError
from feeder_planner.fields_io import yaml_mapping_from_text

__all__ = ["import_type", "fill", "from_yaml", "to_plain"]

TYPE_NAME = re.compile(r"(\w+)/(msg|srv|action)/(\w+)")


def import_type(name: str, kind: str, field: str = "TYPE") -> Any:
    """Import ``package/kind/Name`` (e.g. ``feeder_msgs/srv/InjectFault``); refuse another kind."""
    match = TYPE_NAME.fullmatch(name.strip())
    if match is None or match.group(2) != kind:
        raise InputError(field, f"expected a {kind} type such as feeder_msgs/{kind}/Name, got {name!r}")
    package, _, type_name = match.groups()
    try:
        module = importlib.import_module(f"{package}.{kind}")
        return getattr(module, type_name)
    except (ImportError, AttributeError):
        raise InputError(field, f"no {kind} type {name} in this environment") from None


def _element_class(msg: Any, key: str) -> Any | None:
    """Return the message class of a sequence field's elements (None for basic values)."""
    index = list(msg.get_fields_and_field_types()).index(key)
    slot = msg.SLOT_TYPES[index]
    value_type = getattr(slot, "value_type", None)
    namespaces = getattr(value_type, "namespaces", None)
    if value_type is None or not namespaces:
        return None
    return getattr(importlib.import_module(".".join(namespaces)), value_type.name)


def fill(msg: Any, values: dict[str, Any], field: str) -> Any:
    """Set ``msg``'s fields from a mapping (nested messages from nested mappings); return ``msg``."""
    fields = msg.get_fields_and_field_types()
    for key, value in values.items():
        where = f"{field}.{key}"
        if key not in fields:
            raise InputError(where, f"no such field; the fields are {', '.join(fields) or '(none)'}")
        current = getattr(msg, key)
        try:
            if hasattr(current, "get_fields_and_field_types"):
                if not isinstance(value, dict):
                    raise InputError(where, f"expected a mapping of the message's fields, got {value!r}")
                fill(current, value, where)
                continue
            element = _element_class(msg, key) if isinstance(value, list) else None
            if element is not None:
                value = [fill(element(), item, f"{where}[{i}]") for i, item in enumerate(value)]
            elif isinstance(current, float) and isinstance(value, int) and not isinstance(value, bool):
                value = float(value)
            setattr(msg, key, value)
        except (AssertionError, TypeError, ValueError) as error:
            raise InputError(where, f"refused: {error or type(error).__name__}") from None
    return msg


def from_yaml(cls: Any, text: str, field: str = "VALUES") -> Any:
    """Return a ``cls`` message from YAML text (empty: the defaults)."""
    values = yaml_mapping_from_text(text, field, field) if text.strip() else {}
    return fill(cls(), values, field)


def to_plain(msg: Any) -> Any:
    """Return a message as plain data (dicts, lists, numbers, strings) for JSON or printing."""
    if hasattr(msg, "get_fields_and_field_types"):
        return {key: to_plain(getattr(msg, key)) for key in msg.get_fields_and_field_types()}
    if isinstance(msg, (list, tuple)) or type(msg).__name__ in ("array", "ndarray"):
        return [to_plain(item) for item in msg]
    if isinstance(msg, bytes):
        return list(msg)
    return msg
