"""Who may do what over OPC UA: three of OPC 10000-18's well-known roles, and each session's own.

A PLC, an HMI and a dashboard are not equally trusted, so every session has a role:

- **Observer** browses, reads and subscribes (data changes, events);
- **Operator** also calls the devices' methods (PackML commands, the infeed, fault injection) and
  acknowledges alarms;
- **Engineer** also loads and runs programs (``RunProgram``, ``LoadProgram``) and writes what is writable
  (no gateway variable is, today).

A user's role is in the users file (``users``); an anonymous session gets the ``anonymous_role``
parameter's. asyncua knows no roles of this kind, so the gateway enforces them itself: a method call out
of the session's role is Bad_UserAccessDenied (``GatewayServer``, ``Alarms``), and a Read of
UserExecutable, UserAccessLevel, RolePermissions or UserRolePermissions answers with the roles' rights
(``answer_read``). The session's user reaches a method's callback, which asyncua calls without it,
through ``CALLER``: ``enforce`` sets it around each session's Call service.
"""

from __future__ import annotations

import contextvars
import enum
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, cast

from asyncua import Server, ua
from asyncua.common.callback import CallbackType
from asyncua.crypto.permission_rules import User, UserRole

from feeder_planner.errors import InputError

__all__ = [
    "Role",
    "GatewayUser",
    "CALLER",
    "PROGRAM_METHODS",
    "parse_role",
    "caller_role",
    "required_role",
    "permissions",
    "role_permissions",
    "answer_read",
    "enforce",
]


class Role(enum.IntEnum):
    """A session's role, ordered: each has the rights of the ones below it."""

    Observer = 1
    Operator = 2
    Engineer = 3

    @property
    def node_id(self) -> ua.NodeId:
        """The well-known role's NodeId (OPC 10000-18, 4.2: WellKnownRole_Observer ...)."""
        return ua.NodeId(cast(ua.Int32, _ROLE_IDS[self]))


_ROLE_IDS = {
    Role.Observer: ua.ObjectIds.WellKnownRole_Observer,
    Role.Operator: ua.ObjectIds.WellKnownRole_Operator,
    Role.Engineer: ua.ObjectIds.WellKnownRole_Engineer,
}
# The methods that load or run a program: an Engineer's. Every other method is an Operator's.
PROGRAM_METHODS = frozenset({"RunProgram", "LoadProgram"})


@dataclass
class GatewayUser(User):
    """asyncua's session user (its UserRole stays User: asyncua lets it read, browse and call) and a role."""

    access: Role = Role.Observer


# The user of the session whose Call service is running (None: the server's own call).
CALLER: contextvars.ContextVar[User | None] = contextvars.ContextVar("opcua_caller", default=None)


def parse_role(text: object, field: str) -> Role:
    """Return the role named ``text``; InputError naming ``field`` otherwise."""
    names = ", ".join(r.name for r in Role)
    if not isinstance(text, str) or text not in Role.__members__:
        raise InputError(field, f"must be one of {names}, got {text!r}")
    return Role[text]


def caller_role() -> tuple[Role, str]:
    """Return the calling session's role and user name (the server's own calls: Engineer)."""
    user = CALLER.get()
    if user is None or user.role == UserRole.Admin:
        return Role.Engineer, "the server"
    if isinstance(user, GatewayUser):
        return user.access, user.name or "anonymous"
    return Role.Observer, user.name or "anonymous"


def required_role(method: str) -> Role:
    """Return the least role that may call a device method."""
    return Role.Engineer if method in PROGRAM_METHODS else Role.Operator


_SEE = (
    ua.PermissionType.Browse,
    ua.PermissionType.ReadRolePermissions,
    ua.PermissionType.Read,
    ua.PermissionType.ReceiveEvents,
)


def permissions(role: Role, callable_by: Role | None) -> int:
    """Return a role's PermissionType mask on a node (a method's ``callable_by``: its least role)."""
    mask = 0
    for permission in _SEE:  # PermissionType's values are the bits themselves (AccessLevel's: indices)
        mask |= int(permission)
    if callable_by is not None and role >= callable_by:
        mask |= int(ua.PermissionType.Call)
    return mask


