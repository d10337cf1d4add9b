"""Over DDS: the MEMS field array's ~/run_program action (feeder_msgs/RunProgram).

One array for the module (the L bracket of examples/mems, ideal model, unit damping) driven by an
``rclpy.action.ActionClient`` in the test's client node: a part settles at the equilibrium the planner
predicts (computed here with the ROS-free planner, never hard-coded), timeout, a power loss mid-goal
(FAULT 201, then ~/reset and a goal that succeeds), cancel, deactivation mid-goal, a field without a
prediction, and goals rejected while one runs, in FAULT and inactive (bad goals, each naming its field,
are the conformance suite's: tests/devices). A second array on a held cell clock shows the goal waiting
with the clock.
"""

from __future__ import annotations

import math
import re
import threading
import time
from pathlib import Path
from typing import Any, Callable

import pytest
import ros_harness
from ros_harness import counters

from feeder_planner.mems import final_equilibrium, find_equilibria
from feeder_planner.parts import load_part
from feeder_sim.mems.settling import EQUILIBRIUM_ANGLE_TOLERANCE

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "mems"
PART_FILE = EXAMPLES / "bracket.yaml"
PART = load_part(PART_FILE)
NAMESPACE = "/runprog"
DEVICE = f"{NAMESPACE}/mems_field_array"
DELTA = 0.3  # the small constant field of the goals: u = |r| + 0.3 eta
START = (3e-4, -2e-4, 1.0)  # a pose 0.36 mm off the origin, well inside one basin of the bracket
# The ideal model ends within 1e-8 rad of the planner's equilibrium; the match tolerance of the node
# (EQUILIBRIUM_ANGLE_TOLERANCE, 0.01 rad) covers the array model's discretisation too. This test asks
# for 1e-4 rad.
REACHED_TOLERANCE = 1e-4
# A program no part can settle in for its first 3 s (settling counts in the last step only): a goal of it
# is surely still running when the test acts on it, however loaded the machine.
LONG_PROGRAM = ({"type": "radial", "duration": 3.0}, {"type": "combined", "delta": DELTA})


def device_parameters(**overrides: Any) -> dict[str, Any]:
    return {
        "part_files": [str(PART_FILE)],
        "initial_poses": list(START),
        "default_delta": 0.2,
        "damping": 1.0,
        "time_step": 1e-3,
        "publish_rate": 20.0,
        **overrides,
    }


# --- action helpers -------------------------------------------------------------------------------
def field_program(*steps: dict[str, Any]) -> Any:
    from feeder_msgs.msg import FieldProgram, FieldSpec

    return FieldProgram(steps=[FieldSpec(**step) for step in steps])


def run_goal(
    steps: tuple[dict[str, Any], ...] = ({"type": "combined", "delta": DELTA},),
    timeout: float = 30.0,
    tolerance: float = 0.0,
    dwell: float = 0.0,
) -> Any:
    from feeder_msgs.action import RunProgram

    return RunProgram.Goal(program=field_program(*steps), timeout=timeout, tolerance=tolerance, dwell=dwell)


def wait_future(future: Any, timeout: float, what: str) -> Any:
    done = threading.Event()
    future.add_done_callback(lambda _: done.set())
    if not done.wait(timeout):
        raise AssertionError(f"{what} did not complete within {timeout:.0f} s")
    return future.result()


class Goal:
    """A goal sent to ~/run_program: its handle, the feedback that arrived, and its result."""

    def __init__(self, handle: Any, feedback: list[Any]) -> None:
        self.handle, self.feedback = handle, feedback
        self._result = handle.get_result_async() if handle.accepted else None

    @property
    def accepted(self) -> bool:
        return bool(self.handle.accepted)

    def wait_feedback(self, accept: Callable[[Any], bool] = lambda f: True, timeout: float = 30.0) -> Any:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            for message in list(self.feedback):
                if accept(message):
                    return message
            time.sleep(0.02)
        raise AssertionError(f"no accepted feedback within {timeout} s; got {len(self.feedback)}")

    def result(self, timeout: float = 60.0) -> tuple[int, Any]:
        """Return (GoalStatus code, RunProgram.Result) once the goal has ended."""
        assert self._result is not None, "the goal was rejected"
        response = wait_future(self._result, timeout, "the goal's result")
        return response.status, response.result

    def cancel(self) -> Any:
        return wait_future(self.handle.cancel_goal_async(), 30.0, "cancel")


