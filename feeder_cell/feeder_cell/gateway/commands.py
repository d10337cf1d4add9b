"""The methods every device object has: PackML's state commands and fault injection.

A PLC runs a device through PackML's state machine (OPC 30050, after ISA-TR88.00.02) with commands; here
each command is a method whose effect depends on the device's state, as one row per state of
``COMMANDS``: the device calls it makes, in order, and the transient PackML state the gateway shows
while they run. A command in a state without a row is refused with BadInvalidState, naming the states it
applies in::

    Stop         Idle, Execute, Stopped   ~/stop                          Stopping
    Reset        Stopped                  ~/reset                         Resetting   -> Idle
                 Unconfigured             lifecycle configure, activate   Resetting   -> Idle
                 Idle, Suspended          ~/reset (clears warnings; no PackML transition)
    Clear        Aborted                  ~/clear                         Clearing    -> Stopped
    Abort        Idle, Execute, Stopped   ~/abort                         Aborting    -> Aborted
    Suspend      Idle, Execute, Stopped,  lifecycle deactivate            Suspending  -> Suspended
                 Aborted
    Unsuspend    Suspended                lifecycle activate              Unsuspending -> Idle
    Unconfigure  Suspended                lifecycle cleanup                           -> Unconfigured
                 Idle, Stopped, Aborted   lifecycle deactivate, cleanup               -> Unconfigured

So a fault is left the standard's way, Aborted -> Clearing -> Stopped -> Resetting -> Idle (Reset in
Aborted is refused: Clear first), and a device is brought up (Reset from Unconfigured) and down
(Unconfigure) through its ROS lifecycle. PackML's Start is the kind's action method (FeedPart,
RunProgram, FollowPath: Start with the command's parameters); the device returns to Idle when the goal
ends, so Completing and Complete do not occur. Hold and Unhold have no device behind them.

``InjectFault`` and ``ClearFault`` (``~/inject_fault``) are commissioning tools: a PLC programmer tests
the fault handling of a cell controller against the faults a device declares (docs/cell.md lists them).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from lifecycle_msgs.msg import Transition

from feeder_cell.gateway.arguments import ArgumentError, check_count, read_number, read_string
from feeder_cell.gateway.config import packml_state
from feeder_cell.gateway.spec import Argument, ArgumentSpec, Availability, MethodSpec, ServiceLink
from feeder_msgs.msg import DeviceStatus
from feeder_msgs.srv import InjectFault

__all__ = [
    "Command",
    "Plan",
    "COMMANDS",
    "FAULT_SERVICES",
    "TRIGGERS",
    "LIFECYCLE",
    "plan",
    "cancels_goal",
]

# Device calls a command is made of: a std_srvs/Trigger service of the device (~/NAME) ...
TRIGGERS = ("stop", "reset", "clear", "abort")
# ... or a transition of its ROS lifecycle (lifecycle_msgs/srv/ChangeState on ~/change_state).
LIFECYCLE: Mapping[str, int] = {
    "configure": Transition.TRANSITION_CONFIGURE,
    "activate": Transition.TRANSITION_ACTIVATE,
    "deactivate": Transition.TRANSITION_DEACTIVATE,
    "cleanup": Transition.TRANSITION_CLEANUP,
}

_S = DeviceStatus


@dataclass(frozen=True)
class Plan:
    """What a command does in one device state: the PackML state shown meanwhile and the device calls."""

    transient: str  # "" : none (the command is no PackML transition in this state)
    calls: tuple[str, ...]


@dataclass(frozen=True)
class Command:
    """A PackML command: its method and what it does per device state (``DeviceStatus`` state)."""

    method: MethodSpec
    plans: Mapping[int, Plan]


def _row(transient: str, *calls: str) -> Plan:
    return Plan(transient, calls)


COMMANDS: Mapping[str, Command] = {
    "Stop": Command(
        MethodSpec("Stop", "PackML Stop: halt the device at once (~/stop): Stopped; an executing goal ends"),
        {s: _row("Stopping", "stop") for s in (_S.IDLE, _S.RUNNING, _S.STOPPED)},
    ),
    "Reset": Command(
        MethodSpec(
            "Reset",
            "PackML Reset: Stopped -> Resetting -> Idle (~/reset); Unconfigured: the lifecycle's configure "
            "and activate; in Idle or Suspended ~/reset clears warnings. Aborted: Clear first",
        ),
        {
            _S.STOPPED: _row("Resetting", "reset"),
            _S.UNCONFIGURED: _row("Resetting", "configure", "activate"),
            _S.IDLE: _row("", "reset"),
            _S.PAUSED: _row("", "reset"),
        },
    ),
    "Clear": Command(
        MethodSpec("Clear", "PackML Clear: Aborted -> Clearing -> Stopped (~/clear: every fault cleared)"),
        {_S.FAULT: _row("Clearing", "clear")},
    ),
    "Abort": Command(
        MethodSpec("Abort", "PackML Abort: halt at once into Aborted (~/abort, fault 4); Clear leaves it"),
        {s: _row("Aborting", "abort") for s in (_S.IDLE, _S.RUNNING, _S.STOPPED)},
    ),
    "Suspend": Command(
        MethodSpec("Suspend", "PackML Suspend: the lifecycle's deactivate; the physics freeze (Suspended)"),
        {s: _row("Suspending", "deactivate") for s in (_S.IDLE, _S.RUNNING, _S.STOPPED, _S.FAULT)},
    ),
    "Unsuspend": Command(
        MethodSpec("Unsuspend", "PackML Unsuspend: the lifecycle's activate; the physics go on"),
        {_S.PAUSED: _row("Unsuspending", "activate")},
    ),
    "Unconfigure": Command(
        MethodSpec(
            "Unconfigure",
            "bring the device down through its lifecycle (deactivate, cleanup): Unconfigured; Reset "
            "brings it up again",
        ),
        {
            _S.PAUSED: _row("", "cleanup"),
            **{s: _row("", "deactivate", "cleanup") for s in (_S.IDLE, _S.STOPPED, _S.FAULT)},
        },
    ),
}


def plan(command: Command, state: int) -> Plan | str:
    """Return the command's plan in device state ``state``, or why it is refused there (one line)."""
    row = command.plans.get(state)
    if row is not None:
        return row
    here = packml_state(state)[0]
    valid = ", ".join(packml_state(s)[0] for s in command.plans)
    remedy = "; Clear it first" if state == _S.FAULT and command.method.name == "Reset" else ""
    if state == _S.RUNNING and command.method.name == "Unconfigure":
        remedy = "; Stop it first"
    return f"{command.method.name} refused: the device is {here}; it applies in {valid}{remedy}"


