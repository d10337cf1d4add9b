"""The throwing arm as the gateway shows it: its sensor bit, its methods and its counters.

Methods: FeedPart (~/feed_part) and PlacePart (~/place_part: the infeed of a new part).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from std_msgs.msg import Bool

from feeder_cell.gateway.arguments import UINT32_MAX, ArgumentError, check_count, read_integer, read_number
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
from feeder_msgs.action import FeedPart
from feeder_msgs.msg import DeviceStatus
from feeder_msgs.srv import ArmPlacePart
from feeder_sim.throwing.counters import COUNTERS

__all__ = ["PROFILE", "FeedPartGoal", "PlacePartCall", "check_feed_part", "check_place_part"]


@dataclass(frozen=True)
class FeedPartGoal:
    """A checked FeedPart call."""

    max_throws: int
    timeout: float

    def message(self) -> Any:
        """Return the ~/feed_part goal."""
        return FeedPart.Goal(max_throws=self.max_throws, timeout=self.timeout)


def check_feed_part(spec: MethodSpec, args: list[Argument]) -> FeedPartGoal:
    """Check FeedPart(MaxThrows, Timeout)."""
    check_count(spec, args)
    max_throws = read_integer(args[0], 0, "MaxThrows")
    if not 1 <= max_throws <= UINT32_MAX:
        raise ArgumentError("BadInvalidArgument", 0, f"MaxThrows: must be >= 1 (a UInt32), got {max_throws}")
    timeout = read_number(args[1], 1, "Timeout")
    if timeout < 0:
        raise ArgumentError(
            "BadInvalidArgument", 1, f"Timeout: must be >= 0 s (0: no limit), got {timeout!r}"
        )
    return FeedPartGoal(max_throws, timeout)


@dataclass(frozen=True)
class PlacePartCall:
    """A checked PlacePart call: the infeed puts a new part at rest on a hull edge at a throw radius."""

    edge: int
    radius: float

    def message(self) -> Any:
        """Return the ~/place_part request."""
        return ArmPlacePart.Request(edge=self.edge, radius=self.radius)


def check_place_part(spec: MethodSpec, args: list[Argument]) -> PlacePartCall:
    """Check PlacePart(Edge, Radius); the device checks the edge against the part and the radius's range."""
    check_count(spec, args)
    edge = read_integer(args[0], 0, "Edge", "Int32")
    radius = read_number(args[1], 1, "Radius")
    if radius <= 0:
        raise ArgumentError("BadInvalidArgument", 1, f"Radius: must be > 0 m, got {radius!r}")
    return PlacePartCall(edge, radius)


def _sensor(msg: Any) -> Values:
    return {"Signals.Sensor": bool(msg.data)}


def _feedback(fb: Any) -> Values:
    return {
        "Command.Feedback.Throws": int(fb.throws),
        "Command.Feedback.SensorAtRest": bool(fb.sensor_at_rest),
    }


def _final_feedback(result: Any) -> Values:
    """Return the last throw's feedback as the result states it (feeding.py: it counts the throws used)."""
    return {
        "Command.Feedback.Throws": int(result.throws),
        "Command.Feedback.SensorAtRest": bool(result.sensor_at_rest),
    }


def _result(result: Any) -> Values:
    return {
        "Command.Result.Throws": int(result.throws),
        "Command.Result.SensorAtRest": bool(result.sensor_at_rest),
        "Command.Result.Edge": int(result.edge),
    }


PROFILE = KindProfile(
    counters=COUNTERS,
    signals=(
        VariableSpec(
            "Signals.Sensor", "Boolean", "the one-bit proximity sensor (~/sensor) as the device delivers it"
        ),
    ),
    # std_msgs/Bool has no header: the link stamps it by its arrival (ros_link.RosLink).
    streams=(StreamLink("sensor", Bool, _sensor, stamped=False),),
    action=ActionLink(
        method=MethodSpec(
            "FeedPart",
            "start ~/feed_part: throw until the sensor presents the part, MaxThrows or Timeout",
            (
                ArgumentSpec("MaxThrows", "UInt32", "maximum throws, >= 1"),
                ArgumentSpec(
                    "Timeout", "Double", "s of the device's clock, >= 0 (0: no limit beyond MaxThrows)"
                ),
            ),
        ),
        check=lambda spec, args, _context: check_feed_part(spec, args),
        action_type=FeedPart,
        action_name="feed_part",
        feedback=(
            VariableSpec("Command.Feedback.Throws", "UInt32", "throws so far in the executing goal"),
            VariableSpec(
                "Command.Feedback.SensorAtRest", "Boolean", "the bit read at rest after the last throw"
            ),
        ),
        result=(
            VariableSpec("Command.Result.Throws", "UInt32", "throws the last goal used"),
            VariableSpec("Command.Result.SensorAtRest", "Boolean", "the last bit read with the part at rest"),
            VariableSpec(
                "Command.Result.Edge",
                "Int32",
                "ground-truth edge after the last throw (logging only; -1 unknown)",
            ),
        ),
        feedback_values=_feedback,
        result_values=_result,
        final_feedback=_final_feedback,
    ),
    services=(
        ServiceLink(
            MethodSpec(
                "PlacePart",
                "infeed: a new part at rest on hull edge Edge at throw radius Radius (~/place_part)",
                (
                    ArgumentSpec("Edge", "Int32", "stable hull edge of the part"),
                    ArgumentSpec("Radius", "Double", "m from the arm's axis, > 0, in the throw map's domain"),
                ),
            ),
            lambda spec, args, _context: check_place_part(spec, args),
            ArmPlacePart,
            "place_part",
            # Placing a part is how a lost part's FAULT ends, so that FAULT does not refuse it.
            Availability(fault_codes=frozenset({DeviceStatus.FAULT_PART_LOST})),
        ),
    ),
)
