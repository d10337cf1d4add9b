"""The device kit's rules without ROS: how the cell loop drives a station (docs/devices.md).

The device node's kit (``feeder_device``) owns the loop around a station: the tick grid, the elapsed
node-clock time, the injected and model faults, ``~/stop`` and ``~/reset``, a goal's start after the next
tick. The cell loop has no node: ``StationDriver`` keeps those rules for it, and each device's driver
(``drivers.py``) calls the same station (``feeder_sim.<device>.station``) the node calls.
"""

from __future__ import annotations

from typing import Any

from feeder_cell.experiment.faults_process import FaultSpec
from feeder_device.declarations import ActiveFault, stopping_fault

__all__ = ["StationDriver"]


class StationDriver:
    """What the device kit does around a station, without ROS: the tick grid, elapsed time, faults, stop.

    A driver per device (``drivers.py``) holds that device's station and says what its tick, goal and
    faults are; this base keeps the kit's rules (``feeder_device``: ``ticks.TickLoop``, ``faults``,
    ``goals``) as the loop needs them: every instant of the rate's grid ticked in order, each tick followed
    by the goal's decision; an accepted goal started after the next tick; a stopping fault, injected or
    raised by the model, puts the device in FAULT; ``~/reset`` clears every fault and the stop.
    """

    name = ""
    rate = 20.0

    def __init__(self, origin_ns: int) -> None:
        self.origin_ns = origin_ns
        self.index = 0
        self.last_advance_ns = origin_ns
        self.faults: dict[str, ActiveFault] = {}
        self.model_fault: tuple[int, str] | None = None
        self.stopped = False
        self.pending_goal: Any = None  # accepted, starts after the next tick
        self.goal: Any = None

    def elapsed_ns(self, now_ns: int) -> int:
        """Return the node-clock time (ns) since the station last advanced; move the mark to ``now_ns``."""
        elapsed = max(0, now_ns - self.last_advance_ns)
        self.last_advance_ns = now_ns
        return elapsed

    def stopping_fault(self) -> tuple[int, str] | None:
        """Return (code, text) of the fault that stops the device (the model's first), or None."""
        return stopping_fault(self.model_fault, self.faults.values())

    def ready(self) -> bool:
        """Return whether the device takes commands: no stopping fault, not stopped."""
        return self.stopping_fault() is None and not self.stopped

    def state(self) -> str:
        """Return the state a controller sees: FAULT, RUNNING (a goal or the model busy) or IDLE."""
        if self.stopping_fault() is not None:
            return "FAULT"
        return "RUNNING" if self.goal is not None or self.busy() else "IDLE"

    def busy(self) -> bool:
        """Return whether the model is busy without a goal (nothing by default)."""
        return False

    def advance(self, now_ns: int) -> None:
        """Tick every instant of the grid up to ``now_ns``; then start an accepted goal (at ``now_ns``)."""
        while (instant := self.origin_ns + round((self.index + 1) * 1e9 / self.rate)) <= now_ns:
            self.index += 1
            self.tick(instant)
            if self.goal is not None and not self.goal_done():
                self.advance_goal(instant)
        if self.pending_goal is not None:
            start, self.pending_goal = self.pending_goal, None
            start(now_ns)

    def goal_done(self) -> bool:
        """Return whether there is no goal or it has ended."""
        raise NotImplementedError

    def advance_goal(self, now_ns: int) -> None:
        """Close the tick at ``now_ns`` for the goal: its decision (the station's)."""
        raise NotImplementedError

    def tick(self, now_ns: int) -> None:
        """Tick the station at ``now_ns`` (the node's tick without the streams)."""
        raise NotImplementedError

    def inject(self, spec: FaultSpec, clear: bool, seed: int, faults: Any) -> None:
        """~/inject_fault with ``spec``'s fault, value and state (or its clear), as the kit does."""
        if clear:
            if spec.fault in self.faults:
                self.clear_fault(spec.fault)
                del self.faults[spec.fault]
            return
        fault = ActiveFault(faults[spec.fault], float(spec.value), bool(spec.state), (), 0.0, seed)
        self.apply_fault(fault)
        self.faults[spec.fault] = fault

    def reset(self) -> None:
        """~/reset: every fault cleared, stop ended, the device's own reset."""
        for name in list(self.faults):
            self.clear_fault(name)
        self.faults.clear()
        self.model_fault = None
        self.stopped = False
        self.reset_device()

    def apply_fault(self, fault: ActiveFault) -> None:
        """Put an injected fault into the station's model (the node's ``apply_fault``)."""
        raise NotImplementedError

    def clear_fault(self, name: str) -> None:
        """Take an injected fault out of the station's model (the node's ``clear_fault``)."""
        raise NotImplementedError

    def reset_device(self) -> None:
        """Nothing beyond the kit's reset."""
