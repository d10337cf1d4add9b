"""Over DDS: the throwing arm's ~/feed_part action (feeder_msgs/FeedPart), the paper's sensor-based feeder.

One arm for the module (``/feed``): every test puts the part back at rest on edge 1 of the paper's
triangle at R = 12 cm, clears faults and sets the sensor radius it needs, so the analytic throws are
the local model's, exactly. A second arm (``/feedclock``) runs on a held, stepped cell clock.

Lynch, Northrop and Pan, "Stable Limit Sets in a Dynamic Parts Feeder", section V: a one-bit sensor in
the arm placed where, within the forward limit set, only the goal edge covers it, makes the arm a parts
feeder. The trigger range comes from the ROS-free limit set; the device's bit at rest decides.
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Iterator

import pytest
import ros_harness
from ros_harness import counters, set_parameter, trigger
from ros_harness import inject_fault as inject
from test_throwing_device_ros import (
    BLIND,
    EDGE,
    HEIGHT,
    PAPER,
    RADIUS,
    SEES,
    TRIANGLE,
    arm_parameters,
    command,
    diagnostics,
    local_arm,
    place,
    status,
    values,
)

from feeder_planner.parts import load_part
from feeder_planner.throwing import ThrowParams, arm_part
from feeder_planner.throwing.limit_set import limit_set

DEVICE = "/feed/throwing_arm"
WAIT = 30.0  # s: the bound of every wait on the device (a loaded machine is slow, never this slow)


def trigger_radius() -> float:
    """The middle of the sensor radii that, in the limit set, read true on edge 1 only (goal edge 1)."""
    params = ThrowParams(PAPER["offset"], PAPER["release_speed"], PAPER["gravity"], PAPER["mu"])
    limits = limit_set(arm_part(load_part(TRIANGLE)), params, goal_edge=1, sensing_height=HEIGHT)
    assert limits.trigger is not None
    return (limits.trigger[0] + limits.trigger[1]) / 2


def first_presented(sensor_radius: float, limit: int = 200) -> int:
    """The throw after which the local model's sensor at ``sensor_radius`` first reads true at rest."""
    model = local_arm()
    for k in range(1, limit):
        model.throw()
        if model.sensor(sensor_radius, HEIGHT):
            return k
    raise AssertionError(f"the sensor at {sensor_radius} never reads true within {limit} throws")


# --- the action client ------------------------------------------------------------------------------
def _answered(future: Any, timeout: float) -> bool:
    """Return whether the future (completed by the client's executor thread) is done within ``timeout``."""
    done = threading.Event()
    future.add_done_callback(lambda _: done.set())
    return done.wait(timeout)


def _wait(future: Any, timeout: float, what: str) -> Any:
    if not _answered(future, timeout):
        raise AssertionError(f"{what}: no answer within {timeout:.0f} s")
    return future.result()


@dataclass
class Goal:
    """A goal sent: its handle (None when the answer never came), and the feedback received so far."""

    handle: Any
    feedback: list[Any] = field(default_factory=list)
    sent: float = 0.0  # time.monotonic() at sending

    @property
    def accepted(self) -> bool:
        return bool(self.handle.accepted)

    def wait_feedback(self, count: int, timeout: float = WAIT) -> list[Any]:
        deadline = time.monotonic() + timeout
        while len(self.feedback) < count:
            assert time.monotonic() < deadline, f"{len(self.feedback)} of {count} feedback messages"
            time.sleep(0.01)
        return list(self.feedback)

    def result(self, timeout: float = WAIT) -> tuple[int, Any]:
        """Return (status, result); the request is repeated, as a reply can be lost to late discovery."""
        deadline = time.monotonic() + timeout
        while True:
            future = self.handle.get_result_async()
            if _answered(future, min(5.0, max(deadline - time.monotonic(), 0.1))):
                answer = future.result()
                return answer.status, answer.result
            assert time.monotonic() < deadline, f"no result within {timeout:.0f} s"

    def cancel(self) -> Any:
        return _wait(self.handle.cancel_goal_async(), WAIT, "cancel")


