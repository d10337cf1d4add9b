"""OPC UA alarms of the gateway (OPC 10000-9, Alarms and Conditions): a device's fault and its warning.

Every device object carries two conditions, instances of AlarmConditionType (their mandatory children)
and components of the device object, their ConditionIds ``<key>.Fault`` and ``<key>.Warning``:

- **Fault** (Severity ``FAULT_SEVERITY``): active while ``Status/FaultCode`` is not 0 (the device in FAULT,
  STOPPED or UNCONFIGURED with a code).
- **Warning** (Severity ``WARNING_SEVERITY``): active while ``Status/WarningCode`` is not 0 (a code the
  device reports while it stays operational).

Each change is one event of the condition, emitted by the device object, by the Cell object (the area)
and by the Server object (all three have EventNotifier SubscribeToEvents; HasNotifier Server -> Cell ->
device), with one EventId: raised (ActiveState true, AckedState false,
Retain true; a new code while active is raised again, unacknowledged), cleared (ActiveState false;
Retain stays true until it is acknowledged) and acknowledged (AckedState true; Retain false once
inactive). Acknowledge is the AcknowledgeableConditionType's method, called on the ConditionId with the
EventId of the condition's latest event. ConditionRefresh (asyncua's) re-sends the retained conditions
to a subscription on the Server object. Not supported: Enable/Disable (Bad_NotSupported, conditions
are always enabled), AddComment, Confirm, shelving, branches.
"""

from __future__ import annotations

import copy
import logging
import uuid
from dataclasses import dataclass, field
from datetime import datetime, timezone
from typing import Any, cast

from asyncua import Node, Server, ua
from asyncua.common.event_objects import AlarmCondition

from feeder_cell.gateway.roles import Role, caller_role

__all__ = ["FAULT_SEVERITY", "WARNING_SEVERITY", "KINDS", "Alarms", "condition_id"]

# OPC 10000-5 BaseEventType Severity: 1..1000, 1000 the most urgent. OPC 40083's classes: 667-1000 high
# urgency (error), 334-666 medium (warning), 1-333 low (information).
FAULT_SEVERITY = 900
WARNING_SEVERITY = 500
KINDS = {"Fault": FAULT_SEVERITY, "Warning": WARNING_SEVERITY}

_ACTIVE = ("Active", "Inactive")
_ACKED = ("Acknowledged", "Unacknowledged")
_ENABLED = ("Enabled", "Disabled")
# The event fields the condition's variables in the address space mirror.
_MIRRORED = (
    "EventId",
    "Time",
    "Message",
    "Severity",
    "LastSeverity",
    "Retain",
    "Comment",
    "EnabledState",
    "EnabledState/Id",
    "ActiveState",
    "ActiveState/Id",
    "AckedState",
    "AckedState/Id",
)


def condition_id(key: str, name: str) -> str:
    """Return the string NodeId identifier of a device's condition (``Fault`` or ``Warning``)."""
    return f"{key}.{name}"


def _now() -> datetime:
    return datetime.now(timezone.utc)


def _text(text: str) -> ua.LocalizedText:
    return ua.LocalizedText(text)


def _bytes(value: bytes) -> ua.ByteString:
    return cast(ua.ByteString, value)


def _nid(identifier: int) -> ua.NodeId:
    return ua.NodeId(cast(ua.Int32, identifier))


def _sc(code: int) -> ua.StatusCode:
    return ua.StatusCode(cast(ua.UInt32, code))


@dataclass
class _Condition:
    """One condition's state (one branch, the current one) and the event it emits."""

    name: str
    severity: int
    source: ua.NodeId
    source_name: str
    node: Node
    event: Any  # an AlarmCondition: asyncua adds its fields at run time
    code: int = 0
    text: str = ""
    active: bool = False
    acked: bool = True
    last_time: datetime = datetime.min.replace(tzinfo=timezone.utc)  # Time of its last event
    event_ids: set[bytes] = field(default_factory=set)
    children: dict[str, Node] = field(default_factory=dict)
    variables: dict[str, ua.NodeId] = field(default_factory=dict)

    @property
    def retain(self) -> bool:
        return self.active or not self.acked


