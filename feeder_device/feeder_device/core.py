"""The device's state and the hooks a device implements: the bottom layer of ``ManagedDevice``.

``ManagedDevice`` (``device.py``) is built in layers, one concern each, every layer a class on top of the
one below it, so that each sees what it needs and nothing above it:

    DeviceCore (this module)          the state every concern shares; the device's hooks; its streams
    StatusReporting (status.py)       the controller-facing state, ~/status, /diagnostics, the heartbeat
    TickLoop (ticks.py)               the tick and who drives it: a timer, or the lockstep
    FaultServices (faults.py)         ~/stop, ~/reset, ~/abort, ~/clear, ~/inject_fault and model faults
    LifecycleTransitions (lifecycle.py)  configure .. shutdown, transition events, parameters
    ManagedDevice (device.py)         the wiring at construction

The hooks here do nothing (or the default a device usually wants); a device overrides those it needs.
"""

from __future__ import annotations

from enum import IntEnum
from typing import Any, Generic, Mapping, Protocol, Sequence, TypeVar

from diagnostic_msgs.msg import DiagnosticArray
from lifecycle_msgs.msg import TransitionEvent
from rclpy.action import ActionServer
from rclpy.lifecycle import LifecycleNode
from rclpy.publisher import Publisher
from rclpy.qos import QoSProfile
from rclpy.task import Future
from rclpy.timer import Timer

from feeder_device.declarations import ActiveFault, Counters, CounterSpec, FaultSpec
from feeder_device.drive import LockstepDriver
from feeder_device.parameters import DeviceParameters
from feeder_device.rate import RateMonitor
from feeder_device.streams import Streams
from feeder_msgs.msg import DeviceStatus
from feeder_planner.node_kit.lockstep import Participant
from feeder_planner.node_kit.parameters import ParameterSpec, declare_parameters
from feeder_planner.node_kit.qos import LATCHED
from feeder_planner.node_kit.services import REQUEST_QUEUE_PARAMETER
from feeder_planner.node_kit.tf import namespaced_frame
from feeder_planner.parameter_specs import from_values, specs_of

__all__ = ["DeviceCore", "DeviceState", "StatusKey", "TickedGoal", "device_parameter_specs"]


class DeviceState(IntEnum):
    """The device as a controller sees it (values of feeder_msgs/DeviceStatus.state)."""

    UNCONFIGURED = DeviceStatus.UNCONFIGURED
    IDLE = DeviceStatus.IDLE
    RUNNING = DeviceStatus.RUNNING
    PAUSED = DeviceStatus.PAUSED
    FAULT = DeviceStatus.FAULT
    STOPPED = DeviceStatus.STOPPED


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


class DeviceCore(LifecycleNode, Generic[P]):
    """The state every concern of a device shares, and the hooks a device implements."""

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
        # Lifecycle and faults (lifecycle.py, faults.py).
        self.lifecycle = "unconfigured"
        self.stopped = False
        self.faults: dict[str, ActiveFault] = {}
        self.model_fault: tuple[int, str] | None = None  # (code, text) of a fault the model raised
        self.internal_error = ""  # why the device's own tick raised: FAULT_INTERNAL until configured again
        self.configuration_error = ""
        self.count = Counters(self.COUNTERS)
        self._streams = Streams(self)
        self.goals: list[TickedGoal] = []  # the goals executing (feeder_device.goals), advanced per tick
        self.action_servers: list[ActionServer] = []  # made by goals.serve_goal, ended by destroy_node
        self.last_goal_rejection = ""
        # The tick (ticks.py). Under use_sim_time the node clock reads 0 until the first /clock arrives;
        # the device's model starts from that first reading, whatever the order in which the clock and the
        # device came up.
        self.monitor = RateMonitor(rate)
        self.tick_rate = rate
        self._tick_timer: Timer | None = None
        self.clock_start_ns = 0
        self.last_tick_due_ns = 0
        self.last_advance_ns = 0
        self.tick_waiters: list[Future] = []
        self.ticks_done = 0  # ticks since the node started: a goal's start is placed by it (goals.py)
        self.tick_instant_ns = 0  # the instant being ticked (0 outside a tick)
        # Lockstep: the grid of tick instants (origin, index of the last instant ticked), the driver that
        # announces cell time, and the DDS participant when the device answers the cell clock itself
        # (None when a cell host drives it, or when it runs on its own timer: then the driver is None too).
        self._grid_origin_ns = 0
        self._grid_index = 0
        self.lockstep_driver: LockstepDriver | None = None
        self.lockstep: Participant | None = None
        # Status (status.py): what ~/status last said, to publish it again only when it changes.
        self._last_status: StatusKey | None = None
        self._last_status_msg: DeviceStatus | None = None
        self._status_pub = self.create_publisher(DeviceStatus, "~/status", LATCHED)
        self._diagnostics_pub = self.create_publisher(DiagnosticArray, "/diagnostics", 10)

    # --- hooks for the device -------------------------------------------------------------------
    def configure_device(self, p: P) -> None:
        """Load files, build the model and its streams from validated parameters; InputError names a field."""

    def activate_device(self) -> None:
        """Resume the simulation (the kit starts the tick after this)."""

    def deactivate_device(self) -> None:
        """Freeze the simulation where it is (the kit has stopped the tick; state is kept)."""

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

    # --- what the device calls -------------------------------------------------------------------
    def stream(
        self, msg_type: Any, topic: str, qos: QoSProfile | int, *, lifecycle: bool = True
    ) -> Publisher:
        """Create a publisher (a lifecycle one, live only while active, unless ``lifecycle`` is False).

        Called from ``configure_device``; the kit destroys it at cleanup, a failed configure included, so
        a device never keeps a publisher of a model it no longer has.
        """
        return self._streams.make(msg_type, topic, qos, lifecycle=lifecycle)

    @property
    def active(self) -> bool:
        """Whether the lifecycle state is active."""
        return self.lifecycle == "active"

    @property
    def in_lockstep(self) -> bool:
        """Whether the cell clock's lockstep drives the tick (a DDS participant or a cell host)."""
        return self.lockstep_driver is not None

    def sim_seconds(self) -> float:
        """Node clock (simulated time under use_sim_time) in seconds."""
        return self.get_clock().now().nanoseconds * 1e-9

    def frame(self, base: str) -> str:
        """Return a per-instance frame id: ``base`` under the node's namespace (``cell/feeder_a/base``)."""
        return namespaced_frame(self, base)
