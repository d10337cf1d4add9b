"""Managed devices: what makes a simulator node indistinguishable from hardware by its interfaces.

Every simulator node is a ``ManagedDevice``: a lifecycle node (``rclpy.lifecycle``, the standard
``lifecycle_msgs`` services and transition events) that publishes a latched ``~/status``
(feeder_msgs/DeviceStatus) on every change and as a 1 Hz heartbeat, a ``diagnostic_msgs/DiagnosticArray``
on ``/diagnostics`` at 1 Hz (diagnostic_updater conventions), serves ``~/stop``, ``~/reset``
(std_srvs/Trigger), ``~/abort`` and ``~/clear`` (std_srvs/Trigger: PackML's Abort and Clear, for the
OPC UA gateway's PLC) and ``~/inject_fault`` (feeder_msgs/InjectFault), and applies or refuses every
parameter change (read-only parameters are declared read-only; the others are validated and applied).

The kit owns the loop, as ros2_control's framework does; a device implements what is its own:

- **Declarations** (class attributes): ``FAULTS`` (name -> ``FaultSpec``) and ``COUNTERS`` (the
  ``CounterSpec`` tuple of its model package); ``self.count`` is the running tally of those counters.
- **Streams**: ``self.stream(type, topic, qos)`` in ``configure_device`` makes a publisher (a lifecycle
  one unless told otherwise) that the kit destroys at cleanup, whatever path cleanup takes.
- **The tick**: ``expect_rate(rate)`` at configure sets the main stream's rate; the kit runs the timer on
  the node clock while active, skips instants already ticked, calls ``tick(now_ns)``, advances the running
  goals (``feeder_device.goals``), then counts the tick and wakes the goals' coroutines. Under the cell
  clock's lockstep (parameter ``lockstep``) there is no timer: each announced time T runs every instant of
  the rate's grid up to T, in order, each with its own ``now_ns``, and the device answers T once the
  samples and results are sent (``feeder_planner.node_kit.lockstep``). So ``tick`` must stamp with
  ``now_ns``, never with the clock.
  ``elapsed_ns(now_ns)`` is the one definition of the node-clock time since the model last advanced.
- **Hooks**: ``configure_device`` (load and validate; raise InputError naming the field),
  ``activate_device``/``deactivate_device``, ``cleanup_device``, ``apply_parameter`` (runtime parameters),
  ``busy``, ``counters``, ``stop_device``, ``reset_device``, ``apply_fault``/``clear_fault``.

The sequence a controller follows is in docs/cell.md; adding a device is docs/devices.md.
"""

from __future__ import annotations

import copy
import dataclasses
import time
from enum import IntEnum
from typing import Any, Generic, Mapping, Protocol, Sequence, TypeVar

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from lifecycle_msgs.msg import State, Transition, TransitionEvent
from rcl_interfaces.msg import SetParametersResult
from rclpy.action import ActionServer
from rclpy.clock import Clock, ClockType, JumpThreshold
from rclpy.duration import Duration
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.lifecycle import LifecycleNode, LifecycleNodeMixin, LifecycleState, TransitionCallbackReturn
from rclpy.parameter import Parameter
from rclpy.publisher import Publisher
from rclpy.qos import QoSProfile
from rclpy.task import Future
from rclpy.timer import Timer
from std_srvs.srv import Trigger

from feeder_device.declarations import (
    ActiveFault,
    Counters,
    CounterSpec,
    DeviceError,
    FaultSpec,
    parse_fault_parameter,
    unknown_fault,
)
from feeder_device.parameters import DeviceParameters
from feeder_device.rate import RateMonitor, RateReport
from feeder_msgs.msg import DeviceStatus
from feeder_msgs.srv import InjectFault
from feeder_planner.errors import FeederError, InputError
from feeder_planner.node_kit.lockstep import Participant
from feeder_planner.node_kit.parameters import ParameterSpec, check_value, declare_parameters
from feeder_planner.node_kit.qos import LATCHED
from feeder_planner.node_kit.services import REQUEST_QUEUE_PARAMETER, serve
from feeder_planner.node_kit.tf import namespaced_frame
from feeder_planner.parameter_specs import from_values, specs_of

__all__ = ["DeviceState", "ManagedDevice", "device_parameter_specs"]


class TickedGoal(Protocol):
    """What the tick needs of an executing goal (``goals.RunningGoal``); ``goal`` is the device's adapter."""

    @property
    def goal(self) -> object:
        """The device's own adapter of the goal."""
        ...

    def advance_guarded(self, now_ns: int) -> None:
        """Take in the tick at ``now_ns``; a bug inside the goal ends the goal, not the tick."""
        ...

    def poke(self) -> None:
        """Wake the goal's coroutine now."""
        ...


RCLError = _rclpy.RCLError

