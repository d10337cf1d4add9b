"""The asyncua side of the gateway: the server, its security, the address space, values and method calls.

ROS-free. It runs on an asyncio loop (the main thread of the node process). Two hand-offs cross threads:

- **Values in.** ``post`` may be called from any thread (the rclpy executor's): it keeps the newest value
  per variable under a lock and schedules one flush on the loop (``call_soon_threadsafe``), which writes
  every pending value with its source timestamp. A value equal to the last one written is not written
  again: its SourceTimestamp stays that of the sample that changed it, and no notification is sent.
- **Calls out.** A method call is a coroutine on the loop: the arguments are checked here (the device
  kind's check, ``kinds.KINDS[kind].action.check``, or only counted for Stop and Reset), then handed to a
  ``Handler`` (the ROS link), whose answer is a status code name and a message.

A Bad call returns its status code, the bad argument's own status in InputArgumentResults with the
message in that argument's InputArgumentDiagnosticInfos (AdditionalInfo), the message as the Message
output argument, and the message in the device's Command.LastMessage (a PLC that reads no diagnostics
reads that variable). The codes are those OPC 10000-4 gives each case (docs/cell.md: the status code
table): an argument of the wrong data type is Bad_InvalidArgument for the call with Bad_TypeMismatch for
the argument; a method called on an object it is not a component of, Bad_MethodInvalid; a write to any
of the gateway's variables (all read-only), Bad_NotWritable.
"""

from __future__ import annotations

import asyncio
import logging
import threading
from collections.abc import Awaitable, Callable, Mapping
from dataclasses import dataclass
from datetime import datetime, timezone
from importlib import metadata
from pathlib import Path
from typing import Protocol, cast

from asyncua import Node, Server, ua
from asyncua.crypto.permission_rules import User, UserRole
from asyncua.crypto.truststore import TrustStore
from asyncua.crypto.validator import CertificateValidator, CertificateValidatorOptions
from asyncua.server.internal_server import InternalServer
from asyncua.server.user_managers import UserManager

from feeder_cell.gateway import arguments, layout, roles, units
from feeder_cell.gateway.alarms import Alarms
from feeder_cell.gateway.config import PACKML_STATES, DeviceEntry, Endpoint, SecurityConfig
from feeder_cell.gateway.kinds import KINDS
from feeder_cell.gateway.logins import ATTEMPT, Attempt, LoginGuard, install, thumbprint
from feeder_cell.gateway.roles import GatewayUser, Role
from feeder_cell.gateway.spec import ArgumentSpec, CallContext, Goal, MethodSpec, Value
from feeder_cell.gateway.users import Users

__all__ = ["Handler", "GatewayServer", "GatewayUsers", "POLICY_TYPES", "PRODUCT_NAME", "product_version"]

PRODUCT_NAME = "feeder opcua_gateway"
PRODUCT_URI = "urn:feeder"
MANUFACTURER = "the feeder project"
PACKAGE = "feeder_cell"
# Argument-level codes of OPC 10000-4 (5.12.2.4, Call, inputArgumentResults): the call's own code is then
# Bad_InvalidArgument, and the argument's result carries the specific code.
_ARGUMENT_CODES = ("BadTypeMismatch", "BadOutOfRange")

POLICY_TYPES = {
    "None": ua.SecurityPolicyType.NoSecurity,
    "Basic256Sha256_Sign": ua.SecurityPolicyType.Basic256Sha256_Sign,
    "Basic256Sha256_SignAndEncrypt": ua.SecurityPolicyType.Basic256Sha256_SignAndEncrypt,
}

# Variables written by the gateway itself start Good; those mirrored from DDS start
# BadWaitingForInitialData until the device's first sample.
_OWN_PREFIXES = ("Kind", "NodeName", "Command.", "Status.Online", "Status.PackMLState")


class Handler(Protocol):
    """What executes a checked method call (the ROS link, ``ros_link.RosLink``)."""

    async def call(self, device: DeviceEntry, method: str, goal: Goal | None) -> tuple[str, str]:
        """Run ``method`` on ``device`` with a checked call (None: a PackML command); (status, message)."""
        ...