def cancels_goal(command: Command) -> bool:
    """Whether the command ends a goal the gateway sent (the device halts: the goal must not run on)."""
    return command.method.name in ("Stop", "Abort")


# --- fault injection: one ~/inject_fault call each ----------------------------------------------------

# A fault is injected in any configured state, a goal executing or not (a commissioning test injects one
# into a running cycle); clearing one is never refused for the device's state.
_CONFIGURED = frozenset({_S.IDLE, _S.RUNNING, _S.PAUSED, _S.FAULT, _S.STOPPED})
_INJECTS = Availability(states=_CONFIGURED, goal_blocks=False)
_CLEARS = Availability(states=_CONFIGURED | {_S.UNCONFIGURED}, goal_blocks=False)


@dataclass(frozen=True)
class _FaultCall:
    fault: str
    clear: bool
    value: float = 0.0
    state: bool = False

    def message(self) -> Any:
        return InjectFault.Request(fault=self.fault, clear=self.clear, value=self.value, state=self.state)


def _check_inject(spec: MethodSpec, args: list[Argument]) -> _FaultCall:
    check_count(spec, args)
    fault = read_string(args[0], 0, "Fault").strip()
    value = read_number(args[1], 1, "Value")
    state = args[2].value
    if args[2].type != "Boolean" or not isinstance(state, bool):
        raise ArgumentError("BadTypeMismatch", 2, f"State: expected a Boolean, got {args[2].type} {state!r}")
    return _FaultCall(fault, False, value, state)


def _check_clear(spec: MethodSpec, args: list[Argument]) -> _FaultCall:
    check_count(spec, args)
    return _FaultCall(read_string(args[0], 0, "Fault").strip(), True)


FAULT_SERVICES: tuple[ServiceLink, ...] = (
    ServiceLink(
        MethodSpec(
            "InjectFault",
            "inject a fault the device declares (~/inject_fault), for commissioning tests; docs/cell.md "
            "lists each device's faults and what Value and State mean for each",
            (
                ArgumentSpec("Fault", "String", "the fault's name, e.g. motor_fault, sensor_stuck"),
                ArgumentSpec("Value", "Double", "probability, fraction, scale or angle: per fault"),
                ArgumentSpec("State", "Boolean", "sensor_stuck: the stuck reading; else per fault"),
            ),
        ),
        lambda spec, args, _context: _check_inject(spec, args),
        InjectFault,
        "inject_fault",
        _INJECTS,
    ),
    ServiceLink(
        MethodSpec(
            "ClearFault",
            "clear an injected fault (~/inject_fault clear); an empty Fault clears every one",
            (ArgumentSpec("Fault", "String", "the fault's name; empty: all"),),
        ),
        lambda spec, args, _context: _check_clear(spec, args),
        InjectFault,
        "inject_fault",
        _CLEARS,
    ),
)
