"""The gateway's alarms without ROS: a GatewayServer in this process, values posted as the ROS link does.

An asyncua client subscribes to AlarmConditionType events on a device object and on the Server object
and sees each condition raised, acknowledged and cleared (docs/cell.md: Alarms).
"""

from __future__ import annotations

import asyncio
import socket
import time
from datetime import datetime, timedelta, timezone
from typing import Any

import pytest
from asyncua import Client, ua

from feeder_cell.gateway import alarms, layout
from feeder_cell.gateway.config import DeviceEntry, Endpoint, SecurityConfig
from feeder_cell.gateway.server import GatewayServer
from feeder_cell.gateway.spec import Goal

ARM = DeviceEntry("throwing_arm", "/t/throwing_arm")
KEY = ARM.key


class _NoCalls:
    async def call(self, device: DeviceEntry, method: str, goal: Goal | None) -> tuple[str, str]:
        return "BadNotSupported", "no ROS here"


def _port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


class Events:
    """An event subscription's notifications, as a queue."""

    def __init__(self) -> None:
        self.queue: asyncio.Queue[Any] = asyncio.Queue()

    def event_notification(self, event: Any) -> None:
        self.queue.put_nowait(event)

    async def next(self, timeout: float = 5.0) -> Any:
        return await asyncio.wait_for(self.queue.get(), timeout)


def _status(fault: int, fault_text: str, warning: int, warning_text: str) -> dict[str, Any]:
    return {
        "Status.FaultCode": fault,
        "Status.FaultText": fault_text,
        "Status.WarningCode": warning,
        "Status.WarningText": warning_text,
    }


async def _acknowledge(client: Client, event: Any, comment: str) -> ua.CallMethodResult:
    request = ua.CallMethodRequest()
    request.ObjectId = event.NodeId  # the ConditionId
    request.MethodId = ua.NodeId(ua.ObjectIds.AcknowledgeableConditionType_Acknowledge)
    request.InputArguments = [
        ua.Variant(event.EventId, ua.VariantType.ByteString),
        ua.Variant(ua.LocalizedText(comment), ua.VariantType.LocalizedText),
    ]
    return (await client.uaclient.call([request]))[0]