class Feeder:
    """One ActionClient of a device's ~/feed_part for the module's life (replies need discovery)."""

    def __init__(self, client: Any, device: str) -> None:
        from feeder_msgs.action import FeedPart
        from feeder_planner.node_kit.action_client import ActionClient

        self.type = FeedPart
        self.client = ActionClient(client, FeedPart, f"{device}/feed_part")
        assert self.client.wait_for_server(timeout_sec=WAIT), f"{device}/feed_part not served"
        # A refused goal moves nothing: repeat it until its answer comes, so that the server has
        # discovered this client's reply readers before any goal that matters is sent.
        deadline = time.monotonic() + WAIT
        while True:
            future = self.client.send_goal_async(FeedPart.Goal(max_throws=0, timeout=0.0))
            if _answered(future, 3.0):
                assert not future.result().accepted
                return
            assert time.monotonic() < deadline, "the feed_part server never answered a goal"

    def send(self, max_throws: int, timeout: float = 0.0) -> Goal:
        goal = Goal(None, sent=time.monotonic())

        def on_feedback(message: Any) -> None:
            goal.feedback.append(message.feedback)

        future = self.client.send_goal_async(
            self.type.Goal(max_throws=max_throws, timeout=timeout), feedback_callback=on_feedback
        )
        goal.handle = _wait(future, WAIT, "send_goal")
        return goal


@pytest.fixture(scope="module")
def arm(launch_module_node: Callable[..., Any], ros_client: Any) -> Iterator[Feeder]:
    launch_module_node("feeder_sim", "throwing_arm", arm_parameters(), namespace="/feed")
    yield Feeder(ros_client, DEVICE)


def fresh(ros_client: Any, listen: Callable[..., Any], sensor_radius: float) -> Any:
    """Back to IDLE with no fault, the part at rest at (EDGE, RADIUS), the sensor at ``sensor_radius``."""
    assert trigger(ros_client, DEVICE, "reset").success
    assert inject(ros_client, DEVICE, "", clear=True).ok
    assert place(ros_client, DEVICE).ok
    assert set_parameter(ros_client, DEVICE, "sensor_radius", sensor_radius).successful
    return status(listen, DEVICE, lambda s: s.state_name == "IDLE" and not s.active_faults and not s.busy)


def events_since(listen: Callable[..., Any], mark: int) -> list[Any]:
    from feeder_msgs.msg import ThrowEvent

    return listen(ThrowEvent, f"{DEVICE}/throw_events").since(mark)


def event_mark(listen: Callable[..., Any]) -> int:
    from feeder_msgs.msg import ThrowEvent

    return listen(ThrowEvent, f"{DEVICE}/throw_events").count()


def status_names() -> dict[int, str]:
    from action_msgs.msg import GoalStatus

    return {GoalStatus.STATUS_SUCCEEDED: "SUCCEEDED", GoalStatus.STATUS_ABORTED: "ABORTED"} | {
        GoalStatus.STATUS_CANCELED: "CANCELED"
    }


def check_feedback(goal: Goal, result: Any, listen: Callable[..., Any], mark: int) -> list[Any]:
    """One feedback per throw, numbered, each with its landing's event; as many events as throws.

    The result, the feedback and the events travel apart: the last ones may arrive after the result.
    Returns the goal's events.
    """
    goal.wait_feedback(result.throws)
    deadline = time.monotonic() + WAIT
    while len(events_since(listen, mark)) < result.throws:
        assert time.monotonic() < deadline, f"{len(events_since(listen, mark))} of {result.throws} events"
        time.sleep(0.01)
    events = events_since(listen, mark)
    assert [f.throws for f in goal.feedback] == list(range(1, result.throws + 1))
    assert len(events) == result.throws
    assert [f.event.index for f in goal.feedback] == [e.index for e in events]
    for f, e in zip(goal.feedback, events, strict=True):
        assert (f.edge, f.radius) == (e.edge_after, e.radius_after)  # the ground truth, logged
    return events


