"""The hosted cell clock's side of the lockstep for the participants in its own process.

A device built in the cell host (``feeder_cell.host``) makes its ``Participant`` as it would in a process
of its own, but the participant finds this hub installed (``lockstep.host_in_process``) and joins it instead
of the DDS topics. The clock's barrier (``lockstep_barrier``) keeps one set of rules for both kinds of
member: a hosted participant is a member under its own name and role, answers T when it is done with T,
and is dropped after the same timeout. What changes is the path: the clock calls ``arrive(T)`` on each
hosted participant of the phase, in the order they joined (the scene's order), and the host's loop hands
each answer back after its drain.

A hosted participant whose decisions run on a thread of its own (the reference controller, ``hold``)
answers from that thread: its answer is queued and taken in by the executor's thread (a guard condition),
which alone touches the clock.
"""

from __future__ import annotations

import threading
from collections import deque
from typing import Callable

from rclpy.node import Node

from feeder_cell.lockstep_barrier import Barrier
from feeder_planner.node_kit.lockstep import ROLES, Participant

__all__ = ["ClockHub"]


class ClockHub:
    """The hosted participants of one cell clock, by role, in the order they joined."""

    def __init__(self, node: Node, barrier: Barrier, pump: Callable[[], None]) -> None:
        self.barrier = barrier
        self.pump = pump  # the clock's: run the phases as far as the answers allow
        self.members: dict[str, list[Participant]] = {role: [] for role in ROLES}
        self._thread = threading.get_ident()  # the executor's: the clock is built on it
        self._foreign: deque[tuple[Participant, int, bool]] = deque()
        self._wake = node.create_guard_condition(self._take_foreign)

    def join(self, participant: Participant) -> None:
        """Take ``participant`` in: a member of its role from the next quantum, like a DDS join."""
        self.members[participant.role].append(participant)
        self.barrier.answer(participant.role, "/" + participant.name, 0)

    def answer(self, participant: Participant, now_ns: int, leave: bool) -> None:
        """Take an answer (done with ``now_ns``, or leaving) and let the clock go on."""
        if threading.get_ident() != self._thread:
            self._foreign.append((participant, now_ns, leave))  # deque appends are atomic
            self._wake.trigger()
            return
        if leave and participant in self.members[participant.role]:
            self.members[participant.role].remove(participant)
        self.barrier.answer(participant.role, "/" + participant.name, -1 if leave else now_ns, leave)
        self.pump()

    def _take_foreign(self) -> None:
        while self._foreign:
            self.answer(*self._foreign.popleft())

    def arrive(self, role: str, now_ns: int) -> None:
        """Announce ``now_ns`` to the hosted participants of ``role`` (each answers after its drain)."""
        for participant in list(self.members[role]):
            participant.arrive(now_ns)

    def participants(self) -> list[Participant]:
        """Every hosted participant, tick first (the host's loop answers them in this order)."""
        return [p for role in ROLES for p in self.members[role]]