def test_a_fault_is_raised_acknowledged_and_cleared_and_a_warning_is_a_lower_severity_alarm() -> None:
    async def main() -> None:
        url = f"opc.tcp://127.0.0.1:{_port()}"
        security = SecurityConfig(("None",), "", "", True, "")
        gateway = GatewayServer(Endpoint(url, "127.0.0.1", 0), security, None, (ARM,), _NoCalls())
        gateway.endpoint = Endpoint(url, "127.0.0.1", int(url.rsplit(":", 1)[1]))
        await gateway.start()
        client = Client(url, timeout=10)
        await client.connect()
        try:
            idx = await client.get_namespace_index(layout.NAMESPACE_URI)
            device = client.get_node(ua.NodeId(KEY, idx))
            notifier = await device.read_attribute(ua.AttributeIds.EventNotifier)
            assert notifier.Value.Value & (1 << ua.EventNotifier.SubscribeToEvents)
            server_notifier = await client.nodes.server.read_attribute(ua.AttributeIds.EventNotifier)
            assert server_notifier.Value.Value & (1 << ua.EventNotifier.SubscribeToEvents)
            on_device, on_server = Events(), Events()
            sub_device = await client.create_subscription(0, on_device)
            await sub_device.subscribe_events(device, ua.ObjectIds.AlarmConditionType)
            sub_server = await client.create_subscription(0, on_server)
            await sub_server.subscribe_events(client.nodes.server, ua.ObjectIds.AlarmConditionType)

            gateway.post_all(KEY, _status(101, "motor_fault injected", 0, ""))
            raised = await on_device.next()
            assert raised.Severity == alarms.FAULT_SEVERITY
            assert raised.SourceNode == ua.NodeId(KEY, idx)
            assert raised.NodeId == ua.NodeId(alarms.condition_id(KEY, "Fault"), idx)
            assert raised.ConditionName == "Fault"
            assert "101" in raised.Message.Text and "motor_fault" in raised.Message.Text
            assert getattr(raised, "ActiveState/Id") is True
            assert getattr(raised, "AckedState/Id") is False
            assert raised.Retain is True
            assert (await on_server.next()).EventId == raised.EventId

            # ConditionRefresh sends the retained condition again to the subscription on Server.
            refresh = ua.CallMethodRequest()
            refresh.ObjectId = ua.NodeId(ua.ObjectIds.ConditionType)
            refresh.MethodId = ua.NodeId(ua.ObjectIds.ConditionType_ConditionRefresh)
            refresh.InputArguments = [ua.Variant(sub_server.subscription_id, ua.VariantType.UInt32)]
            assert (await client.uaclient.call([refresh]))[0].StatusCode.is_good()
            assert (await on_server.next()).EventId == raised.EventId
            # Enable, Disable and AddComment are not supported.
            for method in (ua.ObjectIds.ConditionType_Disable, ua.ObjectIds.ConditionType_Enable):
                request = ua.CallMethodRequest()
                request.ObjectId, request.MethodId = raised.NodeId, ua.NodeId(method)
                result = (await client.uaclient.call([request]))[0]
                assert result.StatusCode.value == ua.StatusCodes.BadNotSupported

            # A stale EventId is refused, the current one acknowledges; a second acknowledge is refused.
            stale = await _acknowledge(client, type("E", (), {"NodeId": raised.NodeId, "EventId": b"x"}), "")
            assert stale.StatusCode.value == ua.StatusCodes.BadEventIdUnknown
            assert (await _acknowledge(client, raised, "seen")).StatusCode.is_good()
            acked = await on_device.next()
            assert getattr(acked, "AckedState/Id") is True and getattr(acked, "ActiveState/Id") is True
            assert acked.Retain is True
            again = await _acknowledge(client, acked, "")
            assert again.StatusCode.value == ua.StatusCodes.BadConditionBranchAlreadyAcked

            gateway.post_all(KEY, _status(0, "", 0, ""))
            cleared = await on_device.next()
            assert getattr(cleared, "ActiveState/Id") is False
            assert cleared.Retain is False  # acknowledged and inactive

            # A warning: lower severity; cleared before acknowledged it stays retained until acknowledged.
            gateway.post_all(KEY, _status(0, "", 2, "behind real time"))
            warning = await on_device.next()
            assert warning.ConditionName == "Warning" and warning.Severity == alarms.WARNING_SEVERITY
            assert warning.Severity < alarms.FAULT_SEVERITY
            gateway.post_all(KEY, _status(0, "", 0, ""))
            gone = await on_device.next()
            assert getattr(gone, "ActiveState/Id") is False and gone.Retain is True
            assert (await _acknowledge(client, gone, "")).StatusCode.is_good()
            final = await on_device.next()
            assert final.Retain is False

            # The condition object mirrors the state in the address space.
            condition = client.get_node(ua.NodeId(alarms.condition_id(KEY, "Warning"), idx))
            retain = await condition.get_child(ua.QualifiedName("Retain", 0))
            assert await retain.read_value() is False
        finally:
            await client.disconnect()
            await gateway.stop()

    asyncio.run(main())


