"""The cell controller's state machine and fault policy, driven by scripted outcomes (no ROS)."""

from __future__ import annotations

import math

import pytest

from feeder_cell.controller import (
    FAULT_POLICY,
    TRANSITIONS,
    CellMachine,
    Outcome,
    Policy,
    State,
    policy_for,
    policy_table,
    transition_table,
)
from feeder_planner.errors import InputError

DONE = Outcome("DONE")
SETTLED = Outcome("SETTLED")
PRESENTED = Outcome("PRESENTED")
REACHED = Outcome("REACHED")
REFUSED = Outcome("REFUSED", 0, "sample 3 unstable: block")
PLANNED = Outcome("PLANNED")

ONE_CYCLE = [SETTLED, DONE, PRESENTED, REACHED, REACHED]


def run(machine: CellMachine, outcomes: list[Outcome], start: float = 0.0, dt: float = 1.0) -> float:
    """Feed the outcomes one per ``dt`` seconds; return the time of the last."""
    now = start
    for outcome in outcomes:
        now += dt
        machine.advance(outcome, now)
    return now


def states(machine: CellMachine) -> list[str]:
    return [t.target.value for t in machine.history]


def test_a_cycle_visits_every_work_state_in_order_and_counts_its_part() -> None:
    machine = CellMachine(cycles=1)
    run(machine, [DONE, *ONE_CYCLE])
    assert states(machine) == ["ORIENT", "INFEED", "FEED", "TILT", "RETURN", "FINISHED"]
    assert machine.finished and machine.state is State.FINISHED
    m = machine.metrics
    assert (m.cycles_completed, m.parts_presented, m.faults_seen, m.retries) == (1, 1, 0, 0)
    # The cycle started when the bring-up ended (t = 1) and ended with the return (t = 6).
    assert m.last_cycle_time == pytest.approx(5.0)


def test_n_cycles_then_finished_with_cycle_time_and_parts_per_minute() -> None:
    machine = CellMachine(cycles=3)
    end = run(machine, [DONE, *ONE_CYCLE * 3], dt=2.0)
    m = machine.metrics
    assert machine.state is State.FINISHED and machine.cycle == 3
    assert (m.cycles_completed, m.parts_presented) == (3, 3)
    assert m.mean_cycle_time == pytest.approx(10.0) and m.last_cycle_time == pytest.approx(10.0)
    # 3 parts over the 30 s since the first cycle started: 6 per minute.
    assert m.parts_per_minute(end) == pytest.approx(6.0)
    with pytest.raises(InputError, match="outcome"):
        machine.advance(SETTLED, end + 1)


def test_zero_cycles_runs_until_stopped() -> None:
    machine = CellMachine(cycles=0)
    run(machine, [DONE, *ONE_CYCLE * 5])
    assert machine.state is State.ORIENT and machine.metrics.cycles_completed == 5
    machine.stop("stop requested")
    assert machine.state is State.STOPPED and machine.stop_reason == "stop requested"


def test_interlock_refusal_takes_the_planners_safe_path_both_ways() -> None:
    machine = CellMachine(cycles=1)
    run(machine, [DONE, SETTLED, DONE, PRESENTED, REFUSED, PLANNED, REACHED, REFUSED, PLANNED, REACHED])
    assert states(machine)[4:] == [
        "PLAN_TILT",
        "TILT_SAFE",
        "RETURN",
        "PLAN_RETURN",
        "RETURN_SAFE",
        "FINISHED",
    ]
    assert machine.metrics.reroutes == 2 and machine.metrics.faults_seen == 0


def test_safe_path_refused_too_stops_the_cell() -> None:
    machine = CellMachine(cycles=1)
    run(machine, [DONE, SETTLED, DONE, PRESENTED, REFUSED, PLANNED, REFUSED])
    assert machine.state is State.STOPPED
    assert machine.stop_reason.startswith("TILT_SAFE: REFUSED")


def test_no_safe_path_stops_the_cell() -> None:
    machine = CellMachine(cycles=1)
    run(machine, [DONE, SETTLED, DONE, PRESENTED, REFUSED, Outcome("NO_PATH", 0, "goal: not stable")])
    assert machine.state is State.STOPPED and "goal: not stable" in machine.stop_reason


@pytest.mark.parametrize("event", ["MAX_THROWS", "TIMEOUT"])
def test_feed_without_presentation_resets_the_arm_and_retries_then_recovers(event: str) -> None:
    machine = CellMachine(cycles=2, max_retries=2)
    run(machine, [DONE, SETTLED, DONE])
    assert machine.state is State.FEED
    t = machine.advance(Outcome(event, 0, "sensor never true"), 10.0)
    assert (t.policy, t.target) == (Policy.RESET_RETRY, State.RECOVER)
    assert machine.device == "arm"  # what RECOVER resets
    assert machine.advance(DONE, 11.0).target is State.FEED
    run(machine, [PRESENTED, REACHED, REACHED, *ONE_CYCLE], start=11.0)
    m = machine.metrics
    assert machine.state is State.FINISHED
    assert (m.faults_seen, m.faults_handled, m.retries, m.parts_presented) == (1, 1, 1, 2)
    assert m.last_fault == f"FEED: {event} (sensor never true)"


