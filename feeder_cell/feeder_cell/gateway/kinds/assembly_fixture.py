"""The assembly fixture as the gateway shows it: tilt and stability, FollowPath (~/follow_path), counters."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from geometry_msgs.msg import Vector3
from sensor_msgs.msg import JointState

from feeder_cell.gateway.arguments import ArgumentError, check_count, read_numbers
from feeder_cell.gateway.spec import (
    ActionLink,
    Argument,
    ArgumentSpec,
    KindProfile,
    MethodSpec,
    StreamLink,
    Values,
    VariableSpec,
)
from feeder_msgs.action import FollowPath
from feeder_msgs.msg import StabilityStatus
from feeder_sim.fixture.counters import COUNTERS

__all__ = ["PROFILE", "FollowPathGoal", "check_follow_path"]

# The tilt joints as ~/joint_states names them, their variables, and their index when a message has no
# names (the fixture publishes them in this order).
_JOINTS = (("tilt_x", "Signals.TiltX", 0), ("tilt_y", "Signals.TiltY", 1))


@dataclass(frozen=True)
class FollowPathGoal:
    """A checked FollowPath call: exactly one of the waypoint lists is non-empty."""

    tilt: tuple[float, ...]  # flattened pairs
    gravity: tuple[tuple[float, float, float], ...]

    def message(self) -> Any:
        """Return the ~/follow_path goal."""
        return FollowPath.Goal(
            tilt_waypoints=list(self.tilt),
            gravity_waypoints=[Vector3(x=g[0], y=g[1], z=g[2]) for g in self.gravity],
        )


def check_follow_path(spec: MethodSpec, args: list[Argument]) -> FollowPathGoal:
    """Check FollowPath(TiltWaypoints, GravityWaypoints): one kind of waypoint, whole pairs or triples."""
    check_count(spec, args)
    tilt = read_numbers(args[0], 0, "TiltWaypoints")
    flat = read_numbers(args[1], 1, "GravityWaypoints")
    if bool(tilt) == bool(flat):
        which = "both are given" if tilt else "both are empty"
        raise ArgumentError(
            "BadInvalidArgument",
            0 if tilt else 1,
            f"TiltWaypoints, GravityWaypoints: give exactly one ({which})",
        )
    if tilt and len(tilt) % 2:
        raise ArgumentError(
            "BadInvalidArgument", 0, f"TiltWaypoints: must be (tilt_x, tilt_y) pairs, got {len(tilt)} numbers"
        )
    if flat and len(flat) % 3:
        raise ArgumentError(
            "BadInvalidArgument", 1, f"GravityWaypoints: must be (x, y, z) triples, got {len(flat)} numbers"
        )
    gravity = tuple((flat[i], flat[i + 1], flat[i + 2]) for i in range(0, len(flat), 3))
    for i, g in enumerate(gravity):
        if math.hypot(*g) == 0.0:
            raise ArgumentError(
                "BadInvalidArgument", 1, f"GravityWaypoints[{i}]: a zero vector has no direction"
            )
    return FollowPathGoal(tilt, gravity)


def _joints(msg: Any) -> Values:
    names = list(msg.name)
    values: Values = {}
    for joint, path, default in _JOINTS:
        index = names.index(joint) if joint in names else default
        if index < len(msg.position):
            values[path] = float(msg.position[index])
    return values


def _stability(msg: Any) -> Values:
    g = msg.gravity
    return {
        "Signals.Gravity": [float(g.x), float(g.y), float(g.z)],
        "Signals.Stable": bool(msg.stable),
        "Signals.StabilityMargin": float(msg.margin),
        "Signals.Moving": bool(msg.moving),
    }


def _feedback(fb: Any) -> Values:
    return {
        "Command.Feedback.Progress": float(fb.progress),
        "Command.Feedback.Stable": bool(fb.stable),
        "Command.Feedback.Margin": float(fb.margin),
    }


def _result(result: Any) -> Values:
    return {
        "Command.Result.Tilt": [float(t) for t in result.tilt],
        "Command.Result.FirstUnstableSample": int(result.first_unstable_sample),
        "Command.Result.UnbalancedBodies": list(result.unbalanced_bodies),
    }


PROFILE = KindProfile(
    counters=COUNTERS,
    signals=(
        VariableSpec(
            "Signals.TiltX",
            "Double",
            "tilt_x joint angle as the encoders read it (~/joint_states), rad",
            unit="C81",
        ),
        VariableSpec(
            "Signals.TiltY", "Double", "tilt_y joint angle as the encoders read it, rad", unit="C81"
        ),
        VariableSpec(
            "Signals.Gravity",
            "Double",
            "unit gravity direction, assembly frame (~/stability)",
            array=True,
            unit="C62",
        ),
        VariableSpec("Signals.Stable", "Boolean", "the assembly is potentially stable at this gravity"),
        VariableSpec(
            "Signals.StabilityMargin",
            "Double",
            "rad to the stable region's boundary (> 0 inside)",
            unit="C81",
        ),
        VariableSpec("Signals.Moving", "Boolean", "a commanded path is being executed"),
    ),
    streams=(
        StreamLink("joint_states", JointState, _joints),
        StreamLink("stability", StabilityStatus, _stability),
    ),
    action=ActionLink(
        method=MethodSpec(
            "FollowPath",
            "start ~/follow_path through waypoints: give TiltWaypoints or GravityWaypoints, the other empty",
            (
                ArgumentSpec("TiltWaypoints", "Double", "flattened (tilt_x, tilt_y) pairs, rad", True),
                ArgumentSpec("GravityWaypoints", "Double", "flattened (x, y, z) gravity directions", True),
            ),
        ),
        check=lambda spec, args, _context: check_follow_path(spec, args),
        action_type=FollowPath,
        action_name="follow_path",
        feedback=(
            VariableSpec(
                "Command.Feedback.Progress", "Double", "0..1 of the planned path's duration", unit="C62"
            ),
            VariableSpec("Command.Feedback.Stable", "Boolean", "stable now"),
            VariableSpec("Command.Feedback.Margin", "Double", "rad, stability margin now", unit="C81"),
        ),
        result=(
            VariableSpec(
                "Command.Result.Tilt",
                "Double",
                "(tilt_x, tilt_y) where the fixture stopped, rad",
                array=True,
                unit="C81",
            ),
            VariableSpec(
                "Command.Result.FirstUnstableSample",
                "Int32",
                "REFUSED: first path sample not certified, else -1",
            ),
            VariableSpec(
                "Command.Result.UnbalancedBodies",
                "String",
                "REFUSED: bodies that lose equilibrium there",
                array=True,
            ),
        ),
        feedback_values=_feedback,
        result_values=_result,
    ),
)
