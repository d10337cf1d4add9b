"""What SpawnEntity and SetEntityState accept: part documents, names, and poses a device can hold.

A spawnable is a part file (contract section 2, YAML): ``uri`` names one (a path or ``file://`` URI),
or ``resource_string`` holds one inline; either is read by the project's one bounded reading layer and
checked as a part file is (every problem names the field). Poses are checked before a device sees them:
finite, a unit quaternion (to ``QUATERNION_TOLERANCE``), and one the device can hold at rest:

- on the MEMS array, a pose in the array's plane (z = 0, no roll or pitch, to ``PLANE_TOLERANCE``);
- on the throwing arm, a rest pose of eq. (5) at t = 0 (``feeder_planner.throwing.flight.rest_pose``):
  x = R, y = h + d^i and Theta = -alpha_i for a hull edge i (to ``PLANE_TOLERANCE``): the edge is the one
  whose rest angle the pose's yaw is, the radius its x.

Parts are placed at rest: a non-zero twist is refused (the standard's OPERATION_FAILED) with the reason
``support.VELOCITY`` gives for the entity's kind; acceleration is ignored, as the standard allows.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from feeder_cell.simulation.results import (
    NAME_INVALID,
    NAMESPACE_INVALID,
    NO_RESOURCE,
    NOT_FOUND,
    OPERATION_FAILED,
    RESOURCE_PARSE_ERROR,
    UNSUPPORTED_FORMAT,
    SimulationError,
)
from feeder_cell.simulation.support import VELOCITY
from feeder_planner.errors import InputError
from feeder_planner.fields_io import yaml_mapping_from_text
from feeder_planner.parts import Part, part_from_mapping
from feeder_planner.reading import read_text

__all__ = [
    "SPAWN_FORMAT",
    "PART_SUFFIXES",
    "QUATERNION_TOLERANCE",
    "PLANE_TOLERANCE",
    "Spawnable",
    "check_name",
    "check_namespace",
    "read_spawnable",
    "planar_pose",
    "check_at_rest",
    "arm_rest",
]

SPAWN_FORMAT = "feeder_part_yaml"  # SimulatorFeatures.spawn_formats: a part file, contract section 2
PART_SUFFIXES = (".yaml", ".yml")
QUATERNION_TOLERANCE = 1e-6  # |q| - 1
PLANE_TOLERANCE = 1e-6  # m out of the plane, rad of roll or pitch, rad and m off an arm rest pose
NAME_RE = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,63}")
NAMESPACE_RE = re.compile(r"/?[A-Za-z_][A-Za-z0-9_]*(/[A-Za-z_][A-Za-z0-9_]*)*")


@dataclass(frozen=True)
class Spawnable:
    """A checked part document: its YAML text (what the device is sent), the part, where it came from."""

    text: str
    part: Part
    source: str
    named: bool = True  # the document names the part (else the part's name is a default)


def check_name(name: str, field: str = "name") -> str:
    """Return ``name`` if it can name a part (a letter, then letters, digits, underscores; at most 64)."""
    if not NAME_RE.fullmatch(name):
        raise SimulationError(
            NAME_INVALID,
            f"{field}: a part name is a letter, then letters, digits or underscores (at most 64), "
            f"got {name!r}",
        )
    return name


def check_namespace(namespace: str, field: str = "entity_namespace") -> str:
    """Return ``namespace`` if it meets ROS naming rules (empty: none), else NAMESPACE_INVALID.

    The rules of a ROS 2 namespace: tokens of letters, digits and underscores, not starting with a digit,
    separated by single slashes, an optional leading slash and (but for ``/`` itself) no trailing one.
    """
    if namespace and namespace != "/" and not NAMESPACE_RE.fullmatch(namespace):
        raise SimulationError(
            NAMESPACE_INVALID,
            f"{field}: not a ROS namespace (tokens of letters, digits and underscores, none starting "
            f"with a digit, separated by single slashes), got {namespace!r}",
        )
    return namespace


def read_spawnable(uri: str, resource_string: str) -> Spawnable:
    """Read the part a SpawnEntity request names (``uri`` wins over ``resource_string``: the standard)."""
    if uri:
        path_text = uri.removeprefix("file://")
        if "://" in path_text:
            raise SimulationError(
                UNSUPPORTED_FORMAT, f"uri: only file paths and file:// URIs are read, got {uri!r}"
            )
        path = Path(path_text)
        if path.suffix.lower() not in PART_SUFFIXES:
            raise SimulationError(
                UNSUPPORTED_FORMAT, f"uri: a part file is YAML ({', '.join(PART_SUFFIXES)}), got {uri!r}"
            )
        if not path.exists():
            raise SimulationError(NOT_FOUND, f"uri: no such file: {path_text}")
        try:
            text = read_text(path)
        except InputError as error:
            raise SimulationError(RESOURCE_PARSE_ERROR, f"uri: {error}") from None
        source, field = path_text, "uri"
    elif resource_string:
        text, source, field = resource_string, "resource_string", "resource_string"
        head = text.lstrip()[:64].lower()
        if head.startswith("<") or head.startswith("#usda") or head.startswith("#sdf"):
            # SDFormat, URDF, MJCF (XML) or USD: formats the standard names that this cell does not read.
            raise SimulationError(
                UNSUPPORTED_FORMAT,
                f"resource_string: XML or USD (SDFormat, URDF, MJCF, USD) is not a spawn format here; "
                f"spawn_formats is [{SPAWN_FORMAT}] (a part file, contract section 2)",
            )
    else:
        raise SimulationError(
            NO_RESOURCE, "uri, resource_string: both are empty; name a part file or give one"
        )
    try:
        mapping = yaml_mapping_from_text(text, source, field)
        part = part_from_mapping(mapping)
    except InputError as error:
        message = str(error) if error.source else f"{source}: {error}"
        raise SimulationError(RESOURCE_PARSE_ERROR, message) from None
    return Spawnable(text, part, source, bool(mapping.get("name")))


def _finite(values: tuple[float, ...], field: str, code: int) -> None:
    if not all(math.isfinite(v) for v in values):
        raise SimulationError(code, f"{field}: must be finite, got {values}")


def planar_pose(
    position: tuple[float, float, float],
    orientation: tuple[float, float, float, float],
    field: str,
    code: int,
) -> tuple[float, float, float]:
    """Return (x, y, yaw) of a pose in a plane's frame, or raise ``code`` naming ``field``."""
    _finite(position, f"{field}.position", code)
    _finite(orientation, f"{field}.orientation", code)
    qx, qy, qz, qw = orientation
    norm = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    if abs(norm - 1.0) > QUATERNION_TOLERANCE:
        raise SimulationError(code, f"{field}.orientation: not a unit quaternion (|q| = {norm:.9g})")
    # Tilt of the frame's z axis: 2 asin(sqrt(qx^2 + qy^2)) for a unit quaternion.
    tilt = 2.0 * math.asin(min(1.0, math.hypot(qx, qy) / norm))
    if tilt > PLANE_TOLERANCE or abs(position[2]) > PLANE_TOLERANCE:
        raise SimulationError(
            code,
            f"{field}: must lie in the plane (z = 0, no roll or pitch), got z = {position[2]:.6g} m "
            f"and a tilt of {tilt:.6g} rad",
        )
    yaw = 2.0 * math.atan2(qz, qw)
    return float(position[0]), float(position[1]), math.remainder(yaw, 2 * math.pi)


