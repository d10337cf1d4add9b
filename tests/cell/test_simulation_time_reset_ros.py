"""The rewind of a ResetSimulation of time, part by part, in one process: each follows the clock back.

The cell clock's ``~/rewind`` sets cell time back to its start (docs/cell.md, "Reset"). These tests drive each
part through the calls the clock makes (the barrier's rules, the hub's ``arrive``, a device's
``advance_lockstep``, the node clock's override, which is what rclpy's time source does with a /clock
message) and check that it starts again at the start as at launch:

- rclpy's ROS-time timers follow a backward jump (rcl resets them): a planner's timer fires one period
  after the rewound time, not after the old one;
- the barrier sets every member's marks back with the time: set back alone, it would count every member
  done with the rewound quanta (they would run unsimulated);
- a lockstep participant takes an earlier announcement as a rewind: its node clock jumps back, it works
  and answers at the start again (hosted or over DDS); a holding one counts the rewind for its thread;
- a device reconfigured after the rewind ticks the same instants as after its first configuration.
"""

from __future__ import annotations

from typing import Iterator

import pytest
import rclpy
from rclpy.clock import ClockType
from rclpy.executors import SingleThreadedExecutor
from rclpy.lifecycle import TransitionCallbackReturn
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions
from rclpy.time import Time
from std_msgs.msg import Header

from feeder_cell.lockstep_barrier import Barrier
from feeder_device.device import ManagedDevice, hosted
from feeder_device.parameters import DeviceParameters
from feeder_planner.node_kit.lockstep import Participant, host_in_process

NANOSECONDS = 1_000_000_000
START_NS = 1_000 * NANOSECONDS  # the cell's start time
QUANTUM_NS = NANOSECONDS // 10
RATE = 20.0  # Hz: two ticks a quantum


def run_quanta(barrier: Barrier, quanta: int, answer: bool = True) -> None:
    """Run ``quanta`` quanta from ``done`` with one tick member answering each (or, unanswered, none run)."""
    for _ in range(quanta):
        barrier.next_phase(0.0)  # the next quantum's tick phase
        assert [m.name for m in barrier.waiting_for()] == ["/device"]
        barrier.answer("tick", "/device", barrier.now_ns)
        while barrier.complete() and barrier.phase != "done":
            barrier.next_phase(0.0)
        assert barrier.phase == "done"


def test_a_barrier_rewound_waits_for_every_member_again_from_the_start() -> None:
    barrier = Barrier(START_NS, QUANTUM_NS, ["/device", "/controller"], phase_started=0.0)
    barrier.answer("tick", "/device", START_NS)  # a tick participant joins by answering T0
    barrier.answer("react", "/controller", 0)
    barrier.answer("react", "/planner", 0)
    while barrier.complete() and barrier.phase != "done":
        barrier.next_phase(0.0)
    barrier.answer("react", "/planner", START_NS)  # T0's react phase
    barrier.answer("react", "/controller", START_NS)
    while barrier.complete() and barrier.phase != "done":
        barrier.next_phase(0.0)
    # Only tick members follow a rewind (the clock refuses while others take part): they leave first.
    barrier.answer("react", "/planner", -1, leave=True)
    barrier.answer("react", "/controller", -1, leave=True)
    run_quanta(barrier, 10)
    assert barrier.now_ns == START_NS + 10 * QUANTUM_NS
    barrier.next_phase(0.0)
    with pytest.raises(ValueError, match="between quanta"):
        barrier.rewind(START_NS, 0.0)  # mid-quantum: refused
    barrier.answer("tick", "/device", barrier.now_ns)
    while barrier.complete() and barrier.phase != "done":
        barrier.next_phase(0.0)
    barrier.rewind(START_NS, 1.0)
    assert (barrier.now_ns, barrier.phase, barrier.phase_started) == (START_NS, "join", 1.0)
    # Not before the device has answered the start; the controller that left is not waited for.
    assert not barrier.complete(), "the rewound start is complete before the device answered it"
    barrier.answer("tick", "/device", START_NS)
    assert barrier.complete()
    while barrier.complete() and barrier.phase != "done":
        barrier.next_phase(0.0)
    run_quanta(barrier, 3)
    assert barrier.now_ns == START_NS + 3 * QUANTUM_NS
    # A device that never answers the rewound start is dropped after the join timeout, naming it.
    barrier.rewind(START_NS, 0.0)
    (late,) = barrier.overdue(barrier.join_timeout_s + 1.0)
    assert late.name == "/device" and late.phase == "join" and barrier.complete()


@pytest.fixture()
def sim_time_context(ros_domain: int) -> Iterator[None]:
    """An rclpy context of this process whose nodes run on sim time in lockstep, shut down after the test."""
    assert not rclpy.ok(), "the default rclpy context is in use in this process"
    rclpy.init(
        args=["--ros-args", "-p", "use_sim_time:=true", "-p", "lockstep:=true"],
        signal_handler_options=SignalHandlerOptions.NO,
    )
    try:
        yield
    finally:
        host_in_process(None)
        rclpy.try_shutdown()


def set_clock(node: Node, now_ns: int) -> None:
    """What rclpy's time source does with a /clock message: the node clock reads ``now_ns``."""
    node.get_clock().set_ros_time_override(Time(nanoseconds=now_ns, clock_type=ClockType.ROS_TIME))