# --- outcomes ---------------------------------------------------------------------------------------
@pytest.mark.ros
def test_a_feed_with_the_paper_trigger_presents_the_part_on_edge_1(arm, ros_client, listen) -> None:
    from action_msgs.msg import GoalStatus

    from feeder_msgs.action import FeedPart

    sensor_radius = trigger_radius()
    expected = first_presented(sensor_radius)
    before = counters(fresh(ros_client, listen, sensor_radius))
    mark, status_mark = event_mark(listen), listen_status(listen).count()
    goal = arm.send(max_throws=expected + 10, timeout=60.0)
    assert goal.accepted
    state, result = goal.result()
    assert state == GoalStatus.STATUS_SUCCEEDED, status_names().get(state, state)
    assert (result.outcome, result.outcome_name) == (FeedPart.Result.PRESENTED, "PRESENTED")
    assert result.throws == expected and len(goal.feedback) == expected
    check_feedback(goal, result, listen, mark)
    assert [f.sensor_at_rest for f in goal.feedback] == [False] * (expected - 1) + [True]
    # The paper's claim, checked on the ground truth: detected in the trigger range means edge 1.
    assert result.sensor_at_rest and result.edge == 1 == goal.feedback[-1].edge
    assert result.radius == goal.feedback[-1].radius and "presented after" in result.message
    assert result.fault_code == 0
    seen = listen_status(listen).since(status_mark)
    assert any(s.state_name == "RUNNING" and s.busy for s in seen)  # busy while the goal executed
    after = counters(status(listen, DEVICE, lambda s: s.state_name == "IDLE" and not s.busy))
    assert after["feed_goals"] == before["feed_goals"] + 1
    assert after["feeds_presented"] == before["feeds_presented"] + 1
    assert after["throws"] == before["throws"] + expected


def listen_status(listen: Callable[..., Any]) -> Any:
    from feeder_msgs.msg import DeviceStatus

    return listen(DeviceStatus, f"{DEVICE}/status", True)


@pytest.mark.ros
def test_max_throws_with_a_sensor_where_the_part_never_is(arm, ros_client, listen) -> None:
    from action_msgs.msg import GoalStatus

    from feeder_msgs.action import FeedPart

    model = local_arm()
    rests = []
    for _ in range(50):
        model.throw()
        rests.append(model.sensor(BLIND, HEIGHT))
    assert not any(rests)  # the part never rests over a sensor at 35 cm
    fresh(ros_client, listen, BLIND)
    mark = event_mark(listen)
    goal = arm.send(max_throws=3)
    state, result = goal.result()
    assert state == GoalStatus.STATUS_ABORTED and result.outcome == FeedPart.Result.MAX_THROWS
    assert result.outcome_name == "MAX_THROWS" and result.throws == 3 and not result.sensor_at_rest
    check_feedback(goal, result, listen, mark)
    assert not any(f.sensor_at_rest for f in goal.feedback)
    assert status(listen, DEVICE, lambda s: not s.busy).state_name == "IDLE"


@pytest.mark.ros
def test_a_sensor_stuck_false_decides_max_throws_though_the_part_is_there(arm, ros_client, listen) -> None:
    from feeder_msgs.action import FeedPart

    fresh(ros_client, listen, SEES)
    assert inject(ros_client, DEVICE, "sensor_stuck", state=False).ok
    mark = event_mark(listen)
    goal = arm.send(max_throws=2)
    _, result = goal.result()
    assert result.outcome == FeedPart.Result.MAX_THROWS and result.throws == 2
    events = check_feedback(goal, result, listen, mark)
    # The true sensor saw the part after each throw; the faulty bit, which decides, never did.
    assert all(e.sensor_at_rest for e in events) and not any(f.sensor_at_rest for f in goal.feedback)


@pytest.mark.ros
def test_a_sensor_stuck_true_presents_with_zero_throws_though_nothing_is_there(
    arm, ros_client, listen
) -> None:
    from action_msgs.msg import GoalStatus

    from feeder_msgs.action import FeedPart

    fresh(ros_client, listen, BLIND)
    assert inject(ros_client, DEVICE, "sensor_stuck", state=True).ok
    mark = event_mark(listen)
    goal = arm.send(max_throws=5)
    state, result = goal.result()
    assert state == GoalStatus.STATUS_SUCCEEDED and result.outcome == FeedPart.Result.PRESENTED
    assert result.throws == 0 and goal.feedback == [] and events_since(listen, mark) == []
    assert result.sensor_at_rest and (result.edge, result.radius) == (EDGE, RADIUS)
    assert not local_arm().sensor(BLIND, HEIGHT)  # ground truth: no part over the sensor


@pytest.mark.ros
def test_timeout_ends_the_goal_by_node_clock(arm, ros_client, listen) -> None:
    from feeder_msgs.action import FeedPart

    fresh(ros_client, listen, BLIND)
    mark = event_mark(listen)
    goal = arm.send(max_throws=1000, timeout=0.5)
    _, result = goal.result()
    took = time.monotonic() - goal.sent
    assert result.outcome == FeedPart.Result.TIMEOUT and result.outcome_name == "TIMEOUT"
    assert took >= 0.5 and "timeout of 0.5 s" in result.message
    # a throw every 0.2 s from the goal's start; the one in flight at the deadline lands first
    assert 1 <= result.throws <= 4
    check_feedback(goal, result, listen, mark)