class ProgramClient:
    """The module's one action client of an array's ~/run_program (one client per server, for its life)."""

    def __init__(self, client: Any, device: str) -> None:
        from feeder_msgs.action import RunProgram
        from feeder_planner.node_kit.action_client import ActionClient

        self.action = ActionClient(client, RunProgram, f"{device}/run_program")
        assert self.action.wait_for_server(timeout_sec=30.0), f"{device}/run_program not available"

    def send(self, goal: Any, timeout: float = 30.0) -> Goal:
        feedback: list[Any] = []
        future = self.action.send_goal_async(goal, feedback_callback=lambda m: feedback.append(m.feedback))
        return Goal(wait_future(future, timeout, "send_goal"), feedback)

    def warm_up(self, timeout: float = 60.0) -> None:
        """Send rejected goals until one is answered: the server has then discovered this client.

        Fast DDS drops a reply to a client the server has not matched yet; a rejected goal (an empty
        program) has no effect but a rejection reason, so it is safe to send again.
        """
        deadline = time.monotonic() + timeout
        while True:
            future = self.action.send_goal_async(run_goal(steps=()))
            done = threading.Event()
            future.add_done_callback(lambda _, event=done: event.set())
            if done.wait(3.0):
                assert not future.result().accepted
                return
            assert time.monotonic() < deadline, "the action server never answered a goal"


# --- the module's array ---------------------------------------------------------------------------
class Array:
    """The array under test: its status and diagnostics through the module's listeners, its services."""

    def __init__(self, client: Any, listen: Any, name: str) -> None:
        self.client, self.listen, self.name = client, listen, name
        self.program = ProgramClient(client, name)
        self.program.warm_up()

    def status(self, accept: Callable[[Any], bool] = lambda s: True, timeout: float = 30.0) -> Any:
        from feeder_msgs.msg import DeviceStatus

        return self.listen(DeviceStatus, f"{self.name}/status", latched=True).wait(
            accept, timeout, current=True
        )

    def field_program(self, accept: Callable[[Any], bool]) -> Any:
        from feeder_msgs.msg import FieldProgram

        return self.listen(FieldProgram, f"{self.name}/field_program", latched=True).wait(
            accept, current=True
        )

    def diagnostics(self, accept: Callable[[dict[str, str]], bool], timeout: float = 30.0) -> dict[str, str]:
        """Return the values of this array's next /diagnostics entry that ``accept`` takes."""
        from diagnostic_msgs.msg import DiagnosticArray

        def values(msg: Any) -> dict[str, str] | None:
            for entry in msg.status:
                if entry.name == self.name:
                    return {kv.key: kv.value for kv in entry.values}
            return None

        msg = self.listen(DiagnosticArray, "/diagnostics").wait(
            lambda m: (v := values(m)) is not None and accept(v), timeout
        )
        found = values(msg)
        assert found is not None
        return found

    def place(self, pose: tuple[float, float, float]) -> None:
        from feeder_msgs.srv import MemsPlaceParts

        request = MemsPlaceParts.Request(names=["bracket"], x=[pose[0]], y=[pose[1]], theta=[pose[2]])
        response = ros_harness.call_service(self.client, MemsPlaceParts, f"{self.name}/place_parts", request)
        assert response.ok, response.error

    def ready(self) -> Any:
        """Wait until the device accepts goals (after a fault, a cancel or a deactivation)."""
        return self.status(lambda s: s.ready)


@pytest.fixture(scope="module")
def array(launch_module_node, ros_client, listen) -> Array:
    launch_module_node(
        "feeder_sim",
        "mems_field_array",
        device_parameters(),
        namespace=NAMESPACE,
        wait_topics=(f"{DEVICE}/part_states",),
    )
    return Array(ros_client, listen, DEVICE)


@pytest.fixture
def device(array: Array) -> Array:
    """Every test starts with a healthy, ready array and its part at START."""
    assert ros_harness.inject_fault(array.client, array.name, "", clear=True).ok
    array.ready()
    array.place(START)
    return array


