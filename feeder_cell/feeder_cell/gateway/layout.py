"""The gateway's OPC UA address space, as data: what every device object holds and what its methods take.

ROS-free and asyncua-free, so that the layout, the documentation and the tests read one definition.
Every node has a string NodeId in the gateway's namespace (``NAMESPACE_URI``): a device object is its key
(``cell.throwing_arm`` for ``/cell/throwing_arm``), a variable ``KEY.PATH`` (``cell.throwing_arm.Status.
PackMLState``) and a method ``KEY.NAME`` (``cell.throwing_arm.FeedPart``). Browse names are the path's
last part, under folders named by the path (``Status``, ``Signals``, ``Command``...)::

    Objects/Cell/Devices/<key>/{Kind, NodeName, Status/..., Signals/..., Command/..., methods}
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    "NAMESPACE_URI",
    "APPLICATION_URI",
    "CELL",
    "DEVICES_FOLDER",
    "VariableSpec",
    "ArgumentSpec",
    "MethodSpec",
    "COUNTERS",
    "variables",
    "methods",
    "variable_id",
    "method_id",
]

NAMESPACE_URI = "urn:feeder:cell"
APPLICATION_URI = "urn:feeder:cell:opcua_gateway"
CELL = "Cell"
DEVICES_FOLDER = "Cell.Devices"


@dataclass(frozen=True)
class VariableSpec:
    """A read-only variable of a device object: path under the object, OPC UA built-in type, meaning."""

    path: str  # e.g. Status.FaultCode
    type: str  # asyncua VariantType name: Boolean, Byte, Int32, UInt32, UInt64, Double, String
    description: str
    array: bool = False


@dataclass(frozen=True)
class ArgumentSpec:
    """An input argument of a method."""

    name: str
    type: str
    description: str
    array: bool = False


@dataclass(frozen=True)
class MethodSpec:
    """A method of a device object; every method has one output argument, Message (String)."""

    name: str
    description: str
    inputs: tuple[ArgumentSpec, ...] = ()


def _v(path: str, type_: str, description: str, array: bool = False) -> VariableSpec:
    return VariableSpec(path, type_, description, array)


STATUS = (
    _v("Status.Online", "Boolean", "a ~/status heard within the last 5 s (the device's heartbeat is 1 Hz)"),
    _v("Status.State", "Byte", "feeder_msgs/DeviceStatus state (0 UNCONFIGURED ... 5 STOPPED)"),
    _v(
        "Status.StateName",
        "String",
        "the device's state name: UNCONFIGURED, IDLE, RUNNING, PAUSED, FAULT, STOPPED",
    ),
    _v("Status.PackMLState", "String", "PackML state name (docs/cell.md: the mapping table)"),
    _v("Status.PackMLStateCode", "Int32", "PackML StateCurrent number (ISA-TR88.00.02; 0 Undefined)"),
    _v("Status.Ready", "Boolean", "the device accepts commands"),
    _v("Status.Busy", "Boolean", "the device is executing a command"),
    _v("Status.FaultCode", "UInt32", "DeviceStatus fault code (0 none; docs/cell.md)"),
    _v("Status.FaultText", "String", "what the fault is and what clears it"),
    _v("Status.ActiveFaults", "String", "injected faults in force, as name(value)", True),
    _v("Status.CounterNames", "String", "the device's counters, names", True),
    _v("Status.CounterValues", "UInt64", "the device's counters, values in CounterNames' order", True),
    _v("Status.BehindRealTime", "Boolean", "the device cannot hold its configured rate or real-time factor"),
    _v("Status.ConfiguredRate", "Double", "Hz of the device's main stream, configured"),
    _v("Status.AchievedRate", "Double", "Hz of the device's main stream, achieved"),
    _v("Status.ConfiguredRealTimeFactor", "Double", "simulated seconds per wall second asked for"),
    _v("Status.AchievedRealTimeFactor", "Double", "simulated seconds per wall second achieved"),
)

# The counters each kind reports, one UInt64 variable each under Status.Counters (BadWaitingForInitialData
# until the device reports it); every counter, a new one too, is in CounterNames/CounterValues.
COUNTERS: dict[str, tuple[str, ...]] = {
    "throwing_arm": ("throws", "faults", "parts_presented", "feed_goals", "feeds_presented"),
    "mems_field_array": (
        "steps",
        "steps_dropped",
        "programs",
        "placements",
        "parts_settled",
        "program_goals",
        "stiff_steps",
    ),
    "assembly_fixture": (
        "moves",
        "refused_moves",
        "moves_completed",
        "stalls",
        "capped_ticks",
        "path_goals",
        "path_goals_reached",
        "path_goals_refused",
    ),
}

COMMAND = (
    _v("Command.Busy", "Boolean", "a goal this gateway sent is executing"),
    _v(
        "Command.Action",
        "String",
        "the action of the executing or last goal: FeedPart, RunProgram, FollowPath",
    ),
    _v("Command.GoalCount", "UInt32", "goals accepted by the device since the gateway started"),
    _v("Command.ResultCount", "UInt32", "goal results received; equal to GoalCount when none is executing"),
    _v("Command.LastOutcome", "String", "outcome_name of the last result (PRESENTED, SETTLED, REACHED, ...)"),
    _v("Command.LastOutcomeCode", "Byte", "outcome of the last result (the action's result constants)"),
    _v("Command.LastStatus", "String", "status of the last method call: Good or the Bad code's name"),
    _v("Command.LastMessage", "String", "message of the last method call or goal result"),
    _v("Command.Result.FaultCode", "UInt32", "fault_code of the last result (0 unless its outcome is FAULT)"),
)

SIGNALS: dict[str, tuple[VariableSpec, ...]] = {
    "throwing_arm": (
        _v("Signals.Sensor", "Boolean", "the one-bit proximity sensor (~/sensor) as the device delivers it"),
    ),
    "mems_field_array": (
        _v("Signals.PartNames", "String", "parts on the array (~/part_states)", True),
        _v("Signals.PartOrientations", "Double", "orientation theta of each part, rad in [0, 2 pi)", True),
        _v("Signals.PartPositions", "Double", "centroid (x, y) of each part, m, flattened pairs", True),
    ),
    "assembly_fixture": (
        _v("Signals.TiltX", "Double", "tilt_x joint angle as the encoders read it (~/joint_states), rad"),
        _v("Signals.TiltY", "Double", "tilt_y joint angle as the encoders read it, rad"),
        _v("Signals.Gravity", "Double", "unit gravity direction, assembly frame (~/stability)", True),
        _v("Signals.Stable", "Boolean", "the assembly is potentially stable at this gravity"),
        _v("Signals.StabilityMargin", "Double", "rad to the stable region's boundary (> 0 inside)"),
        _v("Signals.Moving", "Boolean", "a commanded path is being executed"),
    ),
}

FEEDBACK_AND_RESULT: dict[str, tuple[VariableSpec, ...]] = {
    "throwing_arm": (
        _v("Command.Feedback.Throws", "UInt32", "throws so far in the executing goal"),
        _v("Command.Feedback.SensorAtRest", "Boolean", "the bit read at rest after the last throw"),
        _v("Command.Result.Throws", "UInt32", "throws the last goal used"),
        _v("Command.Result.SensorAtRest", "Boolean", "the last bit read with the part at rest"),
        _v(
            "Command.Result.Edge",
            "Int32",
            "ground-truth edge after the last throw (logging only; -1 unknown)",
        ),
    ),
    "mems_field_array": (
        _v("Command.Feedback.Time", "Double", "s of node clock since the program started"),
        _v("Command.Feedback.Settled", "Boolean", "per part: settled", True),
        _v(
            "Command.Feedback.EquilibriumDistance",
            "Double",
            "per part: rad to the nearest predicted equilibrium",
            True,
        ),
        _v("Command.Result.Settled", "Boolean", "every part settled"),
        _v("Command.Result.Equilibrium", "Int32", "per part: predicted equilibrium reached (-1 none)", True),
        _v("Command.Result.EquilibriumDistance", "Double", "per part: rad to that equilibrium", True),
    ),
    "assembly_fixture": (
        _v("Command.Feedback.Progress", "Double", "0..1 of the planned path's duration"),
        _v("Command.Feedback.Stable", "Boolean", "stable now"),
        _v("Command.Feedback.Margin", "Double", "rad, stability margin now"),
        _v("Command.Result.Tilt", "Double", "(tilt_x, tilt_y) where the fixture stopped, rad", True),
        _v(
            "Command.Result.FirstUnstableSample", "Int32", "REFUSED: first path sample not certified, else -1"
        ),
        _v("Command.Result.UnbalancedBodies", "String", "REFUSED: bodies that lose equilibrium there", True),
    ),
}

STOP = MethodSpec("Stop", "halt the device at once (~/stop): STOPPED; an executing goal ends")
RESET = MethodSpec("Reset", "clear faults and a stop (~/reset): back to IDLE")
ACTIONS: dict[str, MethodSpec] = {
    "throwing_arm": MethodSpec(
        "FeedPart",
        "start ~/feed_part: throw until the sensor presents the part, MaxThrows or Timeout",
        (
            ArgumentSpec("MaxThrows", "UInt32", "maximum throws, >= 1"),
            ArgumentSpec("Timeout", "Double", "s of the device's clock, >= 0 (0: no limit beyond MaxThrows)"),
        ),
    ),
    "mems_field_array": MethodSpec(
        "RunProgram",
        "start ~/run_program: run a field program until every part settled or Timeout",
        (
            ArgumentSpec(
                "Program",
                "String",
                "a program file name in the gateway's program_dir, or an inline YAML program "
                "starting with '{' (e.g. {steps: [{field: {type: radial, center: [0, 0]}}]})",
            ),
            ArgumentSpec("Timeout", "Double", "s of the device's clock, > 0"),
            ArgumentSpec(
                "Tolerance", "Double", "settled below this change (m and rad), >= 0 (0: device default)"
            ),
            ArgumentSpec(
                "Dwell", "Double", "s the change must stay below Tolerance, >= 0 (0: device default)"
            ),
        ),
    ),
    "assembly_fixture": MethodSpec(
        "FollowPath",
        "start ~/follow_path through waypoints: give TiltWaypoints or GravityWaypoints, the other empty",
        (
            ArgumentSpec("TiltWaypoints", "Double", "flattened (tilt_x, tilt_y) pairs, rad", True),
            ArgumentSpec("GravityWaypoints", "Double", "flattened (x, y, z) gravity directions", True),
        ),
    ),
}


def variables(kind: str) -> tuple[VariableSpec, ...]:
    """Return every variable of a device object of ``kind``, in browse order."""
    counters = tuple(_v(f"Status.Counters.{name}", "UInt64", f"counter {name}") for name in COUNTERS[kind])
    return (
        _v("Kind", "String", "device kind: throwing_arm, mems_field_array or assembly_fixture"),
        _v("NodeName", "String", "the device's fully qualified ROS node name"),
        *STATUS,
        *counters,
        *SIGNALS[kind],
        *COMMAND,
        *FEEDBACK_AND_RESULT[kind],
    )


def methods(kind: str) -> tuple[MethodSpec, ...]:
    """Return the methods of a device object of ``kind``."""
    return (ACTIONS[kind], STOP, RESET)


def variable_id(key: str, path: str) -> str:
    """Return the string NodeId identifier of a device's variable."""
    return f"{key}.{path}"


def method_id(key: str, name: str) -> str:
    """Return the string NodeId identifier of a device's method."""
    return f"{key}.{name}"