@pytest.mark.ros
def test_a_dropped_sample_is_waited_for_over_the_rest_window_never_longer(arm, ros_client, listen) -> None:
    from feeder_msgs.action import FeedPart

    # Every sample dropped: each bit at rest is unread (not presented), and the goal still ends.
    fresh(ros_client, listen, SEES)
    assert inject(ros_client, DEVICE, "sensor_dropout", value=1.0).ok
    mark = event_mark(listen)
    goal = arm.send(max_throws=3)
    _, result = goal.result()
    assert result.outcome == FeedPart.Result.MAX_THROWS and result.throws == 3
    check_feedback(goal, result, listen, mark)
    assert not any(f.sensor_at_rest for f in goal.feedback) and not result.sensor_at_rest
    assert all(e.sensor_at_rest for e in events_since(listen, mark))  # the part was there all along
    # Half the samples dropped: the next delivered one, well within the rest window, decides.
    assert inject(ros_client, DEVICE, "sensor_dropout", value=0.5, seed=5).ok
    assert place(ros_client, DEVICE).ok
    _, result = arm.send(max_throws=3).result()
    assert result.outcome == FeedPart.Result.PRESENTED and result.throws == 0


# --- faults, cancel, stop ---------------------------------------------------------------------------
@pytest.mark.ros
def test_a_motor_fault_mid_goal_ends_it_faulted_and_after_reset_a_goal_succeeds(
    arm, ros_client, listen
) -> None:
    from action_msgs.msg import GoalStatus

    from feeder_msgs.action import FeedPart
    from feeder_msgs.msg import DeviceStatus

    fresh(ros_client, listen, BLIND)
    mark = event_mark(listen)
    goal = arm.send(max_throws=1000)
    goal.wait_feedback(2)
    assert inject(ros_client, DEVICE, "motor_fault").ok
    state, result = goal.result()
    assert state == GoalStatus.STATUS_ABORTED and result.outcome == FeedPart.Result.FAULT
    assert result.fault_code == DeviceStatus.FAULT_MOTOR == 101 and "motor_fault" in result.fault_text
    assert "motor_fault" in result.message
    time.sleep(0.3)  # nothing thrown after the fault: a late event would show by now
    check_feedback(goal, result, listen, mark)
    assert status(listen, DEVICE, lambda s: not s.busy).state_name == "FAULT"
    refused = arm.send(max_throws=1)
    assert not refused.accepted
    fresh(ros_client, listen, SEES)
    again = arm.send(max_throws=1)
    state, result = again.result()
    assert state == GoalStatus.STATUS_SUCCEEDED and result.outcome == FeedPart.Result.PRESENTED


@pytest.mark.ros
def test_a_part_lost_mid_goal_ends_it_with_fault_102(arm, ros_client, listen) -> None:
    from feeder_msgs.action import FeedPart
    from feeder_msgs.msg import DeviceStatus

    fresh(ros_client, listen, BLIND)
    mark = event_mark(listen)
    goal = arm.send(max_throws=1000)
    goal.wait_feedback(1)
    assert inject(ros_client, DEVICE, "part_lost").ok
    _, result = goal.result()
    assert result.outcome == FeedPart.Result.FAULT and result.fault_code == DeviceStatus.FAULT_PART_LOST
    assert "part_lost" in result.fault_text

    # A throw in the air when the part fell off never lands: no event and no feedback for it.
    def consistent() -> bool:
        events = events_since(listen, mark)
        return len(goal.feedback) == len(events) and result.throws - len(events) in (0, 1)

    deadline = time.monotonic() + WAIT
    while not consistent():
        assert time.monotonic() < deadline, (result.throws, len(goal.feedback), events_since(listen, mark))
        time.sleep(0.01)
    assert (result.edge, math.isnan(result.radius)) == (-1, True)  # ground truth: off the arm
    assert status(listen, DEVICE, lambda s: not s.busy).fault_code == DeviceStatus.FAULT_PART_LOST


