"""The ROS side of the gateway: device topics mirrored into OPC UA variables, method calls run as ROS calls.

Threads: rclpy spins in one background thread (a SingleThreadedExecutor); the asyncua server runs on the
asyncio loop of the main thread. Subscriptions post values to the server (``GatewayServer.post`` is
thread-safe). A method call, a coroutine on the loop, never touches rclpy objects itself: it hands a
coroutine to the executor (``Executor.create_task`` is thread-safe), which sends the service request or
the goal in the executor's own thread (rclpy's action client is not safe to call from a second thread), and
the result comes back to the loop by ``call_soon_threadsafe``. Every wait is bounded by ``call_timeout``.

What a device kind has of its own (its topics, its action, the variables its feedback and result set, its
service methods) is read from its profile (``kinds.KINDS``), and the PackML commands every device has
from ``commands.COMMANDS``; this module only runs them.
"""

from __future__ import annotations

import asyncio
import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Coroutine, TypeVar

# Generated, untyped, and not in pyproject's list of ROS message modules (outside this change's reach).
from action_msgs.msg import GoalStatus, GoalStatusArray  # type: ignore[import-untyped]
from diagnostic_msgs.msg import DiagnosticArray
from lifecycle_msgs.srv import ChangeState
from rcl_interfaces.msg import Log
from rclpy.action.client import ClientGoalHandle
from rclpy.client import Client
from rclpy.clock import Clock, ClockType
from rclpy.executors import Executor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.task import Task
from std_srvs.srv import Trigger

from feeder_cell.gateway.commands import (
    COMMANDS,
    FAULT_SERVICES,
    LIFECYCLE,
    TRIGGERS,
    Command,
    cancels_goal,
    plan,
)
from feeder_cell.gateway.config import PACKML_STATES, DeviceEntry, is_warning, packml_state
from feeder_cell.gateway.health import Health
from feeder_cell.gateway.kinds import KINDS
from feeder_cell.gateway.layout import UINT32_MODULUS, counter32_path, counter_path
from feeder_cell.gateway.server import GatewayServer
from feeder_cell.gateway.spec import Availability, Goal, KindProfile, StreamLink, Value, Values
from feeder_msgs.msg import DeviceStatus
from feeder_planner.node_kit import LATCHED, STREAM_DEPTH
from feeder_planner.node_kit.action_client import ActionClient

__all__ = ["STATUS_TIMEOUT", "REJECTION_WAIT", "DeviceLink", "RosLink"]

T = TypeVar("T")

# A device whose ~/status (1 Hz heartbeat) is not heard for this long is offline (Online false, PackML
# Undefined); five missed heartbeats, so that a starved process on a loaded host does not flap it. A goal
# in progress is given up (LOST) only once the device's action server has left the graph as well: a
# device that is merely slow still delivers its result.
STATUS_TIMEOUT = 5.0
# How long a rejected goal waits for the device's reason on /rosout (logged just before it answers).
REJECTION_WAIT = 2.0


def _ns(stamp: Any) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


