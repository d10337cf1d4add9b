"""The squeeze gripper's goal machine: a plan's squeezes one after another (``~/squeeze``: a plan of one).

ROS-free: the squeeze_gripper node's ``~/squeeze`` and ``~/run_plan`` actions drive a ``PlanGoal`` from its
ticks, and a test drives it the same way without ROS. After each tick of the gripper the goal takes in the
squeezes read, starts the next squeeze when the gripper is idle, and ends:

- **DONE** once every squeeze has been read (and the jaws opened);
- **FAULT** when a fault stops the gripper (a stall, a dropped part), at once;
- **CANCELED** or **TIMEOUT** (node clock from acceptance) once the jaws are open again: the squeeze in
  progress is halted where it is and its jaws open (a squeeze halted before it read is not counted).

Order of the decision at a tick: a fault, then every squeeze done, then cancel, then timeout.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from feeder_device.declarations import deadline_ns
from feeder_planner.errors import FeederError, InputError
from feeder_planner.limits import MAX_GOAL_TIMEOUT
from feeder_planner.squeeze import check_plan_angles
from feeder_sim.squeeze.gripper import SqueezeGripper
from feeder_sim.squeeze.tolerances import MAX_GOAL_SQUEEZES

__all__ = ["OUTCOME_CODES", "PlanGoal", "PlanOutcome", "PlanReport", "PlanRequest", "check_plan_goal"]

# The result codes of feeder_msgs/action/Squeeze and RunPlan (tests/squeeze checks they agree).
OUTCOME_CODES = {"DONE": 1, "TIMEOUT": 3, "FAULT": 4, "CANCELED": 5}


@dataclass(frozen=True)
class PlanRequest:
    """A checked goal: the gripper angles (rad) in order, and a timeout (s of node clock; 0: none)."""

    angles: tuple[float, ...]
    timeout: float


def check_plan_goal(angles: object, timeout: object, field: str = "angles") -> PlanRequest:
    """Return the checked goal, or raise InputError naming ``field`` (or ``field[i]``) or ``timeout``."""
    if isinstance(angles, (list, tuple)) and len(angles) > MAX_GOAL_SQUEEZES:
        raise InputError(field, f"{len(angles)} squeezes; the limit per goal is {MAX_GOAL_SQUEEZES}")
    checked = check_plan_angles(list(angles) if isinstance(angles, (list, tuple)) else angles, field)
    if isinstance(timeout, bool) or not isinstance(timeout, (int, float)):
        raise InputError("timeout", f"must be a number of seconds, got {timeout!r}")
    if not math.isfinite(timeout) or timeout < 0:
        raise InputError("timeout", f"must be finite and >= 0 s (0: no limit), got {timeout!r}")
    if timeout > MAX_GOAL_TIMEOUT:
        raise InputError("timeout", f"must be at most {MAX_GOAL_TIMEOUT:.6g} s (a year), got {timeout!r}")
    return PlanRequest(checked, float(timeout))


@dataclass(frozen=True)
class PlanReport:
    """One feedback: the squeeze in progress (0-based) of how many, the phase, width and orientation."""

    squeeze: int
    total: int
    phase: str
    width: float
    orientation: float


@dataclass(frozen=True)
class PlanOutcome:
    """How a goal ended: the outcome, why, the widths read, the part's orientation, the fault."""

    name: str
    message: str
    widths: tuple[float, ...]
    orientation: float
    fault_code: int = 0
    fault_text: str = ""

    @property
    def code(self) -> int:
        """The action's result code of the outcome."""
        return OUTCOME_CODES[self.name]


class PlanGoal:
    """One goal, fed the gripper's ticks: it starts each squeeze in turn and ends (module docstring)."""

    def __init__(self, request: PlanRequest, start_ns: int) -> None:
        self.request = request
        self.deadline_ns = deadline_ns(start_ns, request.timeout)
        self.widths: list[float] = []
        self.started = 0
        self.reports: list[PlanReport] = []
        self.outcome: PlanOutcome | None = None
        self.cancel_reason = ""
        self._stopping = ""  # CANCELED or TIMEOUT once asked: the jaws are opening
        self._last_phase = ""
        self._counted = 0  # the gripper's squeeze count when this goal's last squeeze started

    @property
    def done(self) -> bool:
        """Whether the goal has ended (``outcome`` says how)."""
        return self.outcome is not None

    def cancel(self, reason: str) -> None:
        """End CANCELED once the jaws are open again."""
        if not self.done and not self.cancel_reason:
            self.cancel_reason = reason

    def end_now(
        self, name: str, message: str, gripper: SqueezeGripper | None, code: int = 0, text: str = ""
    ) -> None:
        """End at once (the device stopped, or stopped being active)."""
        if not self.done:
            self._finish(name, message, gripper, code, text)

    def tick(
        self,
        now_ns: int,
        gripper: SqueezeGripper,
        fault: tuple[int, str] | None,
    ) -> None:
        """Close the device's tick: take in the squeeze read, then end, or start the next squeeze."""
        if self.done:
            return
        if self.started > len(self.widths) and gripper.squeezes > self._counted:
            # The squeeze this goal started has been read (the gripper counts every squeeze it reads).
            self._counted = gripper.squeezes
            self.widths.append(gripper.readings[-1].width)
        if gripper.phase != self._last_phase:
            self._last_phase = gripper.phase
            self.reports.append(
                PlanReport(
                    max(self.started - 1, 0),
                    len(self.request.angles),
                    gripper.phase,
                    gripper.jaw_width,
                    gripper.orientation,
                )
            )
        if fault is not None:
            self._finish("FAULT", f"device faulted during the goal: {fault[1]}", gripper, *fault)
            return
        total = len(self.request.angles)
        timed_out = self.deadline_ns is not None and now_ns >= self.deadline_ns
        if not self._stopping and (self.cancel_reason or timed_out) and len(self.widths) < total:
            self._stopping = "CANCELED" if self.cancel_reason else "TIMEOUT"
            gripper.halt()
        if gripper.phase != "IDLE":
            return
        if len(self.widths) == total:
            self._finish("DONE", f"{total} squeeze{'' if total == 1 else 's'} done", gripper)
        elif self._stopping == "CANCELED":
            self._finish(
                "CANCELED", f"{self.cancel_reason} after {len(self.widths)} of {total} squeezes", gripper
            )
        elif self._stopping == "TIMEOUT":
            self._finish(
                "TIMEOUT",
                f"timeout of {self.request.timeout:g} s (node clock) passed after "
                f"{len(self.widths)} of {total} squeezes",
                gripper,
            )
        else:
            try:
                self._counted = gripper.squeezes
                gripper.start(self.request.angles[self.started])
            except FeederError as error:
                self._finish("FAULT", f"squeeze {self.started} not started: {error}", gripper)
                return
            self.started += 1

    def _finish(
        self, name: str, message: str, gripper: SqueezeGripper | None, code: int = 0, text: str = ""
    ) -> None:
        orientation = gripper.orientation if gripper is not None else math.nan
        self.outcome = PlanOutcome(name, message, tuple(self.widths), orientation, code, text)
