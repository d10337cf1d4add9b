"""The squeeze gripper as the gateway shows it: jaws and part, RunPlan (~/run_plan), PlacePart, counters.

A PLC runs a plan over OPC UA: the angles from `feeder squeeze-plan` (or the squeeze_planner node) as the
RunPlan method's Angles array; PlacePart is the infeed of a new part between the open jaws.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from feeder_cell.gateway.arguments import ArgumentError, check_count, read_number, read_numbers
from feeder_cell.gateway.spec import (
    ActionLink,
    Argument,
    ArgumentSpec,
    Availability,
    KindProfile,
    MethodSpec,
    ServiceLink,
    StreamLink,
    Values,
    VariableSpec,
)
from feeder_msgs.action import RunPlan
from feeder_msgs.msg import SqueezeState
from feeder_msgs.srv import SqueezePlacePart
from feeder_sim.squeeze.counters import COUNTERS
from feeder_sim.squeeze.tolerances import MAX_GOAL_SQUEEZES

__all__ = ["PROFILE", "PlacePartCall", "RunPlanGoal", "check_place_part", "check_run_plan"]


@dataclass(frozen=True)
class RunPlanGoal:
    """A checked RunPlan call: at least one finite angle."""

    angles: tuple[float, ...]
    timeout: float

    def message(self) -> Any:
        """Return the ~/run_plan goal."""
        return RunPlan.Goal(angles=list(self.angles), timeout=self.timeout)


def check_run_plan(spec: MethodSpec, args: list[Argument]) -> RunPlanGoal:
    """Check RunPlan(Angles, Timeout)."""
    check_count(spec, args)
    angles = read_numbers(args[0], 0, "Angles")
    if not angles:
        raise ArgumentError("BadInvalidArgument", 0, "Angles: a plan needs at least one squeeze, got none")
    if len(angles) > MAX_GOAL_SQUEEZES:
        raise ArgumentError(
            "BadInvalidArgument", 0, f"Angles: {len(angles)} squeezes; the limit is {MAX_GOAL_SQUEEZES}"
        )
    timeout = read_number(args[1], 1, "Timeout")
    if timeout < 0:
        raise ArgumentError(
            "BadInvalidArgument", 1, f"Timeout: must be >= 0 s (0: no limit), got {timeout!r}"
        )
    return RunPlanGoal(angles, timeout)


@dataclass(frozen=True)
class PlacePartCall:
    """A checked PlacePart call: the infeed puts a new part between the open jaws at an orientation."""

    orientation: float

    def message(self) -> Any:
        """Return the ~/place_part request."""
        return SqueezePlacePart.Request(orientation=self.orientation)


def check_place_part(spec: MethodSpec, args: list[Argument]) -> PlacePartCall:
    """Check PlacePart(Orientation)."""
    check_count(spec, args)
    return PlacePartCall(read_number(args[0], 0, "Orientation"))


def _state(msg: Any) -> Values:
    return {
        "Signals.JawWidth": float(msg.jaw_width),
        "Signals.GripperAngle": float(msg.gripper_angle),
        "Signals.Holding": bool(msg.holding),
        "Signals.Phase": str(msg.phase),
    }


def _feedback(fb: Any) -> Values:
    return {"Command.Feedback.Squeeze": int(fb.squeeze), "Command.Feedback.JawWidth": float(fb.jaw_width)}


def _result(result: Any) -> Values:
    return {
        "Command.Result.Squeezes": int(result.squeezes),
        "Command.Result.JawWidths": [float(w) for w in result.jaw_widths],
    }


PROFILE = KindProfile(
    counters=COUNTERS,
    signals=(
        VariableSpec(
            "Signals.JawWidth",
            "Double",
            "distance between the jaws (~/state), the jaw-width sensor, m",
            unit="MTR",
        ),
        VariableSpec("Signals.GripperAngle", "Double", "gripper angle, world frame, rad", unit="C81"),
        VariableSpec("Signals.Holding", "Boolean", "a part is between the jaws"),
        VariableSpec("Signals.Phase", "String", "IDLE, TURNING, CLOSING or OPENING"),
    ),
    streams=(StreamLink("state", SqueezeState, _state),),
    action=ActionLink(
        method=MethodSpec(
            "RunPlan",
            "start ~/run_plan: squeeze at each angle in turn (a plan from feeder squeeze-plan)",
            (
                ArgumentSpec("Angles", "Double", "gripper angles, rad, world frame, at least one", True),
                ArgumentSpec("Timeout", "Double", "s of the device's clock, >= 0 (0: no limit)"),
            ),
        ),
        check=lambda spec, args, _context: check_run_plan(spec, args),
        action_type=RunPlan,
        action_name="run_plan",
        feedback=(
            VariableSpec("Command.Feedback.Squeeze", "UInt32", "index of the squeeze in progress (0-based)"),
            VariableSpec("Command.Feedback.JawWidth", "Double", "jaw width now, m", unit="MTR"),
        ),
        result=(
            VariableSpec("Command.Result.Squeezes", "UInt32", "squeezes the last goal completed"),
            VariableSpec(
                "Command.Result.JawWidths",
                "Double",
                "the width read at each squeeze, m",
                array=True,
                unit="MTR",
            ),
        ),
        feedback_values=_feedback,
        result_values=_result,
    ),
    services=(
        ServiceLink(
            MethodSpec(
                "PlacePart",
                "infeed: a new part between the open jaws at Orientation (~/place_part)",
                (ArgumentSpec("Orientation", "Double", "rad, world frame, finite"),),
            ),
            lambda spec, args, _context: check_place_part(spec, args),
            SqueezePlacePart,
            "place_part",
            # Placing a part is how a dropped part's FAULT ends, so that FAULT does not refuse it.
            Availability(fault_codes=frozenset({SqueezeState.FAULT_PART_DROPPED})),
        ),
    ),
)
