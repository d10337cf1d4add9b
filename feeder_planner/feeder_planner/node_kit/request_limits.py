"""The stated limits of a request to a node, checked before any work or allocation.

A request is one message, but one message can ask for hours of work or gigabytes (1e5 x 1e5 designs, a
path step of 1e-7 rad, 10,000 waypoints, 10 MB of YAML whose aliases expand a billion times). Each
service checks its counts here first and answers ``ok: false`` naming the field and the limit; the
limits are the README's node table. Magnitudes are checked to the models' stated ranges, so that a
number the float type holds but the mechanics do not (R = 1e308 m) is refused by name rather than
answered ``internal error``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence, Sized
from typing import Any, Protocol

import numpy as np

from feeder_planner.assembly.tolerances import SAME_POINT_ANGLE
from feeder_planner.errors import InputError
from feeder_planner.fields_io import yaml_mapping_from_text
from feeder_planner.limits import (
    MAX_GRAVITY,
    MAX_LENGTH_M,
    MAX_NAME_CHARS,
    MAX_QUEUED_THROWS,
    MAX_RELEASE_SPEED,
    MAX_YAML_DEPTH,
    MIN_LENGTH_M,
)

__all__ = [
    "MAX_LOOP_VERTICES",
    "MAX_HOLES",
    "MAX_PART_VERTICES",
    "MAX_DESIGNS",
    "MAX_STARTS_PER_EDGE",
    "MAX_THROWS",
    "MIN_THROWS",
    "MAX_THROW_WORK",
    "MAX_PATH_SAMPLES",
    "MAX_MOVE_SAMPLES",
    "MAX_FACETS",
    "MAX_YAML_CHARS",
    "MAX_YAML_NODES",
    "MAX_YAML_DEPTH",
    "MAX_WAYPOINTS",
    "MAX_PROGRAM_STEPS",
    "MAX_NAMES",
    "MAX_NAME_CHARS",
    "MAX_QUEUED_THROWS",
    "LENGTH_RANGE_M",
    "MAX_SPEED",
    "MAX_GRAVITY",
    "MAX_MU",
    "check_count",
    "check_magnitude",
    "check_text",
    "check_part_size",
    "check_design",
    "check_arc_samples",
    "bounded_yaml_mapping",
]

MAX_LOOP_VERTICES = 1000  # per loop (outer or hole) of a feeder_msgs/Part
MAX_HOLES = 100
MAX_PART_VERTICES = 2000  # outer and holes together
MAX_DESIGNS = 64  # offsets x release_speeds of one DesignSearch (each a limit set, ~0.5 s)
MAX_STARTS_PER_EDGE = 1000
MAX_THROWS = 10_000
MIN_THROWS = 3  # fewer throws per start cannot show a cycle (the planner's default_throws has the same)
MAX_THROW_WORK = 2_000_000  # starts_per_edge x throws x stable edges: the trajectory arrays' cells
MAX_PATH_SAMPLES = 10_000  # samples of one StablePath (each an LP certificate)
# Certified samples of one fixture ~/move or ~/follow_path path (arc length / path_step, each a stability
# LP of 1-20 ms on the example assemblies): the device is single-threaded, so this bounds how long one
# request holds its ticks. At the default path_step (0.5 degree) it is 500 degrees of arc.
MAX_MOVE_SAMPLES = 1000
MAX_FACETS = 64  # friction-pyramid facets K of a request (the LP grows with K per contact)
MAX_YAML_CHARS = 1 << 20  # characters of an assembly_yaml field
MAX_YAML_NODES = 100_000  # YAML nodes after alias expansion (a billion-laughs document is refused)
MAX_WAYPOINTS = 100  # FixtureMove / FollowPath waypoints (a device is single-threaded: ~0.3 s)
MAX_PROGRAM_STEPS = 1000  # steps of one field program
MAX_NAMES = 10_000  # entries of a list of part names
# The models' stated ranges are the files' and the command's (feeder_planner.limits): one definition.
LENGTH_RANGE_M = (MIN_LENGTH_M, MAX_LENGTH_M)
MAX_SPEED = MAX_RELEASE_SPEED  # rad/s, |release speed|
MAX_MU = 1e3


def check_count(count: int, limit: int, field: str, what: str) -> None:
    """Raise InputError naming ``field`` when ``count`` exceeds ``limit``.

    Parameters
    ----------
    count, limit
        The request's count and the stated limit.
    field
        The request field (or fields) the count comes from.
    what
        What is counted, e.g. ``"waypoints"``.
    """
    if count > limit:
        raise InputError(field, f"has {count} {what}; the limit per request is {limit}")


def check_magnitude(value: float, limit: float, field: str, unit: str) -> float:
    """Return ``value`` as a float if finite and ``|value| <= limit``; else InputError naming ``field``."""
    number = float(value)
    if not math.isfinite(number):
        raise InputError(field, f"must be finite, got {number!r}")
    if abs(number) > limit:
        raise InputError(field, f"must be within +-{limit:g} {unit}, got {number:.6g}")
    return number


def check_text(text: str, limit: int, field: str) -> str:
    """Return ``text`` if at most ``limit`` characters, else raise InputError naming ``field``."""
    if len(text) > limit:
        raise InputError(field, f"has {len(text)} characters; the limit is {limit}")
    return text


class _Loop(Protocol):
    """A feeder_msgs/Polygon2D as far as the size check reads it."""

    @property
    def x(self) -> Sized:
        """The x coordinates."""
        ...

    @property
    def y(self) -> Sized:
        """The y coordinates."""
        ...


def check_part_size(msg: Any, field: str = "part") -> None:
    """Refuse a feeder_msgs/Part whose loops exceed the vertex and hole limits, before reading them."""
    check_text(msg.name, MAX_NAME_CHARS, f"{field}.name")
    check_text(msg.length_unit, MAX_NAME_CHARS, f"{field}.length_unit")
    check_count(len(msg.holes), MAX_HOLES, f"{field}.holes", "holes")
    loops: list[tuple[str, _Loop]] = [(f"{field}.outer", msg.outer)]
    loops += [(f"{field}.holes[{i}]", hole) for i, hole in enumerate(msg.holes)]
    total = 0
    for where, loop in loops:
        for axis in ("x", "y"):
            values: Sized = getattr(loop, axis)
            check_count(len(values), MAX_LOOP_VERTICES, f"{where}.{axis}", "vertices")
        total += len(loop.x)
    check_count(total, MAX_PART_VERTICES, field, "vertices in its loops")


def check_design(
    fields: dict[str, float], *, lengths: tuple[str, ...] = ("offset",), radius: str | None = None
) -> None:
    """Check a throwing design's magnitudes against the model's stated ranges, naming the field.

    ``fields`` maps request field names (offset, release_speed, gravity, mu, radius...) to values;
    lengths are within the length range's upper end, speed, gravity and mu within their own limits.
    """
    for name, value in fields.items():
        if name in lengths or name == radius:
            check_magnitude(value, LENGTH_RANGE_M[1], name, "m")
        elif name in ("release_speed", "release_speeds"):
            check_magnitude(value, MAX_SPEED, name, "rad/s")
        elif name == "gravity":
            check_magnitude(value, MAX_GRAVITY, name, "m/s^2")
        elif name == "mu":
            check_magnitude(value, MAX_MU, name, "")


def check_arc_samples(
    start: Sequence[float] | np.ndarray,
    waypoints: Sequence[Sequence[float] | np.ndarray],
    step: float,
    field: str,
    limit: int,
) -> int:
    """Return how many samples the great arcs from ``start`` through ``waypoints`` take at ``step``.

    Counted from the arcs' angles before any sample is made, as the samplers do: the start, then
    ``ceil(angle / step)`` per arc (an arc shorter than ``SAME_POINT_ANGLE`` adds none).

    Parameters
    ----------
    start, waypoints
        Gravity directions (any non-zero length; zero or non-finite ones are left to the sampler).
    step
        The largest angle between samples (rad, positive).
    field
        The request field the waypoints came from, named by the error.
    limit
        The stated limit on samples (``MAX_MOVE_SAMPLES`` for the fixture).

    Raises
    ------
    InputError
        Naming ``field`` when the count exceeds ``limit``: the count, the total angle, the step and
        the smallest step that would fit.
    """
    points = [np.asarray(start, dtype=float), *(np.asarray(w, dtype=float) for w in waypoints)]
    units = []
    for point in points:
        norm = float(np.linalg.norm(point))
        if not math.isfinite(norm) or norm == 0.0:
            return 0  # the sampler refuses it by name; nothing to count
        units.append(point / norm)
    samples, total, arcs = 1, 0.0, 0
    for a, b in zip(units, units[1:], strict=False):
        angle = math.acos(float(np.clip(a @ b, -1.0, 1.0)))
        if angle >= SAME_POINT_ANGLE:
            samples += max(1, math.ceil(angle / step))
            total, arcs = total + angle, arcs + 1
    if samples > limit:
        # Each arc's ceil may add one sample: a step that fits whatever the rounding, printed rounded up
        # (4 digits round by at most 5e-4 relative).
        fits = ""
        if limit > arcs + 1:
            fits = f", or a path_step of at least {total / (limit - 1 - arcs) * 1.001:.4g} rad"
        raise InputError(
            field,
            f"{total:.4g} rad of great arcs at path_step {step:.3g} rad is {samples} path samples; the "
            f"limit per request is {limit} (fewer or closer waypoints{fits})",
        )
    return samples


def bounded_yaml_mapping(text: str, field: str) -> dict[str, Any]:
    """Parse a request's YAML text into a mapping with its size, alias expansion and nesting bounded.

    Parameters
    ----------
    text
        The YAML document (a request field such as ``assembly_yaml``).
    field
        The request field, named by every error.

    Raises
    ------
    InputError
        Over ``MAX_YAML_CHARS`` characters, over ``MAX_YAML_NODES`` nodes once aliases are expanded,
        nested deeper than ``MAX_YAML_DEPTH``, not YAML, or not a mapping. Messages quote nothing of
        the text but a line number.
    """
    check_text(text, MAX_YAML_CHARS, field)
    try:
        return yaml_mapping_from_text(text, field, field, MAX_YAML_NODES)
    except InputError as error:  # one field for the whole text, whatever part of it is wrong
        raise InputError(field, error.problem) from None
