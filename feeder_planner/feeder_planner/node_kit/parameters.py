"""Documented node parameters declared to rclpy: each with its description, validated once.

The specs and their checks are ROS-free (``feeder_planner.parameter_specs``); this module re-exports them
for the nodes and adds the one function that talks to rclpy.
"""

from __future__ import annotations

from typing import Any, Sequence

from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node

from feeder_planner.parameter_specs import (
    Check,
    ParameterSpec,
    check_value,
    finite,
    in_range,
    integer,
    integer_at_least,
    negative,
    non_empty_string,
    non_negative,
    one_of,
    positive,
)

__all__ = [
    "Check",
    "ParameterSpec",
    "declare_parameters",
    "check_value",
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


def declare_parameters(node: Node, specs: Sequence[ParameterSpec], validate: bool = True) -> dict[str, Any]:
    """Declare documented parameters and return their values, validated unless ``validate`` is False.

    A managed device declares without validating and validates at configure, so that a bad value fails
    the configure transition (naming the parameter) instead of the process.
    """
    values: dict[str, Any] = {}
    for spec in specs:
        descriptor = ParameterDescriptor(description=spec.description, read_only=spec.read_only)
        node.declare_parameter(spec.name, spec.default, descriptor)
        value = node.get_parameter(spec.name).value
        if validate:
            check_value(spec, value)
        values[spec.name] = value
    return values
