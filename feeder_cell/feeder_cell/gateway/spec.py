"""The types a device kind's gateway profile is written in: variables, methods, arguments, ROS links.

The bottom of the gateway's imports: nothing here imports the rest of the gateway, so the profiles
(``kinds``), the address space (``layout``), the argument checks (``arguments``), the server and the ROS
link all read these types without a cycle. Neither asyncua nor rclpy is imported: ROS message classes and
messages are plain objects here, typed ``Any`` because the generated message modules carry no types.

A ``KindProfile`` is everything the gateway knows of one device kind:

- ``counters``: the device's own counter declaration (``feeder_sim.<model>.counters.COUNTERS``), one
  ``Status/Counters/<name>`` variable each, described by the declaration;
- ``signals`` and ``streams``: the ``Signals/...`` variables and the device topics that set them;
- ``action``: the long action behind the kind's method (its OPC UA method and arguments, the argument
  check, the ROS action, and the ``Command/Feedback/...`` and ``Command/Result/...`` variables it sets);
- ``services``: the kind's short commands, each one device service call (the arm's ``PlacePart``).

The commands every kind has (PackML's, fault injection) are ``commands.COMMANDS``, in the same types.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol, TypeAlias

from feeder_device.declarations import CounterSpec
from feeder_msgs.msg import DeviceStatus

__all__ = [
    "Value",
    "Values",
    "VariableSpec",
    "ArgumentSpec",
    "MethodSpec",
    "Argument",
    "CallContext",
    "Goal",
    "Check",
    "Convert",
    "StreamLink",
    "ActionLink",
    "Availability",
    "ServiceLink",
    "KindProfile",
]

# A variable's value as the gateway posts it: one of the OPC UA built-in types it uses, or an array of one.
Value: TypeAlias = bool | int | float | str | list[bool] | list[int] | list[float] | list[str]
# Variable path -> value, in the order they are posted (a message's values in its fields' order).
Values: TypeAlias = dict[str, Value]


@dataclass(frozen=True)
class VariableSpec:
    """A read-only variable of a device object: path under the object, OPC UA built-in type, meaning."""

    path: str  # e.g. Status.FaultCode
    type: str  # asyncua VariantType name: Boolean, Byte, Int32, UInt32, UInt64, Double, String
    description: str
    array: bool = False
    # A physical quantity's unit, as its UN/CEFACT common code (units.UNITS: C81 radian, MTR metre, SEC
    # second, HTZ hertz, C62 one): the variable's EngineeringUnits property. Empty: not a physical quantity.
    unit: str = ""
    # The name of a DataType of the gateway's namespace the variable's DataType attribute names (an
    # enumeration: the values are Int32). Empty: the built-in type's own DataType.
    data_type: str = ""


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


@dataclass(frozen=True)
class Argument:
    """One input argument as the client sent it: the value (a list for an array) and its built-in type."""

    value: object  # whatever the client's variant held: checked by the kind's argument check
    type: str  # VariantType name, e.g. Double, UInt32, String; "Null" for an empty variant
    array: bool = False


@dataclass(frozen=True)
class CallContext:
    """What an argument check may need of the gateway's configuration.

    One object, so that a new need is a field here, not a new parameter of every check.
    """

    program_dir: str = ""  # where RunProgram's program file names are looked up


class Goal(Protocol):
    """A checked method call: the kind's own dataclass, which builds its ROS message.

    For an action method the action's Goal, for a service method (``ServiceLink``) the service's Request.
    """

    def message(self) -> Any:
        """Return the ROS message (untyped: a generated message class)."""
        ...


# The kind's argument check: the method, the client's arguments, the gateway's context -> a checked goal;
# it raises arguments.ArgumentError naming the argument.
Check: TypeAlias = Callable[[MethodSpec, list[Argument], CallContext], Goal]
# A ROS message (untyped) -> the variables it sets.
Convert: TypeAlias = Callable[[Any], Values]


@dataclass(frozen=True)
class StreamLink:
    """A device topic mirrored into ``Signals/...`` variables."""

    topic: str  # under the device's node: sensor is /cell/throwing_arm/sensor
    message_type: Any  # the ROS message class
    values: Convert
    # The message has a header, whose stamp is the variables' SourceTimestamp; False: no header, so the
    # DDS source timestamp (or the gateway's clock under use_sim_time) stamps it.
    stamped: bool = True


@dataclass(frozen=True)
class ActionLink:
    """The long action behind a kind's method: the OPC UA side and the ROS side of one goal."""

    method: MethodSpec  # the OPC UA method and its input arguments
    check: Check
    action_type: Any  # the ROS action class (feeder_msgs.action.*)
    action_name: str  # under the device's node: feed_part is /cell/throwing_arm/feed_part
    feedback: tuple[VariableSpec, ...]  # Command.Feedback.* variables
    result: tuple[VariableSpec, ...]  # Command.Result.* variables of this kind (FaultCode is every kind's)
    feedback_values: Convert  # the action's Feedback message -> the feedback variables
    result_values: Convert  # the action's Result message -> the result variables
    # The action's Result -> the feedback variables it settles, for a kind whose Result states the goal's
    # final progress (the arm's throws): posted with the result, so Feedback/... and Result/... agree once
    # ResultCount moves. The device sends its last feedback before the result, but the feedback topic and
    # the result service are two DDS writers in no order (ci35: Feedback/Throws 10 beside Result/Throws
    # 11). None: the Result does not state it, and a last feedback that comes after the result is posted.
    final_feedback: Convert | None = None


