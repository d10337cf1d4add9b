"""The feed-part goal without ROS: the bit at rest decides, every end is bounded, one report per throw.

A small driver below plays the device as the throwing_arm node does (ticks at a rate, a throw every
period shown over a motion window, the goal told of starts, landings, samples and the tick's end); the
node's own behaviour over DDS is in test_feed_part_action_ros.py.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import pytest

from feeder_planner.errors import InputError
from feeder_planner.parts import load_part
from feeder_planner.throwing import ThrowParams, arm_part
from feeder_planner.throwing.limit_set import limit_set
from feeder_sim.throwing import ArmFaults, ThrowingArm
from feeder_sim.throwing.feeding import OUTCOME_CODES, FeedGoal, check_feed_goal

TRIANGLE = Path(__file__).resolve().parents[2] / "examples" / "throwing" / "triangle.yaml"
PAPER = ThrowParams(-0.005, math.radians(320), -9.66, 0.5)
HEIGHT = 0.001
MS = 1_000_000


# --- the goal's checks --------------------------------------------------------------------------------
@pytest.mark.parametrize("value", [0, -1, True, 1.5, "3"])
def test_max_throws_below_one_or_not_an_integer_is_refused_naming_it(value: object) -> None:
    with pytest.raises(InputError) as error:
        check_feed_goal(value, 1.0)
    assert error.value.field == "max_throws" and repr(value) in error.value.problem


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf, -0.5, None])
def test_a_timeout_that_is_negative_or_not_finite_is_refused_naming_it(value: object) -> None:
    with pytest.raises(InputError) as error:
        check_feed_goal(3, value)
    assert error.value.field == "timeout"


def test_a_good_goal_is_returned_with_zero_meaning_no_timeout() -> None:
    request = check_feed_goal(5, 0)
    assert (request.max_throws, request.timeout) == (5, 0.0)
    assert FeedGoal(request, 7, 10, 1, 0.1).deadline_ns is None
    assert FeedGoal(check_feed_goal(1, 2.5), 7, 10, 1, 0.1).deadline_ns == 7 + 2_500_000_000


def test_outcome_codes_are_the_actions_constants() -> None:
    from feeder_msgs.action import FeedPart

    result = FeedPart.Result
    assert OUTCOME_CODES == {
        "PRESENTED": result.PRESENTED,
        "MAX_THROWS": result.MAX_THROWS,
        "TIMEOUT": result.TIMEOUT,
        "FAULT": result.FAULT,
        "CANCELED": result.CANCELED,
    }


# --- a device played tick by tick -----------------------------------------------------------------
@dataclass
class Device:
    """The node's tick loop around a goal: 10 ms ticks, a throw every 200 ms shown for 60 ms.

    ``bits`` gives the bit the sensor delivers at rest after each throw (index 0: before any throw);
    None is a dropped sample. ``flight`` is the motion window in ticks. The rest window is the node's:
    the rest time between throws less one tick, so that an unread bit keeps the throws' period.
    """

    bits: Callable[[int, int], bool | None]  # (throws landed, ticks at rest) -> delivered bit
    tick_ns: int = 10 * MS
    period_ticks: int = 20
    flight: int = 6
    now: int = 1_000 * MS
    throws: int = 0
    motion_left: int = 0
    last_throw_tick: int | None = None
    ticks: int = 0
    rest_ticks: int = 0
    fault: tuple[int, str] | None = None
    lose_in_flight: bool = False
    events: list[int] = field(default_factory=list)

    def goal(self, max_throws: int = 10, timeout: float = 0.0) -> FeedGoal[int]:
        window = (self.period_ticks - self.flight - 1) * self.tick_ns
        return FeedGoal(check_feed_goal(max_throws, timeout), self.now, window, 1, 0.12)

    def tick(self, goal: FeedGoal[int]) -> None:
        self.ticks += 1
        self.now += self.tick_ns
        if self.motion_left:
            self.motion_left -= 1
            if self.lose_in_flight:
                self.motion_left = 0  # the part fell off in the air: no landing
            elif self.motion_left == 0:
                self.events.append(self.throws)
                goal.landed(self.now, 1, 0.1 + self.throws / 100, self.throws)
                self.rest_ticks = 0
        else:
            due = self.last_throw_tick is None or self.ticks - self.last_throw_tick >= self.period_ticks
            if self.fault is None and due and goal.wants_throw(self.now):
                self.throws += 1
                self.last_throw_tick = self.ticks
                self.motion_left = self.flight
                goal.throw_started()
        if not self.motion_left:
            goal.sample(self.bits(len(self.events), self.rest_ticks))
            self.rest_ticks += 1
        goal.tick(self.now, self.fault, self.motion_left > 0)

    def run(self, goal: FeedGoal[int], ticks: int = 10_000) -> None:
        for _ in range(ticks):
            if goal.done:
                return
            self.tick(goal)
        raise AssertionError(f"the goal did not end within {ticks} ticks")


def true_after(throw: int) -> Callable[[int, int], bool | None]:
    return lambda landed, _: landed >= throw


def test_a_part_already_presented_ends_the_goal_with_zero_throws() -> None:
    device = Device(true_after(0))
    goal = device.goal()
    device.run(goal)
    outcome = goal.outcome
    assert outcome is not None and outcome.name == "PRESENTED" and outcome.code == 1
    assert outcome.throws == 0 and outcome.sensor_at_rest and goal.reports == []
    assert (outcome.edge, outcome.radius) == (1, 0.12) and device.ticks == 1


def test_presented_after_throws_one_report_per_throw_the_last_one_true() -> None:
    device = Device(true_after(4))
    goal = device.goal()
    device.run(goal)
    assert goal.outcome is not None and goal.outcome.name == "PRESENTED" and goal.outcome.throws == 4
    assert [r.throws for r in goal.reports] == [1, 2, 3, 4] and [r.event for r in goal.reports] == [
        1,
        2,
        3,
        4,
    ]
    assert [r.sensor_at_rest for r in goal.reports] == [False, False, False, True]
    assert all(r.read for r in goal.reports)
    assert goal.outcome.radius == goal.reports[-1].radius == pytest.approx(0.14)
    # The start's bit is judged at the first tick; then a throw every period, as ~/command throw makes
    # them: 20 ticks apart from tick 2, each landing 6 ticks later.
    assert device.ticks == 2 + 3 * 20 + 6


def test_max_throws_ends_after_the_last_throw_is_judged() -> None:
    device = Device(true_after(99))
    goal = device.goal(max_throws=3)
    device.run(goal)
    assert goal.outcome is not None and goal.outcome.name == "MAX_THROWS"
    assert goal.outcome.throws == 3 == len(goal.reports) and device.throws == 3
    assert not goal.outcome.sensor_at_rest and "max_throws 3" in goal.outcome.message


def test_timeout_waits_for_the_throw_in_flight_and_starts_no_throw_after_it() -> None:
    device = Device(true_after(99))
    goal = device.goal(max_throws=100, timeout=0.45)  # throws at 20, 220, 420 ms; the last lands at 480
    device.run(goal)
    assert goal.outcome is not None and goal.outcome.name == "TIMEOUT" and goal.outcome.throws == 3
    assert len(goal.reports) == 3 and device.now == 1_000 * MS + 480 * MS
    assert "timeout of 0.45 s" in goal.outcome.message


def test_timeout_at_rest_ends_at_the_deadline() -> None:
    device = Device(true_after(99))
    goal = device.goal(max_throws=100, timeout=0.3)
    device.run(goal)
    assert goal.outcome is not None and goal.outcome.name == "TIMEOUT"
    assert device.now == 1_300 * MS and goal.outcome.throws == 2 == len(goal.reports)


def test_a_landing_that_reads_true_after_the_deadline_still_presents() -> None:
    device = Device(true_after(1))
    goal = device.goal(timeout=0.03)  # the first throw is in flight from 20 to 80 ms
    device.run(goal)
    assert goal.outcome is not None and goal.outcome.name == "PRESENTED" and goal.outcome.throws == 1


def test_cancel_in_flight_ends_after_the_landing_with_its_report() -> None:
    device = Device(true_after(99))
    goal = device.goal()
    for _ in range(25):  # the second throw is in the air
        device.tick(goal)
    assert goal.in_flight and device.throws == 2
    goal.cancel("canceled by its client")
    assert not goal.wants_throw(device.now)
    device.run(goal)
    assert goal.outcome is not None and goal.outcome.name == "CANCELED" and goal.outcome.code == 5
    assert goal.outcome.throws == 2 == len(goal.reports) == len(device.events)
    assert goal.outcome.message == "canceled by its client after 2 throws"


def test_cancel_at_rest_ends_at_the_next_tick_without_another_throw() -> None:
    device = Device(true_after(99))
    goal = device.goal()
    for _ in range(10):
        device.tick(goal)
    assert not goal.in_flight and goal.wants_throw(device.now)
    goal.cancel("stopped by ~/command stop")
    goal.tick(device.now, None, False)
    assert goal.outcome is not None and goal.outcome.name == "CANCELED" and device.throws == 1


def test_a_fault_at_rest_ends_the_goal_with_its_code_a_fault_in_flight_after_the_landing() -> None:
    device = Device(true_after(99))
    goal = device.goal()
    device.tick(goal)
    device.tick(goal)  # the first throw is in the air
    device.fault = (101, "injected fault motor_fault")
    device.run(goal)
    outcome = goal.outcome
    assert outcome is not None and outcome.name == "FAULT" and outcome.code == 4
    assert (outcome.fault_code, outcome.fault_text) == (101, "injected fault motor_fault")
    assert outcome.throws == 1 == len(goal.reports) and device.ticks == 8  # the throw landed first
    # At rest, the fault ends the goal at the next tick.
    device = Device(true_after(99))
    goal = device.goal()
    device.tick(goal)
    device.fault = (101, "motor")
    device.tick(goal)
    assert goal.outcome is not None and goal.outcome.name == "FAULT" and goal.outcome.throws == 0
    # The fault comes before the bit: a part presented on a faulted device is still a FAULT.
    device = Device(true_after(1))
    goal = device.goal()
    device.tick(goal)
    device.tick(goal)
    device.fault = (101, "motor")
    device.run(goal)
    assert goal.outcome is not None and goal.outcome.name == "FAULT" and goal.outcome.sensor_at_rest


def test_a_throw_lost_in_the_air_ends_the_goal_faulted_without_a_report() -> None:
    device = Device(true_after(99))
    goal = device.goal()
    device.tick(goal)
    device.tick(goal)
    device.lose_in_flight, device.fault = True, (102, "injected fault part_lost")
    device.run(goal)
    assert goal.outcome is not None and goal.outcome.name == "FAULT" and goal.outcome.fault_code == 102
    assert goal.outcome.throws == 1 and goal.reports == []


def test_a_dropped_sample_waits_for_the_next_one_delivered_within_the_rest_window() -> None:
    # After each landing the first 5 samples are dropped; the 6th reads true after throw 2.
    device = Device(lambda landed, rest: None if rest < 5 else landed >= 2)
    goal = device.goal()
    device.run(goal)
    assert goal.outcome is not None and goal.outcome.name == "PRESENTED" and goal.outcome.throws == 2
    assert [r.read for r in goal.reports] == [True, True]


def test_no_sample_over_the_rest_window_counts_as_unread_and_the_next_throw_follows() -> None:
    device = Device(lambda landed, rest: None)  # sensor_dropout 1: nothing delivered
    goal = device.goal(max_throws=3)
    device.run(goal)
    assert goal.outcome is not None and goal.outcome.name == "MAX_THROWS" and device.throws == 3
    assert [(r.read, r.sensor_at_rest) for r in goal.reports] == [(False, False)] * 3
    # Bounded without a timeout: an unread bit after 13 ticks at rest (the start's at tick 13), the
    # throws still a period apart (ticks 14, 34, 54), the last judged 6 + 13 ticks after it started.
    assert device.ticks == 14 + 2 * 20 + 6 + 13


def test_end_now_reports_a_landed_throw_whose_bit_was_not_read() -> None:
    device = Device(lambda landed, rest: None)
    goal = device.goal()
    for _ in range(14 + 6 + 2):  # the first throw landed (tick 20), its bit not delivered yet
        device.tick(goal)
    assert device.events == [1] and goal.reports == []
    goal.end_now("CANCELED", "stopped by ~/stop")
    assert goal.outcome is not None and goal.outcome.name == "CANCELED"
    assert [(r.throws, r.read) for r in goal.reports] == [(1, False)]
    goal.tick(device.now, (101, "late"), False)  # nothing changes an ended goal
    assert goal.outcome.name == "CANCELED"


# --- the paper's sensor-based feeder with the arm model ----------------------------------------------
def test_the_paper_feeder_presents_the_part_on_the_goal_edge_with_the_limit_set_trigger() -> None:
    """Lynch, Northrop and Pan, section V: a sensor in the trigger range reads true only on edge 1."""
    part = arm_part(load_part(TRIANGLE))
    limits = limit_set(part, PAPER, goal_edge=1, sensing_height=HEIGHT)
    assert limits.trigger is not None
    sensor_radius = sum(limits.trigger) / 2
    arm = ThrowingArm(part, PAPER, 1, 0.12, arm_length=0.4)
    faults = ArmFaults(arm)
    goal: FeedGoal[int] = FeedGoal(check_feed_goal(100, 0.0), 0, 10, arm.edge, arm.radius)
    now = 0
    while not goal.done:
        now += 20
        if goal.wants_throw(now):
            goal.throw_started()
            out = faults.throw()
            goal.landed(now, out.edge_after, out.radius_after, goal.throws)
        goal.sample(faults.sensor(arm.sensor(sensor_radius, HEIGHT)))
        goal.tick(now, None, False)
    outcome = goal.outcome
    assert outcome is not None and outcome.name == "PRESENTED" and outcome.throws >= 1
    assert outcome.edge == 1 and limits.trigger[0] <= sensor_radius <= limits.trigger[1]
    assert [r.sensor_at_rest for r in goal.reports] == [False] * (outcome.throws - 1) + [True]
    check = ThrowingArm(part, PAPER, 1, 0.12, arm_length=0.4)
    first = next(k for k in range(1, 200) if (check.throw(), check.sensor(sensor_radius, HEIGHT))[1])
    assert outcome.throws == first
    # A stuck-false sensor misleads the goal as it would mislead a controller: it never presents.
    arm = ThrowingArm(part, PAPER, 1, 0.12, arm_length=0.4)
    faults = ArmFaults(arm)
    faults.inject("sensor_stuck", state=False)
    goal = FeedGoal(check_feed_goal(outcome.throws + 5, 0.0), 0, 10, arm.edge, arm.radius)
    while not goal.done:
        now += 20
        if goal.wants_throw(now):
            goal.throw_started()
            out = faults.throw()
            goal.landed(now, out.edge_after, out.radius_after, goal.throws)
        goal.sample(faults.sensor(arm.sensor(sensor_radius, HEIGHT)))
        goal.tick(now, None, False)
    assert goal.outcome is not None and goal.outcome.name == "MAX_THROWS"


def test_a_timeout_beyond_a_year_is_refused_before_its_deadline_could_overflow():
    from feeder_planner.limits import MAX_GOAL_TIMEOUT

    assert check_feed_goal(1, MAX_GOAL_TIMEOUT).timeout == MAX_GOAL_TIMEOUT
    with pytest.raises(InputError, match="timeout: must be at most"):
        check_feed_goal(1, 1e308)
