"""The throwing arm as a device runs it, ROS-free: the command queue, the period, and the throw being shown.

The paper's model throws in an instant (an impulsive throw, section II); a device shows each throw over a
motion window of its period so that a subscriber sees the part fly and land. ``ThrowCycle`` keeps what
that adds to the model, on the model's simulated time in integer ns:

- the commands: ``start`` (throw every period), ``throw N`` (a queue of at most ``MAX_QUEUED_THROWS``),
  ``stop``; a ``~/feed_part`` goal asks for its throws through the same queue and period;
- the throw being shown: when it started, its outcome and the speed released at; it lands (and is
  reported) once ``period x motion_fraction`` has passed;
- the pose and joint shown along the way: the flight path fills the first ``FLIGHT_SHOWN`` of the
  window (the part then rests), and the joint swings up at the release speed and back during the first
  ``RELEASE_SHOWN`` (``joint_swing``).

The node publishes what this returns; the goal machine (``feeding``) decides from what the node publishes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from feeder_planner.errors import InputError
from feeder_planner.limits import MAX_QUEUED_THROWS
from feeder_planner.throwing import ArmPart
from feeder_sim.throwing.arm import ThrowingArm
from feeder_sim.throwing.faults import ArmFaults
from feeder_sim.throwing.outcome import ThrowOutcome

__all__ = ["FLIGHT_SHOWN", "RELEASE_SHOWN", "Pose", "Shown", "Motion", "ThrowCycle", "joint_swing", "ns"]

FLIGHT_SHOWN = 0.8
RELEASE_SHOWN = 0.05
Pose = tuple[float, float, float]


def ns(seconds: float) -> int:
    """Return a duration in integer nanoseconds (no rounding drift at epoch magnitudes)."""
    return int(round(seconds * 1e9))


@dataclass(frozen=True)
class Shown:
    """What a tick shows: the part's pose, the joint's angle and velocity, and the throw landing now."""

    pose: Pose
    joint: float = 0.0
    velocity: float = 0.0
    landed: ThrowOutcome | None = None


@dataclass(frozen=True)
class Motion:
    """A throw being shown: when it started (simulated ns), its outcome, and the speed released at."""

    start: int
    outcome: ThrowOutcome
    speed: float


class ThrowCycle:
    """Commands, period and the throw shown, around one arm model and its injected faults."""

    def __init__(self, arm: ThrowingArm, faults: ArmFaults) -> None:
        self.arm = arm
        self.faults = faults
        self.running = False
        self.pending = 0
        self.motion: Motion | None = None
        self.last_throw: int | None = None  # simulated ns of the last throw

    @property
    def busy(self) -> bool:
        """Throwing every period, throws queued, or a throw being shown."""
        return self.running or self.pending > 0 or self.motion is not None

    def doing(self) -> str:
        """Say what keeps the arm busy, for a refusal."""
        if self.running:
            return "throwing every period"
        if self.pending:
            return f"{self.pending} throw(s) queued"
        return "a throw in flight"

    def command(self, command: str, count: int) -> None:
        """Carry out a checked ~/command: queue ``count`` throws, start throwing every period, or stop."""
        if command == "throw":
            self.queue(count)
        elif command == "start":
            self.running = True
        else:  # stop
            self.cancel_commands()

    def place(self, edge: int, radius: float, arm_length: float) -> None:
        """Put the part at rest at (edge, R) on the arm, ending any throw being shown; fields are named."""
        _check_on_arm(radius, arm_length)
        self.arm.place(edge, radius)
        self.motion = None
        self.faults.clear("part_lost")

    def load(self, part: ArmPart, edge: int, radius: float, arm_length: float) -> None:
        """Hold ``part`` instead, at rest at (edge, R), ending any throw being shown; fields are named."""
        _check_on_arm(radius, arm_length)
        self.arm.replace_part(part, edge, radius)
        self.motion = None
        self.faults.clear("part_lost")

    def queue(self, count: int) -> None:
        """Queue ``count`` more throws, or raise InputError naming ``count``."""
        if count < 1:
            raise InputError("count", f"must be >= 1 for 'throw', got {count}")
        if self.pending + count > MAX_QUEUED_THROWS:
            raise InputError(
                "count",
                f"{count} more throws on {self.pending} queued exceeds the queue limit of "
                f"{MAX_QUEUED_THROWS}",
            )
        self.pending += count

    def cancel_commands(self) -> None:
        """Forget the queue and the running cycle (a throw being shown still lands)."""
        self.running, self.pending = False, 0

    def throw_due(self, t: int, period_ns: int, wanted_by_goal: bool, ready: bool) -> bool:
        """Return whether a throw is wanted (running, queued, or a goal's), allowed, and due at ``t``."""
        wanted = self.running or self.pending > 0 or wanted_by_goal
        waited = self.last_throw is None or t - self.last_throw >= period_ns
        return wanted and ready and waited

    def throw(self, t: int) -> ThrowOutcome:
        """Throw once at ``t``; a throw that did not fault is shown from now (``motion``)."""
        if self.pending > 0:
            self.pending -= 1
        self.last_throw = t
        outcome = self.faults.throw()
        if outcome.kind == "fault":
            self.cancel_commands()
        else:
            self.motion = Motion(t, outcome, self.arm.params.speed * self.faults.last_speed_scale)
        return outcome

    def show(self, t: int, window_ns: int) -> Shown:
        """Return what is shown at ``t`` (part pose, joint angle and velocity) and the landing, if now."""
        motion = self.motion
        if motion is None:
            return Shown(self.arm.rest_pose())
        if t - motion.start >= window_ns:
            self.motion = None
            return Shown(self.arm.rest_pose(), landed=motion.outcome)
        fraction = (t - motion.start) / window_ns
        angle, velocity = joint_swing(
            motion.speed, fraction * window_ns * 1e-9, RELEASE_SHOWN * window_ns * 1e-9
        )
        return Shown(self._along_path(motion, fraction), angle, velocity)

    def _along_path(self, motion: Motion, fraction: float) -> Pose:
        """Return the part's pose along the flight path (at rest when the model gives no path)."""
        path = motion.outcome.path
        if not path:
            return self.arm.rest_pose()
        index = min(int(fraction / FLIGHT_SHOWN * (len(path) - 1)), len(path) - 1)
        _, x, y, theta = path[index]
        return (x, y, theta)


def _check_on_arm(radius: float, arm_length: float) -> None:
    """Refuse an R that is not finite or not on the arm, naming ``radius``."""
    if not math.isfinite(radius):
        raise InputError("radius", f"must be finite, got {radius!r}")
    if abs(radius) > arm_length:
        raise InputError("radius", f"must be on the arm (|R| <= arm_length {arm_length:g} m), got {radius:g}")


def joint_swing(speed: float, since: float, release: float) -> tuple[float, float]:
    """Return the arm's joint angle (rad) and velocity (rad/s) ``since`` s into a throw shown.

    The paper's throw is impulsive (the arm reaches W and stops at once, moving no angle); shown over
    ``release`` s, the arm swings up at W for the first half and back at -W for the second, so the
    angle is exactly the integral of the velocity and the arm is level again to catch the part.
    """
    if since >= release or since < 0:
        return 0.0, 0.0
    half = release / 2
    if since < half:
        return speed * since, speed
    return speed * (release - since), -speed
