"""In one process: a goal accepted in lockstep starts at one tick whether or not the next tick comes first.

rclpy creates a goal's execute task after it has sent the accept answer, so under the cell clock the next
quantum's tick can reach the device before that task first runs (a loaded host; seen once in CI: the
fixture's RUNNING status a quantum late). The kit places the start by its tick count at acceptance
(``feeder_device.goals``), so the goal starts after the device's first tick after acceptance in both orders.

Both orders are built here deterministically, with no cell clock and no thread: a device in lockstep that a
host drives by direct calls (``feeder_device.device.hosted``, ``advance_lockstep``), an action client in the
same executor, and an executor that holds the goal's execute task back until the test lets it run. The goal
is a probe served through the kit's goal runner: it records the node clock at its start and the instants at
which the ticks advance it.
"""

from __future__ import annotations

from typing import Any, Callable, Sequence

import pytest
import rclpy
from rclpy.clock import ClockType
from rclpy.executors import SingleThreadedExecutor
from rclpy.lifecycle import TransitionCallbackReturn
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from rclpy.time import Time

from feeder_device.device import ManagedDevice, hosted
from feeder_device.goals import serve_goal
from feeder_device.parameters import DeviceParameters
from feeder_msgs.action import FeedPart
from feeder_msgs.msg import DeviceStatus
from feeder_planner.node_kit.action_client import ActionClient
from feeder_planner.node_kit.lockstep import drain

pytestmark = pytest.mark.ros

NAMESPACE = "/goal_start"
RATE = 20.0  # Hz: two ticks a quantum
QUANTUM_NS = 100_000_000
START_NS = 1_000 * 1_000_000_000  # the cell time the device is configured at
WAIT_S = 20.0


class ProbeDevice(ManagedDevice[DeviceParameters]):
    """The kit alone: a device whose tick does nothing, at RATE."""

    def __init__(self) -> None:
        super().__init__("probe_device", DeviceParameters)

    def configure_device(self, p: DeviceParameters) -> None:
        self.expect_rate(RATE)


class ProbeGoal:
    """A goal that records the instants it is advanced at and ends after two of them."""

    def __init__(self, started_ns: int) -> None:
        self.started_ns = started_ns
        self.advanced: list[int] = []

    @property
    def done(self) -> bool:
        return len(self.advanced) >= 2

    def advance(self, now_ns: int) -> None:
        self.advanced.append(now_ns)

    def cancel(self, reason: str) -> None:
        """Not used."""

    def interrupt(self, reason: str) -> None:
        """Not used."""

    def feedback(self) -> Sequence[Any]:
        return ()

    def result(self) -> tuple[str, Any]:
        return "succeed", FeedPart.Result(outcome=FeedPart.Result.PRESENTED, outcome_name="PRESENTED")

    def halt(self) -> None:
        """Nothing moves."""