def check_at_rest(
    kind: str, linear: tuple[float, ...], angular: tuple[float, ...], accel: tuple[float, ...]
) -> None:
    """Refuse a twist on an entity whose velocity the cell cannot set (``support.VELOCITY`` says why).

    Acceleration is ignored, as SetEntityState allows ("may be ignored by simulators"), once finite.
    """
    _finite(accel, "state.acceleration", OPERATION_FAILED)
    values = (*linear, *angular)
    _finite(values, "state.twist", OPERATION_FAILED)
    if any(v != 0.0 for v in values):
        what, why = VELOCITY[kind]
        raise SimulationError(OPERATION_FAILED, f"state.twist: must be zero for {what}: {why}; got {values}")


def arm_rest(
    x: float,
    y: float,
    yaw: float,
    edge_angle: np.ndarray,
    d: np.ndarray,
    offset: float,
    field: str,
    code: int,
) -> tuple[int, float]:
    """Return (edge, R) of an arm rest pose (x = R, y = h + d^i, Theta = -alpha_i), or raise ``code``."""
    for edge in range(len(edge_angle)):
        off_angle = abs(math.remainder(yaw + float(edge_angle[edge]), 2 * math.pi))
        if off_angle <= PLANE_TOLERANCE:
            height = offset + float(d[edge])
            if abs(y - height) > PLANE_TOLERANCE:
                raise SimulationError(
                    code,
                    f"{field}.position.y: resting on edge {edge} the centre of mass is at "
                    f"y = h + d = {height:.9g} m, got {y:.9g}",
                )
            return edge, float(x)
    rests = ", ".join(f"{-float(a):.6g}" for a in edge_angle)
    raise SimulationError(
        code,
        f"{field}.orientation: yaw {yaw:.6g} rad is no rest angle of the part's hull edges ({rests} rad)",
    )