@pytest.mark.ros
def test_cancel_mid_goal_stops_after_the_throw_in_flight(arm, ros_client, listen) -> None:
    from action_msgs.msg import GoalStatus

    from feeder_msgs.action import FeedPart

    fresh(ros_client, listen, BLIND)
    mark = event_mark(listen)
    goal = arm.send(max_throws=1000)
    goal.wait_feedback(2)
    answer = goal.cancel()
    assert len(answer.goals_canceling) == 1
    state, result = goal.result()
    assert state == GoalStatus.STATUS_CANCELED and result.outcome == FeedPart.Result.CANCELED
    assert result.outcome_name == "CANCELED" and "canceled by its client" in result.message
    idle = status(listen, DEVICE, lambda s: not s.busy)
    assert idle.state_name == "IDLE" and idle.ready
    time.sleep(0.5)  # more than a period: a throw after the cancel would show by now
    check_feedback(goal, result, listen, mark)
    assert result.throws >= 2
    sensor_radius = trigger_radius()
    fresh(ros_client, listen, sensor_radius)
    state, result = arm.send(max_throws=100).result()
    assert state == GoalStatus.STATUS_SUCCEEDED and result.throws == first_presented(sensor_radius)


@pytest.mark.ros
def test_stop_and_command_stop_end_a_goal_and_commands_wait_for_it(arm, ros_client, listen) -> None:
    from action_msgs.msg import GoalStatus

    from feeder_msgs.action import FeedPart

    fresh(ros_client, listen, BLIND)
    mark = event_mark(listen)
    goal = arm.send(max_throws=1000)
    goal.wait_feedback(1)
    refused = command(ros_client, DEVICE, "throw", 1)
    assert not refused.ok and "feed_part goal is executing" in refused.error
    assert "feed_part goal is executing" in place(ros_client, DEVICE).error
    assert trigger(ros_client, DEVICE, "stop").success
    state, result = goal.result()
    assert state == GoalStatus.STATUS_ABORTED and result.outcome == FeedPart.Result.CANCELED
    assert "~/stop" in result.message
    assert status(listen, DEVICE, lambda s: not s.busy).state_name == "STOPPED"
    time.sleep(0.3)
    check_feedback(goal, result, listen, mark)
    fresh(ros_client, listen, BLIND)
    mark = event_mark(listen)
    goal = arm.send(max_throws=1000)
    goal.wait_feedback(1)
    assert command(ros_client, DEVICE, "stop").ok
    state, result = goal.result()
    assert state == GoalStatus.STATUS_ABORTED and result.outcome == FeedPart.Result.CANCELED
    assert "~/command stop" in result.message
    assert status(listen, DEVICE, lambda s: not s.busy).state_name == "IDLE"
    time.sleep(0.5)
    check_feedback(goal, result, listen, mark)


@pytest.mark.ros
def test_deactivation_mid_goal_ends_it_and_after_activate_a_goal_succeeds(arm, ros_client, listen) -> None:
    from action_msgs.msg import GoalStatus

    from feeder_msgs.action import FeedPart

    fresh(ros_client, listen, BLIND)
    goal = arm.send(max_throws=1000)
    goal.wait_feedback(1)
    life = ros_harness.lifecycle_of(ros_client, DEVICE)
    try:
        assert life.change("deactivate") == "inactive"
        state, result = goal.result()
        assert state == GoalStatus.STATUS_ABORTED and result.outcome == FeedPart.Result.FAULT
        assert "deactivated" in result.message and result.fault_code == 0
        paused = arm.send(max_throws=1)
        assert not paused.accepted
        reason = diagnostics(listen, DEVICE, lambda d: "PAUSED" in values(d)["last_goal_rejection"])
        assert "~/feed_part" in values(reason)["last_goal_rejection"]
        assert life.change("activate") == "active"
    finally:
        life.close()
    fresh(ros_client, listen, SEES)
    state, result = arm.send(max_throws=3).result()
    assert state == GoalStatus.STATUS_SUCCEEDED and result.throws == 0


