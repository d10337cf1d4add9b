"""Fault processes: per device, failures after a mean time between failures, repairs after a mean time.

A scene's ``faults:`` section, one entry per device (by its node name in the scene):

    faults:
      throwing_arm:
        fault: part_lost           # the device's injectable fault (docs/cell.md lists each device's)
        mtbf: 1800.0               # s of cell time from a repair (or the start) to the next failure
        mttr: 30.0                 # s of cell time a failure lasts before it is repaired
        distribution: exponential  # or fixed: every up time mtbf, every repair mttr
        # or per time: up: exponential, repair: fixed
        # value: 0.0, state: false   what ~/inject_fault is told besides the fault (docs/cell.md)

A device's process alternates up times U_1, U_2, ... and repair times D_1, D_2, ...: failure j starts at
t_j = sum_{l<=j} U_l + sum_{l<j} D_l and ends at t_j + D_j. Exponential times have the given means
(the memoryless failures of a constant hazard rate 1 / MTBF), fixed ones are exactly the means. The
long-run availability is MTBF / (MTBF + MTTR). Replication i's device draws from its own stream
(``streams``: purpose ``faults``, key CRC-32 of the device name), up and repair times alternately, so
one device's process is the same whatever the other devices or the arrivals do.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Final, Iterator

import numpy as np

from feeder_cell.experiment.streams import device_key, stream
from feeder_planner.errors import InputError
from feeder_planner.fields_io import finite_number, optional, short_string
from feeder_planner.limits import describe

__all__ = [
    "TIME_DISTRIBUTIONS",
    "FaultSpec",
    "FaultEvent",
    "FaultProcess",
    "faults_from_mapping",
    "scene_faults",
]

TIME_DISTRIBUTIONS: Final = ("exponential", "fixed")
# Shortest mean up or repair time (s): far below any cell's steps (its quantum is 0.1 s), and it bounds
# the failures a controller injects per second of cell time (a mean of 1e-300 s would never end a look).
MIN_MEAN_TIME: Final = 1e-3
# Fault processes per scene: far more than any cell has devices, few enough to read the section whole.
MAX_DEVICES: Final = 100


@dataclass(frozen=True)
class FaultSpec:
    """One device's fault process: which fault, the mean up and repair times (s), their distributions."""

    device: str
    fault: str
    mtbf: float
    mttr: float
    up: str = "exponential"
    repair: str = "exponential"
    value: float = 0.0  # the injection's value (~/inject_fault: a probability, sigma...; docs/cell.md)
    state: bool = False  # the injection's state (sensor_stuck: the stuck reading)

    @property
    def availability(self) -> float:
        """Long-run share of time up: MTBF / (MTBF + MTTR)."""
        return self.mtbf / (self.mtbf + self.mttr)


@dataclass(frozen=True)
class FaultEvent:
    """A failure of ``device`` at ``start`` (s of cell time), repaired at ``end``."""

    device: str
    fault: str
    start: float
    end: float


def _draw(kind: str, mean: float, rng: np.random.Generator) -> float:
    """One time of ``kind`` with ``mean``; a fixed time still takes its number from ``rng``.

    Taking one number either way keeps the stream aligned: switching one time's distribution changes
    that time only, not every later draw.
    """
    u = float(rng.random())
    if kind == "fixed":
        return mean
    return -mean * float(np.log1p(-u))  # inverse CDF of the exponential: u in [0, 1)


class FaultProcess:
    """The failures of one device in one replication, in time order."""

    def __init__(self, spec: FaultSpec, seed: int, replication: int = 0) -> None:
        self.spec = spec
        self.rng = stream(seed, replication, "faults", device_key(spec.device))

    def events(self) -> Iterator[FaultEvent]:
        """Yield the failures one after another, forever (the caller stops at its horizon)."""
        spec, t = self.spec, 0.0
        while True:
            t += _draw(spec.up, spec.mtbf, self.rng)
            repair = _draw(spec.repair, spec.mttr, self.rng)
            yield FaultEvent(spec.device, spec.fault, t, t + repair)
            t += repair

    def until(self, horizon: float) -> list[FaultEvent]:
        """Return the failures that start before ``horizon`` (s of cell time)."""
        found: list[FaultEvent] = []
        for event in self.events():
            if event.start >= horizon:
                return found
            found.append(event)
        return found  # unreachable: events() never ends


def _distribution(value: Any, field: str) -> str:
    if value not in TIME_DISTRIBUTIONS:
        raise InputError(field, f"must be one of {', '.join(TIME_DISTRIBUTIONS)}, got {describe(value)}")
    return str(value)


def _mean(value: Any, field: str) -> float:
    number = finite_number(value, field)
    if number <= 0.0:
        raise InputError(field, f"must be a time > 0 (s), got {number:g}")
    if number < MIN_MEAN_TIME:
        raise InputError(field, f"must be at least {MIN_MEAN_TIME:g} s (a cell time step), got {number:g}")
    return number


FIELDS: Final = ("fault", "mtbf", "mttr", "distribution", "up", "repair", "value", "state")


def faults_from_mapping(
    value: Any, field: str = "faults", devices: tuple[str, ...] | None = None
) -> tuple[FaultSpec, ...]:
    """Validate a ``faults:`` section (``devices``: the scene's node names, if known), naming bad fields."""
    if not isinstance(value, dict) or not value:
        raise InputError(
            field, f"expected a mapping of device names to fault processes, got {describe(value)}"
        )
    if len(value) > MAX_DEVICES:
        raise InputError(field, f"at most {MAX_DEVICES} devices, got {len(value)}")
    specs = []
    for device, entry in value.items():
        where = f"{field}.{device}"
        name = short_string(device, where, "a device name")
        if devices is not None and name not in devices:
            raise InputError(where, f"names no node of the scene (nodes: {', '.join(devices)})")
        if not isinstance(entry, dict):
            raise InputError(where, f"expected a mapping with {', '.join(FIELDS)}, got {describe(entry)}")
        unknown = sorted(str(k) for k in entry if k not in FIELDS)
        if unknown:
            raise InputError(f"{where}.{unknown[0]}", f"is not a field here (fields: {', '.join(FIELDS)})")
        for key in ("fault", "mtbf", "mttr"):
            if key not in entry:
                raise InputError(f"{where}.{key}", "is required but missing")
        state = optional(entry, "state", False)
        if not isinstance(state, bool):
            raise InputError(f"{where}.state", f"expected true or false, got {describe(state)}")
        both = _distribution(optional(entry, "distribution", "exponential"), f"{where}.distribution")
        specs.append(
            FaultSpec(
                name,
                short_string(entry["fault"], f"{where}.fault", "a fault name"),
                _mean(entry["mtbf"], f"{where}.mtbf"),
                _mean(entry["mttr"], f"{where}.mttr"),
                _distribution(optional(entry, "up", both), f"{where}.up"),
                _distribution(optional(entry, "repair", both), f"{where}.repair"),
                finite_number(optional(entry, "value", 0.0), f"{where}.value"),
                state,
            )
        )
    return tuple(specs)


def scene_faults(
    document: dict[str, Any], devices: tuple[str, ...] | None = None
) -> tuple[FaultSpec, ...] | None:
    """Return a scene's validated ``faults:`` section, or None when it has none."""
    if "faults" not in document:
        return None
    return faults_from_mapping(document["faults"], "faults", devices)
