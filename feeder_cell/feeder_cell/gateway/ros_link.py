"""The ROS side of the gateway: device topics mirrored into OPC UA variables, method calls run as ROS calls.

Threads: rclpy spins in one background thread (a SingleThreadedExecutor); the asyncua server runs on the
asyncio loop of the main thread. Subscriptions post values to the server (``GatewayServer.post`` is
thread-safe). A method call, a coroutine on the loop, never touches rclpy objects itself: it hands a
coroutine to the executor (``Executor.create_task`` is thread-safe), which sends the service request or
the goal in the executor's own thread (rclpy's action client is not safe to call from a second thread), and
the result comes back to the loop by ``call_soon_threadsafe``. Every wait is bounded by ``call_timeout``.

What a device kind has of its own (its topics, its action, the variables its feedback and result set, its
service methods) is read from its profile (``kinds.KINDS``), and the PackML commands every device has
from ``commands.COMMANDS``; this module only wires the parts that run them and routes each method call:
``device_link`` (a device's clients and what is known of it), ``device_listener`` (the subscriptions),
``watchdog`` (a silent device), ``in_ros`` (the hand-off to the executor), ``command_runner`` (the PackML
commands), ``service_calls`` (the kind's service methods) and ``goals`` (its action).
"""

from __future__ import annotations

from rclpy.executors import Executor
from rclpy.node import Node

from feeder_cell.gateway.command_runner import CommandRunner
from feeder_cell.gateway.commands import COMMANDS
from feeder_cell.gateway.config import DeviceEntry
from feeder_cell.gateway.device_link import DeviceLink, open_link
from feeder_cell.gateway.device_listener import DeviceListener
from feeder_cell.gateway.goals import REJECTION_WAIT, GoalRunner
from feeder_cell.gateway.health import Health
from feeder_cell.gateway.in_ros import InRos
from feeder_cell.gateway.server import GatewayServer
from feeder_cell.gateway.service_calls import call_service
from feeder_cell.gateway.spec import Goal
from feeder_cell.gateway.watchdog import STATUS_TIMEOUT, Watchdog
from feeder_msgs.msg import DeviceStatus

__all__ = ["STATUS_TIMEOUT", "REJECTION_WAIT", "DeviceLink", "RosLink"]


class RosLink:
    """Subscriptions, clients and the method handler of the gateway, on one rclpy node."""

    def __init__(self, node: Node, executor: Executor, server: GatewayServer, call_timeout: float) -> None:
        self.node, self.executor, self.server = node, executor, server
        self.call_timeout = call_timeout
        self.in_ros = InRos(executor, call_timeout)
        self.links: dict[str, DeviceLink] = {}
        self.listener = DeviceListener(node, server, self.links)
        self.goals = GoalRunner(server)
        self.commands = CommandRunner(server, self.in_ros)
        for entry in server.devices:
            link = open_link(node, entry)
            self.listener.subscribe(link)
            self.links[entry.key] = link
        self.listener.subscribe_cell()
        self.watchdog = Watchdog(node, self.links, server, self.goals.finish)
        self.health = Health(node, self.links, server, self.in_ros.value)

    async def call(self, device: DeviceEntry, method: str, goal: Goal | None) -> tuple[str, str]:
        """Run a checked method call on the device; return (status code name, message)."""
        link = self.links[device.key]
        command = COMMANDS.get(method)
        if command is not None:
            return await self.commands.run(link, command)
        if method in link.services:
            return await self.in_ros.answer(call_service(link, method, goal))
        refusal = _goal_refusal(link, device, method)
        if refusal:
            return "BadInvalidState", refusal
        status, message = await self.in_ros.answer(self.goals.send(link, method, goal))
        if message == "rejected":
            return await self.goals.rejection(link, method)
        return status, message


def _goal_refusal(link: DeviceLink, device: DeviceEntry, method: str) -> str:
    """Return why the device's state refuses a goal now, or "" (the device decides)."""
    with link.lock:
        state, ready, online, name, text = (
            link.state,
            link.ready,
            link.online,
            link.state_name,
            link.fault_text,
        )
        busy = link.goal is not None
    if state is None or not online:
        return f"{method} refused: {device.node} reports no status (is it running?)"
    if not ready:
        return f"{method} refused: device is {name}{_remedy(state, text)}"
    if busy:
        return f"{method} refused: a goal this gateway sent is executing; Stop it or wait"
    return ""


def _remedy(state: int, fault_text: str) -> str:
    """Return what brings a device that is not ready back, as the refusal's parenthesis."""
    if state == DeviceStatus.FAULT:
        return f" ({fault_text}; Clear, then Reset)"
    if state == DeviceStatus.STOPPED:
        return " (Reset returns it to Idle)"
    if state == DeviceStatus.PAUSED:
        return " (Suspended: Unsuspend resumes it)"
    return " (Unconfigured: Reset brings it up)"
