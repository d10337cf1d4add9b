"""The gateway's start-up wait for its devices and its own /diagnostics entry.

The server listens only once every device is ready (``Health.wait_for_devices``): a PLC that connects and
commands at once would otherwise find a device that has not reported yet (PackML Undefined, "reports no
status") or whose services are not yet discovered ("not available"). The gateway's /diagnostics entry
(1 Hz, its node's name) says which devices are online, what that wait found, and the login counts.
"""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Awaitable, Callable, Mapping
from typing import TYPE_CHECKING, Any, Protocol

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.clock import Clock, ClockType
from rclpy.node import Node

from feeder_cell.gateway.config import DeviceEntry

if TYPE_CHECKING:
    from feeder_cell.gateway.server import GatewayServer

__all__ = ["Health"]

# Runs a function in the rclpy executor's thread (in_ros.InRos.value): rclpy objects are touched there.
InRos = Callable[[Callable[[], Any]], Awaitable[Any]]


class DeviceLink(Protocol):
    """What the health of a device needs of its link (``device_link.DeviceLink``)."""

    entry: DeviceEntry
    lock: threading.Lock
    online: bool

    def missing(self) -> list[str]:
        """Return what the device lacks to be commanded: its status, services or action not yet discovered."""
        ...


class Health:
    """What the gateway says of itself: ready to listen, and its /diagnostics entry."""

    def __init__(
        self, node: Node, links: Mapping[str, DeviceLink], server: GatewayServer, in_ros: InRos
    ) -> None:
        self.node, self.links, self.server, self.in_ros = node, links, server, in_ros
        self.startup = "waiting for the devices"
        self.publisher = node.create_publisher(DiagnosticArray, "/diagnostics", 10)
        node.create_timer(1.0, self.publish, clock=Clock(clock_type=ClockType.STEADY_TIME))

    async def wait_for_devices(self, timeout: float, stop: asyncio.Event) -> dict[str, list[str]]:
        """Wait until every device is heard and its services and action discovered, at most ``timeout`` s.

        Returns each device not ready in time with what it lacks.
        """
        loop = asyncio.get_running_loop()
        started = loop.time()
        deadline = started + timeout
        missing: dict[str, list[str]] = {}
        while not stop.is_set():
            missing = {}
            for link in self.links.values():
                gaps = await self.in_ros(link.missing)
                if gaps:
                    missing[link.entry.node] = gaps
            if not missing or loop.time() >= deadline:
                break
            await asyncio.sleep(0.05)
        took = loop.time() - started
        if missing:
            self.startup = f"not ready within {timeout:g} s: " + "; ".join(
                f"{node} lacks {', '.join(gaps)}" for node, gaps in missing.items()
            )
        else:
            self.startup = f"every device heard and its services discovered in {took:.1f} s"
        return missing

    def publish(self) -> None:
        """Publish the gateway's /diagnostics entry (timer, executor thread)."""
        offline = []
        entry = DiagnosticStatus(name=self.node.get_fully_qualified_name(), hardware_id="opcua_gateway")
        for link in self.links.values():
            with link.lock:
                online = link.online
            if not online:
                offline.append(link.entry.node)
            entry.values.append(KeyValue(key=f"{link.entry.node} online", value=str(online).lower()))
        entry.values.append(KeyValue(key="startup", value=self.startup))
        guard = self.server.logins
        if guard is not None:  # the login counts (logins.LoginGuard), once the server is listening
            entry.values += [KeyValue(key=k, value=str(v)) for k, v in dict(guard.counts).items()]
        entry.level = DiagnosticStatus.WARN if offline else DiagnosticStatus.OK
        entry.message = f"offline: {', '.join(offline)}" if offline else "every device online"
        msg = DiagnosticArray(status=[entry])
        msg.header.stamp = self.node.get_clock().now().to_msg()
        self.publisher.publish(msg)