def test_retry_budget_spent_stops_the_cell_and_says_so() -> None:
    machine = CellMachine(cycles=1, max_retries=2)
    run(machine, [DONE, SETTLED, DONE])
    for _ in range(2):
        assert machine.advance(Outcome("MAX_THROWS"), 5.0).target is State.RECOVER
        assert machine.advance(DONE, 5.0).target is State.FEED
    t = machine.advance(Outcome("MAX_THROWS"), 6.0)
    assert t.target is State.STOPPED
    assert "retry budget of 2 spent in cycle 1" in machine.stop_reason
    assert (machine.metrics.faults_seen, machine.metrics.faults_handled) == (3, 0)


def test_budget_is_per_step_and_cycle() -> None:
    machine = CellMachine(cycles=3, max_retries=1)
    run(machine, [DONE])
    for _ in range(3):  # one retry in every cycle: never more than the budget in one
        run(machine, [SETTLED, DONE, Outcome("TIMEOUT"), DONE, PRESENTED, REACHED, REACHED])
    assert machine.state is State.FINISHED
    assert (machine.metrics.faults_seen, machine.metrics.faults_handled) == (3, 3)


def test_motor_fault_stops_the_cell_with_the_fault_named() -> None:
    machine = CellMachine(cycles=5)
    run(machine, [DONE, SETTLED, DONE])
    t = machine.advance(Outcome("FAULT", 101, "injected fault motor_fault"), 4.0)
    assert (t.policy, t.target) == (Policy.STOP, State.STOPPED)
    assert machine.stop_reason == "FEED: FAULT 101 (injected fault motor_fault)"
    assert machine.metrics.faults_seen == 1 and machine.metrics.faults_handled == 0


def test_part_lost_resets_and_retries() -> None:
    assert policy_for(State.FEED, Outcome("FAULT", 102)) is Policy.RESET_RETRY
    assert policy_for(State.INFEED, Outcome("FAULT", 102)) is Policy.RESET_RETRY


def test_orient_timeout_retries_the_program_and_power_loss_stops() -> None:
    machine = CellMachine(cycles=1)
    run(machine, [DONE])
    t = machine.advance(Outcome("TIMEOUT"), 2.0)
    assert (t.policy, t.target) == (Policy.RETRY, State.ORIENT)
    t = machine.advance(Outcome("FAULT", 201, "power loss"), 3.0)
    assert t.target is State.STOPPED and "201" in machine.stop_reason


def test_a_failed_recovery_stops_the_cell() -> None:
    machine = CellMachine(cycles=1)
    run(machine, [DONE, SETTLED, DONE, Outcome("MAX_THROWS")])
    t = machine.advance(Outcome("ERROR", 0, "reset refused"), 5.0)
    assert t.target is State.STOPPED and "recovering FEED: ERROR (reset refused)" == machine.stop_reason


@pytest.mark.parametrize(
    "state, outcome",
    [
        (State.BRING_UP, Outcome("ERROR", 1, "configure refused: parameter part_file")),
        (State.TILT, Outcome("STALLED", 301)),
        (State.FEED, Outcome("CANCELED")),
        (State.FEED, Outcome("NO_ANSWER")),
        (State.ORIENT, Outcome("SOMETHING_NEW")),
        (State.INFEED, Outcome("ERROR", 0, "edge: not stable")),
    ],
)
def test_anything_the_policy_does_not_name_stops(state: State, outcome: Outcome) -> None:
    assert policy_for(state, outcome) is Policy.STOP


def test_failed_bring_up_stops_before_any_cycle() -> None:
    machine = CellMachine(cycles=3)
    machine.advance(Outcome("ERROR", 1, "throwing_arm: configure refused"), 1.0)
    assert machine.state is State.STOPPED and machine.cycle == 0
    assert math.isnan(machine.metrics.parts_per_minute(2.0))
    assert math.isnan(machine.metrics.mean_cycle_time)


@pytest.mark.parametrize("field, kwargs", [("cycles", {"cycles": -1}), ("max_retries", {"max_retries": 1.5})])
def test_bad_settings_are_refused_naming_the_field(field: str, kwargs: dict) -> None:
    with pytest.raises(InputError, match=f"^{field}:"):
        CellMachine(**kwargs)


def test_the_tables_as_rows() -> None:
    rows = transition_table()
    assert ("FEED", "PRESENTED", "TILT") in rows and len(rows) == len(TRANSITIONS)
    policies = policy_table()
    assert ("FEED", "FAULT", "101", "STOP") in policies and len(policies) == len(FAULT_POLICY)
    assert ("FEED", "MAX_THROWS", "any", "RESET_RETRY") in policies
