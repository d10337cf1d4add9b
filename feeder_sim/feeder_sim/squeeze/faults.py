"""Injected faults of the simulated squeeze gripper: their magnitudes checked, their effects on the model.

ROS-free: the squeeze_gripper node wires ``~/inject_fault`` and the ``inject_faults`` parameter to
``GripperFaults``; the gripper asks it at the moments a fault can act. A fault that draws at random has
its own numpy Generator seeded with the fault's seed, so a run is the same for the same seed.

| fault | magnitude | effect |
| --- | --- | --- |
| ``jaw_stall`` | none | armed: the jaws stall at the next squeeze before reaching the part (stops) |
| ``part_dropped`` | value: probability p in [0, 1] | each squeeze drops the part with p (stops) |
| ``jaw_worn`` | value: friction increase in (0, 2] | a worn pad: the dynamic fidelity's friction rises |
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal, get_args

import numpy as np

from feeder_planner.errors import InputError
from feeder_planner.squeeze.tolerances import MAX_FRICTION

__all__ = [
    "FAULT_INFO",
    "GRIPPER_FAULTS",
    "FaultInfo",
    "GripperFaultName",
    "GripperFaults",
    "check_fault_name",
]

GripperFaultName = Literal["jaw_stall", "part_dropped", "jaw_worn"]
GRIPPER_FAULTS: tuple[GripperFaultName, ...] = get_args(GripperFaultName)


@dataclass(frozen=True)
class FaultInfo:
    """What a fault does, what its value means (empty: it takes none), whether it stops the gripper."""

    description: str
    value_meaning: str
    stops: bool


FAULT_INFO: dict[GripperFaultName, FaultInfo] = {
    "jaw_stall": FaultInfo("the jaws stall at the next squeeze before they reach the part", "", True),
    "part_dropped": FaultInfo(
        "each squeeze drops the part from the jaws with probability value", "probability in [0, 1]", True
    ),
    "jaw_worn": FaultInfo(
        "a worn jaw pad raises the friction between jaws and part by value (dynamic fidelity)",
        "friction increase in (0, 2]",
        False,
    ),
}


def check_fault_name(name: str) -> GripperFaultName:
    """Return ``name`` as a gripper fault, or raise InputError naming ``name``."""
    if name not in GRIPPER_FAULTS:
        raise InputError("name", f"unknown fault {name!r}; the gripper's: {', '.join(GRIPPER_FAULTS)}")
    return name


@dataclass
class GripperFaults:
    """The faults in force: an armed stall, a drop probability with its draws, a wear."""

    stall_armed: bool = False
    drop_probability: float = 0.0
    wear: float = 0.0
    drop_rng: np.random.Generator = field(default_factory=lambda: np.random.default_rng(0))

    def inject(self, name: str, value: float = 0.0, seed: int = 0) -> None:
        """Put fault ``name`` in force with its magnitude; InputError names a bad ``value``."""
        fault = check_fault_name(name)
        if fault == "jaw_stall":
            self.stall_armed = True
        elif fault == "part_dropped":
            if not math.isfinite(value) or not 0.0 <= value <= 1.0:
                raise InputError("value", f"part_dropped: a probability in [0, 1], got {value!r}")
            self.drop_probability = value
            self.drop_rng = np.random.default_rng(seed)
        else:
            if not math.isfinite(value) or not 0.0 < value <= MAX_FRICTION:
                raise InputError(
                    "value", f"jaw_worn: a friction increase in (0, {MAX_FRICTION:g}], got {value!r}"
                )
            self.wear = value

    def clear(self, name: str) -> None:
        """Take fault ``name`` out of force."""
        fault = check_fault_name(name)
        if fault == "jaw_stall":
            self.stall_armed = False
        elif fault == "part_dropped":
            self.drop_probability = 0.0
        else:
            self.wear = 0.0

    def describe(self, name: str) -> str:
        """Return what fault ``name`` does now, with its magnitude."""
        fault = check_fault_name(name)
        if fault == "jaw_stall":
            return "armed: the jaws stall at the next squeeze" if self.stall_armed else "not armed"
        if fault == "part_dropped":
            return f"drops the part with probability {self.drop_probability:g} a squeeze"
        return f"friction raised by {self.wear:g}"

    def stalls(self) -> bool:
        """Whether the jaws stall now (an armed stall acts once, at the closing it meets)."""
        if self.stall_armed:
            self.stall_armed = False
            return True
        return False

    def drops(self) -> bool:
        """Whether this squeeze drops the part (one draw a squeeze while the fault is in force)."""
        return self.drop_probability > 0.0 and float(self.drop_rng.random()) < self.drop_probability
