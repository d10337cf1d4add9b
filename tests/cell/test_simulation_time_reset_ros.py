"""Why ResetSimulation does not set cell time back (SIMULATION_RESET_TIME not advertised), measured.

docs/cell.md ("Reset") states what a rewind of the cell clock would meet in each part of the cell. These
tests measure those parts in one process, with no cell clock and no thread, through the same calls the
clock makes (the hub's ``arrive``, a device's ``advance_lockstep``, the node clock's override, which is
what rclpy's time source does with a /clock message):

- rclpy's ROS-time timers do follow a backward jump (rcl resets them): a planner's or a controller's
  timer would fire one period after the rewound time, not after the old one;
- the clock's barrier counts a member done with a quantum once it has answered any time at or after it:
  set back alone, the clock would run the rewound quanta with no participant working;
- a lockstep participant takes an announcement no later than one it has taken as already seen: its
  node clock stays at the later time and it does no work (a hosted device, the controller, the
  recorder); a holding participant (the controller's decision thread) waits for a later time;
- a device reconfigured after its clock went back ticks nothing until cell time passes the last time
  it was announced (its lockstep driver's mark, ``feeder_device.drive``, outlives the reconfiguration;
  activation does set its model's advance mark to the present time).

So a rewind would either race through the rewound quanta unsimulated (the barrier's marks kept; a
participant over DDS answers an announcement it takes as heard again with its last, later time) or hold
every hosted participant until the clock's lockstep timeout dropped it (the marks set back). When the
rewind is built these tests change with docs/cell.md: each pins one fact its reason rests on.
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

from feeder_cell.lockstep_barrier import Barrier
from feeder_device.device import ManagedDevice, hosted
from feeder_device.parameters import DeviceParameters
from feeder_planner.node_kit.lockstep import Participant, host_in_process

NANOSECONDS = 1_000_000_000
START_NS = 1_000 * NANOSECONDS  # the cell's start time
QUANTUM_NS = NANOSECONDS // 10
RATE = 20.0  # Hz: two ticks a quantum


def test_a_barrier_set_back_alone_counts_every_member_done_with_the_rewound_quanta() -> None:
    barrier = Barrier(START_NS, QUANTUM_NS, ["/device"], phase_started=0.0)
    barrier.answer("tick", "/device", START_NS)  # a tick participant joins by answering T0
    quanta = 10
    for _ in range(quanta + 1):
        while barrier.complete() and barrier.phase != "done":
            barrier.next_phase(0.0)
        assert barrier.phase == "done"
        barrier.next_phase(0.0)  # the next quantum's tick phase
        assert [m.name for m in barrier.waiting_for()] == ["/device"]
        barrier.answer("tick", "/device", barrier.now_ns)
    assert barrier.now_ns == START_NS + (quanta + 1) * QUANTUM_NS
    # Cell time set back to the start, nothing else: every rewound quantum's tick phase is complete at
    # once, before any participant has heard of it.
    barrier.now_ns, barrier.phase = START_NS, "done"
    for k in range(1, quanta + 1):
        barrier.next_phase(0.0)
        assert barrier.now_ns == START_NS + k * QUANTUM_NS and barrier.phase == "tick"
        assert barrier.complete() and not barrier.waiting_for()
        barrier.phase = "done"


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
def test_a_participant_takes_an_earlier_cell_time_as_already_seen(sim_time_context: None, hold: bool) -> None:
    hub = RecordingHub()
    host_in_process(hub)
    node = Node("participant_probe")
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    try:
        worked: list[int] = []
        participant = Participant(node, "react", worked.append, hold=hold)
        later = START_NS + 10 * QUANTUM_NS
        for now_ns in (START_NS, later):
            participant.arrive(now_ns)
            participant.answer_pending(executor)
        assert worked == [START_NS, later]
        # The rewind: the clock announces its start time again.
        participant.arrive(START_NS)
        participant.answer_pending(executor)
        assert worked == [START_NS, later], "the earlier time was worked on"
        assert node.get_clock().now().nanoseconds == later, "the node clock followed the earlier time"
        assert not participant.pending
        if hold:
            # The controller's decision thread waits for a time after the last it decided on: it never
            # comes (the clock holds at the start until the participant answers, which it never does).
            assert participant.wait_announcement(later, timeout_s=0.3) == -1
        else:
            assert hub.answers == [START_NS, later], "an answer was sent for the earlier time"
    finally:
        executor.shutdown(timeout_sec=5.0)
        node.destroy_node()


class ProbeDevice(ManagedDevice[DeviceParameters]):
    """The device kit alone: a tick that does nothing at RATE, counted."""

    def __init__(self) -> None:
        super().__init__("probe_device", DeviceParameters)

    def configure_device(self, p: DeviceParameters) -> None:
        self.expect_rate(RATE)


@pytest.mark.ros
def test_a_device_reconfigured_after_its_clock_went_back_does_not_tick(sim_time_context: None) -> None:
    device = hosted(ProbeDevice)()
    try:

        def announce(now_ns: int) -> None:
            set_clock(device, now_ns)
            device.advance_lockstep(now_ns)

        set_clock(device, START_NS)
        assert device.trigger_configure() == TransitionCallbackReturn.SUCCESS
        assert device.trigger_activate() == TransitionCallbackReturn.SUCCESS
        quanta = 10
        for k in range(quanta + 1):
            announce(START_NS + k * QUANTUM_NS)
        ticked = device.ticks_done
        assert ticked == quanta * 2  # RATE: two ticks a quantum
        # What STOPPED does (every device reconfigured), with the clock set back to the start first.
        assert device.trigger_deactivate() == TransitionCallbackReturn.SUCCESS
        assert device.trigger_cleanup() == TransitionCallbackReturn.SUCCESS
        set_clock(device, START_NS)
        assert device.trigger_configure() == TransitionCallbackReturn.SUCCESS
        assert device.trigger_activate() == TransitionCallbackReturn.SUCCESS
        for k in range(1, quanta + 1):
            announce(START_NS + k * QUANTUM_NS)
        assert device.ticks_done == ticked, "the device ticked the rewound quanta"
        # Past the last time it was announced, it ticks again.
        announce(START_NS + (quanta + 1) * QUANTUM_NS)
        assert device.ticks_done > ticked
    finally:
        device.destroy_node()
