"""Pieces every feeder node shares: part messages, guarded service callbacks, documented parameters."""

from __future__ import annotations

import functools
import math
import traceback
from dataclasses import dataclass
from typing import Any, Callable

from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node

from feeder_planner.errors import FeederError, InputError, SolverError
from feeder_planner.parts import Part, make_part
from feeder_planner.units import length_scale


def _loop_points(loop: Any, field: str) -> list[list[float]]:
    xs, ys = list(loop.x), list(loop.y)
    if len(xs) != len(ys):
        raise InputError(field, f"x has {len(xs)} values but y has {len(ys)}")
    return [[x, y] for x, y in zip(xs, ys)]


def part_from_msg(msg: Any, field: str = "part") -> Part:
    """Validate a feeder_msgs/Part; errors name the request field, e.g. ``part.outer``."""
    scale = length_scale(msg.length_unit or "m", f"{field}.length_unit")
    outer = _loop_points(msg.outer, f"{field}.outer")
    holes = [_loop_points(hole, f"{field}.holes[{i}]") for i, hole in enumerate(msg.holes)]
    density = msg.density if msg.density != 0.0 else 1.0
    try:
        return make_part(outer, holes, density, msg.name or "part", scale)
    except InputError as error:
        # make_part names 'vertices'/'holes[i]'/'density'; map them onto the message's fields.
        renamed = error.field.replace("vertices", "outer", 1) if error.field.startswith("vertices") else error.field
        raise InputError(f"{field}.{renamed}", error.problem) from None


def part_to_msg(document: dict[str, Any], msg_type: Any, polygon_type: Any) -> Any:
    """Build a feeder_msgs/Part from a part-file mapping (no validation: the receiver validates)."""
    def loop(points: list[list[float]]) -> Any:
        return polygon_type(x=[float(p[0]) for p in points], y=[float(p[1]) for p in points])

    return msg_type(name=str(document.get("name", "part")), length_unit=str(document.get("length_unit", "m")),
                    outer=loop(document["vertices"]), holes=[loop(h) for h in document.get("holes", []) or []],
                    density=float(document.get("density", 1.0)))


def service_guard(node: Node) -> Callable[[Callable[[Any, Any], Any]], Callable[[Any, Any], Any]]:
    """Decorate a service callback: errors become ``ok=False`` with a one-line ``error``; the node lives on."""

    def decorate(callback: Callable[[Any, Any], Any]) -> Callable[[Any, Any], Any]:
        @functools.wraps(callback)
        def guarded(request: Any, response: Any) -> Any:
            try:
                result = callback(request, response)
                result.ok = True
                result.error = ""
                return result
            except InputError as error:
                message = f"bad request: {error}"
            except SolverError as error:
                message = f"not certified: {error}"
            except FeederError as error:
                message = str(error)
            except Exception as error:  # a bug must not take the node down; log it whole
                node.get_logger().error(f"{callback.__name__} failed:\n{traceback.format_exc()}")
                message = f"internal error: {type(error).__name__}: {error}"
            node.get_logger().warning(f"{callback.__name__}: {message}")
            response.ok = False
            response.error = message
            return response

        return guarded

    return decorate


@dataclass(frozen=True)
class ParameterSpec:
    """A node parameter: name, default (its type is the parameter's type), meaning, and a check."""

    name: str
    default: Any
    description: str
    check: Callable[[Any], str | None] | None = None  # returns a problem description, or None if fine


def declare_parameters(node: Node, specs: tuple[ParameterSpec, ...]) -> dict[str, Any]:
    """Declare documented parameters and return their validated values; a bad value raises InputError."""
    values: dict[str, Any] = {}
    for spec in specs:
        node.declare_parameter(spec.name, spec.default, ParameterDescriptor(description=spec.description))
        value = node.get_parameter(spec.name).value
        problem = spec.check(value) if spec.check else None
        if problem:
            raise InputError(f"parameter {spec.name}", problem)
        values[spec.name] = value
    return values


def _is_number(value: Any) -> bool:
    # bool is an int subclass, but a parameter given as true is not a number.
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def finite(value: Any) -> str | None:
    return None if _is_number(value) else f"must be a finite number, got {value!r}"


def positive(value: Any) -> str | None:
    return None if _is_number(value) and value > 0 else f"must be a finite number > 0, got {value!r}"


def non_negative(value: Any) -> str | None:
    return None if _is_number(value) and value >= 0 else f"must be a finite number >= 0, got {value!r}"


def run_node(factory: Callable[[], Node], name: str, args: list[str] | None = None) -> None:
    """The ``main`` of every feeder node: a bad configuration is a FATAL log and exit 2; Ctrl-C a clean stop."""
    import rclpy
    from rclpy.executors import ExternalShutdownException

    rclpy.init(args=args)
    try:
        node = factory()
    except InputError as error:
        rclpy.logging.get_logger(name).fatal(f"bad configuration: {error}")
        rclpy.try_shutdown()
        raise SystemExit(2) from None
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