# Heartbeat of ~/status and /diagnostics (Hz), on the steady clock so that a paused sim clock does not
# silence a device: a controller must still see that the device is there and why it is not moving.
HEARTBEAT_RATE = 1.0


class DeviceState(IntEnum):
    """The device as a controller sees it (values of feeder_msgs/DeviceStatus.state)."""

    UNCONFIGURED = DeviceStatus.UNCONFIGURED
    IDLE = DeviceStatus.IDLE
    RUNNING = DeviceStatus.RUNNING
    PAUSED = DeviceStatus.PAUSED
    FAULT = DeviceStatus.FAULT
    STOPPED = DeviceStatus.STOPPED


P = TypeVar("P", bound=DeviceParameters)
# What ~/status last said (state, busy, fault code and text, fault labels, counters, behind real time):
# the status is published again when it changes.
StatusKey = tuple[DeviceState, bool, int, str, tuple[str, ...], tuple[tuple[str, int], ...], bool]


def device_parameter_specs(
    parameters: type[DeviceParameters], extra: Sequence[ParameterSpec] = ()
) -> tuple[ParameterSpec, ...]:
    """Return every parameter a device declares: its dataclass's, ``extra`` (the display's), the queue depth.

    The node module's ``PARAMETERS`` is this tuple, so the launcher validates a scene against exactly what
    the node declares.
    """
    return (*specs_of(parameters), *extra, REQUEST_QUEUE_PARAMETER)


