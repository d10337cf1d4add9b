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
  clock's lockstep (parameter ``lockstep``) there is no timer: whoever announces a time T (the device's own
  DDS participant, ``feeder_planner.node_kit.lockstep``, or a cell host: ``hosted``) calls
  ``advance_lockstep(T)``, which runs every instant of the rate's grid up to T, in order, each with its own
  ``now_ns``. So ``tick`` must stamp with ``now_ns``, never with the clock.
  ``elapsed_ns(now_ns)`` is the one definition of the node-clock time since the model last advanced.
- **Hooks**: ``configure_device`` (load and validate; raise InputError naming the field),
  ``activate_device``/``deactivate_device``, ``cleanup_device``, ``apply_parameter`` (runtime parameters),
  ``busy``, ``counters``, ``stop_device``, ``reset_device``, ``apply_fault``/``clear_fault``.

The class is built in layers, one concern a module (``core``, ``status``, ``ticks``, ``faults``,
``lifecycle``; the table is in ``core``'s docstring); this module wires them at construction. The sequence a
controller follows is in docs/cell.md; adding a device is docs/devices.md.
"""

from __future__ import annotations

from typing import Any, Sequence, TypeVar, cast

from feeder_device.core import DeviceState, P, device_parameter_specs
from feeder_device.lifecycle import LifecycleTransitions
from feeder_planner.node_kit.lockstep import Participant
from feeder_planner.node_kit.parameters import ParameterSpec

__all__ = ["DeviceState", "ManagedDevice", "device_parameter_specs", "hosted"]


class ManagedDevice(LifecycleTransitions[P]):
    """Lifecycle, tick, streams, status, diagnostics, stop/reset and fault plumbing of every device.

    See the module docstring for what a subclass declares and implements.
    """

    def __init__(
        self, node_name: str, parameters: type[P], extra: Sequence[ParameterSpec] = (), *, rate: float = 1.0
    ) -> None:
        super().__init__(node_name, parameters, extra, rate=rate)  # the state every layer shares (core)
        self._serve_fault_services()
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self._join_clock()  # the clock's first reading; the lockstep driver and participant
        self._start_heartbeat()
        self.publish_status(force=True)


D = TypeVar("D", bound="ManagedDevice[Any]")


def _no_participant(device: ManagedDevice[Any]) -> Participant | None:
    """Make no lockstep participant: the host announces cell time to a hosted device."""
    return None


def hosted(device_class: type[D]) -> type[D]:
    """Return ``device_class`` for a cell host: in lockstep it makes no DDS participant of its own.

    The host runs the device in its own process and executor with ``lockstep`` and ``use_sim_time`` set
    (as the launcher does), sets the device's node clock to each cell time T and calls
    ``advance_lockstep(T)``. The device behaves as under the cell clock: no status before the first T,
    never behind real time, a goal starting at the first tick after its acceptance.
    """
    name = f"Hosted{device_class.__name__}"
    members = {"make_lockstep_participant": _no_participant, "__doc__": device_class.__doc__}
    return cast(type[D], type(name, (device_class,), members))
