"""The reference cell controller's parameters: one ParameterSpec each, with its default, meaning and check.

ROS-free, so the scene validation and the docs read them without a node (``feeder_cell.node_modules``
finds them through the node module, which re-exports ``PARAMETERS``).
"""

from __future__ import annotations

import math

from feeder_cell.controller.machine import ORIENTERS, POLICIES
from feeder_planner.parameter_specs import (
    ParameterSpec,
    finite,
    in_range,
    integer,
    integer_at_least,
    non_empty_string,
    non_negative,
    one_of,
    positive,
)

__all__ = ["PARAMETERS"]


def _directions(value: object) -> str | None:
    """Check a flattened list of gravity directions: x, y, z per direction, finite, not zero."""
    values = list(value) if isinstance(value, (list, tuple)) else None
    if not values or len(values) % 3 or not all(isinstance(v, (int, float)) for v in values):
        return f"must be gravity directions as x, y, z triples (a multiple of 3 numbers), got {value!r}"
    for i in range(0, len(values), 3):
        triple = values[i : i + 3]
        if not all(math.isfinite(v) for v in triple) or math.hypot(*triple) == 0.0:
            return f"direction {i // 3} must be finite and non-zero, got {triple}"
    return None


PARAMETERS = (
    # The devices and the planner, by name relative to the controller's namespace.
    ParameterSpec("mems_device", "mems_field_array", "MEMS array node", non_empty_string("a node"), True),
    ParameterSpec("arm_device", "throwing_arm", "throwing arm node", non_empty_string("a node"), True),
    ParameterSpec(
        "fixture_device", "assembly_fixture", "assembly fixture node", non_empty_string("a node"), True
    ),
    ParameterSpec(
        "region_planner", "stable_region_planner", "stable region planner", non_empty_string("a node"), True
    ),
    ParameterSpec(
        "squeeze_device", "squeeze_gripper", "squeeze gripper node", non_empty_string("a node"), True
    ),
    ParameterSpec(
        "squeeze_planner", "squeeze_planner", "squeeze planner node", non_empty_string("a node"), True
    ),
    ParameterSpec(
        "orienter",
        "mems",
        "the orienting station ORIENT commands: mems (the MEMS array) or squeeze (the squeeze gripper)",
        one_of(ORIENTERS),
        True,
    ),
    ParameterSpec(
        "policy",
        "sequential",
        "sequential (one station after another) or pipelined (the array orients the next part while the arm "
        "feeds; the ROS-free cell loop only, so far)",
        one_of(POLICIES),
        True,
    ),
    ParameterSpec("cycles", 1, "production cycles to run (0: until stopped)", integer_at_least(0), True),
    ParameterSpec(
        "max_retries",
        2,
        "times one step may be retried in a cycle before the cell stops",
        integer_at_least(0),
        True,
    ),
    ParameterSpec(
        "bring_up", True, "configure and activate the devices first (false: they must be active)", None, True
    ),
    # ORIENT: the MEMS array.
    ParameterSpec(
        "orient_program_file",
        "",
        "field program YAML for ~/run_program ({steps: [{field, duration}]}, metres); "
        "empty: one combined field with orient_delta, forever",
        None,
        True,
    ),
    ParameterSpec(
        "orient_delta",
        0.2,
        "delta of the default combined field (0 <= delta < 1)",
        in_range(0.0, 1.0, include_high=False),
        True,
    ),
    ParameterSpec("orient_timeout", 20.0, "run_program timeout (s, node clock)", positive, True),
    ParameterSpec(
        "orient_tolerance", 0.0, "run_program settle tolerance (0: the array's default)", non_negative, True
    ),
    ParameterSpec(
        "orient_dwell", 0.0, "run_program settle dwell (s; 0: the array's default)", non_negative, True
    ),
    ParameterSpec(
        "new_batch",
        True,
        "~/place_parts reset before each program: a new batch at the initial poses",
        None,
        True,
    ),
    # ORIENT on the squeeze gripper (orienter: squeeze).
    ParameterSpec(
        "squeeze_part_file",
        "",
        "part YAML the squeeze planner's ~/plan is asked for once (the gripper's part_file); required "
        "with orienter squeeze",
        None,
        True,
    ),
    ParameterSpec(
        "squeeze_first_angle", 0.0, "gripper angle of the plan's first squeeze (rad)", finite, True
    ),
    ParameterSpec(
        "squeeze_random",
        True,
        "~/place_part a new part at an orientation from the gripper's seeded stream (false: "
        "squeeze_orientation)",
        None,
        True,
    ),
    ParameterSpec(
        "squeeze_orientation", 0.0, "orientation of a new part when not random (rad)", finite, True
    ),
    ParameterSpec("squeeze_timeout", 30.0, "run_plan timeout (s, node clock)", positive, True),
    # INFEED and FEED: the throwing arm.
    ParameterSpec("infeed_edge", 2, "hull edge a new part arrives on (~/place_part)", integer, True),
    ParameterSpec("infeed_radius", 0.12, "R (m) a new part arrives at (~/place_part)", positive, True),
    # Random arrivals and faults (docs/experiments.md): feeder launch sets the files to a scene with them.
    ParameterSpec(
        "arrivals_file",
        "",
        "YAML with an arrivals: section and a seed (a scene file): each cycle's part poses are drawn "
        "from it; empty: infeed_edge, infeed_radius and the array's initial poses",
        None,
        True,
    ),
    ParameterSpec(
        "faults_file",
        "",
        "YAML with a faults: section and a seed (a scene file): each device's failures are injected "
        "through its ~/inject_fault and repaired after their time; empty: none",
        None,
        True,
    ),
    ParameterSpec(
        "replication",
        0,
        "replication whose random streams the arrivals and faults draw",
        integer_at_least(0),
        True,
    ),
    ParameterSpec("feed_max_throws", 40, "feed_part max_throws", integer_at_least(1), True),
    ParameterSpec(
        "feed_timeout", 60.0, "feed_part timeout (s, node clock; 0: max_throws only)", non_negative, True
    ),
    # TILT and RETURN: the fixture and the planner.
    ParameterSpec(
        "fixture_route",
        [-0.5, 0.0, -0.8660254037844386],
        "the commanded route to the target orientation: gravity directions (x, y, z per waypoint, "
        "assembly frame); the last one is the target",
        _directions,
        True,
    ),
    ParameterSpec(
        "fixture_home",
        [0.0, 0.0, -1.0],
        "gravity direction the fixture returns to (x, y, z)",
        _directions,
        True,
    ),
    ParameterSpec("path_step", 0.0, "safe_path step (rad; 0: the planner's 1 degree)", non_negative, True),
    # Bounds on every wait.
    ParameterSpec(
        "step_timeout",
        120.0,
        "most one step may take beyond its goal's own timeout (s, node clock)",
        positive,
        True,
    ),
    ParameterSpec(
        "wall_timeout",
        300.0,
        "most any one wait may take on the wall clock, whatever the cell clock does (s)",
        positive,
        True,
    ),
    ParameterSpec(
        "answer_timeout",
        10.0,
        "wall seconds for a server to appear, accept a goal or answer a call",
        positive,
        True,
    ),
    ParameterSpec(
        "exit_when_done", False, "end the process when the machine ends (0 FINISHED, 1 STOPPED)", None, True
    ),
    ParameterSpec(
        "lockstep",
        False,
        "decide in the cell clock's lockstep, once per quantum (docs/cell.md; feeder launch "
        "--real-time-factor sets it with use_sim_time)",
        None,
        True,
    ),
)