class GatewayUsers(UserManager):
    """Who may open a session: anonymous (when allowed) and the users file's names with their passwords.

    With ``secure_only`` (the server offers no None endpoint) a session on a channel without a client
    certificate is refused whoever asks: asyncua accepts a None channel whatever the policies (for
    GetEndpoints) and would create and activate sessions on it, unsigned and unencrypted. Each answer is
    recorded and logged by the ``LoginGuard``, which has usually checked the password already, off the
    loop (``logins.ATTEMPT``).
    """

    def __init__(
        self,
        users: Users | None,
        allow_anonymous: bool,
        secure_only: bool = False,
        anonymous_role: Role = Role.Engineer,
        guard: LoginGuard | None = None,
    ) -> None:
        self.users = users
        self.allow_anonymous = allow_anonymous
        self.secure_only = secure_only
        self.anonymous_role = anonymous_role
        self.guard = guard or LoginGuard(users, secure_only=secure_only)

    def get_user(
        self,
        iserver: InternalServer,
        username: str | None = None,
        password: str | None = None,
        certificate: object = None,
    ) -> User | None:
        """Return the session's user, or None (BadUserAccessDenied)."""
        seen = ATTEMPT.get()
        address = seen.address if seen is not None else "an unknown address"
        presented = thumbprint(certificate) if isinstance(certificate, bytes) else ""
        attempt = Attempt(address, presented or (seen.certificate if seen is not None else ""), username)
        if self.secure_only and not certificate:
            # A None channel: only a secured one carries the client's certificate.
            self.guard.refuse(attempt, "a channel without a client certificate (security None)")
            return None
        if username is None and password is None:
            if not self.allow_anonymous:
                self.guard.refuse(attempt, "anonymous sessions are not allowed")
                return None
            self.guard.accept_anonymous(attempt)
            return GatewayUser(role=UserRole.User, name="anonymous", access=self.anonymous_role)
        if self.users is None or not username:
            self.guard.refuse(attempt, "no user name, or no users file")
            return None
        ahead = seen is not None and seen.checked and seen.user == username and seen.password == password
        checking = Attempt(attempt.address, attempt.certificate, username, password)
        ok = seen.ok if ahead and seen is not None else self.guard.check_now(checking)
        if not self.guard.decide(attempt, ok):
            return None
        return GatewayUser(role=UserRole.User, name=username, access=self.users.role(username))


@dataclass
class _Pending:
    value: Value
    stamp_ns: int


def _stamp(ns: int) -> ua.DateTime:
    stamp = datetime.fromtimestamp(ns / 1e9, tz=timezone.utc) if ns > 0 else datetime.now(timezone.utc)
    return cast(ua.DateTime, stamp)


# asyncua annotates its constructors with its marker subclasses of the built-in types (ua.UInt32,
# ua.String, ua.Int16, ua.DateTime) yet takes the built-in values themselves: these casts say so to mypy
# and change nothing at run time.
def _node_id(identifier: str | int, namespace: int = 0) -> ua.NodeId:
    return ua.NodeId(cast("ua.String | ua.Int32", identifier), cast(ua.Int16, namespace))


def _status_code(code: int) -> ua.StatusCode:
    return ua.StatusCode(cast(ua.UInt32, code))