@dataclass
class DeviceLink:
    """One device's ROS endpoints and what the gateway knows of it."""

    entry: DeviceEntry
    profile: KindProfile
    triggers: dict[str, Client]  # commands.TRIGGERS: ~/stop, ~/reset, ~/clear, ~/abort (std_srvs/Trigger)
    change_state: Client  # ~/change_state (lifecycle_msgs/srv/ChangeState)
    services: dict[str, Client]  # method name -> the client of its ServiceLink
    availability: dict[str, Availability]  # method name -> when its ServiceLink's service runs
    action: ActionClient  # the kind's long action
    state: int | None = None  # last DeviceStatus state
    ready: bool = False
    busy: bool = False  # last DeviceStatus busy
    fault_code: int = 0  # last DeviceStatus fault_code
    goals_active: bool = False  # the action server's status lists a goal accepted or executing (any client's)
    state_name: str = ""
    fault_text: str = ""
    heard: float = -math.inf  # monotonic time of the last status
    online: bool = False
    goal: ClientGoalHandle | None = None
    # The goal's Command.Busy is set: with the first status that shows the device executing (or at once
    # when the status already did), so that Command.Busy and the PackML state change in one publish.
    busy_shown: bool = False
    goals: int = 0
    results: int = 0
    rejections: list[tuple[float, str]] = field(default_factory=list)  # (monotonic, /rosout text)
    diagnosed_rejection: str = ""  # /diagnostics last_goal_rejection
    lock: threading.Lock = field(default_factory=threading.Lock)

    def clients(self) -> list[Client]:
        """Return every service client of the device (its commands', its methods')."""
        return [*self.triggers.values(), self.change_state, *self.services.values()]

    def missing(self) -> list[str]:
        """Return what of the device is not heard or discovered yet (executor thread); [] when ready."""
        with self.lock:
            heard = self.state is not None and self.online
        gaps = [] if heard else ["~/status"]
        gaps += [c.srv_name for c in self.clients() if not c.service_is_ready()]
        if not self.action.server_is_ready():
            gaps.append(f"{self.entry.node}/{self.profile.action.action_name} (action)")
        return gaps