class ManagedDevice(LifecycleNode, Generic[P]):
    """Lifecycle, tick, streams, status, diagnostics, stop/reset and fault plumbing of every device.

    See the module docstring for what a subclass declares and implements.
    """

    FAULTS: Mapping[str, FaultSpec] = {}
    COUNTERS: Sequence[CounterSpec] = ()

    def __init__(
        self, node_name: str, parameters: type[P], extra: Sequence[ParameterSpec] = (), *, rate: float = 1.0
    ) -> None:
        super().__init__(node_name)
        # ~/transition_event as rcl_lifecycle offers it (reliable, volatile, depth 10), published here with
        # the stamp and the transition (rcl_lifecycle's own notification carries neither; it is not sent).
        self._transition_events = self.create_publisher(TransitionEvent, "~/transition_event", 10)
        self.parameters = parameters
        self.specs = {spec.name: spec for spec in device_parameter_specs(parameters, extra)}
        # Declared now, validated at configure: a bad value fails the transition, not the process.
        self.p: P = from_values(
            parameters, declare_parameters(self, list(self.specs.values()), validate=False)
        )
        self.lifecycle = "unconfigured"
        self.stopped = False
        self.faults: dict[str, ActiveFault] = {}
        self.model_fault: tuple[int, str] | None = None  # (code, text) of a fault the model raised
        self.configuration_error = ""
        self.count = Counters(self.COUNTERS)
        self.monitor = RateMonitor(rate)
        self.tick_rate = rate
        self._tick_timer: Timer | None = None
        self._streams: list[tuple[Publisher, bool]] = []
        self.goals: list[TickedGoal] = []  # the goals executing (feeder_device.goals), advanced per tick
        self.action_servers: list[ActionServer] = []  # made by goals.serve_goal, ended by destroy_node
        self._last_status: StatusKey | None = None
        self._last_status_msg: DeviceStatus | None = None
        self._status_pub = self.create_publisher(DeviceStatus, "~/status", LATCHED)
        self._diagnostics_pub = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        serve(self, Trigger, "~/stop", self._on_stop)
        serve(self, Trigger, "~/reset", self._on_reset)
        serve(self, Trigger, "~/abort", self._on_abort)
        serve(self, Trigger, "~/clear", self._on_clear)
        serve(self, InjectFault, "~/inject_fault", self._on_inject_fault)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        # Under use_sim_time the node clock reads 0 until the first /clock arrives; the device's model
        # starts from that first reading, whatever the order in which the clock and the device came up.
        self.clock_start_ns = 0
        self.last_tick_due_ns = 0
        self.last_advance_ns = 0
        self.tick_waiters: list[Future] = []
        self.ticks_done = 0  # ticks since the node started: a goal's start is placed by it (goals.py)
        self.last_goal_rejection = ""
        threshold = JumpThreshold(
            min_forward=Duration(nanoseconds=1), min_backward=None, on_clock_change=True
        )
        self._clock_jump = self.get_clock().create_jump_callback(threshold, post_callback=self._on_clock_jump)
        # Lockstep: the grid of tick instants (origin, rate, index of the last instant ticked) and the
        # device's part in the cell clock's protocol; None when the device runs on its own timer.
        self._grid_origin_ns = 0
        self._grid_index = 0
        self.lockstep: Participant | None = None
        self.tick_instant_ns = 0  # the instant being ticked (0 outside a tick)
        if self.p.lockstep:
            self.lockstep = Participant(self, "tick", self._lockstep_ticks)
            self.lockstep.on_first = lambda: self.publish_status(force=True)
        self.clock_origin_ns()  # the wall clock (or a /clock already heard) starts the model now
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.create_timer(1.0 / HEARTBEAT_RATE, self._heartbeat, clock=steady)
        self.publish_status(force=True)

    # --- hooks for the device -------------------------------------------------------------------
    def configure_device(self, p: P) -> None:
        """Load files, build the model and its streams from validated parameters; InputError names a field."""

    def activate_device(self) -> None:
        """Resume the simulation (the kit starts the tick timer after this)."""

    def deactivate_device(self) -> None:
        """Freeze the simulation where it is (the kit has cancelled the tick timer; state is kept)."""

    def cleanup_device(self) -> None:
        """Release the model (the kit destroys the streams and resets the counters)."""

    def tick(self, now_ns: int) -> float | None:
        """Advance the model to ``now_ns`` (node clock) and publish; return its simulated time in s.

        None means the model's time is the node clock's. Called only while active, at most once per instant.
        """
        return None

    def apply_parameter(self, name: str, p: P) -> None:
        """Apply the validated runtime parameter ``name``; raise InputError to refuse it.

        ``p`` holds its new value (``p.<name>``; a display parameter's is not a field of it): ``self.p``
        becomes ``p`` once this returns.
        """

    def busy(self) -> bool:
        """Whether the device is executing a command (by default: a goal is executing)."""
        return bool(self.goals)

    def counters(self) -> Mapping[str, int]:
        """Counters reported in status and diagnostics: ``self.count``, which a device may refresh here."""
        return self.count

    def stop_device(self) -> None:
        """Halt now: cancel queued and running commands, keep the model where it is."""

    def reset_device(self) -> None:
        """Return to a commandable state after a stop or a fault (faults are cleared by the caller)."""

    def apply_fault(self, fault: ActiveFault) -> None:
        """Put an injected fault into effect (the model reads ``self.faults`` or is told here)."""

    def clear_fault(self, name: str) -> None:
        """Take an injected fault out of effect."""

    # --- the kit's loop and streams ------------------------------------------------------------------
    def stream(
        self, msg_type: Any, topic: str, qos: QoSProfile | int, *, lifecycle: bool = True
    ) -> Publisher:
        """Create a publisher (a lifecycle one, live only while active, unless ``lifecycle`` is False).

        Called from ``configure_device``; the kit destroys it at cleanup, a failed configure included, so
        a device never keeps a publisher of a model it no longer has.
        """
        make = self.create_lifecycle_publisher if lifecycle else self.create_publisher
        publisher = make(msg_type, topic, qos)
        self._streams.append((publisher, lifecycle))
        return publisher

    def _destroy_streams(self) -> None:
        for publisher, lifecycle in self._streams:
            if lifecycle:
                self.destroy_lifecycle_publisher(publisher)
            else:
                self.destroy_publisher(publisher)
        self._streams.clear()

    def _start_ticks(self) -> None:
        self._stop_ticks()
        if self.lockstep is not None:
            # The grid goes on from the present time: instants while inactive are not simulated.
            now = self.get_clock().now().nanoseconds
            if self._grid_origin_ns <= 0:
                self._grid_origin_ns = now
            self._grid_index = int((now - self._grid_origin_ns) * self.tick_rate // 1e9)
            return
        self._tick_timer = self.create_timer(1.0 / self.tick_rate, self._on_tick_timer)

    def _stop_ticks(self) -> None:
        if self._tick_timer is not None:
            self.destroy_timer(self._tick_timer)
            self._tick_timer = None

    def _on_tick_timer(self) -> None:
        """One tick at the clock's present time (the free-running timer)."""
        if self.active:
            self._tick_at(self.get_clock().now().nanoseconds)

    def _tick_at(self, now: int) -> None:
        """One tick: the device's model and streams, then its goals, then the tick is counted."""
        if not self.tick_due(now):
            return
        self.tick_instant_ns = now  # what a status published inside the tick is stamped with
        try:
            simulated = self.tick(now)
            for goal in list(self.goals):
                goal.advance_guarded(now)
            self.record_tick(simulated)
        finally:
            self.tick_instant_ns = 0
            self.ticks_done += 1

    def _grid_instant(self, index: int) -> int:
        # Rounded from the index, not accumulated: a rate whose period is no whole number of
        # nanoseconds does not drift, and every host computes the same instants.
        return self._grid_origin_ns + round(index * 1e9 / self.tick_rate)

    def _lockstep_ticks(self, now_ns: int) -> None:
        """Tick every instant of the rate's grid up to ``now_ns``, in order (the lockstep's tick phase)."""
        if not self.active or self._grid_origin_ns <= 0:
            return
        while self.active and (instant := self._grid_instant(self._grid_index + 1)) <= now_ns:
            self._grid_index += 1
            self._tick_at(instant)
        self.publish_status()  # what the ticks changed (counters), stamped with the quantum's time

    def elapsed_ns(self, now_ns: int) -> int:
        """Return the node-clock time (ns) since the model last advanced, and advance the mark to ``now_ns``.

        Activated before the node clock started, the model starts at the clock's first reading; a clock
        set back simulates nothing (never a negative step).
        """
        if self.last_advance_ns <= 0:
            self.last_advance_ns = self.clock_origin_ns() or now_ns
        elapsed = max(0, now_ns - self.last_advance_ns)
        self.last_advance_ns = now_ns
        return elapsed

    # --- what the device calls -------------------------------------------------------------------
    @property
    def active(self) -> bool:
        """Whether the lifecycle state is active."""
        return self.lifecycle == "active"

    def state(self) -> DeviceState:
        """Return the controller-facing state, derived from lifecycle, stop, faults and business."""
        if self.lifecycle != "active" and self.lifecycle != "inactive":
            return DeviceState.UNCONFIGURED
        if self.stopping_fault() is not None:
            return DeviceState.FAULT
        if self.lifecycle == "inactive":
            return DeviceState.PAUSED
        if self.stopped:
            return DeviceState.STOPPED
        return DeviceState.RUNNING if self.busy() else DeviceState.IDLE

    def stopping_fault(self) -> tuple[int, str] | None:
        """(code, text) of the fault that stops the device, or None."""
        if self.model_fault is not None:
            return self.model_fault
        for fault in self.faults.values():
            if fault.spec.stops_device:
                return fault.spec.code, f"injected fault {fault.label}: {fault.spec.description}"
        return None

    def warning_fault(self) -> tuple[int, str] | None:
        """(code, text) of an injected fault in force that has a code but does not stop the device.

        A device overrides this where a fault's code applies only once it acts (a stall that is armed).
        """
        for fault in self.faults.values():
            if fault.spec.code and not fault.spec.stops_device:
                return fault.spec.code, f"injected fault {fault.label}: {fault.spec.description}"
        return None

    def raise_model_fault(self, code: int, text: str) -> None:
        """Enter FAULT because of the model itself (not an injection); ~/reset clears it."""
        self.model_fault = (code, text)
        self.get_logger().error(f"FAULT {code}: {text}")
        self.publish_status()

    def require_ready(self, what: str) -> None:
        """Raise DeviceError naming the state unless the device accepts commands."""
        state = self.state()
        if state not in (DeviceState.IDLE, DeviceState.RUNNING):
            why = ""
            fault = self.stopping_fault()
            if fault is not None:
                why = f" ({fault[1]}; ~/reset clears it)"
            elif state is DeviceState.STOPPED:
                why = " (~/reset returns it to IDLE)"
            raise DeviceError(f"{what} refused: device is {state.name}{why}")

    def _on_clock_jump(self, jump: object) -> None:
        self.clock_origin_ns()

    def clock_origin_ns(self) -> int:
        """Return the node clock's first non-zero reading (ns), or 0 while the clock has not started.

        A device whose model has no start time yet (activated before the first /clock) starts it here,
        not at its first tick: the clock may have moved on by then, and that time is the model's too.
        """
        if self.clock_start_ns == 0:
            now = self.get_clock().now().nanoseconds
            if now > 0:
                self.clock_start_ns = now
        return self.clock_start_ns

    def tick_due(self, now_ns: int) -> bool:
        """Return whether a tick of the main stream at ``now_ns`` (node clock) should simulate and publish.

        Not while the clock has not started (0), and not at an instant already ticked or at the clock
        origin itself: rclpy fires a sim-time timer when the first /clock jumps the clock forward, and
        whether that happens depends on whether the device activated before or after the first /clock.
        A held clock must show no tick either way, or lockstep runs would differ. A clock set back
        ticks (it simulates nothing: the caller's elapsed time is clipped at zero).
        """
        reference = self.last_tick_due_ns or self.clock_origin_ns()
        if now_ns <= 0 or now_ns == reference:
            return False
        self.last_tick_due_ns = now_ns
        return True

    def sim_seconds(self) -> float:
        """Node clock (simulated time under use_sim_time) in seconds."""
        return self.get_clock().now().nanoseconds * 1e-9

    def expect_rate(self, rate: float) -> None:
        """Set the main stream's rate (Hz of the node clock) that status and diagnostics measure against.

        The device keeps up when it ticks at ``rate`` per second of its node clock and its simulated time
        keeps pace with that clock; under a cell clock at factor F that is F * rate ticks per wall second.
        """
        self.tick_rate = rate
        self.monitor.configure(rate, float(self.p.real_time_factor))
        self._grid_origin_ns = self.get_clock().now().nanoseconds  # the grid starts at configure
        self._grid_index = 0

    def frame(self, base: str) -> str:
        """Return a per-instance frame id: ``base`` under the node's namespace (``cell/feeder_a/base``)."""
        return namespaced_frame(self, base)

    def record_tick(self, simulated: float | None = None) -> None:
        """Count one tick of the device's main stream for the rate and real-time-factor figures.

        The tick is over when this is called: the goals waiting in ``next_tick`` resume and read it.
        """
        clock = self.sim_seconds()
        self.monitor.tick(time.monotonic(), clock, clock if simulated is None else simulated)
        self._wake_tick_waiters()

    def next_tick(self) -> Future:
        """Return a future done after the device's next tick, or when it stops being active.

        The goal runner (``feeder_device.goals``) awaits it: the goal advances with the node
        clock and never blocks the executor. After waking, the goal must check ``self.active``.
        """
        waiter = Future()
        if not self.active:
            waiter.set_result(False)
        else:
            self.tick_waiters.append(waiter)
        return waiter

    def wake_goals(self) -> None:
        """Wake every executing goal's coroutine now (a goal that ended outside a tick sends its result)."""
        for goal in self.goals:
            goal.poke()

    def _wake_tick_waiters(self) -> None:
        waiters, self.tick_waiters = self.tick_waiters, []
        for waiter in waiters:
            if not waiter.done():
                waiter.set_result(self.active)

    def record_goal_rejection(self, action: str, reason: str) -> None:
        """Log a goal refused at goal time (ROS 2 has no field for the reason) and keep it for diagnostics."""
        self.last_goal_rejection = f"{action}: {reason}"
        self.get_logger().warning(f"goal rejected: {self.last_goal_rejection}")

    def rate_report(self) -> RateReport:
        """Return the achieved figures over the monitor's window."""
        return self.monitor.report(time.monotonic(), self.sim_seconds())

    def publish_status(self, force: bool = False) -> None:
        """Publish ~/status when anything a controller sees changed (or when forced: the heartbeat).

        In lockstep, not before the first announcement: until then the node clock has no cell time to
        stamp it with (the first announcement publishes it).
        """
        if self.lockstep is not None and self.lockstep.announced_ns < 0:
            return
        state = self.state()
        report = self.rate_report()
        behind = self.is_behind(report)
        fault = self.stopping_fault()
        code, text = fault if fault is not None else (0, "")
        warning = self.warning_fault() if self.lifecycle in ("inactive", "active") else None
        if not fault and self.configuration_error:
            code, text = DeviceStatus.FAULT_CONFIGURATION, self.configuration_error
        elif not fault and warning is not None:
            code, text = warning
        elif not fault and behind:
            code, text = DeviceStatus.FAULT_BEHIND_REAL_TIME, self._behind_text(report)
        configured = self.lifecycle in ("inactive", "active")
        # The device's own hooks run only once it is configured: before that it has no model to ask.
        counters = self.counters() if configured else {}
        busy = self.active and self.busy()
        labels = [f.label for f in self.faults.values()]
        key = (state, busy, code, text, tuple(labels), tuple(counters.items()), behind)
        if not force and key == self._last_status:
            return
        self._last_status = key
        msg = DeviceStatus(
            state=int(state),
            state_name=state.name,
            ready=state in (DeviceState.IDLE, DeviceState.RUNNING),
            busy=busy,
            fault_code=code,
            fault_text=text,
            active_faults=labels,
            counter_names=list(counters),
            counter_values=[int(v) for v in counters.values()],
            configured_rate=report.configured_rate,
            achieved_rate=report.achieved_rate,
            configured_real_time_factor=report.configured_real_time_factor,
            achieved_real_time_factor=report.achieved_real_time_factor,
            behind_real_time=behind,
        )
        # Inside a tick, the tick's own instant: in lockstep one clock time covers several ticks.
        stamp_ns = self.tick_instant_ns or self.get_clock().now().nanoseconds
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp_ns, 1_000_000_000)
        # A frame id, which tf2 refuses with a leading slash: the node's name under its namespace.
        msg.header.frame_id = self.get_fully_qualified_name().lstrip("/")
        self._status_pub.publish(msg)
        self._last_status_msg = msg

    def is_behind(self, report: RateReport) -> bool:
        """Whether the device is behind the clock: never in lockstep, where the clock waits for it."""
        return self.active and self.lockstep is None and report.behind

    @staticmethod
    def _behind_text(report: RateReport) -> str:
        return (
            f"behind real time: rate {report.achieved_rate:.3g} of {report.configured_rate:.3g} Hz, "
            f"simulated {report.keeping_pace:.3g} s per clock second, real-time factor "
            f"{report.achieved_real_time_factor:.3g} of {report.configured_real_time_factor:.3g}"
        )

    # --- lifecycle transitions -------------------------------------------------------------------
    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Validate every parameter and build the model; a bad one fails the transition, naming it."""
        try:
            values = {name: self.get_parameter(name).value for name in self.specs}
            for name, spec in self.specs.items():
                check_value(spec, values[name])
            self.p = from_values(self.parameters, values)
            self.count.reset()
            self.configure_device(self.p)
            self._inject_configured_faults()
        except FeederError as error:
            self.configuration_error = f"configure failed: {error}"
            self.get_logger().error(self.configuration_error)
            self.faults.clear()
            self._release()
            self.publish_status()
            return TransitionCallbackReturn.FAILURE
        self.configuration_error = ""
        self.lifecycle = "inactive"
        self.publish_status()
        return TransitionCallbackReturn.SUCCESS

    def _release(self) -> None:
        """Release the device's model, then the kit's streams and counts: one path for every exit."""
        try:
            self.cleanup_device()
        finally:
            self._destroy_streams()
            self.count.reset()

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Start the simulation and the lifecycle publishers."""
        result = super().on_activate(state)
        self.monitor.reset()
        self.last_advance_ns = self.get_clock().now().nanoseconds  # a paused span is not simulated
        self.activate_device()
        self.lifecycle = "active"
        self._start_ticks()
        self.publish_status()
        return result

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Freeze the physics where it is; latched descriptions stay with their late-joining subscribers."""
        self._stop_ticks()
        self.deactivate_device()
        self.lifecycle = "inactive"
        self._wake_tick_waiters()  # a goal must not outlive the device's activity
        result = super().on_deactivate(state)
        self.publish_status()
        return result

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Release the model; the node is unconfigured again."""
        self._release()
        self.faults.clear()
        self.model_fault = None
        self.stopped = False
        self.lifecycle = "unconfigured"
        self.publish_status()
        return TransitionCallbackReturn.SUCCESS

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Release everything before the node is finalized."""
        if self.lifecycle == "active":
            self._stop_ticks()
            self.deactivate_device()
        if self.lifecycle in ("active", "inactive"):
            self._release()
        self.lifecycle = "finalized"
        self._wake_tick_waiters()
        self.publish_status()
        return TransitionCallbackReturn.SUCCESS

    def on_error(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Recover from a transition that raised: log, release, back to unconfigured (the node lives on)."""
        self.get_logger().error(f"error in lifecycle state {state.label}; cleaning up")
        try:
            self._stop_ticks()
            self._release()
        finally:
            self.lifecycle = "unconfigured"
            self._wake_tick_waiters()
            self.publish_status()
        return TransitionCallbackReturn.SUCCESS

    def destroy_node(self) -> None:
        """Destroy the node with its action servers and state machine, which rclpy's destroy_node leaves.

        An action server keeps its rcl node and its DDS endpoints alive, even past ``rclpy.shutdown``: a
        device destroyed in a process that goes on would still show its actions in the graph.
        """
        if self.lockstep is not None:
            self.lockstep.leave()
        for server in self.action_servers:
            server.destroy()
        self.action_servers.clear()
        super().destroy_node()
        # Likewise the lifecycle state machine and its ~/transition_event publisher (rclpy keeps them).
        self._state_machine.destroy_when_not_in_use()

    def _LifecycleNodeMixin__change_state(self, transition_id: int) -> TransitionCallbackReturn:  # noqa: N802
        """Run a transition as rclpy does, publishing each step's TransitionEvent with stamp and transition.

        rcl_lifecycle's notification on ``~/transition_event`` carries only the start and goal states
        (``timestamp`` 0, ``transition`` {0, ""}), so a recorded bring-up said neither when nor which
        transition. The steps are the same as rclpy's (the transition, the callback, its outcome, and on
        ERROR the error processing), each triggered without rcl's notification and published here.
        """
        callbacks = LifecycleNodeMixin._LifecycleNodeMixin__execute_callback
        initial = self._state_machine.current_state
        initial_state = LifecycleState(state_id=initial[0], label=initial[1])
        self._transition_step(transition_id=transition_id)
        code = callbacks(self, self._state_machine.current_state[0], initial_state)
        self._transition_step(label=code.to_label())
        if code == TransitionCallbackReturn.ERROR:
            error_code = callbacks(self, self._state_machine.current_state[0], initial_state)
            self._transition_step(label=error_code.to_label())
        return code

    def _transition_step(self, transition_id: int | None = None, label: str = "") -> None:
        """Trigger one transition of the state machine (by id or by label) and publish its event."""
        machine = self._state_machine
        start = machine.current_state
        taken = next(
            (
                t
                for t in machine.available_transitions
                if (t[0] == transition_id if label == "" else t[1] == label)
            ),
            None,
        )
        if transition_id is not None:
            machine.trigger_transition_by_id(transition_id, False)
        else:
            machine.trigger_transition_by_label(label, False)
        goal = machine.current_state
        event = TransitionEvent()
        # The node clock (cell time on the cell clock); wall time while a sim-time node has no /clock yet.
        now = self.get_clock().now().nanoseconds
        event.timestamp = now if now > 0 else time.time_ns()
        event.transition = Transition(
            id=taken[0] if taken else (transition_id or 0), label=taken[1] if taken else label
        )
        event.start_state = State(id=start[0], label=start[1])
        event.goal_state = State(id=goal[0], label=goal[1])
        self._transition_events.publish(event)

    def _LifecycleNodeMixin__on_change_state(self, request: Any, response: Any) -> Any:  # noqa: N802
        """Refuse a transition the present state does not have, instead of dying of it.

        rclpy's lifecycle node raises out of its ~/change_state callback for a transition id that is not
        registered in the present state (ros2/rclpy#1209, fixed upstream after the pinned Jazzy wheel),
        which ends the device's process: a controller sending ``activate`` to an unconfigured device would
        kill it. Overriding the name-mangled callback is the one place to catch it; the answer is
        ``success: false``, as for a transition named by an unknown label.
        """
        try:
            return LifecycleNodeMixin._LifecycleNodeMixin__on_change_state(self, request, response)
        except RCLError as error:
            self.get_logger().warning(
                f"change_state refused: transition {request.transition.id} "
                f"{request.transition.label!r} is not available in state {self.lifecycle}: {error}"
            )
            response.success = False
            return response

    # --- services --------------------------------------------------------------------------------
    def _on_stop(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        if self.lifecycle != "active":
            response.success, response.message = False, f"stop refused: device is {self.state().name}"
            return response
        self.stop_device()
        self.stopped = True
        self.publish_status()
        response.success, response.message = True, "stopped"
        return response

    def _on_reset(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        if self.lifecycle not in ("active", "inactive"):
            response.success, response.message = False, f"reset refused: device is {self.state().name}"
            return response
        self._clear_every_fault()
        self.stopped = False
        self.reset_device()
        self.publish_status()
        response.success, response.message = True, f"reset: {self.state().name}"
        return response

    def _clear_every_fault(self) -> None:
        """Clear the injected faults (each hook told) and the model's own: what reset and clear share."""
        for name in list(self.faults):
            self.clear_fault(name)
        self.faults.clear()
        self.model_fault = None

    def _on_abort(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        """PackML Abort: halt at once and enter FAULT (code FAULT_ABORTED) until ~/clear or ~/reset."""
        if self.lifecycle != "active":
            response.success, response.message = False, f"abort refused: device is {self.state().name}"
            return response
        self.stop_device()
        self.model_fault = (
            DeviceStatus.FAULT_ABORTED,
            "aborted by command (~/abort); ~/clear stops it, ~/reset returns it to IDLE",
        )
        self.get_logger().warning("aborted by command")
        self.publish_status()
        response.success, response.message = True, "aborted"
        return response

    def _on_clear(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        """PackML Clear (Aborted -> Clearing -> Stopped): clear every fault and leave the device STOPPED.

        Unlike ~/reset, which goes on to IDLE, so that a PLC that clears a fault still resets the machine
        before it runs again, as PackML's state machine has it.
        """
        if self.lifecycle != "active" or self.stopping_fault() is None:
            response.success = False
            response.message = f"clear refused: device is {self.state().name} (clear applies in FAULT)"
            return response
        self._clear_every_fault()
        self.stopped = True
        self.publish_status()
        response.success, response.message = True, f"cleared: {self.state().name}"
        return response

    def _on_inject_fault(
        self, request: InjectFault.Request, response: InjectFault.Response
    ) -> InjectFault.Response:
        try:
            self._inject(request)
            response.ok, response.error = True, ""
        except FeederError as error:
            response.ok, response.error = False, f"bad request: {error}"
            self.get_logger().warning(f"inject_fault: {response.error}")
        response.active_faults = [f.label for f in self.faults.values()]
        self.publish_status()
        return response

    def _inject(self, request: InjectFault.Request) -> None:
        name = request.fault.strip()
        if request.clear:
            names = [name] if name else list(self.faults)
            if name and name not in self.FAULTS:
                raise InputError("fault", unknown_fault(name, self.FAULTS))
            for each in names:
                if each in self.faults:
                    self.clear_fault(each)
                    del self.faults[each]
            return
        if name not in self.FAULTS:
            raise InputError("fault", unknown_fault(name, self.FAULTS))
        if self.lifecycle not in ("active", "inactive"):
            raise DeviceError(f"inject_fault refused: device is {self.state().name} (configure it first)")
        fault = ActiveFault(
            self.FAULTS[name],
            float(request.value),
            bool(request.state),
            tuple(int(i) for i in request.indices),
            float(request.angle),
            int(request.seed) or int(self.p.fault_seed),
        )
        self.apply_fault(fault)  # validates the magnitudes (InputError naming value/indices/angle)
        self.faults[name] = fault

    def _inject_configured_faults(self) -> None:
        self.faults.clear()
        for index, entry in enumerate(e for e in self.p.inject_faults if e):
            parsed = parse_fault_parameter(entry, index)
            if parsed.name not in self.FAULTS:
                raise InputError(f"parameter inject_faults[{index}]", unknown_fault(parsed.name, self.FAULTS))
            spec = self.FAULTS[parsed.name]
            name = parsed.name
            fault = ActiveFault(
                spec,
                parsed.value,
                parsed.state,
                parsed.indices,
                parsed.angle,
                int(self.p.fault_seed),
            )
            try:
                self.apply_fault(fault)
            except InputError as error:
                raise InputError(f"parameter inject_faults[{index}] ({error.field})", error.problem) from None
            self.faults[name] = fault

    # --- parameters ------------------------------------------------------------------------------
    def _on_set_parameters(self, changes: list[Parameter]) -> SetParametersResult:
        # Read-only parameters never reach here (rclpy refuses them by their descriptor). A runtime
        # parameter is validated, then applied at once when the device is configured; never ignored.
        for change in changes:
            spec = self.specs.get(change.name)
            if spec is None:
                continue  # rclpy's own (use_sim_time) and anything undeclared: rclpy decides
            try:
                check_value(spec, change.value)
            except InputError as error:
                return SetParametersResult(successful=False, reason=str(error))
        if self.lifecycle in ("active", "inactive"):
            for change in changes:
                if change.name in self.specs:
                    changed = self.p
                    if change.name in self.p.__dataclass_fields__:
                        changed = dataclasses.replace(self.p, **{change.name: change.value})
                    try:
                        self.apply_parameter(change.name, changed)
                    except FeederError as error:
                        return SetParametersResult(successful=False, reason=str(error))
                    self.p = changed
        return SetParametersResult(successful=True)

    # --- heartbeat -------------------------------------------------------------------------------
    def _heartbeat(self) -> None:
        if self.lockstep is not None and self._last_status_msg is not None:
            # In lockstep the wall-clock heartbeat repeats what was last said, never news: a change is
            # published at the end of the tick phase that made it, at a defined cell time. Only the
            # wall-clock figures (rate and real-time factor achieved) are fresh.
            msg = copy.copy(self._last_status_msg)
            report = self.rate_report()
            msg.achieved_rate = report.achieved_rate
            msg.achieved_real_time_factor = report.achieved_real_time_factor
            self._status_pub.publish(msg)
        else:
            self.publish_status(force=True)
        self._diagnostics_pub.publish(self._diagnostics())

    def _diagnostics(self) -> DiagnosticArray:
        state = self.state()
        report = self.rate_report()
        fault = self.stopping_fault()
        behind = self.is_behind(report)
        if fault is not None or self.configuration_error:
            level, message = DiagnosticStatus.ERROR, fault[1] if fault else self.configuration_error
        elif self.lifecycle in ("inactive", "active") and (warning := self.warning_fault()) is not None:
            level, message = DiagnosticStatus.WARN, warning[1]
        elif behind:
            level, message = DiagnosticStatus.WARN, self._behind_text(report)
        elif state in (DeviceState.UNCONFIGURED, DeviceState.PAUSED):
            level, message = DiagnosticStatus.STALE, f"{state.name.lower()}: not simulating"
        elif state is DeviceState.STOPPED:
            level, message = DiagnosticStatus.WARN, "stopped (~/reset returns it to IDLE)"
        else:
            level, message = DiagnosticStatus.OK, state.name.lower()
        values = {
            "state": state.name,
            "configured_rate_hz": f"{report.configured_rate:.6g}",
            "achieved_rate_hz": f"{report.achieved_rate:.6g}",
            "configured_real_time_factor": f"{report.configured_real_time_factor:.6g}",
            "achieved_real_time_factor": f"{report.achieved_real_time_factor:.6g}",
            "keeping_pace": f"{report.keeping_pace:.6g}",
            "behind_real_time": str(behind).lower(),
            "active_faults": ", ".join(f.label for f in self.faults.values()),
            "last_goal_rejection": self.last_goal_rejection,
            **{
                name: str(value)
                for name, value in (
                    self.counters() if self.lifecycle in ("inactive", "active") else {}
                ).items()
            },
        }
        name = self.get_fully_qualified_name()
        hardware_id = str(self.p.hardware_id or f"sim:{name}")
        status = DiagnosticStatus(
            level=level,
            name=name,
            message=message,
            hardware_id=hardware_id,
            values=[KeyValue(key=k, value=v) for k, v in values.items()],
        )
        array = DiagnosticArray(status=[status])
        array.header.stamp = self.get_clock().now().to_msg()
        return array