class GatewayServer:
    """The OPC UA server of the gateway: one object per device under Objects/Cell/Devices."""

    def __init__(
        self,
        endpoint: Endpoint,
        security: SecurityConfig,
        users: Users | None,
        devices: tuple[DeviceEntry, ...],
        handler: Handler,
        program_dir: str = "",
        logger: logging.Logger | None = None,
    ) -> None:
        self.endpoint, self.security, self.users = endpoint, security, users
        self.devices, self.handler, self.program_dir = devices, handler, program_dir
        self.context = CallContext(program_dir=program_dir)
        self.log = logger or logging.getLogger("opcua_gateway")
        self.server: Server | None = None
        self.logins: LoginGuard | None = None  # made with the server (start)
        self.idx = 0
        self._types: dict[str, ua.VariantType] = {}
        self._lock = threading.Lock()
        self._pending: dict[str, _Pending] = {}
        self._written: dict[str, Value] = {}
        self._scheduled = False
        self._loop: asyncio.AbstractEventLoop | None = None
        self._flushing: asyncio.Task[None] | None = None
        self._flush_lock = asyncio.Lock()
        self.alarms: Alarms | None = None
        self._alarm_lock = asyncio.Lock()
        # Every method a role restricts -> its least role (roles.required_role; Acknowledge: Operator).
        self.method_roles: dict[ua.NodeId, Role] = {}

    # --- start and stop --------------------------------------------------------------------------
    async def start(self) -> None:
        """Build the address space and listen on the endpoint (OSError when it cannot bind)."""
        self._loop = asyncio.get_running_loop()
        secure_only = "None" not in self.security.policies
        self.logins = LoginGuard(
            self.users,
            failures=self.security.login_failures,
            lockout=self.security.login_lockout,
            secure_only=secure_only,
            log=self.log,
        )
        users = GatewayUsers(
            self.users, self.security.allow_anonymous, secure_only, self.security.anonymous_role, self.logins
        )
        server = Server(user_manager=users)
        await server.init()
        install(server.iserver, self.logins)
        roles.enforce(server, lambda: self.idx, self.method_roles)
        server.set_endpoint(self.endpoint.url)
        server.set_server_name("feeder cell OPC UA gateway")
        await server.set_application_uri(layout.APPLICATION_URI)
        version, built = product_version()
        await server.set_build_info(PRODUCT_URI, MANUFACTURER, PRODUCT_NAME, version, version, built)
        _refuse_writes(server)
        _refuse_events_of_non_notifiers(server)
        server.set_security_policy([POLICY_TYPES[p] for p in self.security.policies])
        tokens: list[type] = []
        if self.security.allow_anonymous:
            tokens.append(ua.AnonymousIdentityToken)
        if self.users is not None:
            tokens.append(ua.UserNameIdentityToken)
        server.set_identity_tokens(tokens)
        if self.security.certificate_file:
            await server.load_certificate(self.security.certificate_file)
            await server.load_private_key(self.security.private_key_file)
        if self.security.trusted_certificates_dir:
            store = TrustStore([Path(self.security.trusted_certificates_dir)], [])
            await store.load()
            options = CertificateValidatorOptions.TRUSTED_VALIDATION | CertificateValidatorOptions.PEER_CLIENT
            server.set_certificate_validator(CertificateValidator(options, store))
        else:
            # No trust list: any issuer opens a channel, but a certificate is still checked for itself
            # (OPC 10000-4, 6.1.3): its validity period and that its URI is the client's ApplicationUri.
            options = CertificateValidatorOptions.BASIC_VALIDATION | CertificateValidatorOptions.PEER_CLIENT
            server.set_certificate_validator(CertificateValidator(options))
        self.idx = await server.register_namespace(layout.NAMESPACE_URI)
        await self._build(server)
        await server.start()
        self.server = server
        self._schedule()  # values posted before the server existed

    async def stop(self) -> None:
        """Stop listening and release the server."""
        if self.server is not None:
            server, self.server = self.server, None
            await server.stop()
        if self.logins is not None:
            self.logins.close()

    # --- address space ---------------------------------------------------------------------------
    def _id(self, identifier: str) -> ua.NodeId:
        return _node_id(identifier, self.idx)

    def _name(self, name: str) -> ua.QualifiedName:
        return ua.QualifiedName(name, self.idx)

    async def _build(self, server: Server) -> None:
        await self._packml_enumeration(server)
        cell = await server.nodes.objects.add_object(self._id(layout.CELL), self._name("Cell"))
        self.alarms = Alarms(server, self.idx, self.log, cell)
        await self.alarms.setup()
        folder = await cell.add_folder(self._id(layout.DEVICES_FOLDER), self._name("Devices"))
        for device in self.devices:
            await self._build_device(server, folder, device)
        for method in self.alarms.acknowledge_methods:
            self.method_roles[method] = Role.Operator

    async def _build_device(self, server: Server, folder: Node, device: DeviceEntry) -> None:
        key = device.key
        obj = await folder.add_object(self._id(key), self._name(key))
        await self._describe(obj, f"{device.kind} {device.node}")
        parents: dict[str, Node] = {"": obj}
        for spec in layout.variables(device.kind):
            *folders, name = spec.path.split(".")
            parent = await self._folder(parents, key, folders)
            vtype = ua.VariantType[spec.type]
            vid = layout.variable_id(key, spec.path)
            initial = [] if spec.array else _INITIAL.get(spec.path, _default(vtype))
            analog = ua.ObjectIds.BaseAnalogType if spec.unit else ua.ObjectIds.BaseDataVariableType
            node = await _add_variable(
                parent, self._id(vid), self._name(name), ua.Variant(initial, vtype), analog
            )
            if spec.array:
                await node.write_attribute(
                    ua.AttributeIds.ValueRank,
                    ua.DataValue(ua.Variant(ua.ValueRank.OneDimension, ua.VariantType.Int32)),
                )
            await self._describe(node, spec.description)
            if spec.unit:
                await self._engineering_units(node, vid, spec.unit)
            if spec.data_type:
                await node.write_attribute(
                    ua.AttributeIds.DataType,
                    ua.DataValue(ua.Variant(self._id(spec.data_type), ua.VariantType.NodeId)),
                )
            self._types[vid] = vtype
            if not spec.path.startswith(_OWN_PREFIXES):
                await server.write_attribute_value(
                    node.nodeid,
                    ua.DataValue(StatusCode=_status_code(ua.StatusCodes.BadWaitingForInitialData)),
                )
        if self.alarms is not None:
            await self.alarms.add_device(key, obj)
        self.post(key, "Kind", device.kind)
        self.post(key, "NodeName", device.node)
        for spec_m in layout.methods(device.kind):
            self.method_roles[self._id(layout.method_id(key, spec_m.name))] = roles.required_role(spec_m.name)
            await obj.add_method(
                self._id(layout.method_id(key, spec_m.name)),
                self._name(spec_m.name),
                self._method(device, spec_m),
                [_argument(a) for a in spec_m.inputs],
                [_argument(ArgumentSpec("Message", "String", "what the gateway or the device says"))],
            )

    async def _folder(self, parents: dict[str, Node], key: str, folders: list[str]) -> Node:
        path = ""
        for name in folders:
            child = f"{path}.{name}" if path else name
            if child not in parents:
                parents[child] = await parents[path].add_folder(self._id(f"{key}.{child}"), self._name(name))
            path = child
        return parents[path]

    async def _packml_enumeration(self, server: Server) -> None:
        """Add the enumeration DataTypes: PackML's, the device state's, each kind's outcomes."""
        await self._enumeration(
            server,
            layout.PACKML_STATE_TYPE,
            "PackML state: ISA-TR88.00.02 StateCurrent numbers; 100 Unconfigured",
            PACKML_STATES,
        )
        kinds = sorted({d.kind for d in self.devices})
        for name, fields in layout.enumerations(kinds).items():
            await self._enumeration(server, name, name.removesuffix("Enumeration"), fields)

    async def _enumeration(self, server: Server, name: str, text: str, fields: layout.Fields) -> None:
        """Add an Enumeration subtype with EnumValues (OPC 10000-3) named ``name``.

        PackML's numbers are not contiguous (Unconfigured is 100), so each carries EnumValues, not
        EnumStrings, and its DataTypeDefinition (an EnumDefinition) for clients that build types from it.
        """
        dtype = await server.nodes.enum_data_type.add_data_type(self._id(name), self._name(name))
        await self._describe(dtype, text)
        definition = ua.EnumDefinition()
        values = []
        for number, state, meaning in fields:
            definition.Fields.append(
                ua.EnumField(
                    Value=cast(ua.Int64, number),
                    DisplayName=ua.LocalizedText(state),
                    Description=ua.LocalizedText(meaning),
                    Name=cast(ua.String, state),
                )
            )
            values.append(
                ua.EnumValueType(
                    Value=cast(ua.Int64, number),
                    DisplayName=ua.LocalizedText(state),
                    Description=ua.LocalizedText(meaning),
                )
            )
        await dtype.write_data_type_definition(definition)
        prop = await dtype.add_property(
            self._id(f"{name}.EnumValues"),
            ua.QualifiedName("EnumValues", 0),
            ua.Variant(values, ua.VariantType.ExtensionObject),
            datatype=_node_id(ua.ObjectIds.EnumValueType),
        )
        await prop.write_attribute(
            ua.AttributeIds.ValueRank,
            ua.DataValue(ua.Variant(ua.ValueRank.OneDimension, ua.VariantType.Int32)),
        )

    async def _engineering_units(self, node: Node, vid: str, code: str) -> None:
        """Give a BaseAnalogType variable its EngineeringUnits property (OPC 10000-8, 5.3.2)."""
        unit = units.UNITS[code]
        info = ua.EUInformation(
            NamespaceUri=cast(ua.String, units.UNECE_NAMESPACE),
            UnitId=cast(ua.Int32, units.unit_id(code)),
            DisplayName=ua.LocalizedText(unit.symbol),
            Description=ua.LocalizedText(unit.name),
        )
        await node.add_property(
            self._id(f"{vid}.EngineeringUnits"),
            ua.QualifiedName("EngineeringUnits", 0),
            ua.Variant(info, ua.VariantType.ExtensionObject),
            datatype=_node_id(ua.ObjectIds.EUInformation),
        )

    @staticmethod
    async def _describe(node: Node, text: str) -> None:
        await node.write_attribute(
            ua.AttributeIds.Description,
            ua.DataValue(ua.Variant(ua.LocalizedText(text), ua.VariantType.LocalizedText)),
        )

    # --- values ----------------------------------------------------------------------------------
    def post(self, key: str, path: str, value: Value, stamp_ns: int = 0) -> None:
        """Set a device variable (any thread); written on the loop's next turn unless unchanged."""
        self.post_all(key, {path: value}, stamp_ns)

    def post_all(self, key: str, values: Mapping[str, Value], stamp_ns: int = 0) -> None:
        """Set several variables of a device together (any thread): one flush writes them all.

        They are pending together under one lock, so no flush writes some of them without the others,
        and the flush writes them without yielding to the loop between them: a subscription's next
        publish carries all of their changes (Command.Busy with the state that shows the goal, say).
        """
        with self._lock:
            for path, value in values.items():
                vid = layout.variable_id(key, path)
                if self._written.get(vid, _UNSET) == value and vid not in self._pending:
                    continue
                self._pending[vid] = _Pending(value, stamp_ns)
            if self._scheduled or self._loop is None or not self._pending:
                return
            self._scheduled = True
        self._loop.call_soon_threadsafe(self._start_flush)

    async def flush_now(self) -> None:
        """Write what is pending before the caller goes on (on the loop).

        A PackML command's transient state (Clearing) must be written before the device calls that end
        it: posted only, the device's answer (Stopped) could be pending with it and replace it unseen.
        """
        await self._flush()

    def _schedule(self) -> None:
        with self._lock:
            if self._scheduled or not self._pending:
                return
            self._scheduled = True
        self._start_flush()

    def _start_flush(self) -> None:
        self._flushing = asyncio.ensure_future(self._flush())

    async def _flush(self) -> None:
        # One flush at a time: a second one started while the first awaits its writes would otherwise
        # write a newer value before the first writes an older one of the same variable.
        async with self._flush_lock:
            with self._lock:
                self._scheduled = False
                if self.server is None:
                    return  # not listening yet: start() flushes what is pending
                pending, self._pending = self._pending, {}
                for vid, item in pending.items():
                    self._written[vid] = item.value
                changes = self._alarm_changes(pending)
            now = cast(ua.DateTime, datetime.now(timezone.utc))
            for vid, item in pending.items():
                dv = ua.DataValue(
                    ua.Variant(item.value, self._types[vid]),
                    StatusCode=_status_code(ua.StatusCodes.Good),
                    SourceTimestamp=_stamp(item.stamp_ns),
                    ServerTimestamp=now,
                )
                await self.server.write_attribute_value(self._id(vid), dv)
            # The alarms follow the values, in flush order, but outside the flush lock: the next values
            # are not held up by the events.
            await self._alarm_lock.acquire()
        try:
            await self._update_alarms(changes)
        finally:
            self._alarm_lock.release()

    def _alarm_changes(self, pending: Mapping[str, _Pending]) -> list[tuple[str, str, int, str]]:
        """Return (key, condition, code, text) of each device whose fault or warning changed."""
        changes = []
        for device in self.devices:
            for name in ("Fault", "Warning"):
                code_vid = layout.variable_id(device.key, f"Status.{name}Code")
                text_vid = layout.variable_id(device.key, f"Status.{name}Text")
                if code_vid not in pending and text_vid not in pending:
                    continue
                code = cast(int, self._written.get(code_vid, 0))
                text = str(self._written.get(text_vid, ""))
                changes.append((device.key, name, int(code), text))
        return changes

    async def _update_alarms(self, changes: list[tuple[str, str, int, str]]) -> None:
        """Raise or clear the devices' Fault and Warning conditions (alarms.py)."""
        if self.alarms is None:
            return
        for key, name, code, text in changes:
            try:
                await self.alarms.update(key, name, code, text)
            except Exception:  # noqa: BLE001 - an alarm's failure must not stop the values
                self.log.exception("%s: the %s alarm failed", key, name)

    def read(self, key: str, path: str) -> Value | None:
        """Return the last value set of a variable (for the handler's own bookkeeping)."""
        vid = layout.variable_id(key, path)
        with self._lock:
            if vid in self._pending:
                return self._pending[vid].value
            return self._written.get(vid)

    # --- methods ---------------------------------------------------------------------------------
    def _method(self, device: DeviceEntry, spec: MethodSpec) -> Callable[..., Awaitable[ua.CallMethodResult]]:
        own = self._id(device.key)

        async def call(parent: ua.NodeId, *variants: ua.Variant) -> ua.CallMethodResult:
            count = len(variants)
            if parent != own:
                # OPC 10000-4 5.12.2.4: the method is not a component of the object it was called on.
                return self._result(
                    device,
                    spec,
                    count,
                    "BadMethodInvalid",
                    f"{spec.name} of {device.key} is not a method of {parent.to_string()}; "
                    f"call it on {own.to_string()}",
                    -1,
                    post=False,
                )
            role, user = roles.caller_role()
            needed = roles.required_role(spec.name)
            if role < needed:
                # Not posted: a session without the right must not write the device's command channel.
                message = f"{spec.name} refused: user {user} is {role.name}; it needs {needed.name} or above"
                return self._result(device, spec, count, "BadUserAccessDenied", message, -1, post=False)
            try:
                goal = self._check(device, spec, [_from_variant(v) for v in variants])
            except arguments.ArgumentError as error:
                return self._result(device, spec, count, error.status, error.message, error.index)
            try:
                status, message = await self.handler.call(device, spec.name, goal)
            except Exception as error:  # noqa: BLE001 - a PLC gets a Bad code, the gateway keeps serving
                self.log.exception("%s.%s failed", device.key, spec.name)
                status, message = (
                    "BadInternalError",
                    f"{spec.name}: gateway error {type(error).__name__}: {error}",
                )
            return self._result(device, spec, count, status, message, -1)

        return call

    def _check(self, device: DeviceEntry, spec: MethodSpec, args: list[arguments.Argument]) -> Goal | None:
        action = KINDS[device.kind].action
        if spec.name == action.method.name:
            return action.check(spec, args, self.context)
        link = layout.service(device.kind, spec.name)
        if link is not None:
            return link.check(spec, args, self.context)
        arguments.check_count(spec, args)  # the PackML commands: no arguments, no goal
        return None

    def _result(
        self,
        device: DeviceEntry,
        spec: MethodSpec,
        count: int,
        status: str,
        message: str,
        index: int,
        post: bool = True,
    ) -> ua.CallMethodResult:
        # An argument-level code (Bad_TypeMismatch) goes into the argument's result; the call's is then
        # Bad_InvalidArgument (OPC 10000-4 5.12.2.4).
        argument_status = status
        if status in _ARGUMENT_CODES and 0 <= index < count:
            status = "BadInvalidArgument"
        if post:  # not for a call on another object: that device's command channel was not addressed
            self.post_all(device.key, {"Command.LastStatus": status, "Command.LastMessage": message})
        code = _status_code(getattr(ua.StatusCodes, status, ua.StatusCodes.BadInternalError))
        result = ua.CallMethodResult()
        result.StatusCode = code
        result.OutputArguments = [ua.Variant(message, ua.VariantType.String)]
        result.InputArgumentResults = [_status_code(ua.StatusCodes.Good) for _ in range(count)]
        if code.is_bad():
            self.log.warning("%s.%s: %s: %s", device.key, spec.name, argument_status, message)
            result.InputArgumentDiagnosticInfos = [ua.DiagnosticInfo() for _ in range(count)]
            targets = [index] if 0 <= index < count else list(range(count))
            for i in targets:
                if index >= 0:
                    result.InputArgumentResults[i] = _status_code(
                        getattr(ua.StatusCodes, argument_status, ua.StatusCodes.BadInternalError)
                    )
                result.InputArgumentDiagnosticInfos[i] = ua.DiagnosticInfo(
                    AdditionalInfo=cast(ua.String, message)
                )
        return result