@pytest.mark.ros
def test_a_ros_time_timer_fires_one_period_after_a_backward_jump(sim_time_context: None) -> None:
    node = Node("timer_probe")
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    try:
        fired: list[int] = []
        set_clock(node, START_NS)
        node.create_timer(1.0, lambda: fired.append(node.get_clock().now().nanoseconds))

        def at(seconds: float) -> None:
            set_clock(node, START_NS + int(seconds * NANOSECONDS))
            for _ in range(5):
                executor.spin_once(timeout_sec=0.01)

        for seconds in (0.5, 1.0, 2.0, 5.0, 5.5):
            at(seconds)
        assert fired == [START_NS + s * NANOSECONDS for s in (1, 2, 5)]
        fired.clear()
        # Back to the start: rcl resets the timer on the jump, so it is due one period after the start
        # again (not at 6 s, one period after its last call).
        for seconds in (0.0, 0.5, 1.0, 1.5, 2.0):
            at(seconds)
        assert fired == [START_NS + s * NANOSECONDS for s in (1, 2)]
    finally:
        executor.shutdown(timeout_sec=5.0)
        node.destroy_node()


class RecordingHub:
    """A hub that takes participants in and records their answers (what the hosted cell clock does)."""

    def __init__(self) -> None:
        self.answers: list[int] = []

    def join(self, participant: Participant) -> None:
        """Nothing to admit: the test announces by hand."""

    def answer(self, participant: Participant, now_ns: int, leave: bool) -> None:
        self.answers.append(now_ns)


@pytest.mark.ros
@pytest.mark.parametrize("hold", [False, True], ids=["answering", "holding"])
@pytest.mark.parametrize("path", ["hosted", "dds"])
def test_a_participant_takes_an_earlier_cell_time_as_a_rewind(
    sim_time_context: None, hold: bool, path: str
) -> None:
    hub = RecordingHub()
    host_in_process(hub if path == "hosted" else None)
    node = Node("participant_probe")
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    try:
        worked: list[int] = []
        participant = Participant(node, "react", worked.append, hold=hold)

        def announce(now_ns: int) -> None:
            if path == "hosted":
                participant.arrive(now_ns)
            else:
                header = Header()
                header.stamp.sec, header.stamp.nanosec = divmod(now_ns, NANOSECONDS)
                participant._on_message(header)  # what the DDS subscription hands it
            participant.answer_pending(executor)
            if hold:
                participant.release(participant.drained_ns)  # the holding thread's answer

        later = START_NS + 10 * QUANTUM_NS
        for now_ns in (START_NS, later):
            announce(now_ns)
        assert worked == [START_NS, later] and participant.rewinds == 0
        announce(later)  # the same time again: answered again over DDS, worked on once
        assert worked == [START_NS, later]
        announce(START_NS)  # the rewind
        assert worked == [START_NS, later, START_NS]
        assert node.get_clock().now().nanoseconds == START_NS, "the node clock did not jump back"
        assert participant.rewinds == 1 and participant.answered_ns == START_NS
        if hold:
            assert participant.wait_announcement(START_NS - 1, timeout_s=0.3) == START_NS
        if path == "hosted":
            assert hub.answers[-1] == START_NS
        announce(START_NS + QUANTUM_NS)
        assert worked[-1] == START_NS + QUANTUM_NS
    finally:
        executor.shutdown(timeout_sec=5.0)
        node.destroy_node()


class ProbeDevice(ManagedDevice[DeviceParameters]):
    """The device kit alone: a tick at RATE that records its instants."""

    def __init__(self) -> None:
        super().__init__("probe_device", DeviceParameters)
        self.instants: list[int] = []

    def configure_device(self, p: DeviceParameters) -> None:
        self.expect_rate(RATE)

    def tick(self, now_ns: int) -> None:
        self.instants.append(now_ns)


@pytest.mark.ros
def test_a_device_reconfigured_after_a_rewind_ticks_as_after_its_first_configuration(
    sim_time_context: None,
) -> None:
    device = hosted(ProbeDevice)()
    try:

        def announce(now_ns: int) -> None:
            set_clock(device, now_ns)
            device.advance_lockstep(now_ns)

        def run(quanta: int) -> list[int]:
            """Configure and activate at the start, then tick ``quanta`` quanta (what launch and reset do)."""
            device.instants.clear()
            announce(START_NS)
            assert device.trigger_configure() == TransitionCallbackReturn.SUCCESS
            assert device.trigger_activate() == TransitionCallbackReturn.SUCCESS
            for k in range(1, quanta + 1):
                announce(START_NS + k * QUANTUM_NS)
            return list(device.instants)

        first = run(10)
        assert first == [START_NS + k * QUANTUM_NS // 2 for k in range(1, 21)]  # RATE: two ticks a quantum
        # The order of a reset: the rewind while the device is still active (it ticks nothing at the
        # start), then the reconfiguration there.
        announce(START_NS)
        assert device.instants == first
        assert device.trigger_deactivate() == TransitionCallbackReturn.SUCCESS
        assert device.trigger_cleanup() == TransitionCallbackReturn.SUCCESS
        assert run(10) == first, "after the rewind the device did not tick the same instants"
        assert device.lockstep_driver is not None and device.lockstep_driver.rewinds == 1
    finally:
        device.destroy_node()
