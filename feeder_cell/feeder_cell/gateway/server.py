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

This module starts and stops the server and wires its parts, each a module of its own:
``session_users`` (who may open a session), ``server_security`` (policies, tokens, certificates),
``service_answers`` (asyncua's answers made OPC 10000-4's), ``address_space`` (the nodes),
``value_writer`` (values in) and ``method_calls`` (calls out).
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Mapping
from datetime import datetime, timezone
from importlib import metadata
from pathlib import Path

from asyncua import Server, ua

from feeder_cell.gateway import layout, roles
from feeder_cell.gateway.address_space import AddressSpace
from feeder_cell.gateway.alarms import Alarms
from feeder_cell.gateway.config import DeviceEntry, Endpoint, SecurityConfig
from feeder_cell.gateway.logins import LoginGuard, install
from feeder_cell.gateway.method_calls import Handler, MethodCalls
from feeder_cell.gateway.roles import Role
from feeder_cell.gateway.server_security import POLICY_TYPES, secure
from feeder_cell.gateway.service_answers import refuse_events_of_non_notifiers, refuse_writes
from feeder_cell.gateway.session_users import GatewayUsers
from feeder_cell.gateway.spec import CallContext, Value
from feeder_cell.gateway.ua_casts import node_id
from feeder_cell.gateway.users import Users
from feeder_cell.gateway.value_writer import ValueWriter

__all__ = ["Handler", "GatewayServer", "GatewayUsers", "POLICY_TYPES", "PRODUCT_NAME", "product_version"]

PRODUCT_NAME = "feeder opcua_gateway"
PRODUCT_URI = "urn:feeder"
MANUFACTURER = "the feeder project"
PACKAGE = "feeder_cell"


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
        self.logins: LoginGuard | None = None  # made with the server (start)
        self.idx = 0
        self._types: dict[str, ua.VariantType] = {}
        self.values = ValueWriter(devices, self._types, self._id, self.log)
        self.calls = MethodCalls(handler, self.context, self.log, self.post_all, self._id)
        # Every method a role restricts -> its least role (roles.required_role; Acknowledge: Operator).
        self.method_roles: dict[ua.NodeId, Role] = {}
        self._made: Server | None = None  # from its construction in start to stop, a start cut short too

    @property
    def server(self) -> Server | None:
        """The asyncua server while it listens (start to stop), else None."""
        return self.values.server

    @property
    def alarms(self) -> Alarms | None:
        """The devices' Fault and Warning conditions, made with the address space (start)."""
        return self.values.alarms

    # --- start and stop --------------------------------------------------------------------------
    async def start(self) -> None:
        """Build the address space and listen on the endpoint (OSError when it cannot bind)."""
        self.values.loop = asyncio.get_running_loop()
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
        server = self._made = Server(user_manager=users)
        await server.init()
        install(server.iserver, self.logins)
        roles.enforce(server, lambda: self.idx, self.method_roles)
        server.set_endpoint(self.endpoint.url)
        server.set_server_name("feeder cell OPC UA gateway")
        await server.set_application_uri(layout.APPLICATION_URI)
        version, built = product_version()
        await server.set_build_info(PRODUCT_URI, MANUFACTURER, PRODUCT_NAME, version, version, built)
        refuse_writes(server)
        refuse_events_of_non_notifiers(server)
        await secure(server, self.security, self.users)
        self.idx = await server.register_namespace(layout.NAMESPACE_URI)
        await self._build(server)
        await server.start()
        self.values.server = server
        self.values.schedule()  # values posted before the server existed

    async def stop(self) -> None:
        """Stop listening and release the server, also one whose start was cancelled part way."""
        server, self._made, self.values.server = self._made, None, None
        if server is not None:
            await server.stop()
        if self.logins is not None:
            self.logins.close()

    def _id(self, identifier: str) -> ua.NodeId:
        return node_id(identifier, self.idx)

    async def _build(self, server: Server) -> None:
        space = AddressSpace(
            server,
            self.idx,
            self.devices,
            self.log,
            self._types,
            self.method_roles,
            self.post,
            self.calls.method,
        )
        await space.build()
        self.values.alarms = space.alarms

    # --- values ----------------------------------------------------------------------------------
    def post(self, key: str, path: str, value: Value, stamp_ns: int = 0) -> None:
        """Set a device variable (any thread); written on the loop's next turn unless unchanged."""
        self.post_all(key, {path: value}, stamp_ns)

    def post_all(self, key: str, values: Mapping[str, Value], stamp_ns: int = 0) -> None:
        """Set several variables of a device together (any thread): one flush writes them all.

        ``value_writer.ValueWriter.post_all`` says how they stay together.
        """
        self.values.post_all(key, values, stamp_ns)

    async def flush_now(self) -> None:
        """Write what is pending before the caller goes on (on the loop; ``ValueWriter.flush_now``)."""
        await self.values.flush_now()

    def read(self, key: str, path: str) -> Value | None:
        """Return the last value set of a variable (for the handler's own bookkeeping)."""
        return self.values.read(key, path)


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
