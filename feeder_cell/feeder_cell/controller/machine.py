"""The production cycle of the reference cell controller as an explicit state machine, free of ROS.

Why a plain state machine and not a behaviour tree (py_trees): a cell cycle is a fixed sequence with a
few detours (a retry, a reset, the planner's safe path), every one of which a controller developer
must be able to see and copy. Here each state, each transition and each fault rule is one row of a
table (``TRANSITIONS``, ``FAULT_POLICY``), the machine is a few lines that read them, and there is no
extra dependency. The node (``feeder_cell.nodes.cell_controller``) performs the work of a state (an
action goal, a service call) and hands the machine the ``Outcome``; the machine says what comes next.
Tests drive it with scripted outcomes: pure logic.

One cycle, as a controller sees it::

    ORIENT      MEMS array: ~/place_parts (a new batch arrives), then ~/run_program until SETTLED;
                or (``orienter: squeeze``) the squeeze gripper: ~/place_part (a new part), then ~/run_plan
                with the squeeze planner's plan (asked once) until DONE
    INFEED      throwing arm: ~/place_part at the infeed pose (the last part was taken, a new one arrives)
    FEED        throwing arm: ~/feed_part until PRESENTED (the sensor bit at rest decides)
    TILT        fixture: ~/follow_path along the commanded route to the target orientation
    PLAN_TILT   (the interlock REFUSED the route) planner ~/safe_path from where the fixture stands
    TILT_SAFE   fixture: ~/follow_path along the planner's certified path
    RETURN      fixture: ~/follow_path back home (PLAN_RETURN, RETURN_SAFE as above when refused)

A failed step goes to the fault policy: RETRY the step, RESET_RETRY (``RECOVER``: ~/reset the device,
for the arm and the squeeze gripper also a fresh part, then the step again), or STOP the cell and report.
Retries are bounded per step and cycle (``max_retries``); an outcome the table does not name stops the
cell.

The controller's ``policy`` says what work may overlap (``AHEAD``). ``sequential`` (the default) runs the
states one after another, as above. ``pipelined`` starts the next cycle's ORIENT in the background as soon
as INFEED has put the current part on the arm: the array orients the next part while the arm feeds and the
fixture tilts; the next cycle's ORIENT then takes that work's outcome (at once if it has ended) instead of
starting it, and the tables above apply to it unchanged (a TIMEOUT retries in the foreground). The ROS-free
cell loop runs ``pipelined``; the ROS reference controller refuses it, so far.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum

from feeder_planner.errors import InputError

__all__ = [
    "State",
    "Policy",
    "Outcome",
    "Transition",
    "CellMetrics",
    "CellMachine",
    "TRANSITIONS",
    "FAULT_POLICY",
    "DEVICE_OF",
    "ORIENTERS",
    "POLICIES",
    "AHEAD",
    "ANY_CODE",
    "policy_for",
    "transition_table",
    "policy_table",
    "ahead_table",
]


class State(str, Enum):
    """Where the cell is; every state but the last three performs one piece of work."""

    BRING_UP = "BRING_UP"  # configure and activate every device through its lifecycle
    ORIENT = "ORIENT"
    INFEED = "INFEED"
    FEED = "FEED"
    TILT = "TILT"
    PLAN_TILT = "PLAN_TILT"
    TILT_SAFE = "TILT_SAFE"
    RETURN = "RETURN"
    PLAN_RETURN = "PLAN_RETURN"
    RETURN_SAFE = "RETURN_SAFE"
    RECOVER = "RECOVER"  # ~/reset the device that failed, then the failed step again
    CYCLE_END = "CYCLE_END"  # in the table only: the next cycle's ORIENT, or FINISHED
    FINISHED = "FINISHED"  # the cycles asked for are done
    STOPPED = "STOPPED"  # the cell stopped on a fault: the machine's stop_reason says which


class Policy(str, Enum):
    """What the controller does about an outcome that is not a success."""

    RETRY = "RETRY"  # the same step again
    RESET_RETRY = "RESET_RETRY"  # ~/reset the device (RECOVER), then the step again
    STOP = "STOP"  # stop the cell and report


# Outcome events: the action results' outcome_name (SETTLED, PRESENTED, MAX_THROWS, TIMEOUT, FAULT,
# CANCELED, REACHED, REFUSED, STALLED), and what the node reports for the other work:
DONE = "DONE"  # a service call or a bring-up that succeeded
ERROR = "ERROR"  # a service answered ok: false (its error is the message)
NO_ANSWER = "NO_ANSWER"  # a server missing, or no answer within the step's bound
PLANNED = "PLANNED"  # the planner returned a certified path
NO_PATH = "NO_PATH"  # the planner found none (an unstable end, antipodal ends...)

ANY_CODE = -1  # a FAULT_POLICY key that matches every fault code

# Successful outcomes: (state, event) -> next state. Nothing else is a success.
TRANSITIONS: dict[tuple[State, str], State] = {
    (State.BRING_UP, DONE): State.ORIENT,
    (State.ORIENT, "SETTLED"): State.INFEED,  # the MEMS array's parts have settled
    (State.ORIENT, "DONE"): State.INFEED,  # the squeeze gripper ran every squeeze of the plan
    (State.INFEED, DONE): State.FEED,
    (State.FEED, "PRESENTED"): State.TILT,
    (State.TILT, "REACHED"): State.RETURN,
    (State.TILT, "REFUSED"): State.PLAN_TILT,
    (State.PLAN_TILT, PLANNED): State.TILT_SAFE,
    (State.TILT_SAFE, "REACHED"): State.RETURN,
    (State.RETURN, "REACHED"): State.CYCLE_END,
    (State.RETURN, "REFUSED"): State.PLAN_RETURN,
    (State.PLAN_RETURN, PLANNED): State.RETURN_SAFE,
    (State.RETURN_SAFE, "REACHED"): State.CYCLE_END,
}

# The fault policy: (state, event, fault code or ANY_CODE) -> policy. Anything not listed: STOP.
FAULT_POLICY: dict[tuple[State, str, int], Policy] = {
    # The sensor never said "presented" (a stuck or dead sensor looks exactly like this): reset the arm
    # (which clears what was injected), put a fresh part on it and feed again.
    (State.FEED, "MAX_THROWS", ANY_CODE): Policy.RESET_RETRY,
    (State.FEED, "TIMEOUT", ANY_CODE): Policy.RESET_RETRY,
    # The part left the arm: reset, place a part, feed again.
    (State.FEED, "FAULT", 102): Policy.RESET_RETRY,
    (State.INFEED, "FAULT", 102): Policy.RESET_RETRY,
    # A motor fault needs a person: stop the cell and name it.
    (State.FEED, "FAULT", 101): Policy.STOP,
    (State.INFEED, "FAULT", 101): Policy.STOP,
    # Parts still moving at the timeout: run the program again from where they are.
    (State.ORIENT, "TIMEOUT", ANY_CODE): Policy.RETRY,
    # No field at all: stop.
    (State.ORIENT, "FAULT", 201): Policy.STOP,
    # The part left the squeeze gripper's jaws: reset, place a new part, run the plan again.
    (State.ORIENT, "FAULT", 402): Policy.RESET_RETRY,
    # A stalled jaw is mechanical: stop the cell and name it.
    (State.ORIENT, "FAULT", 401): Policy.STOP,
    # A stalled axis is mechanical: stop where the fixture stands (on a certified-stable sample).
    (State.TILT, "STALLED", ANY_CODE): Policy.STOP,
    (State.TILT_SAFE, "STALLED", ANY_CODE): Policy.STOP,
    (State.RETURN, "STALLED", ANY_CODE): Policy.STOP,
    (State.RETURN_SAFE, "STALLED", ANY_CODE): Policy.STOP,
    # A late answer may be a loaded machine: try once more within the budget.
    (State.PLAN_TILT, NO_ANSWER, ANY_CODE): Policy.RETRY,
    (State.PLAN_RETURN, NO_ANSWER, ANY_CODE): Policy.RETRY,
}

# Which device a state commands (what RECOVER resets).
DEVICE_OF: dict[State, str] = {
    State.ORIENT: "mems",
    State.INFEED: "arm",
    State.FEED: "arm",
    State.TILT: "fixture",
    State.TILT_SAFE: "fixture",
    State.RETURN: "fixture",
    State.RETURN_SAFE: "fixture",
    State.PLAN_TILT: "planner",
    State.PLAN_RETURN: "planner",
}

# The orienting stations ORIENT may command (the controller's ``orienter``): the device RECOVER resets.
ORIENTERS = ("mems", "squeeze")

# The controller's policies: which work of the next cycle starts ahead, in the background.
POLICIES = ("sequential", "pipelined")

# Per policy: (state, event) of a success -> the next cycle's state whose work starts now, in the
# background; the machine reaching that state in the next cycle takes the background work's outcome.
AHEAD: dict[str, dict[tuple[State, str], State]] = {
    "sequential": {},
    # The part is on the arm, the array is free: it orients the next part while the arm feeds this one.
    "pipelined": {(State.INFEED, DONE): State.ORIENT},
}

# The first state of every cycle.
CYCLE_START = State.ORIENT
# Work states of one cycle, in order (for the status message and the docs).
WORK_STATES = tuple(s for s in State if s not in (State.CYCLE_END, State.FINISHED, State.STOPPED))


@dataclass(frozen=True)
class Outcome:
    """What one piece of work ended with: the event, a device fault code when there was one, the text."""

    event: str
    fault_code: int = 0
    message: str = ""

    def label(self) -> str:
        """Return the outcome as a log shows it, e.g. ``FAULT 101 (motor fault)``."""
        code = f" {self.fault_code}" if self.fault_code else ""
        text = f" ({self.message})" if self.message else ""
        return f"{self.event}{code}{text}"


@dataclass(frozen=True)
class Transition:
    """One step of the machine: from, the outcome, the policy applied (None for a success), to."""

    source: State
    outcome: Outcome
    policy: Policy | None
    target: State
    note: str = ""
    ahead: State | None = None  # the next cycle's state whose work starts now in the background (AHEAD)


@dataclass
class CellMetrics:
    """Cycle metrics on the controller's clock (simulated seconds under the cell clock)."""

    cycles_completed: int = 0
    parts_presented: int = 0
    faults_seen: int = 0  # outcomes the fault policy handled (any policy)
    faults_handled: int = 0  # of those, the ones a retry or reset recovered from (the cell went on)
    retries: int = 0  # steps performed again (RETRY and RESET_RETRY)
    reroutes: int = 0  # interlock refusals answered with the planner's safe path
    last_cycle_time: float = math.nan  # s
    total_cycle_time: float = 0.0  # s, over the completed cycles
    first_cycle_start: float = math.nan  # s
    last_fault: str = ""

    @property
    def mean_cycle_time(self) -> float:
        """Mean time of a completed cycle (s); NaN before the first."""
        return self.total_cycle_time / self.cycles_completed if self.cycles_completed else math.nan

    def parts_per_minute(self, now: float) -> float:
        """Parts presented per minute since the first cycle started; NaN before any time passed."""
        elapsed = now - self.first_cycle_start
        if not math.isfinite(elapsed) or elapsed <= 0:
            return math.nan
        return 60.0 * self.parts_presented / elapsed