# --- bad goals ---------------------------------------------------------------------------------------
@pytest.mark.ros
def test_bad_goals_are_rejected_at_goal_time_naming_the_field_and_the_node_keeps_serving(
    arm, ros_client, listen
) -> None:
    from action_msgs.msg import GoalStatus

    def rejected(max_throws: int, timeout: float, named: str) -> None:
        goal = arm.send(max_throws=max_throws, timeout=timeout)
        assert not goal.accepted
        diag = diagnostics(listen, DEVICE, lambda d: named in values(d)["last_goal_rejection"])
        assert values(diag)["last_goal_rejection"].startswith("~/feed_part")

    fresh(ros_client, listen, BLIND)
    rejected(0, 0.0, "max_throws: must be an integer >= 1, got 0")
    rejected(3, math.nan, "timeout: must be finite and >= 0 s (0: no limit), got nan")
    rejected(3, -1.0, "timeout: must be finite and >= 0 s (0: no limit), got -1.0")
    rejected(3, math.inf, "timeout: must be finite and >= 0 s (0: no limit), got inf")
    assert inject(ros_client, DEVICE, "motor_fault").ok
    status(listen, DEVICE, lambda s: s.state_name == "FAULT")
    rejected(3, 0.0, "device is FAULT (injected fault motor_fault")
    fresh(ros_client, listen, BLIND)
    assert command(ros_client, DEVICE, "start").ok
    rejected(3, 0.0, "~/command keeps the arm busy (throwing every period)")
    assert command(ros_client, DEVICE, "stop").ok
    status(listen, DEVICE, lambda s: not s.busy)
    first = arm.send(max_throws=1000)
    assert first.accepted
    rejected(3, 0.0, "a goal is executing; cancel it first")
    first.cancel()
    state, _ = first.result()
    assert state == GoalStatus.STATUS_CANCELED
    fresh(ros_client, listen, SEES)
    state, result = arm.send(max_throws=1).result()
    assert state == GoalStatus.STATUS_SUCCEEDED and result.throws == 0


# --- one clock ---------------------------------------------------------------------------------------
@pytest.mark.ros
def test_under_a_held_stepped_cell_clock_the_timeout_follows_the_clock(
    launch_node, ros_client, listen
) -> None:
    from action_msgs.msg import GoalStatus
    from sensor_msgs.msg import JointState

    from feeder_msgs.action import FeedPart
    from feeder_msgs.msg import DeviceStatus

    stamp = ros_harness.stamp_ns
    launch_node(
        "feeder_cell",
        "cell_clock",
        {"start_paused": True, "start_time": 1.0e9},
        wait_services=("/cell_clock/step",),
    )
    device = "/feedclock/throwing_arm"
    # 20 Hz ticks, a throw every 0.2 s shown for 0.06 s: with 0.05 s steps, one tick per step.
    launch_node(
        "feeder_sim",
        "throwing_arm",
        arm_parameters(use_sim_time=True, sensor_rate=20.0),
        namespace="/feedclock",
    )
    statuses = listen(DeviceStatus, f"{device}/status", latched=True)
    joints = listen(JointState, f"{device}/joint_states")
    statuses.wait(lambda s: stamp(s) == 10**18, WAIT, current=True)  # it has heard the held clock
    feeder = Feeder(ros_client, device)

    def tick() -> int:
        now = ros_harness.step_clock(ros_client, 0.05)
        joints.wait(lambda m: stamp(m) == now, WAIT, current=True)
        return now

    # Held: a cancel still ends a goal (it is at rest), without a tick.
    goal = feeder.send(max_throws=1000, timeout=1.0)
    assert goal.accepted
    goal.cancel()
    state, result = goal.result()
    assert state == GoalStatus.STATUS_CANCELED and result.throws == 0
    # Held: the goal waits with the clock, however long the wall clock runs.
    goal = feeder.send(max_throws=1000, timeout=1.0)
    pending = goal.handle.get_result_async()
    time.sleep(2.0)
    assert not pending.done() and goal.feedback == []
    for _ in range(19):
        tick()
    goal.wait_feedback(4)  # landings at 0.2, 0.4, 0.6, 0.8 s
    time.sleep(0.5)  # a result (or a fifth feedback) sent by mistake would show by now
    assert not pending.done() and len(goal.feedback) == 4
    tick()  # 20 steps of 0.05 s: the deadline, as the fifth throw (at 0.9 s) lands at 1.0 s
    state, result = goal.result()
    assert state == GoalStatus.STATUS_ABORTED and result.outcome == FeedPart.Result.TIMEOUT
    assert result.throws == 5 == len(goal.feedback)
    assert [f.event.header.stamp.sec * 10**9 + f.event.header.stamp.nanosec for f in goal.feedback] == [
        10**18 + k * 50_000_000 for k in (4, 8, 12, 16, 20)
    ]