class HoldingExecutor(SingleThreadedExecutor):
    """An executor that holds a goal's execute task back while ``hold`` is set, until ``release``.

    rclpy's action server schedules the execute task with ``executor.create_task(server._execute_goal, ...)``
    once it has sent the accept answer: holding it is how the test makes a tick come first.
    """

    def __init__(self) -> None:
        super().__init__()
        self.hold = False
        self.held: list[tuple[Callable[..., Any], tuple[Any, ...], dict[str, Any]]] = []

    def create_task(self, callback: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
        if self.hold and getattr(callback, "__name__", "") == "_execute_goal":
            self.held.append((callback, args, kwargs))
            return None  # rclpy's notify_execute does not use the task
        return super().create_task(callback, *args, **kwargs)

    def release(self) -> None:
        self.hold = False
        for callback, args, kwargs in self.held:
            super().create_task(callback, *args, **kwargs)
        self.held.clear()


def spin_until(executor: SingleThreadedExecutor, done: Callable[[], bool], what: str) -> None:
    for _ in range(int(WAIT_S / 0.01)):
        if done():
            return
        executor.spin_once(timeout_sec=0.01)
    raise AssertionError(f"no {what} within {WAIT_S:.0f} s")


def run(tick_first: bool) -> dict[str, Any]:
    """Run one goal; with ``tick_first`` the next quantum's tick comes before its execute task first runs."""
    rclpy.init(
        args=["--ros-args", "-r", f"__ns:={NAMESPACE}", "-p", "use_sim_time:=true", "-p", "lockstep:=true"],
        signal_handler_options=SignalHandlerOptions.NO,
    )
    executor = HoldingExecutor()
    device = client_node = client = None
    try:
        device = hosted(ProbeDevice)()
        assert device.in_lockstep and device.lockstep is None  # driven by direct calls, no participant
        goals: list[ProbeGoal] = []

        def start(handle: Any) -> ProbeGoal:
            goals.append(ProbeGoal(device.get_clock().now().nanoseconds))
            return goals[-1]

        serve_goal(device, FeedPart, "~/probe", lambda goal: None, start)
        client_node = Node("goal_start_client")
        statuses: list[DeviceStatus] = []
        latched = QoSProfile(
            depth=100, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
        )
        client_node.create_subscription(
            DeviceStatus, f"{NAMESPACE}/probe_device/status", statuses.append, latched
        )
        client = ActionClient(client_node, FeedPart, f"{NAMESPACE}/probe_device/probe")
        executor.add_node(device)
        executor.add_node(client_node)
        now = [START_NS]

        def announce(now_ns: int) -> None:
            """What a host does each quantum: the device's clock at T, its ticks, then the drain."""
            now[0] = now_ns
            device.get_clock().set_ros_time_override(Time(nanoseconds=now_ns, clock_type=ClockType.ROS_TIME))
            device.advance_lockstep(now_ns)
            drain(executor)

        device.get_clock().set_ros_time_override(Time(nanoseconds=START_NS, clock_type=ClockType.ROS_TIME))
        assert device.trigger_configure() == TransitionCallbackReturn.SUCCESS
        assert device.trigger_activate() == TransitionCallbackReturn.SUCCESS
        announce(START_NS)
        announce(START_NS + QUANTUM_NS)
        assert device.ticks_done == 2
        assert client.wait_for_server(timeout_sec=WAIT_S)
        # the status reader has matched (it takes the latched IDLE): it will see the RUNNING to come
        spin_until(executor, lambda: any(s.state_name == "IDLE" for s in statuses), "IDLE status")
        executor.hold = tick_first
        sent = client.send_goal_async(FeedPart.Goal(max_throws=1))
        spin_until(executor, sent.done, "goal response")
        assert sent.result().accepted
        accepted_ns = now[0]
        if tick_first:
            assert executor.held, "the execute task was not held"
            announce(accepted_ns + QUANTUM_NS)  # the next quantum's tick reaches the device first
            executor.release()
        drain(executor)  # the execute task runs: it starts the goal, or waits for the next tick
        result = sent.result().get_result_async()
        quantum = now[0]
        while not (goals and goals[0].done):
            quantum += QUANTUM_NS
            assert quantum <= accepted_ns + 10 * QUANTUM_NS, "the goal did not end"
            announce(quantum)
        spin_until(executor, result.done, "goal result")
        spin_until(executor, lambda: any(s.state_name == "RUNNING" for s in statuses), "RUNNING status")
        running = next(s for s in statuses if s.state_name == "RUNNING")
        (goal,) = goals
        return {
            "accepted_ns": accepted_ns,
            "started_ns": goal.started_ns,
            "advanced": goal.advanced,
            "running_ns": running.header.stamp.sec * 1_000_000_000 + running.header.stamp.nanosec,
        }
    finally:
        executor.shutdown(timeout_sec=5.0)
        if client is not None:
            # rclpy's destroy_node leaves an action client and its DDS endpoints alive: a later test of
            # this process saw /goal_start/.../_action/status in its graph.
            client.destroy()
        if client_node is not None:
            client_node.destroy_node()
        if device is not None:
            device.destroy_node()
        rclpy.try_shutdown()


def test_a_goal_starts_at_the_first_tick_after_acceptance_whichever_runs_first(ros_domain: int) -> None:
    assert not rclpy.ok(), "the default rclpy context is in use in this process"
    task_first = run(tick_first=False)
    tick_first = run(tick_first=True)
    accepted = task_first["accepted_ns"]
    # The goal starts after the quantum after acceptance has been ticked: at that quantum's time, with
    # RUNNING stamped then, and is advanced first by the next quantum's first tick.
    expected = {
        "accepted_ns": accepted,
        "started_ns": accepted + QUANTUM_NS,
        "advanced": [accepted + QUANTUM_NS + QUANTUM_NS // 2, accepted + 2 * QUANTUM_NS],
        "running_ns": accepted + QUANTUM_NS,
    }
    assert task_first == expected
    assert tick_first == task_first