def policy_for(state: State, outcome: Outcome) -> Policy:
    """Return the fault policy for a non-success outcome: the exact code's row, the ANY row, or STOP."""
    exact = FAULT_POLICY.get((state, outcome.event, outcome.fault_code))
    if exact is not None:
        return exact
    return FAULT_POLICY.get((state, outcome.event, ANY_CODE), Policy.STOP)


@dataclass
class CellMachine:
    """The cell's cycle: feed it each step's outcome, read the next state.

    Parameters
    ----------
    cycles
        Production cycles to run; 0 runs until stopped.
    max_retries
        Times one step may be performed again within a cycle (RETRY or RESET_RETRY) before the cell stops.
    orienter
        The orienting station ORIENT commands, one of ``ORIENTERS``: the device RECOVER resets after it.
    policy
        One of ``POLICIES``: which work of the next cycle starts ahead (``AHEAD``).
    """

    cycles: int = 1
    max_retries: int = 2
    orienter: str = "mems"
    policy: str = "sequential"
    state: State = State.BRING_UP
    metrics: CellMetrics = field(default_factory=CellMetrics)
    stop_reason: str = ""
    retry_state: State | None = None  # RECOVER: the step performed again once the device is reset
    attempts: int = 0  # retries of the present step in this cycle
    cycle: int = 0  # the cycle in progress (1-based; 0 before the first)
    cycle_start: float = math.nan
    _unhandled: int = 0  # faults of the present step that a later success will have handled
    history: list[Transition] = field(default_factory=list)

    def __post_init__(self) -> None:
        if isinstance(self.cycles, bool) or not isinstance(self.cycles, int) or self.cycles < 0:
            raise InputError("cycles", f"must be an integer >= 0 (0: until stopped), got {self.cycles!r}")
        if (
            isinstance(self.max_retries, bool)
            or not isinstance(self.max_retries, int)
            or self.max_retries < 0
        ):
            raise InputError("max_retries", f"must be an integer >= 0, got {self.max_retries!r}")
        if self.orienter not in ORIENTERS:
            raise InputError("orienter", f"must be one of {', '.join(ORIENTERS)}, got {self.orienter!r}")
        if self.policy not in POLICIES:
            raise InputError("policy", f"must be one of {', '.join(POLICIES)}, got {self.policy!r}")

    @property
    def finished(self) -> bool:
        """Whether the machine has ended (FINISHED or STOPPED)."""
        return self.state in (State.FINISHED, State.STOPPED)

    @property
    def device(self) -> str:
        """The device the present state commands ('' for bring-up), or for RECOVER the one to reset."""
        state = self.retry_state if self.state is State.RECOVER else self.state
        return self.device_of(state) if state is not None else ""

    def device_of(self, state: State) -> str:
        """Return the device ``state`` commands: ``DEVICE_OF``'s, with ORIENT on the configured orienter."""
        return self.orienter if state is State.ORIENT else DEVICE_OF.get(state, "")

    def stop(self, reason: str) -> Transition:
        """Stop the cell from outside the table (a stop request, the node shutting down)."""
        return self._go(Outcome("STOP_REQUEST", 0, reason), None, State.STOPPED, reason)

    def advance(self, outcome: Outcome, now: float) -> Transition:
        """Apply the outcome of the present state's work at time ``now`` (s); return the transition."""
        if self.finished:
            raise InputError("outcome", f"the machine has ended ({self.state.value}); nothing follows")
        source = self.state
        if source is State.RECOVER:
            return self._after_recover(outcome, now)
        target = TRANSITIONS.get((source, outcome.event))
        if target is None:
            return self._apply_policy(outcome, now)
        note = self._succeeded(source, outcome, now)
        if target is State.CYCLE_END:
            return self._end_cycle(outcome, now)
        if source is State.BRING_UP:
            self._start_cycle(now)
        return self._go(outcome, None, target, note, self._ahead(source, outcome))

    # --- internals ------------------------------------------------------------------------------
    def _go(
        self,
        outcome: Outcome,
        policy: Policy | None,
        target: State,
        note: str = "",
        ahead: State | None = None,
    ) -> Transition:
        transition = Transition(self.state, outcome, policy, target, note, ahead)
        if target is State.STOPPED:
            self.stop_reason = note or outcome.label()
        self.state = target
        self.history.append(transition)
        return transition

    def _succeeded(self, source: State, outcome: Outcome, now: float) -> str:
        """Book a step's success: the faults before it are now handled; a refusal answered is a reroute."""
        self.metrics.faults_handled += self._unhandled
        self._unhandled = 0
        self.attempts = 0
        if source is State.FEED:
            self.metrics.parts_presented += 1
        if outcome.event == "REFUSED":
            self.metrics.reroutes += 1
            return "interlock refused the route: asking the planner for a safe path"
        return ""

    def _ahead(self, source: State, outcome: Outcome) -> State | None:
        """Return the next cycle's state whose work starts now (``AHEAD``), if there is a next cycle."""
        ahead = AHEAD[self.policy].get((source, outcome.event))
        if ahead is None or (self.cycles and self.cycle >= self.cycles):
            return None
        return ahead

    def _start_cycle(self, now: float) -> None:
        self.cycle += 1
        self.cycle_start = now
        if not math.isfinite(self.metrics.first_cycle_start):
            self.metrics.first_cycle_start = now
        self.attempts = 0

    def _end_cycle(self, outcome: Outcome, now: float) -> Transition:
        elapsed = now - self.cycle_start
        self.metrics.cycles_completed += 1
        self.metrics.last_cycle_time = elapsed
        self.metrics.total_cycle_time += elapsed
        note = f"cycle {self.cycle} done in {elapsed:.3f} s"
        if self.cycles and self.metrics.cycles_completed >= self.cycles:
            return self._go(outcome, None, State.FINISHED, note)
        self._start_cycle(now)
        return self._go(outcome, None, CYCLE_START, note)

    def _apply_policy(self, outcome: Outcome, now: float) -> Transition:
        source = self.state
        policy = policy_for(source, outcome)
        self.metrics.faults_seen += 1
        self.metrics.last_fault = f"{source.value}: {outcome.label()}"
        if policy is Policy.STOP:
            return self._go(outcome, policy, State.STOPPED, f"{source.value}: {outcome.label()}")
        if self.attempts >= self.max_retries:
            reason = (
                f"{source.value}: {outcome.label()}; retry budget of {self.max_retries} spent in cycle "
                f"{self.cycle}"
            )
            return self._go(outcome, policy, State.STOPPED, reason)
        self.attempts += 1
        self.metrics.retries += 1
        self._unhandled += 1
        if policy is Policy.RETRY:
            return self._go(outcome, policy, source, f"retry {self.attempts} of {self.max_retries}")
        self.retry_state = source
        note = f"reset {self.device_of(source) or 'device'}, then retry {self.attempts} of {self.max_retries}"
        return self._go(outcome, policy, State.RECOVER, note)

    def _after_recover(self, outcome: Outcome, now: float) -> Transition:
        retry = self.retry_state
        assert retry is not None  # RECOVER is entered only with the step to retry
        if outcome.event != DONE:
            self.metrics.faults_seen += 1
            self.metrics.last_fault = f"RECOVER {self.device_of(retry)}: {outcome.label()}"
            return self._go(
                outcome, Policy.STOP, State.STOPPED, f"recovering {retry.value}: {outcome.label()}"
            )
        self.retry_state = None
        return self._go(outcome, None, retry, f"{self.device_of(retry) or 'device'} reset")


def transition_table() -> list[tuple[str, str, str]]:
    """Return the success transitions as (state, outcome, next state) rows, for docs and status."""
    return [(s.value, event, t.value) for (s, event), t in TRANSITIONS.items()]


def policy_table() -> list[tuple[str, str, str, str]]:
    """Return the fault policy as (state, outcome, fault code, policy) rows; every other outcome: STOP."""
    return [
        (s.value, event, "any" if code == ANY_CODE else str(code), p.value)
        for (s, event, code), p in FAULT_POLICY.items()
    ]


def ahead_table() -> list[tuple[str, str, str, str]]:
    """Return the work started ahead as (policy, state, outcome, next cycle's state) rows."""
    return [
        (policy, s.value, event, t.value) for policy, rows in AHEAD.items() for (s, event), t in rows.items()
    ]