_UNSET = object()
_ADMIN = User(role=UserRole.Admin)  # asyncua's default for a write without a session (the server's own)
# Initial values other than the type's zero: no status heard yet is PackML Undefined (code 0).
_INITIAL: dict[str, Value] = {"Status.PackMLState": "Undefined"}


def _default(vtype: ua.VariantType) -> Value:
    if vtype == ua.VariantType.Boolean:
        return False
    if vtype == ua.VariantType.String:
        return ""
    if vtype in (ua.VariantType.Double, ua.VariantType.Float):
        return 0.0
    return 0


def _refuse_writes(server: Server) -> None:
    """Answer a write to a node whose AccessLevel (or WriteMask) forbids it with Bad_NotWritable.

    asyncua answers Bad_UserAccessDenied for both; OPC 10000-4 (5.11.4.4, Write) keeps that for a
    node the user may not write although the node itself is writable. Every gateway variable is
    read-only (AccessLevel CurrentRead, WriteMask 0), so every client write is Bad_NotWritable.
    """
    service = server.iserver.attribute_service
    write = service.write
    aspace = server.iserver.aspace

    def writable(item: ua.WriteValue) -> bool:
        if item.AttributeId != ua.AttributeIds.Value:
            mask = aspace.read_attribute_value(item.NodeId, ua.AttributeIds.WriteMask)
            return bool(
                mask.StatusCode is not None and mask.StatusCode.is_good() and mask.Value and mask.Value.Value
            )
        level = aspace.read_attribute_value(item.NodeId, ua.AttributeIds.AccessLevel)
        if level.StatusCode is None or not level.StatusCode.is_good() or level.Value is None:
            return True  # an unknown node: asyncua's own answer (Bad_NodeIdUnknown)
        return bool(int(level.Value.Value) & (1 << ua.AccessLevel.CurrentWrite))

    async def refuse_read_only(params: ua.WriteParameters, user: User = _ADMIN) -> list[ua.StatusCode]:
        codes = await write(params, user)
        for i, item in enumerate(params.NodesToWrite):
            denied = codes[i].value == ua.StatusCodes.BadUserAccessDenied
            if denied and item.NodeId in aspace and not writable(item):
                codes[i] = _status_code(ua.StatusCodes.BadNotWritable)
        return codes

    service.write = refuse_read_only  # type: ignore[method-assign]


