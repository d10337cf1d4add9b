"""The squeeze gripper's station: what one tick does to the gripper and what a plan goal starts, free of ROS.

One definition of the gripper's behaviour per tick (docs/devices.md, "The station"), run by the
squeeze_gripper node (an adapter: the device kit owns the loop, the node publishes and counts what the
station reports) and by any ROS-free driver.

One tick advances the gripper by the elapsed node-clock time, at most ``MAX_ADVANCE_PER_TICK`` (a longer
gap is reported as capped): the jaws close, the part turns to the next stable orientation of the
squeeze function (Goldberg, "Orienting polygonal parts without sensors": the diameter function's
squeeze map), the jaws open. A fault that acts during the advance (a stall, a dropped part) stops the
gripper; the station reports it with the remedy. A ``~/squeeze`` or ``~/run_plan`` goal is one
``PlanGoal``, decided after each tick.
"""

from __future__ import annotations

from typing import NamedTuple

from feeder_device.declarations import ActiveFault
from feeder_planner.parts import Part
from feeder_sim.squeeze.gripper import GripperFaultError, SqueezeGripper
from feeder_sim.squeeze.parameters import GripperParameters, configure_gripper
from feeder_sim.squeeze.plan_goal import PlanGoal, PlanRequest
from feeder_sim.squeeze.tolerances import MAX_ADVANCE_PER_TICK

__all__ = ["SqueezeTick", "SqueezeStation"]

NANOSECONDS = 1_000_000_000
REMEDY = {"part_dropped": " (~/place_part puts it back)", "jaw_stall": " (~/reset opens the jaws)"}


class SqueezeTick(NamedTuple):
    """What one tick did: squeezes finished, whether the gap was capped, the fault that acted (or None).

    ``fault`` is (fault name, text with its remedy).
    """

    squeezes: int
    capped: bool
    fault: tuple[str, str] | None


class SqueezeStation:
    """The gripper and its part, with the tick, the plan goal's start and the faults.

    Parameters
    ----------
    p
        The device's parameters.
    """

    def __init__(self, p: GripperParameters) -> None:
        self.p = p
        gripper, part = configure_gripper(p)
        self.gripper: SqueezeGripper = gripper
        self.part: Part = part

    def tick(self, elapsed_ns: int) -> SqueezeTick:
        """Advance the gripper by ``elapsed_ns`` (capped); report the squeezes done and a fault that acted."""
        gripper = self.gripper
        elapsed = elapsed_ns / NANOSECONDS
        capped = elapsed > MAX_ADVANCE_PER_TICK
        before = gripper.squeezes
        fault = None
        try:
            gripper.advance(MAX_ADVANCE_PER_TICK if capped else elapsed)
        except GripperFaultError as error:
            fault = (error.name, f"{error}{REMEDY.get(error.name, '')}")
        return SqueezeTick(gripper.squeezes - before, capped, fault)

    @staticmethod
    def start(request: PlanRequest, start_ns: int) -> PlanGoal:
        """Return the goal machine of a checked request, started at ``start_ns``."""
        return PlanGoal(request, start_ns)

    def advance_goal(self, goal: PlanGoal, now_ns: int, fault: tuple[int, str] | None) -> None:
        """Close the tick for the goal: the squeezes read, then end or start the next squeeze."""
        goal.tick(now_ns, self.gripper, fault)

    def apply_fault(self, fault: ActiveFault) -> None:
        """Put an injected fault into the gripper model (checked there: InputError naming the value)."""
        self.gripper.faults.inject(fault.spec.name, fault.value, fault.seed)

    def clear_fault(self, name: str, stalled: bool) -> bool:
        """Take a fault out of the model; return whether the stall that acted ends (the jaws open).

        ``stalled``: whether the driver holds the stall's FAULT. A dropped part stays dropped until a part
        is placed again.
        """
        self.gripper.faults.clear(name)
        if name == "jaw_stall" and stalled:
            self.gripper.recover()
            return True
        return False
