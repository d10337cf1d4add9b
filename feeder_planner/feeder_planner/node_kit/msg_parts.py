"""Conversions between part files, the mechanics' ``Part`` and feeder_msgs/Part."""

from __future__ import annotations

from typing import Any, Protocol, Sequence

from feeder_msgs.msg import Part as PartMsg
from feeder_msgs.msg import Polygon2D
from feeder_planner.errors import InputError
from feeder_planner.parts import DEFAULT_DENSITY, Part, make_part
from feeder_planner.units import length_scale

__all__ = ["part_from_msg", "part_to_msg"]


class _Loop(Protocol):
    x: Sequence[float]
    y: Sequence[float]


def _loop_points(loop: _Loop, field: str) -> list[list[float]]:
    xs, ys = list(loop.x), list(loop.y)
    if len(xs) != len(ys):
        raise InputError(field, f"x has {len(xs)} values but y has {len(ys)}")
    return [[x, y] for x, y in zip(xs, ys, strict=True)]


def part_from_msg(msg: PartMsg, field: str = "part") -> Part:
    """Validate a feeder_msgs/Part; errors name the request field, e.g. ``part.outer``."""
    scale = length_scale(msg.length_unit or "m", f"{field}.length_unit")
    outer = _loop_points(msg.outer, f"{field}.outer")
    holes = [_loop_points(hole, f"{field}.holes[{i}]") for i, hole in enumerate(msg.holes)]
    # A message cannot leave a float out: 0 stands for "not given", as an absent field does in a file.
    density = msg.density if msg.density != 0.0 else DEFAULT_DENSITY
    try:
        return make_part(outer, holes, density, msg.name or "part", scale)
    except InputError as error:
        # make_part names 'vertices'/'holes[i]'/'density'; map them onto the message's fields.
        renamed = (
            error.field.replace("vertices", "outer", 1) if error.field.startswith("vertices") else error.field
        )
        raise InputError(f"{field}.{renamed}", error.problem) from None


def part_to_msg(document: dict[str, Any]) -> PartMsg:
    """Build a feeder_msgs/Part from a part-file mapping (no validation: the receiver validates)."""

    def loop(points: list[list[float]]) -> Polygon2D:
        return Polygon2D(x=[float(p[0]) for p in points], y=[float(p[1]) for p in points])

    return PartMsg(
        name=str(document.get("name", "part")),
        length_unit=str(document.get("length_unit", "m")),
        outer=loop(document["vertices"]),
        holes=[loop(h) for h in document.get("holes", []) or []],
        density=float(document.get("density", DEFAULT_DENSITY)),
    )