def _refuse_events_of_non_notifiers(server: Server) -> None:
    """Answer an event item on a node that is no event notifier with Bad_NotSupported.

    asyncua answers Bad_ServiceUnsupported, which OPC 10000-4 does not list among CreateMonitoredItems'
    operation results (it is a service-level code: the whole service is not supported); the OPC
    Foundation's reference server answers Bad_NotSupported there.
    """
    service = server.iserver.subscription_service
    create = service.create_monitored_items
    unsupported = ua.StatusCodes.BadServiceUnsupported

    async def create_monitored_items(
        params: ua.CreateMonitoredItemsParameters,
    ) -> list[ua.MonitoredItemCreateResult]:
        results = await create(params)
        for item, result in zip(params.ItemsToCreate, results, strict=False):
            events = item.ItemToMonitor.AttributeId == ua.AttributeIds.EventNotifier
            if events and result.StatusCode.value == unsupported:
                result.StatusCode = _status_code(ua.StatusCodes.BadNotSupported)
        return results

    service.create_monitored_items = create_monitored_items  # type: ignore[method-assign]


async def _add_variable(
    parent: Node, nodeid: ua.NodeId, name: ua.QualifiedName, value: ua.Variant, type_definition: int
) -> Node:
    """Add a read-only variable of the given VariableType, a HasComponent of ``parent``.

    asyncua's ``add_variable`` makes a BaseDataVariableType; swapping the node's HasTypeDefinition
    afterwards leaves the parent's reference (what Browse returns as TypeDefinition) stale, so the type is
    the AddNodes request's own.
    """
    item = ua.AddNodesItem()
    item.RequestedNewNodeId, item.BrowseName = nodeid, name
    item.NodeClass = ua.NodeClass.Variable
    item.ParentNodeId = parent.nodeid
    item.ReferenceTypeId = _node_id(ua.ObjectIds.HasComponent)
    item.TypeDefinition = _node_id(type_definition)
    attrs = ua.VariableAttributes()
    attrs.DisplayName = attrs.Description = ua.LocalizedText(name.Name)
    attrs.DataType = _node_id(value.VariantType.value)
    attrs.Value = value
    array = isinstance(value.Value, list)
    attrs.ValueRank = ua.ValueRank.OneDimension if array else ua.ValueRank.Scalar
    attrs.WriteMask = attrs.UserWriteMask = cast(ua.UInt32, 0)
    attrs.AccessLevel = attrs.UserAccessLevel = cast(ua.Byte, ua.AccessLevel.CurrentRead.mask)
    attrs.Historizing = False
    item.NodeAttributes = attrs
    result = (await parent.session.add_nodes([item]))[0]
    result.StatusCode.check()
    return Node(parent.session, result.AddedNodeId)


