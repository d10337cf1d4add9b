"""The throwing arm device's parameters, ROS-free: one declaration for the node, the scene and the docs.

Each entry is a ``ParameterSpec`` (type by its default, meaning, check, read-only or runtime). The node
declares them to rclpy with the display parameters of the node kit; the launcher's scene validation and
the docs' parameter table read them from here without ROS. ``configure_arm`` builds the model from
validated values, every problem naming its parameter (a failed lifecycle configure says which).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from feeder_device.parameters import DeviceParameters
from feeder_planner.errors import InputError
from feeder_planner.parameter_specs import (
    finite,
    in_range,
    integer,
    negative,
    non_empty_string,
    non_negative,
    one_of,
    param,
    positive,
)
from feeder_planner.parts import load_part
from feeder_planner.throwing import ArmPart, ThrowParams, arm_part, lowest_radius
from feeder_sim.throwing.arm import FIDELITIES, FIDELITY_ALIASES, ThrowingArm
from feeder_sim.throwing.tolerances import DEFAULT_STEP

__all__ = ["ArmParameters", "BASE_FRAME", "DEFAULT_RADIUS_FACTOR", "configure_arm"]

# A start-up R of 0 means this multiple of the edge's lowest throwable R: clear of the domain's edge,
# where the left contact vertex barely lifts.
DEFAULT_RADIUS_FACTOR = 1.5
BASE_FRAME = "arm_pivot"


@dataclass(frozen=True)
class ArmParameters(DeviceParameters):
    """The throwing arm's parameters (the device kit's come with ``DeviceParameters``)."""

    part_file: str = param(
        "", "part file (YAML, contract section 2); required", non_empty_string("a part file"), read_only=True
    )
    offset: float = param(-0.005, "h: height of the arm surface above the pivot (m)", finite, read_only=True)
    release_speed: float = param(
        math.radians(320),
        "W: release angular speed (rad/s, > 0); applied from the next throw when set at run time",
        positive,
    )
    gravity: float = param(-9.66, "g: gravity along y (m/s^2, < 0)", negative, read_only=True)
    mu: float = param(0.5, "friction coefficient between arm and part (> 0)", positive, read_only=True)
    fidelity: str = param(
        "paper",
        "paper (the paper's model; analytic is accepted for it), contact (paper plus lift-off and "
        "Coulomb impacts) or dynamic (pymunk, restitution and friction)",
        one_of((*FIDELITIES, *FIDELITY_ALIASES)),
        read_only=True,
    )
    dynamic_step: float = param(
        DEFAULT_STEP,
        "pymunk step (s) of the dynamic fidelity; applied from the next throw when set at run time",
        positive,
    )
    period: float = param(
        0.5, "time between throws (s, node clock); applied at once when set at run time", positive
    )
    motion_fraction: float = param(
        0.3,
        "fraction of the period spent showing the throw (the rest is at rest); applied from the next throw",
        in_range(0.0, 1.0, include_low=False, include_high=False),
    )
    sensor_radius: float = param(
        0.2, "x of the proximity sensor on the arm (m); applied at once at run time", finite
    )
    sensing_height: float = param(
        0.001, "sensing height above the arm surface (m, >= 0); applied at once at run time", non_negative
    )
    sensor_rate: float = param(
        100.0,
        "rate of the sensor, joint state and part pose topics (Hz of the node clock): the main stream",
        positive,
        read_only=True,
    )
    initial_edge: int = param(
        -1, "stable hull edge the part starts on (-1: the first stable edge)", integer, read_only=True
    )
    initial_radius: float = param(
        0.0,
        f"R at start (m); 0: {DEFAULT_RADIUS_FACTOR:g} x the lowest throwable radius of the edge",
        non_negative,
        read_only=True,
    )
    arm_length: float = param(
        0.4,
        "length of the arm from the pivot (m); a part beyond it has left the arm",
        positive,
        read_only=True,
    )
    autostart: bool = param(
        False, "throw every period once active (else wait for a start/throw command)", read_only=True
    )
    frame_id: str = param(
        "",
        f"frame of the part pose and throw events (at the arm pivot, gravity along -y); "
        f"empty: {BASE_FRAME} under the node's namespace",
        read_only=True,
    )


def configure_arm(p: ArmParameters) -> ThrowingArm:
    """Load the part and build the arm at its start (edge, R) from validated parameter values ``p``."""
    try:
        part = arm_part(load_part(p.part_file))
    except InputError as error:
        raise InputError("parameter part_file", str(error)) from None
    try:
        params = ThrowParams(p.offset, p.release_speed, p.gravity, p.mu)
    except InputError as error:
        raise InputError(f"parameter {error.field}", error.problem) from None
    edge = _initial_edge(part, p.initial_edge)
    radius = p.initial_radius or DEFAULT_RADIUS_FACTOR * lowest_radius(part, edge, params)
    try:
        return ThrowingArm(part, params, edge, radius, p.fidelity, p.arm_length, p.dynamic_step)
    except InputError as error:
        raise InputError(f"parameter initial_{error.field}", error.problem) from None


def _initial_edge(part: ArmPart, initial_edge: int) -> int:
    """Return the start edge (-1: the first stable edge), or raise InputError naming initial_edge."""
    edge = initial_edge if initial_edge >= 0 else part.stable_edges[0]
    if not (0 <= edge < part.n) or not part.stable[edge]:
        raise InputError("parameter initial_edge", f"must be a stable edge {part.stable_edges}, got {edge}")
    return edge
