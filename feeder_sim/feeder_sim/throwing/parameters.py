"""The throwing arm device's parameters, ROS-free: one declaration for the node, the scene and the docs.

Each entry is a ``ParameterSpec`` (type by its default, meaning, check, read-only or runtime). The node
declares them to rclpy with the display parameters of the node kit; the launcher's scene validation and
the docs' parameter table read them from here without ROS.
"""

from __future__ import annotations

import math

from feeder_planner.parameter_specs import (
    ParameterSpec,
    finite,
    in_range,
    integer,
    negative,
    non_empty_string,
    non_negative,
    one_of,
    positive,
)
from feeder_sim.throwing.arm import FIDELITIES, FIDELITY_ALIASES
from feeder_sim.throwing.tolerances import DEFAULT_STEP

__all__ = ["ARM_PARAMETERS", "BASE_FRAME", "DEFAULT_RADIUS_FACTOR"]

# A start-up R of 0 means this multiple of the edge's lowest throwable R: clear of the domain's edge,
# where the left contact vertex barely lifts.
DEFAULT_RADIUS_FACTOR = 1.5
BASE_FRAME = "arm_pivot"

ARM_PARAMETERS = (
    ParameterSpec(
        "part_file",
        "",
        "part file (YAML, contract section 2); required",
        non_empty_string("a part file"),
        read_only=True,
    ),
    ParameterSpec(
        "offset", -0.005, "h: height of the arm surface above the pivot (m)", finite, read_only=True
    ),
    ParameterSpec(
        "release_speed",
        math.radians(320),
        "W: release angular speed (rad/s, > 0); applied from the next throw when set at run time",
        positive,
    ),
    ParameterSpec("gravity", -9.66, "g: gravity along y (m/s^2, < 0)", negative, read_only=True),
    ParameterSpec("mu", 0.5, "friction coefficient between arm and part (> 0)", positive, read_only=True),
    ParameterSpec(
        "fidelity",
        "paper",
        "paper (the paper's model; analytic is accepted for it), contact (paper plus lift-off and "
        "Coulomb impacts) or dynamic (pymunk, restitution and friction)",
        one_of((*FIDELITIES, *FIDELITY_ALIASES)),
        read_only=True,
    ),
    ParameterSpec(
        "dynamic_step",
        DEFAULT_STEP,
        "pymunk step (s) of the dynamic fidelity; applied from the next throw when set at run time",
        positive,
    ),
    ParameterSpec(
        "period", 0.5, "time between throws (s, node clock); applied at once when set at run time", positive
    ),
    ParameterSpec(
        "motion_fraction",
        0.3,
        "fraction of the period spent showing the throw (the rest is at rest); applied from the next throw",
        in_range(0.0, 1.0, include_low=False, include_high=False),
    ),
    ParameterSpec(
        "sensor_radius", 0.2, "x of the proximity sensor on the arm (m); applied at once at run time", finite
    ),
    ParameterSpec(
        "sensing_height",
        0.001,
        "sensing height above the arm surface (m, >= 0); applied at once at run time",
        non_negative,
    ),
    ParameterSpec(
        "sensor_rate",
        100.0,
        "rate of the sensor, joint state and part pose topics (Hz of the node clock): the main stream",
        positive,
        read_only=True,
    ),
    ParameterSpec(
        "initial_edge",
        -1,
        "stable hull edge the part starts on (-1: the first stable edge)",
        integer,
        read_only=True,
    ),
    ParameterSpec(
        "initial_radius",
        0.0,
        f"R at start (m); 0: {DEFAULT_RADIUS_FACTOR:g} x the lowest throwable radius of the edge",
        non_negative,
        read_only=True,
    ),
    ParameterSpec(
        "arm_length",
        0.4,
        "length of the arm from the pivot (m); a part beyond it has left the arm",
        positive,
        read_only=True,
    ),
    ParameterSpec(
        "autostart",
        False,
        "throw every period once active (else wait for a start/throw command)",
        read_only=True,
    ),
    ParameterSpec(
        "frame_id",
        "",
        f"frame of the part pose and throw events (at the arm pivot, gravity along -y); "
        f"empty: {BASE_FRAME} under the node's namespace",
        read_only=True,
    ),
)