@dataclass(frozen=True)
class Availability:
    """When a device runs a service: what decides whether its refusal is the device's state or the request's.

    A refusal while the device's latest ~/status is outside these (its ``state``, its ``fault_code`` in
    FAULT) or, with ``goal_blocks``, while a goal of its action executes, is Bad_InvalidState; inside them
    the request's contents were refused, Bad_InvalidArgument. Typed, because the device's message text is
    for people: matching its words misread "a ~/feed_part goal is executing" as a bad argument.
    """

    states: frozenset[int] = frozenset({DeviceStatus.IDLE, DeviceStatus.RUNNING})  # the device's ``ready``
    fault_codes: frozenset[int] = frozenset()  # in FAULT with one of these codes it still runs
    goal_blocks: bool = True  # refused while a goal of the kind's action executes (any client's)

    def refuses(self, state: int | None, fault_code: int, goal_active: bool) -> bool:
        """Return whether a device in this state refuses the service whatever the request."""
        if state is None:
            return True
        runs = state in self.states or (state == DeviceStatus.FAULT and fault_code in self.fault_codes)
        return not runs or (self.goal_blocks and goal_active)


@dataclass(frozen=True)
class ServiceLink:
    """A method that is one call of a device service, answered when the device answers.

    The response is read by the project's two conventions: ``ok``/``error`` (feeder_msgs services) or
    ``success``/``message`` (std_srvs/Trigger). ``check`` returns a call whose ``message()`` is the request.
    """

    method: MethodSpec
    check: Check
    service_type: Any  # the ROS service class
    service_name: str  # under the device's node: place_part is /cell/throwing_arm/place_part
    availability: Availability = Availability()


@dataclass(frozen=True)
class KindProfile:
    """Everything the gateway knows of one device kind; ``kinds.KINDS`` maps the kind's name to it."""

    counters: tuple[CounterSpec, ...]  # the device's own declaration, in its order
    signals: tuple[VariableSpec, ...]  # Signals.* variables, in browse order
    streams: tuple[StreamLink, ...]  # the topics that set them
    action: ActionLink
    services: tuple[ServiceLink, ...] = ()

    @property
    def counter_names(self) -> tuple[str, ...]:
        """The names of the counters this kind shows as variables of their own."""
        return tuple(counter.name for counter in self.counters)