def expected_equilibrium(theta: float, delta: float = DELTA) -> tuple[int, Any]:
    """The planner's prediction, ROS-free: the stable equilibrium at the end of theta's arc (Prop. 5)."""
    result = find_equilibria(PART, delta)
    reached = final_equilibrium(result, theta)
    return result.equilibria.index(reached), reached


# --- tests ----------------------------------------------------------------------------------------
@pytest.mark.ros
def test_a_part_settles_at_the_equilibrium_the_planner_predicts(device: Array) -> None:
    from action_msgs.msg import GoalStatus

    from feeder_msgs.action import RunProgram

    before = counters(device.status())["program_goals"]
    goal = device.program.send(run_goal(timeout=30.0))
    assert goal.accepted
    # accepting installs the program at once, as ~/set_program does: the latched topic shows it
    shown = device.field_program(lambda m: len(m.steps) == 1 and m.steps[0].delta == DELTA)
    assert shown.steps[0].type == "combined"
    running = device.status(lambda s: counters(s)["program_goals"] == before + 1)
    assert running.busy and running.state_name == "RUNNING"
    status, result = goal.result()
    assert status == GoalStatus.STATUS_SUCCEEDED, result.message
    assert result.outcome == RunProgram.Result.SETTLED and result.outcome_name == "SETTLED"
    assert result.settled and result.fault_code == 0
    index, reached = expected_equilibrium(START[2])
    assert list(result.equilibrium) == [index], result.message
    assert result.equilibrium_theta[0] == pytest.approx(reached.theta % (2 * math.pi), abs=1e-9)
    assert result.equilibrium_distance[0] < REACHED_TOLERANCE
    final = result.parts[0]
    assert final.name == "bracket"
    assert abs(math.remainder(final.theta - reached.theta, 2 * math.pi)) < REACHED_TOLERANCE
    assert math.hypot(final.pose.position.x - reached.x, final.pose.position.y - reached.y) < 1e-6
    assert f"at predicted equilibrium {index}" in result.message
    # feedback: node-clock time since the start, at most every 0.1 s, the distance to the equilibrium
    times = [f.time for f in goal.feedback]
    assert len(times) >= 5 and times == sorted(times) and times[0] >= 0.0
    assert min(b - a for a, b in zip(times, times[1:], strict=False)) >= 0.1 - 1e-6
    assert all(len(f.parts) == 1 and len(f.settled) == 1 for f in goal.feedback)
    # (a loaded client may lose the oldest feedback from its queue: judged message by message)
    for f in goal.feedback:
        turn = abs(math.remainder(f.parts[0].theta - reached.theta, 2 * math.pi))
        assert f.equilibrium_distance[0] == pytest.approx(turn, abs=1e-12)
    assert goal.feedback[-1].equilibrium_distance[0] < 1e-3  # it ended at the equilibrium
    device.status(lambda s: s.state_name == "IDLE" and not s.busy)
    # A goal on parts already at rest is RUNNING for its whole dwell, though nothing moves.
    goal = device.program.send(run_goal(dwell=1.5))
    busy = device.status(lambda s: s.busy and counters(s)["program_goals"] == before + 2)
    assert busy.state_name == "RUNNING" and counters(busy)["parts_settled"] == 1
    status, result = goal.result()
    assert status == GoalStatus.STATUS_SUCCEEDED and list(result.equilibrium) == [index]
    took = re.search(r"every part settled ([0-9.e+-]+) s into the goal", result.message)
    assert took and float(took.group(1)) >= 1.5, result.message  # it took the dwell
    device.status(lambda s: s.state_name == "IDLE")


@pytest.mark.ros
def test_a_timeout_too_short_to_settle_aborts_with_timeout(device: Array) -> None:
    from action_msgs.msg import GoalStatus

    from feeder_msgs.action import RunProgram

    goal = device.program.send(run_goal(timeout=0.3))
    status, result = goal.result()
    assert status == GoalStatus.STATUS_ABORTED
    assert result.outcome == RunProgram.Result.TIMEOUT and result.outcome_name == "TIMEOUT"
    assert not result.settled and "timeout 0.3 s passed" in result.message and "bracket" in result.message
    assert list(result.equilibrium) == [-1]  # still on its way
    assert result.equilibrium_distance[0] > EQUILIBRIUM_ANGLE_TOLERANCE
    assert all(f.time < 0.3 for f in goal.feedback)
    device.status(lambda s: s.ready)