class Alarms:
    """The gateway's conditions: built with the address space, updated on the server's loop."""

    def __init__(self, server: Server, idx: int, log: logging.Logger, area: Node) -> None:
        self.server, self.idx, self.log = server, idx, log
        self.area = area  # the Cell object: an HMI subscribes to the area for all of its devices' alarms
        self._conditions: dict[ua.NodeId, _Condition] = {}
        # The Acknowledge methods (the type's and each condition's own): an Operator's (roles.py).
        self.acknowledge_methods: list[ua.NodeId] = [
            _nid(ua.ObjectIds.AcknowledgeableConditionType_Acknowledge)
        ]
        self._by_key: dict[tuple[str, str], _Condition] = {}

    def _id(self, identifier: str) -> ua.NodeId:
        return ua.NodeId(cast(ua.String, identifier), cast(ua.Int16, self.idx))

    async def setup(self) -> None:
        """Make Server and the area notifiers and link the Acknowledge (and Enable, Disable) methods."""
        await self.server.nodes.server.set_event_notifier([ua.EventNotifier.SubscribeToEvents])
        await self.area.set_event_notifier([ua.EventNotifier.SubscribeToEvents])
        await self.server.nodes.server.add_reference(
            self.area.nodeid, _nid(ua.ObjectIds.HasNotifier), forward=True, bidirectional=True
        )
        # asyncua's ConditionRefresh (and its RefreshStart/RefreshEnd events, Severity 1) is off by default.
        iserver = self.server.iserver
        iserver.bind_condition_methods = 1
        await iserver.setup_condition_methods()
        for method, name in (
            (ua.ObjectIds.AcknowledgeableConditionType_Acknowledge, "Acknowledge"),
            (ua.ObjectIds.ConditionType_Enable, "Enable"),
            (ua.ObjectIds.ConditionType_Disable, "Disable"),
            (ua.ObjectIds.ConditionType_AddComment, "AddComment"),
        ):
            self.server.link_method(self.server.get_node(_nid(method)), self._methods()[name])

    def _methods(self) -> dict[str, Any]:
        return {
            "Acknowledge": self._acknowledge,
            "Enable": self._not_supported,
            "Disable": self._not_supported,
            "AddComment": self._not_supported,
        }

    async def add_device(self, key: str, device: Node) -> None:
        """Add the device's Fault and Warning conditions and make the device object an event notifier."""
        await device.set_event_notifier([ua.EventNotifier.SubscribeToEvents])
        # The notifier hierarchy (OPC 10000-3, HasNotifier): Server -> Cell -> each device.
        await self.area.add_reference(
            device.nodeid, _nid(ua.ObjectIds.HasNotifier), forward=True, bidirectional=True
        )
        for name, severity in KINDS.items():
            cid = self._id(condition_id(key, name))
            alarm_type = ua.ObjectIds.AlarmConditionType
            qname = ua.QualifiedName(name, self.idx)
            node = await device.add_object(cid, qname, alarm_type, instantiate_optional=False)
            has_condition = _nid(ua.ObjectIds.HasCondition)
            await device.add_reference(cid, has_condition, forward=True, bidirectional=False)
            event = AlarmCondition(sourcenode=device.nodeid, severity=severity)
            event.add_property("NodeId", cid, ua.VariantType.NodeId)  # the ConditionId (asyncua's field name)
            for field_name, data_type in list(event.data_types.items()):
                # asyncua types these fields by their DataType's NodeId, which a Variant cannot take.
                if data_type == _nid(ua.ObjectIds.UtcTime):
                    event.data_types[field_name] = ua.VariantType.DateTime
                elif data_type == _nid(ua.ObjectIds.Duration):
                    event.data_types[field_name] = ua.VariantType.Double
            condition = _Condition(name, severity, device.nodeid, key, node, event)
            methods = self._methods()
            for child in await node.get_children():
                child_name = (await child.read_browse_name()).Name
                condition.children[child_name] = child
                if child_name in methods and await child.read_node_class() == ua.NodeClass.Method:
                    self.server.link_method(child, methods[child_name])  # the instance's own copy
                    if child_name == "Acknowledge":
                        self.acknowledge_methods.append(child.nodeid)
            await self._resolve(condition)
            self._conditions[cid] = condition
            self._by_key[(key, name)] = condition
            self._fill(condition, _now(), f"{name}: none")
            await self._write_variables(condition)

    async def update(self, key: str, name: str, code: int, text: str) -> None:
        """Raise, re-raise or clear a condition from the device's code (0: none) and text."""
        condition = self._by_key.get((key, name))
        if condition is None:
            return
        if code:
            if condition.active and code == condition.code and text == condition.text:
                return
            condition.active, condition.acked = True, False
            condition.code, condition.text = code, text
            message = f"{name} {code}: {text}" if text else f"{name} {code}"
        else:
            if not condition.active:
                return
            condition.active = False
            message = f"{name} {condition.code} cleared" + (f": {condition.text}" if condition.text else "")
            condition.code, condition.text = 0, ""
        await self._emit(condition, message)

    def _fill(self, c: _Condition, stamp: datetime, message: str) -> None:
        e = c.event
        e.SourceNode, e.SourceName = c.source, c.source_name
        e.ConditionName, e.ConditionClassId = c.name, _nid(ua.ObjectIds.BaseConditionClassType)
        e.ConditionClassName = _text("BaseConditionClass")
        e.BranchId = ua.NodeId()
        e.Severity, e.LastSeverity = c.severity, c.severity
        e.Message, e.Time, e.ReceiveTime = _text(message), stamp, _now()
        e.Retain = c.retain
        e.Quality = _sc(ua.StatusCodes.Good)
        states = {  # two-state variables and their Id properties: asyncua names the fields by browse path
            "EnabledState": _text(_ENABLED[0]),
            "EnabledState/Id": True,
            "ActiveState": _text(_ACTIVE[0] if c.active else _ACTIVE[1]),
            "ActiveState/Id": c.active,
            "ActiveState/TransitionTime": stamp,
            "AckedState": _text(_ACKED[0] if c.acked else _ACKED[1]),
            "AckedState/Id": c.acked,
            "SuppressedOrShelved": False,
        }
        for name, value in states.items():
            setattr(e, name, value)
        e.InputNode = ua.NodeId()

    async def _emit(self, c: _Condition, message: str) -> None:
        # One clock for every event of a condition, the gateway's wall clock: the device's stamp (its
        # cell clock, ahead of the wall at a factor above 1) has no counterpart for an acknowledge, and
        # mixing the two put an acknowledge before its raise. The device's stamp is the SourceTimestamp of
        # Status/FaultCode (WarningCode). Never behind the condition's last event, should the wall step.
        stamp = max(_now(), c.last_time)
        c.last_time = stamp
        self._fill(c, stamp, message)
        event_id = uuid.uuid4().hex.encode()
        c.event.EventId = _bytes(event_id)
        c.event_ids = {event_id}
        service = self.server.iserver.isession.subscription_service
        # One event, notified by the device object, by its area (Cell) and by the Server object (the last
        # copy is the one asyncua keeps for ConditionRefresh).
        for emitter in (c.source, self.area.nodeid, _nid(ua.ObjectIds.Server)):
            event = copy.copy(c.event)
            event.emitting_node = emitter
            await service.trigger_event(event)
        await self._write_variables(c)

    async def _write_variables(self, c: _Condition) -> None:
        """Mirror the event's fields in the condition's variables (its instance in the address space)."""
        for name, nodeid in c.variables.items():
            value = getattr(c.event, name, None)
            if value is not None:
                variant = ua.Variant(value, c.event.data_types[name])
                await self.server.write_attribute_value(nodeid, ua.DataValue(variant))

    @staticmethod
    async def _resolve(c: _Condition) -> None:
        """Find the condition's variables that mirror its state (once: a browse per write would cost)."""
        for name in _MIRRORED:
            *path, last = name.split("/")
            node = c.children.get(path[0] if path else last)
            try:
                if node is not None and path:
                    node = await node.get_child(ua.QualifiedName(last, 0))
            except ua.UaError:
                node = None
            if node is not None:
                c.variables[name] = node.nodeid

    # --- methods ---------------------------------------------------------------------------------
    async def _acknowledge(self, parent: ua.NodeId, *args: Any) -> ua.CallMethodResult:
        result = ua.CallMethodResult()
        result.InputArgumentResults = [ua.StatusCode() for _ in args]
        role, user = caller_role()
        if role < Role.Operator:
            self.log.warning("Acknowledge of %s refused: user %s is %s", parent.to_string(), user, role.name)
            result.StatusCode = _sc(ua.StatusCodes.BadUserAccessDenied)
            return result
        code = self._check_acknowledge(parent, args)
        result.StatusCode = _sc(code)
        condition = self._conditions.get(parent)
        if code == ua.StatusCodes.Good and condition is not None:
            comment = args[1].Value if isinstance(args[1], ua.Variant) else args[1]
            if isinstance(comment, ua.LocalizedText) and comment.Text:
                condition.event.Comment = comment
            state = "active" if condition.active else "inactive"
            await self._emit(condition, f"{condition.name} acknowledged ({state})")
        return result

    def _check_acknowledge(self, parent: ua.NodeId, args: tuple[Any, ...]) -> int:
        if len(args) < 2:
            return ua.StatusCodes.BadArgumentsMissing
        if len(args) > 2:
            return ua.StatusCodes.BadTooManyArguments
        condition = self._conditions.get(parent)
        if condition is None:
            return ua.StatusCodes.BadNodeIdInvalid
        event_id = args[0].Value if isinstance(args[0], ua.Variant) else args[0]
        if event_id not in condition.event_ids:
            return ua.StatusCodes.BadEventIdUnknown
        if condition.acked:
            return ua.StatusCodes.BadConditionBranchAlreadyAcked
        condition.acked = True
        return ua.StatusCodes.Good

    @staticmethod
    async def _not_supported(parent: ua.NodeId, *args: Any) -> ua.StatusCode:
        return _sc(ua.StatusCodes.BadNotSupported)
