"""The simulated squeeze gripper: parallel jaws that turn, close on the part, read its width and open.

ROS-free: the squeeze_gripper node advances a ``SqueezeGripper`` by node-clock time and publishes what it
shows. A squeeze at gripper angle alpha has three phases, each timed by the gripper's speeds:

- TURNING: the gripper turns to alpha the short way modulo pi (its jaws are symmetric), at ``turn_speed``;
- CLOSING: the jaws close from ``open_width`` at ``jaw_speed`` (each jaw at half of it) until they stop on
  the part; the part turns as the fidelity says, shown turning while the jaws touch it;
- OPENING: the jaws open back to ``open_width``; the width read when they stopped is the squeeze's reading.

The outcome of a squeeze is the fidelity's: ``ideal`` is Goldberg's frictionless quasi-static squeeze
(``feeder_sim.squeeze.ideal``, the contact walk), ``dynamic`` the pymunk model with friction and jaw
speed (``feeder_sim.squeeze.dynamic``). Faults act here (``feeder_sim.squeeze.faults``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from feeder_planner.errors import FeederError, InputError
from feeder_planner.fields_io import finite_number
from feeder_planner.squeeze import SqueezeFunction, check_friction, squeeze_function
from feeder_planner.squeeze.diameter import TWO_PI, wrap
from feeder_sim.squeeze.dynamic import DynamicSettings, dynamic_squeeze
from feeder_sim.squeeze.faults import GripperFaults
from feeder_sim.squeeze.ideal import ideal_squeeze

__all__ = ["FIDELITIES", "Phase", "SqueezeGripper", "SqueezeReading", "GripperFaultError"]

Phase = Literal["IDLE", "TURNING", "CLOSING", "OPENING"]
FIDELITIES = ("ideal", "dynamic")


class GripperFaultError(FeederError):
    """A fault stopped the gripper: its code name (``jaw_stall``, ``part_dropped``) and what happened."""

    def __init__(self, name: str, text: str) -> None:
        self.name = name
        super().__init__(text)


@dataclass(frozen=True)
class SqueezeReading:
    """One finished squeeze: the gripper angle, the width read (m) and the part's orientation after."""

    angle: float
    width: float
    orientation: float
    index: int


@dataclass
class _Squeeze:
    """The squeeze in progress: its target, the outcome the fidelity gave, and the phase clocks."""

    angle: float
    turn_from: float
    turn_time: float
    close_time: float
    contact_time: float
    width: float
    orientation_before: float
    orientation_after: float
    elapsed: float = 0.0
    stalled: bool = False
    dropped: bool = False


