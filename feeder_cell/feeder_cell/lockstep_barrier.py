"""The cell clock's side of the lockstep, free of ROS: who must answer, in which phase, and who is late.

The protocol is ``feeder_planner.node_kit.lockstep`` (read it first): each quantum T runs the phases
tick, react and observe in order; a phase is complete when every member of its role that was admitted
before T has answered T. The clock node announces, feeds answers in and asks what to do next; this
module decides. It never waits: the node calls ``complete`` after each answer and ``overdue`` on a
timer, so a member that dies costs ``timeout_s`` of wall time once, never a hang.

Start-up: the clock holds T0 (phase ``join``) until every name in ``expect`` has answered, so a run
starts at the same cell time whatever the order in which the processes came up; a name that has not
joined within ``join_timeout_s`` is dropped as a late member is. The tick participants join by
answering T0 (their clocks then read T0); the others by their join messages. Then T0's react and
observe phases run: a controller's first decisions are at T0, with every device already there.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Iterable

from feeder_planner.node_kit.lockstep import ROLES

__all__ = ["Member", "Dropped", "Barrier", "PHASES", "REWIND_REFUSED", "REWOUND_TO"]

PHASES = ("join", *ROLES, "done")  # "done": quantum T is complete, the clock may advance
# The clock's ~/rewind (std_srvs/Trigger) answers: refused because a participant that is no tick
# participant cannot follow (its message names them after this), or done: "rewound to <T> ns".
REWIND_REFUSED = "do not follow a rewind"
REWOUND_TO = "rewound to"


@dataclass
class Member:
    """One participant in one role: waited for from ``since_ns`` on; ``done_ns`` is its last answer."""

    name: str
    role: str
    since_ns: int
    done_ns: int = -1


@dataclass(frozen=True)
class Dropped:
    """A participant dropped from the lockstep: who, in which phase, at which T, after how long."""

    name: str
    role: str
    phase: str
    now_ns: int
    waited_s: float

    def describe(self) -> str:
        """One line naming the participant and what it did not answer."""
        what = "did not join" if self.phase == "join" else f"did not answer {self.phase} of {self.now_ns} ns"
        return f"{self.name} ({self.role or 'expected'}) {what} within {self.waited_s:.3g} s: dropped"


@dataclass
class Barrier:
    """Members, the present quantum and phase, and the rules of completion, admission and dropping."""

    now_ns: int
    quantum_ns: int
    expect: Iterable[str] = ()
    timeout_s: float = 30.0
    join_timeout_s: float = 60.0
    phase: str = "join"
    phase_started: float = 0.0  # wall (monotonic) s
    members: dict[tuple[str, str], Member] = field(default_factory=dict)
    dropped: list[Dropped] = field(default_factory=list)

    def __post_init__(self) -> None:
        if self.quantum_ns <= 0:
            raise ValueError(f"quantum must be > 0 ns, got {self.quantum_ns}")
        self.expect = frozenset(self.expect)
        self._gone: set[str] = set()  # dropped names are not readmitted: their ticks were not waited for

    # --- answers ------------------------------------------------------------------------------------
    def answer(self, role: str, name: str, stamp_ns: int, leave: bool = False) -> None:
        """Take in an answer on ``role``'s topic: join, progress or leave."""
        key = (role, name)
        if leave:
            self.members.pop(key, None)
            return
        if name in self._gone:
            return
        member = self.members.get(key)
        if member is None:
            # Admitted from the next quantum (the present one was announced without it); at start-up
            # from T0, whose react and observe phases run once everyone has joined.
            since = self.now_ns if self.phase == "join" else self.now_ns + self.quantum_ns
            self.members[key] = Member(name, role, since, stamp_ns)
        else:
            member.done_ns = max(member.done_ns, stamp_ns)

    # --- phases -------------------------------------------------------------------------------------
    def waiting_for(self) -> list[Member]:
        """Return the members the present phase still waits for."""
        if self.phase not in ROLES:
            return []
        return [
            m
            for m in self.members.values()
            if m.role == self.phase and m.since_ns <= self.now_ns and m.done_ns < self.now_ns
        ]

    def joined(self) -> set[str]:
        """Names with at least one role."""
        return {m.name for m in self.members.values()}

    def complete(self) -> bool:
        """Whether the present phase is complete (``join``: every expected name has joined)."""
        if self.phase == "join":
            # A tick participant's clock reads T0 only once it has answered T0 (a join message may
            # come first): no react phase before, or a controller would configure a device at time 0.
            ticked = all(m.done_ns >= self.now_ns for m in self.members.values() if m.role == ROLES[0])
            return ticked and self.expect <= self.joined() | self._gone  # type: ignore[operator]
        if self.phase == "done":
            return True
        return not self.waiting_for()

    def next_phase(self, wall: float) -> str:
        """Enter the next phase (``done``: the next quantum's tick; ``join``: the react phase of T0)."""
        if self.phase == "join":
            self.phase = ROLES[1]  # T0's ticks were the join answers
        elif self.phase == "done":
            self.now_ns += self.quantum_ns
            self.phase = ROLES[0]
        else:
            index = ROLES.index(self.phase)
            self.phase = ROLES[index + 1] if index + 1 < len(ROLES) else "done"
        self.phase_started = wall
        return self.phase

    def rewind(self, now_ns: int, wall: float) -> None:
        """Set cell time back to ``now_ns`` (the start): every member starts again there, as at start-up.

        Only between quanta (phase ``done``: every member has answered the present one). The phase is
        ``join`` again: complete once every tick member has answered ``now_ns`` (its clock then reads it),
        then ``now_ns``'s react and observe phases run, as at start-up. A member's marks go back with the
        time: kept, an answer of a later time would count it done with every rewound quantum unheard.
        """
        if self.phase != "done":
            raise ValueError(f"a rewind between quanta only, not in phase {self.phase}")
        self.now_ns = now_ns
        for member in self.members.values():
            member.since_ns, member.done_ns = now_ns, -1
        # The members are who is waited for now; an expected name that has left since (a controller
        # whose run ended) is not waited for again.
        self.expect = frozenset()
        self.phase, self.phase_started = "join", wall

    def overdue(self, wall: float) -> list[Dropped]:
        """Drop and return the members the present phase has waited for longer than its timeout."""
        waited = wall - self.phase_started
        if self.phase == "join":
            if waited <= self.join_timeout_s:
                return []
            late = [Dropped(n, "", "join", self.now_ns, waited) for n in sorted(self.expect - self.joined())]  # type: ignore[operator]
            # A tick member that joined and never answered the start (or a rewind's) holds the join too.
            late += [
                Dropped(m.name, m.role, "join", self.now_ns, waited)
                for m in self.members.values()
                if m.role == ROLES[0] and m.done_ns < self.now_ns and m.name not in {d.name for d in late}
            ]
        elif waited > self.timeout_s:
            late = [Dropped(m.name, m.role, self.phase, self.now_ns, waited) for m in self.waiting_for()]
        else:
            return []
        for d in late:
            self._gone.add(d.name)
            for key in [k for k in self.members if k[1] == d.name]:
                del self.members[key]
        self.dropped.extend(late)
        return late
