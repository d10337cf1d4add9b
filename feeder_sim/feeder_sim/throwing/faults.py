"""Injected faults of the simulated throwing arm: their magnitudes checked, their effects on the model.

ROS-free: the throwing_arm node wires ``~/inject_fault`` and the ``inject_faults`` parameter to
``ArmFaults``, which holds the faults in force and puts each into effect on the arm and its sensor. Every
fault that draws at random has its own numpy Generator seeded with the fault's seed, so a run (the same
sensor samples and throws in the same order) is the same for the same seed.

| fault | magnitude | effect |
| --- | --- | --- |
| ``sensor_stuck`` | state: the stuck reading | every sensor sample reads ``state`` |
| ``sensor_dropout`` | value: probability p in [0, 1] | each sample is missing (not published) with p |
| ``sensor_bit_flip`` | value: probability p in [0, 1] | each published bit is inverted with p |
| ``release_speed_error`` | value: sigma, or the fixed e with state | each throw releases at W (1 + e) |
| ``motor_fault`` | none | the arm does not throw (``throw`` raises MotorFaultError) |
| ``part_lost`` | none | the part falls off the arm; it is not sensed or thrown until placed |
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, Sequence, get_args

import numpy as np

from feeder_planner.errors import FeederError, InputError
from feeder_sim.throwing.arm import ThrowingArm
from feeder_sim.throwing.outcome import ThrowOutcome
from feeder_sim.throwing.tolerances import MAX_SPEED_ERROR, MAX_SPEED_ERROR_SIGMA, MIN_SPEED_SCALE

__all__ = [
    "ArmFaultName",
    "ARM_FAULTS",
    "FaultInfo",
    "FAULT_INFO",
    "check_fault_name",
    "MotorFaultError",
    "ArmFaults",
]

ArmFaultName = Literal[
    "sensor_stuck", "sensor_dropout", "sensor_bit_flip", "release_speed_error", "motor_fault", "part_lost"
]
ARM_FAULTS: tuple[ArmFaultName, ...] = get_args(ArmFaultName)


@dataclass(frozen=True)
class FaultInfo:
    """What a fault does, what its value means (empty: it takes none), whether it stops the arm."""

    description: str
    value_meaning: str
    stops: bool


FAULT_INFO: dict[ArmFaultName, FaultInfo] = {
    "sensor_stuck": FaultInfo("the proximity sensor reads the request's state whatever is there", "", False),
    "sensor_dropout": FaultInfo(
        "each sensor sample is missing (not published) with probability value", "probability in [0, 1]", False
    ),
    "sensor_bit_flip": FaultInfo(
        "each published sensor bit is inverted with probability value", "probability in [0, 1]", False
    ),
    "release_speed_error": FaultInfo(
        "each throw releases at W (1 + e): e ~ Normal(0, value) drawn per throw, or e = value when state",
        "sigma (or the fixed e when state is true)",
        False,
    ),
    "motor_fault": FaultInfo("the arm motor does not move: throws are refused", "", True),
    "part_lost": FaultInfo(
        "the part falls off the arm: nothing is sensed or thrown until ~/place_part puts it back", "", True
    ),
}


def check_fault_name(name: str, field: str = "fault") -> ArmFaultName:
    """Return ``name`` as an arm fault, or raise InputError naming ``field``."""
    for fault in ARM_FAULTS:
        if name == fault:
            return fault
    raise InputError(field, f"unknown fault {name!r} (the arm knows: {', '.join(ARM_FAULTS)})")


class MotorFaultError(FeederError):
    """A throw asked of an arm whose motor has a fault."""


def _probability(value: float) -> float:
    """Return ``value`` if it is a probability, else raise InputError naming ``value``."""
    if not (math.isfinite(value) and 0.0 <= value <= 1.0):
        raise InputError("value", f"must be a probability in [0, 1], got {value!r}")
    return float(value)


def _speed_error(value: float, fixed: bool) -> float:
    """Return the checked sigma (``fixed`` False) or fixed error e of release_speed_error."""
    if fixed:
        low = MIN_SPEED_SCALE - 1.0
        if not (math.isfinite(value) and low <= value <= MAX_SPEED_ERROR):
            raise InputError(
                "value",
                f"the fixed release speed error e (state true) must be in [{low:g}, {MAX_SPEED_ERROR:g}], "
                f"got {value!r}",
            )
    elif not (math.isfinite(value) and 0.0 <= value <= MAX_SPEED_ERROR_SIGMA):
        raise InputError(
            "value",
            f"the release speed error's sigma (state false) must be in [0, {MAX_SPEED_ERROR_SIGMA:g}], "
            f"got {value!r}",
        )
    return float(value)


@dataclass
class _Fault:
    """One fault in force: its magnitude and, for the random ones, its own generator."""

    name: ArmFaultName
    value: float
    state: bool
    rng: np.random.Generator


class ArmFaults:
    """The injected faults in force on one simulated arm, and their effects on its sensor and throws."""

    def __init__(self, arm: ThrowingArm) -> None:
        self.arm = arm
        self._faults: dict[ArmFaultName, _Fault] = {}
        self.last_speed_scale = 1.0  # the factor 1 + e the last throw was released at

    @property
    def names(self) -> tuple[ArmFaultName, ...]:
        """The faults in force, in the order they were injected."""
        return tuple(self._faults)

    @property
    def motor_failed(self) -> bool:
        """Whether the motor has a fault (the arm cannot throw)."""
        return "motor_fault" in self._faults

    def inject(
        self, name: str, value: float = 0.0, state: bool = False, indices: Sequence[int] = (), seed: int = 0
    ) -> None:
        """Check a fault's magnitudes (InputError naming fault, value or indices) and put it into effect.

        Injecting a fault already in force replaces it (a fresh generator from ``seed``).
        """
        fault = check_fault_name(name)
        if len(indices):
            raise InputError("indices", f"the arm has no cells or axes to index; got {list(indices)}")
        if fault in ("sensor_dropout", "sensor_bit_flip"):
            value = _probability(value)
        elif fault == "release_speed_error":
            value = _speed_error(value, state)
        self._faults[fault] = _Fault(fault, float(value), bool(state), np.random.default_rng(seed))
        if fault == "part_lost":
            self.arm.lose_part("injected fault part_lost: the part fell off the arm")

    def clear(self, name: str) -> None:
        """Take a fault out of effect (a lost part stays lost: only placing it puts it back)."""
        self._faults.pop(check_fault_name(name), None)

    def sensor(self, reading: bool) -> bool | None:
        """Return the sample the sensor delivers for the true ``reading``: None when it is missing.

        Stuck, then dropout, then bit flip; each random fault draws once per sample.
        """
        out: bool | None = bool(reading)
        stuck = self._faults.get("sensor_stuck")
        if stuck is not None:
            out = stuck.state
        dropout = self._faults.get("sensor_dropout")
        if dropout is not None and dropout.rng.random() < dropout.value:
            out = None
        flip = self._faults.get("sensor_bit_flip")
        if flip is not None and flip.rng.random() < flip.value and out is not None:
            out = not out
        return out

    def speed_scale(self) -> float:
        """Return the factor 1 + e of the next throw's release speed (1 without release_speed_error).

        A drawn e is clipped so that 1 + e >= MIN_SPEED_SCALE (a speed error never stops the arm).
        """
        error = self._faults.get("release_speed_error")
        if error is None:
            return 1.0
        e = error.value if error.state else float(error.rng.normal(0.0, error.value))
        return max(1.0 + e, MIN_SPEED_SCALE)

    def throw(self) -> ThrowOutcome:
        """Throw once with the faults in force; raise MotorFaultError when the motor has a fault."""
        if self.motor_failed:
            raise MotorFaultError("throw refused: the arm motor has a fault (injected fault motor_fault)")
        self.last_speed_scale = self.speed_scale()
        return self.arm.throw(self.last_speed_scale)