@dataclass
class SqueezeGripper:
    """The gripper and the part between its jaws; ``advance`` moves both by simulated time."""

    outline: np.ndarray
    fidelity: str = "ideal"
    friction: float = 0.0
    jaw_speed: float = 0.05
    turn_speed: float = 3.0
    open_width: float = 0.0
    dynamic: DynamicSettings = field(default_factory=DynamicSettings)
    seed: int = 0
    gripper_angle: float = 0.0
    orientation: float = math.nan
    holding: bool = False
    time: float = 0.0
    squeezes: int = 0
    readings: list[SqueezeReading] = field(default_factory=list)
    faults: GripperFaults = field(default_factory=GripperFaults)

    def __post_init__(self) -> None:
        if self.fidelity not in FIDELITIES:
            raise InputError("fidelity", f"must be one of {', '.join(FIDELITIES)}, got {self.fidelity!r}")
        self.friction = check_friction(self.friction)
        self.squeeze: SqueezeFunction = squeeze_function(self.outline)
        hull = self.squeeze.diameter.hull
        largest = float(2.0 * np.hypot(hull[:, 0], hull[:, 1]).max())
        if self.open_width == 0.0:
            self.open_width = 1.2 * largest
        elif self.open_width < largest:
            raise InputError(
                "open_width", f"{self.open_width:g} m is narrower than the part ({largest:.6g} m across)"
            )
        self.jaw_width = self.open_width
        self.phase: Phase = "IDLE"
        self.current: _Squeeze | None = None
        self.dropped = False  # the part fell from the jaws (a fault) and was not placed again
        self.rng = np.random.default_rng(self.seed)

    # --- commands ------------------------------------------------------------------------------------
    def place(self, orientation: float | None) -> float:
        """Put the part between the open jaws at ``orientation`` (rad; None: uniform from the seed)."""
        if self.phase != "IDLE":
            raise FeederError(f"cannot place the part while the gripper is {self.phase}")
        theta = (
            float(self.rng.uniform(0.0, TWO_PI))
            if orientation is None
            else finite_number(orientation, "orientation")
        )
        self.orientation, self.holding, self.dropped = theta, True, False
        return theta

    @property
    def effective_friction(self) -> float:
        """The friction between jaws and part now: the configured one plus a worn jaw's increase."""
        return min(self.friction + self.faults.wear, 2.0)

    def start(self, angle: float) -> None:
        """Start a squeeze at gripper angle ``angle`` (rad, world); refused unless idle and holding a part."""
        angle = finite_number(angle, "angle")
        if self.phase != "IDLE":
            raise FeederError(f"a squeeze is in progress ({self.phase}); wait for it")
        if not self.holding:
            raise FeederError("no part between the jaws: place one first (~/place_part)")
        # The jaws are symmetric: the gripper turns to the nearest angle equal to ``angle`` modulo pi.
        turn = math.remainder(angle - self.gripper_angle, math.pi)
        relative = self.orientation - angle
        if self.fidelity == "ideal":
            outcome = ideal_squeeze(self.outline, relative)
            after, width = angle + outcome.orientation, outcome.width
        else:
            result = dynamic_squeeze(
                self.outline, relative, self.effective_friction, self.jaw_speed, self.dynamic
            )
            after, width = angle + result.orientation, result.width
        travel = max(self.open_width - width, 0.0)
        close_time = travel / self.jaw_speed
        before_contact = max(self.open_width - self.squeeze.diameter.direct(relative), 0.0) / self.jaw_speed
        self.current = _Squeeze(
            angle=angle,
            turn_from=self.gripper_angle,
            turn_time=abs(turn) / self.turn_speed,
            close_time=close_time,
            contact_time=min(before_contact, close_time),
            width=width,
            orientation_before=self.orientation,
            orientation_after=after,
        )
        self.current.angle = self.gripper_angle + turn
        self.phase = "TURNING"

    def recover(self) -> None:
        """After a fault is reset: open the jaws from where they stopped."""
        self.current = None
        self.phase = "OPENING" if self.jaw_width < self.open_width else "IDLE"

    def halt(self) -> None:
        """Stop where it is and open the jaws (a stop or a cancel): the squeeze in progress is not read."""
        if self.current is not None and self.phase in ("TURNING", "CLOSING"):
            self.current = None
            self.phase = "OPENING" if self.jaw_width < self.open_width else "IDLE"

    # --- time ----------------------------------------------------------------------------------------
    def advance(self, dt: float) -> list[SqueezeReading]:
        """Advance by ``dt`` s; return the squeezes read in that time. A fault raises GripperFaultError."""
        if dt <= 0.0:
            return []
        self.time += dt
        done: list[SqueezeReading] = []
        remaining = dt
        while remaining > 0.0:
            remaining = self._step(remaining, done)
        return done

    def _step(self, dt: float, done: list[SqueezeReading]) -> float:
        """Advance within the present phase; return the time left over into the next phase."""
        if self.phase == "IDLE":
            return 0.0
        if self.phase == "OPENING":
            travel = self.open_width - self.jaw_width
            needed = travel / self.jaw_speed
            if dt < needed:
                self.jaw_width += dt * self.jaw_speed
                return 0.0
            self.jaw_width, self.phase, self.current = self.open_width, "IDLE", None
            return dt - needed
        current = self.current
        assert current is not None
        if self.phase == "TURNING":
            left = current.turn_time - current.elapsed
            if dt < left:
                current.elapsed += dt
                fraction = current.elapsed / current.turn_time if current.turn_time > 0 else 1.0
                self.gripper_angle = current.turn_from + fraction * (current.angle - current.turn_from)
                return 0.0
            self.gripper_angle = current.angle
            current.elapsed = 0.0
            self.phase = "CLOSING"
            return dt - left
        # CLOSING
        left = current.close_time - current.elapsed
        step = min(dt, left)
        current.elapsed += step
        self.jaw_width = self.open_width - current.elapsed * self.jaw_speed
        if self.faults.stalls():
            # Stalled before the part: the jaws stay where they are until a reset opens them.
            self.current, self.phase = None, "IDLE"
            raise GripperFaultError(
                "jaw_stall",
                f"the jaws stalled at {self.jaw_width * 1e3:.3f} mm, closing at {current.angle:.4f} rad",
            )
        if current.elapsed > current.contact_time and current.close_time > current.contact_time:
            share = (current.elapsed - current.contact_time) / (current.close_time - current.contact_time)
            self.orientation = current.orientation_before + min(share, 1.0) * (
                current.orientation_after - current.orientation_before
            )
        if dt < left:
            return 0.0
        self.jaw_width = current.width
        self.squeezes += 1
        if self.faults.drops():
            self.orientation, self.holding, self.current, self.phase = math.nan, False, None, "OPENING"
            self.dropped = True
            raise GripperFaultError(
                "part_dropped", f"the part dropped from the jaws at squeeze {self.squeezes}"
            )
        self.orientation = current.orientation_after
        reading = SqueezeReading(current.angle, current.width, wrap(self.orientation, TWO_PI), self.squeezes)
        self.readings.append(reading)
        done.append(reading)
        self.phase = "OPENING"
        return dt - left