@pytest.mark.ros
def test_parts_at_rest_after_steps_beyond_the_stability_margin_are_not_certified(device: Array) -> None:
    """At a twentieth of the drag the 1e-3 s Heun step is far past its limit: the bracket freezes off its
    equilibrium within a tenth of a second and reads as at rest. The goal ends FAULT (FAULT_TIME_STEP),
    not SETTLED; status warns without stopping; the module's drag back, the next goal settles."""
    from action_msgs.msg import GoalStatus

    from feeder_msgs.action import RunProgram
    from feeder_msgs.msg import DeviceStatus

    before = counters(device.status())["stiff_steps"]
    assert ros_harness.set_parameter(device.client, device.name, "damping", 0.05).successful
    try:
        status, result = device.program.send(run_goal(timeout=30.0)).result()
        assert status == GoalStatus.STATUS_ABORTED, result.message
        assert result.outcome == RunProgram.Result.FAULT and not result.settled, result.message
        assert result.fault_code == DeviceStatus.FAULT_TIME_STEP
        assert "every part stopped moving" in result.message and "time_step 0.001 s" in result.message
        assert "damping 0.05" in result.message and "or more damping" in result.message
        warned = device.status(lambda s: s.fault_code == DeviceStatus.FAULT_TIME_STEP)
        assert warned.ready and warned.state_name == "IDLE"  # a warning, not a stop
        assert counters(warned)["stiff_steps"] > before
        from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus

        def warns(msg: Any) -> bool:
            return any(
                e.name == device.name and e.level == DiagnosticStatus.WARN and "not certified" in e.message
                for e in msg.status
            )

        device.listen(DiagnosticArray, "/diagnostics").wait(warns, 30.0)
    finally:
        assert ros_harness.set_parameter(device.client, device.name, "damping", 1.0).successful
    cleared = device.status(lambda s: ros_harness.unfaulted(s.fault_code))
    stiff = counters(cleared)["stiff_steps"]
    device.place(START)
    status, result = device.program.send(run_goal(timeout=30.0)).result()
    assert status == GoalStatus.STATUS_SUCCEEDED and result.settled, result.message
    assert list(result.equilibrium) == [expected_equilibrium(START[2])[0]]
    assert counters(device.status())["stiff_steps"] == stiff


@pytest.mark.ros
def test_power_loss_mid_goal_is_a_fault_then_reset_and_a_goal_succeeds(device: Array) -> None:
    from action_msgs.msg import GoalStatus

    from feeder_msgs.action import RunProgram
    from feeder_msgs.msg import DeviceStatus

    goal = device.program.send(run_goal(steps=LONG_PROGRAM))
    goal.wait_feedback(lambda f: f.time > 0.2)
    assert ros_harness.inject_fault(device.client, device.name, "power_loss").ok
    status, result = goal.result()
    assert status == GoalStatus.STATUS_ABORTED
    assert result.outcome == RunProgram.Result.FAULT and result.outcome_name == "FAULT"
    assert result.fault_code == DeviceStatus.FAULT_POWER_LOSS == 201
    assert "power_loss" in result.fault_text and "faulted" in result.message
    assert not result.settled and len(result.parts) == 1
    device.status(lambda s: s.state_name == "FAULT")
    response = ros_harness.trigger(device.client, device.name, "reset")
    assert response.success, response.message
    device.ready()
    status, result = device.program.send(run_goal()).result()
    assert status == GoalStatus.STATUS_SUCCEEDED and result.outcome == RunProgram.Result.SETTLED
    assert list(result.equilibrium) == [expected_equilibrium(START[2])[0]]


