"""When the controller injects each device's failures and clears them, on its own clock. ROS-free.

The fault processes (``feeder_cell.experiment.faults_process``) say when failures happen, counted from
the first cycle's start; this schedule turns them into what to do at a given controller time: inject
every failure whose start has come, clear every injected one whose repair time has come. The node sends
what ``due`` returns through the devices' ``~/inject_fault``; a loop without ROS can apply it directly.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Iterator

from feeder_cell.experiment.faults_process import FaultEvent, FaultProcess, FaultSpec

__all__ = ["REPAIR_EARLY_S", "FaultAction", "FaultSchedule"]

# A controller waiting out a repair goes on at the first react time at or after its end: its wait's bound
# is this much earlier, so that the float rounding of two equal cell times (whole nanoseconds as seconds,
# from different origins) cannot add a quantum. The ROS controller and the ROS-free loop both use it.
REPAIR_EARLY_S = 1e-6


@dataclass(frozen=True)
class FaultAction:
    """Inject ``event``'s failure (``clear`` False) or clear it at its repair (``clear`` True)."""

    spec: FaultSpec
    event: FaultEvent
    clear: bool


@dataclass
class FaultSchedule:
    """The failures of every device of ``specs`` in replication ``replication`` of ``seed``."""

    specs: tuple[FaultSpec, ...]
    seed: int = 0
    replication: int = 0
    origin: float = math.nan  # controller time (s) of the first cycle's start: failure times count from it
    repair_at: dict[str, float] = field(default_factory=dict)  # device -> controller time its failure ends
    _next: dict[str, tuple[Iterator[FaultEvent], FaultEvent]] = field(default_factory=dict)
    _injected: list[FaultEvent] = field(default_factory=list)  # not yet repaired

    def due(self, now: float) -> list[FaultAction]:
        """Return what is due at controller time ``now`` (s), in order; the first call starts the clock.

        Several failures of one device may be due at once (a long step between two looks): each is
        injected, in time order, and each repair comes at its own end.
        """
        if not self.specs:
            return []
        if math.isnan(self.origin):
            self.origin = now
            for spec in self.specs:
                events = FaultProcess(spec, self.seed, self.replication).events()
                self._next[spec.device] = (events, next(events))
        actions = []
        for spec in self.specs:
            events, event = self._next[spec.device]
            while self.origin + event.start <= now:
                actions.append(FaultAction(spec, event, clear=False))
                self._injected.append(event)
                self.repair_at[spec.device] = self.origin + event.end
                event = next(events)
            self._next[spec.device] = (events, event)
        for event in [e for e in self._injected if self.origin + e.end <= now]:
            self._injected.remove(event)
            spec = next(s for s in self.specs if s.device == event.device)
            actions.append(FaultAction(spec, event, clear=True))
        return actions

    def under_repair_until(self, device: str) -> float:
        """Return the controller time (s) the device's last injected failure ends; -inf when it had none."""
        return self.repair_at.get(device, -math.inf)