def test_every_event_of_a_condition_carries_the_gateways_wall_clock_so_times_never_go_back() -> None:
    """The cell clock runs ahead of the wall clock at a factor above 1: an hour ahead here.

    Raise and clear come with the device's stamp, the acknowledge has none of its own; one clock for all
    of them (the gateway's wall clock) keeps a condition's event Times in order. The device's stamp stays
    the SourceTimestamp of Status/FaultCode.
    """

    async def main() -> None:
        url = f"opc.tcp://127.0.0.1:{_port()}"
        security = SecurityConfig(("None",), "", "", True, "")
        gateway = GatewayServer(
            Endpoint(url, "127.0.0.1", int(url.rsplit(":", 1)[1])), security, None, (ARM,), _NoCalls()
        )
        await gateway.start()
        client = Client(url, timeout=10)
        await client.connect()
        try:
            idx = await client.get_namespace_index(layout.NAMESPACE_URI)
            events = Events()
            subscription = await client.create_subscription(0, events)
            await subscription.subscribe_events(
                client.get_node(ua.NodeId(KEY, idx)), ua.ObjectIds.AlarmConditionType
            )
            ahead_ns = time.time_ns() + 3600 * 10**9
            before = datetime.now(timezone.utc)
            gateway.post_all(KEY, _status(101, "motor_fault injected", 0, ""), ahead_ns)
            raised = await events.next()
            assert (await _acknowledge(client, raised, "seen")).StatusCode.is_good()
            acked = await events.next()
            gateway.post_all(KEY, _status(0, "", 0, ""), ahead_ns + 10**9)
            cleared = await events.next()
            after = datetime.now(timezone.utc)
            times = [_utc(e.Time) for e in (raised, acked, cleared)]
            assert times == sorted(times), times
            assert all(before - timedelta(seconds=1) <= t <= after + timedelta(seconds=1) for t in times), (
                times
            )
            code = await client.get_node(
                ua.NodeId(layout.variable_id(KEY, "Status.FaultCode"), idx)
            ).read_data_value()
            assert abs(_utc(code.SourceTimestamp).timestamp() * 1e9 - (ahead_ns + 10**9)) < 1e6
        finally:
            await client.disconnect()
            await gateway.stop()

    asyncio.run(main())


def _utc(stamp: datetime) -> datetime:
    return stamp if stamp.tzinfo else stamp.replace(tzinfo=timezone.utc)


def test_the_cell_object_is_an_event_notifier_carrying_its_devices_alarms() -> None:
    """An HMI subscribes to the area object, Cell, and gets every device's alarm events (OPC 10000-3).

    Before, Cell was no notifier and CreateMonitoredItems answered BadServiceUnsupported, a code that
    OPC 10000-4 does not list for it.
    """

    async def main() -> None:
        url = f"opc.tcp://127.0.0.1:{_port()}"
        security = SecurityConfig(("None",), "", "", True, "")
        endpoint = Endpoint(url, "127.0.0.1", int(url.rsplit(":", 1)[1]))
        fixture = DeviceEntry("assembly_fixture", "/t/assembly_fixture")
        gateway = GatewayServer(endpoint, security, None, (ARM, fixture), _NoCalls())
        await gateway.start()
        client = Client(url, timeout=10)
        await client.connect()
        try:
            idx = await client.get_namespace_index(layout.NAMESPACE_URI)
            cell = client.get_node(ua.NodeId(layout.CELL, idx))
            notifier = await cell.read_attribute(ua.AttributeIds.EventNotifier)
            assert notifier.Value.Value & (1 << ua.EventNotifier.SubscribeToEvents)
            # The notifier hierarchy: Server -> Cell -> each device (HasNotifier).
            below_server = await client.nodes.server.get_referenced_nodes(
                ua.ObjectIds.HasNotifier, ua.BrowseDirection.Forward
            )
            assert cell.nodeid in [n.nodeid for n in below_server]
            below_cell = {
                n.nodeid
                for n in await cell.get_referenced_nodes(ua.ObjectIds.HasNotifier, ua.BrowseDirection.Forward)
            }
            assert below_cell == {ua.NodeId(ARM.key, idx), ua.NodeId(fixture.key, idx)}
            on_cell = Events()
            subscription = await client.create_subscription(0, on_cell)
            await subscription.subscribe_events(cell, ua.ObjectIds.AlarmConditionType)
            # Another node is no notifier: the standard's operation code (not BadServiceUnsupported).
            folder = client.get_node(ua.NodeId(layout.DEVICES_FOLDER, idx))
            with pytest.raises(ua.UaStatusCodeError) as refused:
                await subscription.subscribe_events(folder, ua.ObjectIds.AlarmConditionType)
            assert refused.value.code == ua.StatusCodes.BadNotSupported, refused.value
            gateway.post_all(KEY, _status(101, "motor_fault injected", 0, ""))
            gateway.post_all(fixture.key, _status(0, "", 302, "rate limited"))
            seen = {(e.SourceName, e.ConditionName) for e in [await on_cell.next(), await on_cell.next()]}
            assert seen == {(KEY, "Fault"), (fixture.key, "Warning")}, seen
        finally:
            await client.disconnect()
            await gateway.stop()

    asyncio.run(main())