@pytest.mark.ros
def test_cancel_mid_goal_leaves_the_field_on_and_a_follow_up_goal_succeeds(device: Array) -> None:
    from action_msgs.msg import GoalStatus

    from feeder_msgs.action import RunProgram

    steps = ({"type": "radial", "duration": 3.0}, {"type": "combined", "delta": 0.25})
    goal = device.program.send(run_goal(steps=steps))
    goal.wait_feedback(lambda f: f.time > 0.2)
    response = goal.cancel()
    assert len(response.goals_canceling) == 1
    status, result = goal.result()
    assert status == GoalStatus.STATUS_CANCELED
    assert result.outcome == RunProgram.Result.CANCELED and result.outcome_name == "CANCELED"
    assert "program stays on" in result.message and not result.settled
    # the parts were left where the program had taken them, not moved back to where the goal started
    assert result.parts[0].pose.position.x != pytest.approx(START[0], abs=1e-6)
    # the goal's field stays on (nothing reinstalled): the part comes to rest in it, the device IDLE
    device.field_program(lambda m: len(m.steps) == 2 and m.steps[1].delta == 0.25)
    device.status(lambda s: s.state_name == "IDLE" and s.ready and not s.busy)
    status, result = device.program.send(run_goal()).result()
    assert status == GoalStatus.STATUS_SUCCEEDED and result.outcome == RunProgram.Result.SETTLED


@pytest.mark.ros
def test_stop_mid_goal_ends_it_with_a_fault_outcome_and_reset_serves_again(device: Array) -> None:
    from action_msgs.msg import GoalStatus

    from feeder_msgs.action import RunProgram

    goal = device.program.send(run_goal(steps=LONG_PROGRAM))
    goal.wait_feedback(lambda f: f.time > 0.2)
    assert ros_harness.trigger(device.client, device.name, "stop").success
    status, result = goal.result()
    assert status == GoalStatus.STATUS_ABORTED and result.outcome == RunProgram.Result.FAULT
    assert "stopped by ~/stop" in result.message and result.fault_code == 0
    device.status(lambda s: s.state_name == "STOPPED")
    assert not device.program.send(run_goal()).accepted
    device.diagnostics(lambda v: "device is STOPPED" in v["last_goal_rejection"])
    assert ros_harness.trigger(device.client, device.name, "reset").success
    device.ready()


@pytest.mark.ros
def test_a_field_without_a_prediction_settles_and_says_so(device: Array) -> None:
    from action_msgs.msg import GoalStatus

    goal = device.program.send(run_goal(steps=({"type": "radial"},)))
    status, result = goal.result()
    assert status == GoalStatus.STATUS_SUCCEEDED and result.settled
    assert list(result.equilibrium) == [-1]
    assert math.isnan(result.equilibrium_theta[0]) and math.isnan(result.equilibrium_distance[0])
    assert "no predicted equilibria for a radial field" in result.message
    assert all(math.isnan(f.equilibrium_distance[0]) for f in goal.feedback)


@pytest.mark.ros
def test_a_program_settles_only_once_it_holds_its_last_field(device: Array) -> None:
    from action_msgs.msg import GoalStatus

    # 1.5 s of the radial field (the part comes to rest on its pivot within about a second), then the
    # combined field: settling in the first step does not count.
    steps = ({"type": "radial", "duration": 1.5}, {"type": "combined", "delta": DELTA})
    status, result = device.program.send(run_goal(steps=steps)).result()
    assert status == GoalStatus.STATUS_SUCCEEDED
    assert result.equilibrium[0] >= 0 and result.equilibrium_distance[0] < REACHED_TOLERANCE


@pytest.mark.ros
def test_deactivation_mid_goal_ends_it_with_a_fault_outcome(device: Array) -> None:
    from action_msgs.msg import GoalStatus

    from feeder_msgs.action import RunProgram

    goal = device.program.send(run_goal(steps=LONG_PROGRAM))
    goal.wait_feedback(lambda f: f.time > 0.2)
    lifecycle = ros_harness.lifecycle_of(device.client, device.name)
    try:
        assert lifecycle.change("deactivate") == "inactive"
        status, result = goal.result(timeout=30.0)
        assert status == GoalStatus.STATUS_ABORTED and result.outcome == RunProgram.Result.FAULT
        assert "deactivated" in result.message and result.fault_code == 0
        assert lifecycle.change("activate") == "active"
    finally:
        lifecycle.close()
    device.ready()