def _argument(spec: ArgumentSpec) -> ua.Argument:
    arg = ua.Argument()
    arg.Name = spec.name
    arg.DataType = _node_id(ua.VariantType[spec.type].value)
    arg.ValueRank = ua.ValueRank.OneDimension if spec.array else ua.ValueRank.Scalar
    arg.ArrayDimensions = [0] if spec.array else []
    arg.Description = ua.LocalizedText(spec.description)
    return arg


def _from_variant(variant: object) -> arguments.Argument:
    if not isinstance(variant, ua.Variant):  # a client library that passed a bare value
        variant = ua.Variant(variant)
    value = variant.Value
    return arguments.Argument(
        value, variant.VariantType.name, isinstance(value, list) or bool(variant.is_array)
    )


def product_version() -> tuple[str, datetime]:
    """Return the gateway's package version and build date (the installed package metadata's time)."""
    try:
        distribution = metadata.distribution(PACKAGE)
    except metadata.PackageNotFoundError:
        return "unknown", datetime.fromtimestamp(Path(__file__).stat().st_mtime, tz=timezone.utc)
    files = [f for f in distribution.files or () if f.name in ("METADATA", "PKG-INFO")]
    located = Path(str(distribution.locate_file(files[0]))) if files else Path(__file__)
    stamp = located.stat().st_mtime if located.exists() else Path(__file__).stat().st_mtime
    return str(distribution.version), datetime.fromtimestamp(stamp, tz=timezone.utc)
