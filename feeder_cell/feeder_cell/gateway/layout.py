"""The gateway's OPC UA address space, as data: what every device object holds and what its methods take.

asyncua-free, so that the server, the documentation and the tests read one definition. What every device
object holds is here; what one kind adds (its signals, its action's method, feedback and result, its
counters) is its profile in ``kinds``, and ``variables`` and ``methods`` put the two together.

Every node has a string NodeId in the gateway's namespace (``NAMESPACE_URI``): a device object is its key
(``cell.throwing_arm`` for ``/cell/throwing_arm``), a variable ``KEY.PATH`` (``cell.throwing_arm.Status.
PackMLState``) and a method ``KEY.NAME`` (``cell.throwing_arm.FeedPart``). Browse names are the path's
last part, under folders named by the path (``Status``, ``Signals``, ``Command``...)::

    Objects/Cell/Devices/<key>/{Kind, NodeName, Status/..., Signals/..., Command/..., methods}
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

from feeder_cell.gateway.commands import COMMANDS, FAULT_SERVICES
from feeder_cell.gateway.kinds import KINDS
from feeder_cell.gateway.spec import MethodSpec, ServiceLink, VariableSpec
from feeder_msgs.msg import DeviceStatus

__all__ = [
    "NAMESPACE_URI",
    "PACKML_STATE_TYPE",
    "DEVICE_STATE_TYPE",
    "DEVICE_STATES",
    "enumerations",
    "outcome_type",
    "APPLICATION_URI",
    "CELL",
    "DEVICES_FOLDER",
    "STATUS",
    "COMMAND",
    "STOP",
    "RESET",
    "ACTIONS",
    "COUNTERS",
    "counter_path",
    "counter32_path",
    "UINT32_MODULUS",
    "variables",
    "methods",
    "service",
    "variable_id",
    "method_id",
]

NAMESPACE_URI = "urn:feeder:cell"
APPLICATION_URI = "urn:feeder:cell:opcua_gateway"
CELL = "Cell"
PACKML_STATE_TYPE = "PackMLStateEnumeration"  # the DataType's browse name and string NodeId
DEVICE_STATE_TYPE = "DeviceStateEnumeration"  # Status.State's DataType: feeder_msgs/DeviceStatus states
DEVICES_FOLDER = "Cell.Devices"


def _v(
    path: str, type_: str, description: str, array: bool = False, unit: str = "", data_type: str = ""
) -> VariableSpec:
    return VariableSpec(path, type_, description, array, unit, data_type)


def _one_of(names: list[str]) -> str:
    """Return names as prose: "a, b or c"."""
    return f"{', '.join(names[:-1])} or {names[-1]}" if len(names) > 1 else "".join(names)


IDENTITY = (
    _v("Kind", "String", f"device kind: {_one_of(list(KINDS))}"),
    _v("NodeName", "String", "the device's fully qualified ROS node name"),
)

STATUS = (
    _v("Status.Online", "Boolean", "a ~/status heard within the last 5 s (the device's heartbeat is 1 Hz)"),
    _v(
        "Status.State",
        "Int32",
        "feeder_msgs/DeviceStatus state (DeviceStateEnumeration: 0 UNCONFIGURED ... 5 STOPPED)",
        data_type=DEVICE_STATE_TYPE,
    ),
    _v(
        "Status.StateName",
        "String",
        "the device's state name: UNCONFIGURED, IDLE, RUNNING, PAUSED, FAULT, STOPPED",
    ),
    _v("Status.PackMLState", "String", "PackML state name (docs/cell.md: the mapping table)"),
    _v(
        "Status.PackMLStateCode",
        "Int32",
        "PackML state (PackMLStateEnumeration: ISA-TR88.00.02 StateCurrent numbers, 0 Undefined; "
        "100 Unconfigured, the gateway's own)",
        data_type=PACKML_STATE_TYPE,
    ),
    _v("Status.Ready", "Boolean", "the device accepts commands"),
    _v("Status.Busy", "Boolean", "the device is executing a command"),
    _v("Status.FaultCode", "UInt32", "DeviceStatus fault code of a stopping fault (0 none; docs/cell.md)"),
    _v("Status.FaultText", "String", "what the fault is and what clears it"),
    _v(
        "Status.WarningCode",
        "UInt32",
        "DeviceStatus fault code of a non-stopping fault: the device stays operational (0 none)",
    ),
    _v("Status.WarningText", "String", "what the warning is"),
    _v("Status.ActiveFaults", "String", "injected faults in force, as name(value)", True),
    _v("Status.CounterNames", "String", "the device's counters, names", True),
    _v("Status.CounterValues", "UInt64", "the device's counters, values in CounterNames' order", True),
    _v(
        "Status.CounterValues32",
        "UInt32",
        "the device's counters modulo 2^32 (they roll over like a PLC's UInt32 counter), CounterNames' order",
        True,
    ),
    _v("Status.BehindRealTime", "Boolean", "the device cannot hold its configured rate or real-time factor"),
    _v("Status.ConfiguredRate", "Double", "Hz of the device's main stream, configured", unit="HTZ"),
    _v("Status.AchievedRate", "Double", "Hz of the device's main stream, achieved", unit="HTZ"),
    _v(
        "Status.ConfiguredRealTimeFactor", "Double", "simulated seconds per wall second asked for", unit="C62"
    ),
    _v("Status.AchievedRealTimeFactor", "Double", "simulated seconds per wall second achieved", unit="C62"),
)

COMMAND = (
    _v("Command.Busy", "Boolean", "a goal this gateway sent is executing"),
    _v(
        "Command.Action",
        "String",
        "the action of the executing or last goal: "
        + ", ".join(profile.action.method.name for profile in KINDS.values()),
    ),
    _v("Command.GoalCount", "UInt32", "goals accepted by the device since the gateway started"),
    _v("Command.ResultCount", "UInt32", "goal results received; equal to GoalCount when none is executing"),
    _v("Command.LastOutcome", "String", "outcome_name of the last result (PRESENTED, SETTLED, REACHED, ...)"),
    _v(
        "Command.LastOutcomeCode",
        "Int32",
        "outcome of the last result: the action's result constants (<Action>OutcomeEnumeration; 0 none)",
    ),
    _v("Command.LastStatus", "String", "status of the last method call: Good or the Bad code's name"),
    _v("Command.LastMessage", "String", "message of the last method call or goal result"),
    _v("Command.Result.FaultCode", "UInt32", "fault_code of the last result (0 unless its outcome is FAULT)"),
)

STOP = COMMANDS["Stop"].method
RESET = COMMANDS["Reset"].method

# One facet of every kind, by kind, for the readers that want it across kinds (the tests, the docs); the
# profiles in kinds.KINDS are the one definition.
ACTIONS: Mapping[str, MethodSpec] = {kind: profile.action.method for kind, profile in KINDS.items()}
COUNTERS: Mapping[str, tuple[str, ...]] = {kind: profile.counter_names for kind, profile in KINDS.items()}


UINT32_MODULUS = 2**32


def counter_path(name: str) -> str:
    """Return the variable path of a counter a kind shows: one UInt64 variable each under Status.Counters.

    BadWaitingForInitialData until the device reports it; every counter the device reports, one outside
    its declaration too, is in CounterNames/CounterValues.
    """
    return f"Status.Counters.{name}"


def counter32_path(name: str) -> str:
    """Return the path of a counter's UInt32 twin (Status.Counters32): the count modulo 2^32.

    For PLCs without 64-bit integers: a UInt32 that rolls over, so that the difference of two reads
    (in UInt32 arithmetic) is the count between them as long as fewer than 2^32 happened.
    """
    return f"Status.Counters32.{name}"


# An enumeration DataType's fields: (number, name, meaning), as PACKML_STATES.
Fields = tuple[tuple[int, str, str], ...]

DEVICE_STATES: Fields = (
    (DeviceStatus.UNCONFIGURED, "UNCONFIGURED", "lifecycle unconfigured (or its configuration failed)"),
    (DeviceStatus.IDLE, "IDLE", "active, ready for a command"),
    (DeviceStatus.RUNNING, "RUNNING", "active and executing (a throw cycle, a field program, a move)"),
    (DeviceStatus.PAUSED, "PAUSED", "configured but inactive: the physics frozen where it was"),
    (DeviceStatus.FAULT, "FAULT", "a fault stops the device until it is cleared and reset"),
    (DeviceStatus.STOPPED, "STOPPED", "halted by a stop; a reset returns it to IDLE"),
)
# What each action's outcomes mean (feeder_msgs/action/*.action); 0 is the gateway's own.
_OUTCOMES: Mapping[str, str] = {
    "PRESENTED": "the sensor read true with the part at rest",
    "MAX_THROWS": "MaxThrows thrown, never presented",
    "SETTLED": "every part settled",
    "REACHED": "at the last waypoint",
    "REFUSED": "the interlock refused the path (FirstUnstableSample, UnbalancedBodies say where)",
    "STALLED": "an axis stalled (fault 301): the fixture stopped where it was",
    "TIMEOUT": "the timeout passed first",
    "FAULT": "the device faulted during the goal (Result/FaultCode says which)",
    "CANCELED": "canceled (Stop, Abort or a cancel)",
}
_NO_OUTCOME = (0, "NONE", "no outcome: a goal executing, none yet, or LOST (the device stopped reporting)")


def outcome_type(kind: str) -> str:
    """Return the name of the enumeration DataType of a kind's Command.LastOutcomeCode."""
    return f"{KINDS[kind].action.method.name}OutcomeEnumeration"