@pytest.mark.ros
def test_goals_are_rejected_while_one_runs_in_fault_and_inactive(device: Array) -> None:
    from action_msgs.msg import GoalStatus

    from feeder_msgs.srv import FieldSetProgram

    first = device.program.send(run_goal(steps=LONG_PROGRAM))
    assert first.accepted
    assert not device.program.send(run_goal()).accepted
    device.diagnostics(lambda v: "a goal is executing; cancel it first" in v["last_goal_rejection"])
    # ~/set_program would pull the program from under the goal: refused too
    request = FieldSetProgram.Request(program=field_program({"type": "radial"}))
    response = ros_harness.call_service(device.client, FieldSetProgram, f"{device.name}/set_program", request)
    assert not response.ok and "~/run_program goal is executing" in response.error
    status, _ = first.result()
    assert status == GoalStatus.STATUS_SUCCEEDED  # the first goal was not disturbed
    # in FAULT
    assert ros_harness.inject_fault(device.client, device.name, "power_loss").ok
    device.status(lambda s: s.state_name == "FAULT")
    assert not device.program.send(run_goal()).accepted
    device.diagnostics(
        lambda v: "device is FAULT" in v["last_goal_rejection"] and "power_loss" in v["last_goal_rejection"]
    )
    assert ros_harness.trigger(device.client, device.name, "reset").success
    device.ready()
    # inactive
    lifecycle = ros_harness.lifecycle_of(device.client, device.name)
    try:
        assert lifecycle.change("deactivate") == "inactive"
        assert not device.program.send(run_goal()).accepted
        device.diagnostics(lambda v: "device is PAUSED" in v["last_goal_rejection"])
        assert lifecycle.change("activate") == "active"
    finally:
        lifecycle.close()
    device.ready()
    status, _ = device.program.send(run_goal()).result()
    assert status == GoalStatus.STATUS_SUCCEEDED  # it kept serving


# --- a held cell clock ----------------------------------------------------------------------------
@pytest.mark.ros
def test_under_a_held_clock_the_goal_waits_with_the_clock(launch_node, ros_client, listen) -> None:
    from action_msgs.msg import GoalStatus

    from feeder_msgs.action import RunProgram

    namespace = "/runprog_clock"
    launch_node(
        "feeder_cell",
        "cell_clock",
        {"start_paused": True, "start_time": 100.0},
        namespace=namespace,
        wait_services=(f"{namespace}/cell_clock/step",),
        timeout=60.0,  # a second node start in one test: slow on a loaded machine
    )
    launch_node(
        "feeder_sim",
        "mems_field_array",
        device_parameters(use_sim_time=True),
        namespace=namespace,
        wait_topics=(f"{namespace}/mems_field_array/part_states",),
        timeout=60.0,
    )
    from feeder_msgs.msg import MemsPartStates

    held = Array(ros_client, listen, f"{namespace}/mems_field_array")
    clock = f"{namespace}/cell_clock"
    states = listen(MemsPartStates, f"{namespace}/mems_field_array/part_states")
    # The first reading the device hears is its origin, not a tick: step until one shows as a tick.
    heard = ros_harness.step_clock(ros_client, 0.05, clock)
    held.status(lambda s: ros_harness.stamp_ns(s) >= heard)
    now = ros_harness.step_clock(ros_client, 0.05, clock)
    states.wait(lambda m: ros_harness.stamp_ns(m) == now, current=True)
    goal = held.program.send(run_goal(timeout=0.5))
    assert goal.accepted
    time.sleep(2.0)  # four timeouts of wall time: nothing may end the goal while the clock is held
    assert not goal._result.done()
    for _ in range(5):  # 0.25 s of clock: still short of the 0.5 s timeout
        ros_harness.step_clock(ros_client, 0.05, clock)
    goal.wait_feedback(lambda f: f.time >= 0.2)
    assert not goal._result.done()
    for _ in range(8):
        ros_harness.step_clock(ros_client, 0.05, clock)
    status, result = goal.result(timeout=30.0)
    assert status == GoalStatus.STATUS_ABORTED and result.outcome == RunProgram.Result.TIMEOUT
    assert max(f.time for f in goal.feedback) < 0.5
    # a cancel needs no tick: it ends a goal under the held clock
    goal = held.program.send(run_goal(timeout=0.5))
    assert goal.accepted
    goal.cancel()
    status, result = goal.result(timeout=10.0)
    assert status == GoalStatus.STATUS_CANCELED and result.outcome == RunProgram.Result.CANCELED