class RosLink:
    """Subscriptions, clients and the method handler of the gateway, on one rclpy node."""

    def __init__(self, node: Node, executor: Executor, server: GatewayServer, call_timeout: float) -> None:
        self.node, self.executor, self.server = node, executor, server
        self.call_timeout = call_timeout
        self.sim_time = bool(node.get_parameter("use_sim_time").value)
        self.links: dict[str, DeviceLink] = {}
        for entry in server.devices:
            self.links[entry.key] = self._link(entry)
        rosout_qos = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
        node.create_subscription(Log, "/rosout", self._on_rosout, rosout_qos)
        node.create_subscription(DiagnosticArray, "/diagnostics", self._on_diagnostics, 10)
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        node.create_timer(0.5, self._watchdog, clock=steady)
        self.health = Health(node, self.links, server, self._in_ros_value)

    # --- subscriptions ---------------------------------------------------------------------------
    def _link(self, entry: DeviceEntry) -> DeviceLink:
        node, name = self.node, entry.node
        profile = KINDS[entry.kind]
        action = profile.action
        link = DeviceLink(
            entry,
            profile,
            triggers={t: node.create_client(Trigger, f"{name}/{t}") for t in TRIGGERS},
            change_state=node.create_client(ChangeState, f"{name}/change_state"),
            services={
                s.method.name: node.create_client(s.service_type, f"{name}/{s.service_name}")
                for s in (*profile.services, *FAULT_SERVICES)
            },
            availability={s.method.name: s.availability for s in (*profile.services, *FAULT_SERVICES)},
            action=ActionClient(node, action.action_type, f"{name}/{action.action_name}"),
        )
        node.create_subscription(DeviceStatus, f"{name}/status", lambda m: self._on_status(link, m), LATCHED)
        # The action server's goal status (rclpy's action status QoS: reliable, latched, depth 1) tells of
        # every client's goals, not only the gateway's: what makes a refusal "busy" without reading words.
        node.create_subscription(
            GoalStatusArray,
            f"{name}/{action.action_name}/_action/status",
            lambda m: self._on_goal_status(link, m),
            LATCHED,
        )
        for stream in link.profile.streams:
            self._subscribe(link, stream)
        return link

    def _subscribe(self, link: DeviceLink, stream: StreamLink) -> None:
        """Mirror one of the device's topics into the variables its profile maps it to."""
        topic = f"{link.entry.node}/{stream.topic}"

        def on_stamped(msg: Any) -> None:
            self._post_all(link, stream.values(msg), _ns(msg.header.stamp))

        # rclpy hands the message info (the DDS source timestamp) to a callback taking two arguments.
        def on_headerless(msg: Any, info: Any) -> None:
            self._post_all(link, stream.values(msg), self._arrival_stamp(info))

        callback = on_stamped if stream.stamped else on_headerless
        self.node.create_subscription(stream.message_type, topic, callback, STREAM_DEPTH)

    def _post(self, link: DeviceLink, path: str, value: Value, stamp_ns: int = 0) -> None:
        self.server.post(link.entry.key, path, value, stamp_ns)

    def _post_all(self, link: DeviceLink, values: Values, stamp_ns: int = 0) -> None:
        self.server.post_all(link.entry.key, values, stamp_ns)

    def _on_status(self, link: DeviceLink, msg: DeviceStatus) -> None:
        stamp = _ns(msg.header.stamp)
        executing = _executing(int(msg.state), bool(msg.busy))
        with link.lock:
            link.state, link.ready, link.state_name = int(msg.state), bool(msg.ready), msg.state_name
            link.busy = bool(msg.busy)
            link.fault_code = int(msg.fault_code)
            link.fault_text = msg.fault_text
            back = not link.online and link.heard > -math.inf
            link.heard = time.monotonic()
            link.online = True
            show_busy = link.goal is not None and not link.busy_shown and executing
            if show_busy:
                link.busy_shown = True
        if back:
            self.node.get_logger().info(f"{link.entry.node}: reporting again ({msg.state_name})")
        packml, code = packml_state(int(msg.state))
        # A code the device reports while it stays operational is a warning, not a fault.
        warning = is_warning(int(msg.state), int(msg.fault_code))
        values: Values = {
            "Status.Online": True,
            "Status.State": int(msg.state),
            "Status.StateName": msg.state_name,
            "Status.PackMLState": packml,
            "Status.PackMLStateCode": code,
            "Status.Ready": bool(msg.ready),
            "Status.Busy": bool(msg.busy),
            "Status.FaultCode": 0 if warning else int(msg.fault_code),
            "Status.FaultText": "" if warning else msg.fault_text,
            "Status.WarningCode": int(msg.fault_code) if warning else 0,
            "Status.WarningText": msg.fault_text if warning else "",
            "Status.ActiveFaults": list(msg.active_faults),
            "Status.CounterNames": list(msg.counter_names),
            "Status.CounterValues": [int(v) for v in msg.counter_values],
            "Status.CounterValues32": [int(v) % UINT32_MODULUS for v in msg.counter_values],
            "Status.BehindRealTime": bool(msg.behind_real_time),
            "Status.ConfiguredRate": float(msg.configured_rate),
            "Status.AchievedRate": float(msg.achieved_rate),
            "Status.ConfiguredRealTimeFactor": float(msg.configured_real_time_factor),
            "Status.AchievedRealTimeFactor": float(msg.achieved_real_time_factor),
        }
        known = link.profile.counter_names
        for name, value in zip(msg.counter_names, msg.counter_values, strict=False):
            if name in known:
                values[counter_path(name)] = int(value)
                values[counter32_path(name)] = int(value) % UINT32_MODULUS
        if show_busy:
            values["Command.Busy"] = True
        self._post_all(link, values, stamp)

    def _on_goal_status(self, link: DeviceLink, msg: GoalStatusArray) -> None:
        live = (GoalStatus.STATUS_ACCEPTED, GoalStatus.STATUS_EXECUTING, GoalStatus.STATUS_CANCELING)
        with link.lock:
            link.goals_active = any(g.status in live for g in msg.status_list)

    def _arrival_stamp(self, info: Any) -> int:
        """Stamp a headerless sample (std_msgs/Bool): the DDS sample's source timestamp (wall clock).

        On a cell clock (use_sim_time) that is another timeline than the headers', so the gateway's node
        clock at arrival stamps it instead.
        """
        if self.sim_time:
            return int(self.node.get_clock().now().nanoseconds)
        return int(info.get("source_timestamp", 0)) if isinstance(info, dict) else 0

    def _on_rosout(self, msg: Log) -> None:
        if "goal rejected:" not in msg.msg:
            return
        link = self.links.get(msg.name)  # a node's logger name is its key: cell.throwing_arm
        if link is not None:
            with link.lock:
                link.rejections = [*link.rejections[-9:], (time.monotonic(), msg.msg)]

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        for status in msg.status:
            link = self.links.get(status.name.strip("/").replace("/", "."))
            if link is None:
                continue
            for kv in status.values:
                if kv.key == "last_goal_rejection":
                    with link.lock:
                        link.diagnosed_rejection = kv.value

    def _watchdog(self) -> None:
        now = time.monotonic()
        for link in self.links.values():
            with link.lock:
                silent = now - link.heard > STATUS_TIMEOUT
                went_offline = link.online and silent
                if went_offline:
                    link.online = False
                lost = silent and link.goal is not None and not link.action.server_is_ready()
                if lost:
                    link.goal = None
            if went_offline:
                self.node.get_logger().warning(
                    f"{link.entry.node}: no ~/status for {now - link.heard:.1f} s: offline (PackML Undefined)"
                )
                self._post_all(
                    link,
                    {"Status.Online": False, "Status.PackMLState": "Undefined", "Status.PackMLStateCode": 0},
                )
            if lost:
                self._finish(
                    link, "LOST", 0, "the device stopped reporting and its action server left the graph"
                )

    # --- method calls (on the asyncio loop) ------------------------------------------------------
    async def call(self, device: DeviceEntry, method: str, goal: Goal | None) -> tuple[str, str]:
        """Run a checked method call on the device; return (status code name, message)."""
        link = self.links[device.key]
        command = COMMANDS.get(method)
        if command is not None:
            return await self._command(link, command)
        if method in link.services:
            return await self._in_ros(self._service(link, method, goal))
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
            return "BadInvalidState", f"{method} refused: {device.node} reports no status (is it running?)"
        if not ready:
            return "BadInvalidState", f"{method} refused: device is {name}{_remedy(state, text)}"
        if busy:
            return (
                "BadInvalidState",
                f"{method} refused: a goal this gateway sent is executing; Stop it or wait",
            )
        status, message = await self._in_ros(self._send_goal(link, method, goal))
        if message == "rejected":
            return await self._rejection(link, method)
        return status, message

    async def _in_ros(self, work: Coroutine[object, None, tuple[str, str]]) -> tuple[str, str]:
        """Run a coroutine in the rclpy executor's thread; its result, or BadTimeout after call_timeout."""
        try:
            return await self._in_ros_value(work)
        except asyncio.TimeoutError:
            return "BadTimeout", f"the device did not answer within {self.call_timeout:g} s"

    async def _in_ros_value(self, work: Callable[[], T] | Coroutine[object, None, T]) -> T:
        """Run a function or coroutine in the executor's thread; asyncio.TimeoutError after call_timeout.

        rclpy's objects are touched only there: its action client is not thread-safe.
        """
        loop = asyncio.get_running_loop()
        done: asyncio.Future[T] = loop.create_future()

        def finished(task: Task) -> None:
            def settle() -> None:
                if done.done():
                    return
                error = task.exception()
                if error is not None:
                    done.set_exception(error)
                else:
                    done.set_result(task.result())

            loop.call_soon_threadsafe(settle)

        self.executor.create_task(work).add_done_callback(finished)
        return await asyncio.wait_for(done, self.call_timeout)

    async def _discovered(self, link: DeviceLink, calls: tuple[str, ...]) -> None:
        """Wait, at most call_timeout, until the services of a command's calls are discovered.

        A device that has just come up (or back) reports its status before every one of its services is
        discovered; the command then waits for them rather than failing at once. Whatever is still missing
        after the wait is answered by ``_calls`` (BadCommunicationError, naming the service).
        """
        clients = [link.change_state if c in LIFECYCLE else link.triggers[c] for c in calls]
        loop = asyncio.get_running_loop()
        deadline = loop.time() + self.call_timeout
        while loop.time() < deadline:
            if await self._in_ros_value(lambda: all(c.service_is_ready() for c in clients)):
                return
            await asyncio.sleep(0.05)

    async def _command(self, link: DeviceLink, command: Command) -> tuple[str, str]:
        """Run a PackML command: its plan for the device's state, the transient state shown meanwhile."""
        name = command.method.name
        with link.lock:
            state, online = link.state, link.online
        if state is None or not online:
            return "BadInvalidState", f"{name} refused: {link.entry.node} reports no status (is it running?)"
        row = plan(command, state)
        if isinstance(row, str):
            return "BadInvalidState", row
        await self._discovered(link, row.calls)
        if row.transient:
            self._post_all(link, _packml_values(row.transient))
            await self.server.flush_now()
        status, message = await self._in_ros(self._calls(link, name, row.calls))
        if cancels_goal(command):
            with link.lock:
                goal = link.goal
            if goal is not None:  # the device halted; do not leave the goal running behind it
                await self._in_ros(self._cancel(goal))
        if status != "Good" and row.transient:
            with link.lock:
                shown = link.state
            self._post_all(link, _packml_values(packml_state(shown)[0]))  # nothing changed: say so
        return status, message

    async def _calls(self, link: DeviceLink, method: str, calls: tuple[str, ...]) -> tuple[str, str]:
        """Make a command's device calls in order; the first refusal ends it (executor thread)."""
        said: list[str] = []
        for call in calls:
            if call in LIFECYCLE:
                client = link.change_state
                request = ChangeState.Request()
                request.transition.id = LIFECYCLE[call]
            else:
                client, request = link.triggers[call], Trigger.Request()
            if not client.service_is_ready():
                return (
                    "BadCommunicationError",
                    f"{method}: {client.srv_name} is not available (is the device running?)",
                )
            response = await client.call_async(request)
            text = getattr(response, "message", "") or ("done" if response.success else "refused")
            said.append(f"{call}: {text}")
            if not response.success:  # a PackML command has no arguments: only the state refuses it
                return "BadInvalidState", f"{method}: {'; '.join(said)}"
        return "Good", f"{method}: {'; '.join(said)}"

    async def _cancel(self, goal: ClientGoalHandle) -> tuple[str, str]:
        goal.cancel_goal_async()
        return "Good", ""

    async def _service(self, link: DeviceLink, method: str, call: Goal | None) -> tuple[str, str]:
        """Call a service method's device service; the device's answer decides the status (executor)."""
        client = link.services[method]
        if call is None:
            raise TypeError(f"{method}: not a checked call")
        if not client.service_is_ready():
            return (
                "BadCommunicationError",
                f"{method}: {client.srv_name} is not available (is the device running?)",
            )
        response = await client.call_async(call.message())
        ok = bool(getattr(response, "ok", getattr(response, "success", False)))
        text = str(getattr(response, "error", "") or getattr(response, "message", ""))
        if ok:
            faults = getattr(response, "active_faults", None)
            extra = f"; active faults: {', '.join(faults) or 'none'}" if faults is not None else ""
            return "Good", f"{method}: done{extra}"
        code = "BadInvalidState" if self._refused_for_state(link, method) else "BadInvalidArgument"
        return code, f"{method} refused by the device: {text}"

    def _refused_for_state(self, link: DeviceLink, method: str) -> bool:
        """Whether the device's latest status (and its goals) is why it refused a service method."""
        with link.lock:
            state = link.state if link.online else None
            fault_code = link.fault_code
            goal_active = link.goal is not None or link.goals_active
        return link.availability[method].refuses(state, fault_code, goal_active)

    async def _send_goal(self, link: DeviceLink, method: str, goal: Goal | None) -> tuple[str, str]:
        client: ActionClient = link.action
        if not client.server_is_ready():
            return "BadCommunicationError", f"{method}: the device's action server is not available"
        with link.lock:
            link.rejections.clear()
        if goal is None:
            raise TypeError(f"{method}: not a goal")
        handle = await client.send_goal_async(
            goal.message(), feedback_callback=lambda m: self._feedback(link, m)
        )
        if not handle.accepted:
            return "BadInvalidState", "rejected"
        with link.lock:
            link.goal = handle
            link.goals += 1
            goals = link.goals
            # The device's status already shows it executing (the MEMS array while parts move): Busy now;
            # else with the status that shows it (_on_status), in the same publish as the state change.
            link.busy_shown = link.state is not None and _executing(link.state, link.busy)
            busy = link.busy_shown
        values: Values = {
            "Command.Action": method,
            "Command.GoalCount": goals,
            "Command.LastOutcome": "",  # cleared: the new goal has none yet
            "Command.LastOutcomeCode": 0,
            "Command.Result.FaultCode": 0,
            # The previous goal's progress would read as this one's until the first feedback arrives.
            **link.profile.action.feedback_values(link.profile.action.action_type.Feedback()),
        }
        if busy:
            values["Command.Busy"] = True
        self._post_all(link, values)
        handle.get_result_async().add_done_callback(lambda f: self._on_result(link, handle, f))
        return "Good", f"{method} goal accepted; Command.Busy shows it executing, Command.LastOutcome its end"

    async def _rejection(self, link: DeviceLink, method: str) -> tuple[str, str]:
        """Say why the device rejected a goal: its /rosout line, or its /diagnostics last_goal_rejection."""
        deadline = time.monotonic() + REJECTION_WAIT
        reason = ""
        while time.monotonic() < deadline:
            with link.lock:
                if link.rejections:
                    reason = link.rejections[-1][1].split("goal rejected:", 1)[1].strip()
                    break
            await asyncio.sleep(0.05)
        if not reason:
            with link.lock:
                last = link.diagnosed_rejection
            reason = (
                f"no reason on /rosout; the device's last in /diagnostics: {last}"
                if last
                else "no reason received"
            )
        # Typed, not read from the reason's words: a device that is not ready, or runs another client's
        # goal, refused it for its state; a ready, free device refused the goal's contents.
        with link.lock:
            not_free = not link.ready or not link.online or link.goals_active
        return (
            "BadInvalidState" if not_free else "BadInvalidArgument"
        ), f"{method} rejected by the device: {reason}"

    # --- goal progress (executor thread) ---------------------------------------------------------
    def _feedback(self, link: DeviceLink, message: Any) -> None:
        self._post_all(link, link.profile.action.feedback_values(message.feedback))

    def _on_result(self, link: DeviceLink, handle: ClientGoalHandle, future: Any) -> None:
        with link.lock:
            if link.goal is not handle:
                return  # already ended (the device went offline)
            link.goal = None
        try:
            result = future.result().result
        except Exception as error:  # noqa: BLE001 - reported in the variables, the gateway keeps serving
            self._finish(link, "LOST", 0, f"no result: {type(error).__name__}: {error}")
            return
        values = {
            **link.profile.action.result_values(result),
            "Command.Result.FaultCode": int(result.fault_code),
        }
        self._finish(link, result.outcome_name, int(result.outcome), result.message, values)

    def _finish(
        self, link: DeviceLink, outcome: str, code: int, message: str, result: Values | None = None
    ) -> None:
        """Post a goal's end in one publish: its result variables, outcome, ResultCount and Busy false."""
        with link.lock:
            link.results += 1
            results = link.results
            link.busy_shown = False
        self._post_all(
            link,
            {
                **(result or {}),
                "Command.LastOutcome": outcome,
                "Command.LastOutcomeCode": code,
                "Command.LastMessage": message,
                "Command.ResultCount": results,
                "Command.Busy": False,
            },
        )


def _packml_values(name: str) -> Values:
    """Return the two PackML variables of a state, by name."""
    number = next(n for n, state, _ in PACKML_STATES if state == name)
    return {"Status.PackMLState": name, "Status.PackMLStateCode": number}


def _executing(state: int, busy: bool) -> bool:
    """Whether a DeviceStatus shows the device executing (RUNNING, PackML Execute, or busy)."""
    return busy or state == DeviceStatus.RUNNING


def _remedy(state: int, fault_text: str) -> str:
    """Return what brings a device that is not ready back, as the refusal's parenthesis."""
    if state == DeviceStatus.FAULT:
        return f" ({fault_text}; Clear, then Reset)"
    if state == DeviceStatus.STOPPED:
        return " (Reset returns it to Idle)"
    if state == DeviceStatus.PAUSED:
        return " (Suspended: Unsuspend resumes it)"
    return " (Unconfigured: Reset brings it up)"
