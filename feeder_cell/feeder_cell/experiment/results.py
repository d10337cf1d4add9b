"""What the ROS-free cell loop returns: each cycle's record and one replication's result.

The loop counts cell time in quanta of the cell clock's lockstep (``QUANTUM``) and each device's state at
every quantum's end (``DEVICE_STATES``); the experiment's measures (docs/experiments.md) are read off these
records.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from feeder_cell.experiment.faults_process import FaultEvent

__all__ = ["QUANTUM", "DEVICE_STATES", "CycleRecord", "LoopResult"]

QUANTUM = 0.1  # s: the cell clock's lockstep quantum (feeder launch --quantum default)
DEVICE_STATES = ("RUNNING", "IDLE", "FAULT")


@dataclass
class CycleRecord:
    """One finished cycle: its cell time (s), the throws its feeds used, parts good and rejected, faults."""

    cycle: int
    time: float
    throws: int
    presented: int
    rejected: int
    faults_seen: int
    faults_handled: int
    complete: bool = True  # False: the cell stopped in this cycle (time: until the stop)
    end: float = 0.0  # s from the first cycle's start to this cycle's end
    # Cumulative since the first cycle's start, at this cycle's end: quanta per device and state, and
    # quanta the cell was down (a device in FAULT, or the controller in RECOVER).
    device_quanta: dict[str, dict[str, int]] = field(default_factory=dict)
    down_quanta: int = 0


@dataclass
class LoopResult:
    """What one replication did: its cycles, how it ended, each device's time per state, the failures."""

    cycles: list[CycleRecord]
    end_state: str
    stop_reason: str
    cell_time: float  # s from the first cycle's start to the end
    device_time: dict[str, dict[str, float]]  # device -> state -> s
    failures: list[FaultEvent]  # injected
    transitions: list[tuple[float, str, str, str]] = field(default_factory=list)  # (t, from, outcome, to)