def role_permissions(callable_by: Role | None, only: Role | None = None) -> list[ua.RolePermissionType]:
    """Return a node's RolePermissions (``only``: that role's entry, a session's UserRolePermissions)."""
    return [
        ua.RolePermissionType(
            RoleId=role.node_id, Permissions=cast(ua.UInt32, permissions(role, callable_by))
        )
        for role in Role
        if only is None or role == only
    ]


_ROLE_ATTRIBUTES = (
    ua.AttributeIds.UserExecutable,
    ua.AttributeIds.UserAccessLevel,
    ua.AttributeIds.RolePermissions,
    ua.AttributeIds.UserRolePermissions,
)


def answer_read(
    user: User | None,
    items: list[ua.ReadValueId],
    results: list[ua.DataValue],
    namespace: int,
    methods: Mapping[ua.NodeId, Role],
) -> None:
    """Replace, in place, what a Read answered for the role attributes of the gateway's nodes.

    ``methods`` maps every method a role restricts to its least role; the gateway's other nodes (its
    namespace's) are readable by every role and callable by none.
    """
    role = user.access if isinstance(user, GatewayUser) else Role.Engineer
    for i, item in enumerate(items):
        if item.AttributeId not in _ROLE_ATTRIBUTES:
            continue
        node = item.NodeId
        callable_by = methods.get(node)
        if callable_by is None and node.NamespaceIndex != namespace:
            continue  # the standard's nodes: asyncua's own answer
        value: ua.Variant | None = None
        if item.AttributeId == ua.AttributeIds.UserExecutable:
            if callable_by is not None:
                value = ua.Variant(role >= callable_by, ua.VariantType.Boolean)
        elif item.AttributeId == ua.AttributeIds.UserAccessLevel:
            answered, status = results[i].Value, results[i].StatusCode
            level = answered.Value if answered is not None else None
            if status is not None and status.is_good() and level is not None:
                write = 1 << ua.AccessLevel.CurrentWrite
                own = int(level) if role >= Role.Engineer else int(level) & ~write
                value = ua.Variant(own, ua.VariantType.Byte)
        else:
            only = role if item.AttributeId == ua.AttributeIds.UserRolePermissions else None
            value = ua.Variant(role_permissions(callable_by, only), ua.VariantType.ExtensionObject)
        if value is not None:
            results[i] = ua.DataValue(value)


def enforce(server: Server, namespace: Callable[[], int], methods: Mapping[ua.NodeId, Role]) -> None:
    """Make each session's user known to the method callbacks, and answer reads of the role attributes.

    asyncua calls a method without the session, so each client session's Call service is wrapped to set
    ``CALLER`` around it; a PostRead callback rewrites UserExecutable, UserAccessLevel, RolePermissions and
    UserRolePermissions of the gateway's nodes (``answer_read``; ``namespace()``: the gateway's index).
    """
    iserver = server.iserver
    create = iserver.create_session

    def create_session(name: str, user: User = _NOBODY, external: bool = False) -> Any:
        session = create(name, user, external)
        call = session.call

        async def call_as_user(params: list[ua.CallMethodRequest]) -> list[ua.CallMethodResult]:
            token = CALLER.set(session.user)
            try:
                return await call(params)
            finally:
                CALLER.reset(token)

        session.call = call_as_user  # type: ignore[method-assign]
        return session

    iserver.create_session = create_session  # type: ignore[method-assign]

    async def on_read(event: Any, _dispatcher: Any) -> None:
        if event.response_params is not None:
            answer_read(
                event.user, event.request_params.NodesToRead, event.response_params, namespace(), methods
            )

    server.subscribe_server_callback(CallbackType.PostRead, on_read)


_NOBODY = User(role=UserRole.Anonymous)  # asyncua's default user of a session not yet activated
