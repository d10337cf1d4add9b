"""Two of asyncua's service answers replaced by the codes OPC 10000-4 gives: writes and event items.

Its own module because it wraps asyncua's internal services rather than using its API: what it changes
(and why) is in one place to review when asyncua is upgraded. Both wrappers run on the asyncio loop.
"""

from __future__ import annotations

from asyncua import Server, ua
from asyncua.crypto.permission_rules import User, UserRole

from feeder_cell.gateway.ua_casts import status_code

__all__ = ["refuse_writes", "refuse_events_of_non_notifiers"]

_ADMIN = User(role=UserRole.Admin)  # asyncua's default for a write without a session (the server's own)


def refuse_writes(server: Server) -> None:
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
                codes[i] = status_code(ua.StatusCodes.BadNotWritable)
        return codes

    service.write = refuse_read_only  # type: ignore[method-assign]


def refuse_events_of_non_notifiers(server: Server) -> None:
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
                result.StatusCode = status_code(ua.StatusCodes.BadNotSupported)
        return results

    service.create_monitored_items = create_monitored_items  # type: ignore[method-assign]