def enumerations(kinds: list[str]) -> dict[str, Fields]:
    """Return the enumeration DataTypes the devices of ``kinds`` use, by name (PackML's is the server's)."""
    types: dict[str, Fields] = {DEVICE_STATE_TYPE: DEVICE_STATES}
    for kind in kinds:
        result = KINDS[kind].action.action_type.Result
        names = [n for n in dir(result) if n.isupper() and n != "SLOT_TYPES"]
        fields = sorted((int(getattr(result, n)), n, _OUTCOMES.get(n, n)) for n in names)
        types[outcome_type(kind)] = (_NO_OUTCOME, *fields)
    return types


def variables(kind: str) -> tuple[VariableSpec, ...]:
    """Return every variable of a device object of ``kind``, in browse order."""
    profile = KINDS[kind]
    counters = tuple(_v(counter_path(c.name), "UInt64", c.description) for c in profile.counters)
    counters32 = tuple(
        _v(counter32_path(c.name), "UInt32", f"{c.description} (modulo 2^32)") for c in profile.counters
    )
    return (
        *IDENTITY,
        *STATUS,
        *counters,
        *counters32,
        *profile.signals,
        *(
            dataclasses.replace(spec, data_type=outcome_type(kind))
            if spec.path == "Command.LastOutcomeCode"
            else spec
            for spec in COMMAND
        ),
        *profile.action.feedback,
        *profile.action.result,
    )


def methods(kind: str) -> tuple[MethodSpec, ...]:
    """Return the methods of a device object of ``kind``, in browse order.

    Its action's, its services', then every kind's: the PackML commands, InjectFault and ClearFault.
    """
    profile = KINDS[kind]
    return (
        profile.action.method,
        *(link.method for link in profile.services),
        *(command.method for command in COMMANDS.values()),
        *(link.method for link in FAULT_SERVICES),
    )


def service(kind: str, name: str) -> ServiceLink | None:
    """Return the service link behind method ``name`` of a ``kind`` device object, or None."""
    for link in (*KINDS[kind].services, *FAULT_SERVICES):
        if link.method.name == name:
            return link
    return None


def variable_id(key: str, path: str) -> str:
    """Return the string NodeId identifier of a device's variable."""
    return f"{key}.{path}"


def method_id(key: str, name: str) -> str:
    """Return the string NodeId identifier of a device's method."""
    return f"{key}.{name}"
