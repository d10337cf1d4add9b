"""The ROS side of the gateway: device topics mirrored into OPC UA variables, method calls run as ROS calls.

Threads: rclpy spins in one background thread (a SingleThreadedExecutor); the asyncua server runs on the
asyncio loop of the main thread. Subscriptions post values to the server (``GatewayServer.post`` is
thread-safe). A method call, a coroutine on the loop, never touches rclpy objects itself: it hands a
coroutine to the executor (``Executor.create_task`` is thread-safe), which sends the service request or
the goal in the executor's own thread (rclpy's action client is not safe to call from a second thread), and
the result comes back to the loop by ``call_soon_threadsafe``. Every wait is bounded by ``call_timeout``.
"""

from __future__ import annotations

import asyncio
import math
import threading
import time
from dataclasses import dataclass, field
from typing import Any, Coroutine

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Vector3
from rcl_interfaces.msg import Log
from rclpy.action.client import ClientGoalHandle
from rclpy.clock import Clock, ClockType
from rclpy.executors import Executor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool
from std_srvs.srv import Trigger

from feeder_cell.gateway.arguments import FeedPartGoal, FollowPathGoal, RunProgramGoal
from feeder_cell.gateway.config import DeviceEntry, packml_state
from feeder_cell.gateway.layout import COUNTERS
from feeder_cell.gateway.server import GatewayServer
from feeder_msgs.action import FeedPart, FollowPath, RunProgram
from feeder_msgs.msg import DeviceStatus, FieldProgram, FieldSpec, MemsPartStates, StabilityStatus
from feeder_planner.node_kit import LATCHED, STREAM_DEPTH
from feeder_planner.node_kit.action_client import ActionClient
from feeder_planner.node_kit.msg_fields import fill_field_spec

__all__ = ["STATUS_TIMEOUT", "REJECTION_WAIT", "DeviceLink", "RosLink"]

# A device whose ~/status (1 Hz heartbeat) is not heard for this long is offline (Online false, PackML
# Undefined); five missed heartbeats, so that a starved process on a loaded host does not flap it. A goal
# in progress is given up (LOST) only once the device's action server has left the graph as well: a
# device that is merely slow still delivers its result.
STATUS_TIMEOUT = 5.0
# How long a rejected goal waits for the device's reason on /rosout (logged just before it answers).
REJECTION_WAIT = 2.0

ACTIONS = {
    "throwing_arm": ("FeedPart", FeedPart, "feed_part"),
    "mems_field_array": ("RunProgram", RunProgram, "run_program"),
    "assembly_fixture": ("FollowPath", FollowPath, "follow_path"),
}


def _ns(stamp: Any) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


@dataclass
class DeviceLink:
    """One device's ROS endpoints and what the gateway knows of it."""

    entry: DeviceEntry
    stop: Any = None
    reset: Any = None
    action: Any = None
    state: int | None = None  # last DeviceStatus state
    ready: bool = False
    state_name: str = ""
    fault_text: str = ""
    heard: float = -math.inf  # monotonic time of the last status
    online: bool = False
    goal: ClientGoalHandle | None = None
    goals: int = 0
    results: int = 0
    rejections: list[tuple[float, str]] = field(default_factory=list)  # (monotonic, /rosout text)
    diagnosed_rejection: str = ""  # /diagnostics last_goal_rejection
    lock: threading.Lock = field(default_factory=threading.Lock)


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

    # --- subscriptions ---------------------------------------------------------------------------
    def _link(self, entry: DeviceEntry) -> DeviceLink:
        node, name = self.node, entry.node
        link = DeviceLink(entry)
        link.stop = node.create_client(Trigger, f"{name}/stop")
        link.reset = node.create_client(Trigger, f"{name}/reset")
        _, action_type, action_name = ACTIONS[entry.kind]
        link.action = ActionClient(node, action_type, f"{name}/{action_name}")
        node.create_subscription(DeviceStatus, f"{name}/status", lambda m: self._on_status(link, m), LATCHED)
        if entry.kind == "throwing_arm":
            node.create_subscription(
                Bool, f"{name}/sensor", lambda m, i: self._on_sensor(link, m, i), STREAM_DEPTH
            )
        elif entry.kind == "assembly_fixture":
            node.create_subscription(
                JointState, f"{name}/joint_states", lambda m: self._on_joints(link, m), STREAM_DEPTH
            )
            node.create_subscription(
                StabilityStatus, f"{name}/stability", lambda m: self._on_stability(link, m), STREAM_DEPTH
            )
        else:
            node.create_subscription(
                MemsPartStates, f"{name}/part_states", lambda m: self._on_parts(link, m), STREAM_DEPTH
            )
        return link

    def _post(self, link: DeviceLink, path: str, value: Any, stamp_ns: int = 0) -> None:
        self.server.post(link.entry.key, path, value, stamp_ns)

    def _on_status(self, link: DeviceLink, msg: DeviceStatus) -> None:
        stamp = _ns(msg.header.stamp)
        with link.lock:
            link.state, link.ready, link.state_name = int(msg.state), bool(msg.ready), msg.state_name
            link.fault_text = msg.fault_text
            back = not link.online and link.heard > -math.inf
            link.heard = time.monotonic()
            link.online = True
        if back:
            self.node.get_logger().info(f"{link.entry.node}: reporting again ({msg.state_name})")
        packml, code = packml_state(int(msg.state))
        values: dict[str, Any] = {
            "Status.Online": True,
            "Status.State": int(msg.state),
            "Status.StateName": msg.state_name,
            "Status.PackMLState": packml,
            "Status.PackMLStateCode": code,
            "Status.Ready": bool(msg.ready),
            "Status.Busy": bool(msg.busy),
            "Status.FaultCode": int(msg.fault_code),
            "Status.FaultText": msg.fault_text,
            "Status.ActiveFaults": list(msg.active_faults),
            "Status.CounterNames": list(msg.counter_names),
            "Status.CounterValues": [int(v) for v in msg.counter_values],
            "Status.BehindRealTime": bool(msg.behind_real_time),
            "Status.ConfiguredRate": float(msg.configured_rate),
            "Status.AchievedRate": float(msg.achieved_rate),
            "Status.ConfiguredRealTimeFactor": float(msg.configured_real_time_factor),
            "Status.AchievedRealTimeFactor": float(msg.achieved_real_time_factor),
        }
        known = COUNTERS[link.entry.kind]
        for name, value in zip(msg.counter_names, msg.counter_values, strict=False):
            if name in known:
                values[f"Status.Counters.{name}"] = int(value)
        for path, value in values.items():
            self._post(link, path, value, stamp)

    def _on_sensor(self, link: DeviceLink, msg: Bool, info: Any) -> None:
        # std_msgs/Bool has no header: the DDS sample's source timestamp (wall clock) is its stamp; on a
        # cell clock (use_sim_time) that is another timeline than the headers', so the gateway's node
        # clock at arrival stamps it instead.
        if self.sim_time:
            stamp = self.node.get_clock().now().nanoseconds
        else:
            stamp = int(info.get("source_timestamp", 0)) if isinstance(info, dict) else 0
        self._post(link, "Signals.Sensor", bool(msg.data), stamp)

    def _on_joints(self, link: DeviceLink, msg: JointState) -> None:
        stamp = _ns(msg.header.stamp)
        names = list(msg.name)
        for joint, path, default in (("tilt_x", "Signals.TiltX", 0), ("tilt_y", "Signals.TiltY", 1)):
            index = names.index(joint) if joint in names else default
            if index < len(msg.position):
                self._post(link, path, float(msg.position[index]), stamp)

    def _on_stability(self, link: DeviceLink, msg: StabilityStatus) -> None:
        stamp = _ns(msg.header.stamp)
        g = msg.gravity
        self._post(link, "Signals.Gravity", [float(g.x), float(g.y), float(g.z)], stamp)
        self._post(link, "Signals.Stable", bool(msg.stable), stamp)
        self._post(link, "Signals.StabilityMargin", float(msg.margin), stamp)
        self._post(link, "Signals.Moving", bool(msg.moving), stamp)

    def _on_parts(self, link: DeviceLink, msg: MemsPartStates) -> None:
        stamp = _ns(msg.header.stamp)
        self._post(link, "Signals.PartNames", [p.name for p in msg.parts], stamp)
        self._post(link, "Signals.PartOrientations", [float(p.theta) for p in msg.parts], stamp)
        positions = [float(c) for p in msg.parts for c in (p.pose.position.x, p.pose.position.y)]
        self._post(link, "Signals.PartPositions", positions, stamp)

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
                self._post(link, "Status.Online", False)
                self._post(link, "Status.PackMLState", "Undefined")
                self._post(link, "Status.PackMLStateCode", 0)
            if lost:
                self._finish(
                    link, "LOST", 0, "the device stopped reporting and its action server left the graph"
                )

    # --- method calls (on the asyncio loop) ------------------------------------------------------
    async def call(self, device: DeviceEntry, method: str, goal: Any) -> tuple[str, str]:
        """Run a checked method call on the device; return (status code name, message)."""
        link = self.links[device.key]
        if method in ("Stop", "Reset"):
            return await self._in_ros(self._trigger(link, method))
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

    async def _in_ros(self, work: Coroutine[Any, Any, tuple[str, str]]) -> tuple[str, str]:
        """Run a coroutine in the rclpy executor's thread; its result, or BadTimeout after call_timeout."""
        loop = asyncio.get_running_loop()
        done: asyncio.Future[tuple[str, str]] = loop.create_future()

        def finished(task: Any) -> None:
            def settle() -> None:
                if done.done():
                    return
                error = task.exception()
                if error is not None:
                    done.set_exception(error)
                else:
                    done.set_result(task.result())

            loop.call_soon_threadsafe(settle)

        task = self.executor.create_task(work)
        task.add_done_callback(finished)
        try:
            return await asyncio.wait_for(done, self.call_timeout)
        except asyncio.TimeoutError:
            return "BadTimeout", f"the device did not answer within {self.call_timeout:g} s"

    async def _trigger(self, link: DeviceLink, method: str) -> tuple[str, str]:
        client = link.stop if method == "Stop" else link.reset
        if not client.service_is_ready():
            return (
                "BadCommunicationError",
                f"{method}: {client.srv_name} is not available (is the device running?)",
            )
        response = await client.call_async(Trigger.Request())
        if method == "Stop":
            with link.lock:
                goal = link.goal
            if goal is not None:  # the device halted; do not leave the goal running behind it
                goal.cancel_goal_async()
        if not response.success:
            return "BadInvalidState", f"{method}: {response.message}"
        return "Good", f"{method}: {response.message}"

    async def _send_goal(self, link: DeviceLink, method: str, goal: Any) -> tuple[str, str]:
        client: ActionClient = link.action
        if not client.server_is_ready():
            return "BadCommunicationError", f"{method}: the device's action server is not available"
        with link.lock:
            link.rejections.clear()
        handle = await client.send_goal_async(
            _goal_msg(goal), feedback_callback=lambda m: self._feedback(link, m)
        )
        if not handle.accepted:
            return "BadInvalidState", "rejected"
        with link.lock:
            link.goal = handle
            link.goals += 1
            goals = link.goals
        self._post(link, "Command.Busy", True)
        self._post(link, "Command.Action", method)
        self._post(link, "Command.GoalCount", goals)
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
        # The kit's reasons for the device's state name it; anything else is about the goal's contents.
        state = "device is " in reason or "goal is executing" in reason
        return (
            "BadInvalidState" if state else "BadInvalidArgument"
        ), f"{method} rejected by the device: {reason}"

    # --- goal progress (executor thread) ---------------------------------------------------------
    def _feedback(self, link: DeviceLink, message: Any) -> None:
        fb = message.feedback
        kind = link.entry.kind
        if kind == "throwing_arm":
            self._post(link, "Command.Feedback.Throws", int(fb.throws))
            self._post(link, "Command.Feedback.SensorAtRest", bool(fb.sensor_at_rest))
        elif kind == "mems_field_array":
            self._post(link, "Command.Feedback.Time", float(fb.time))
            self._post(link, "Command.Feedback.Settled", [bool(s) for s in fb.settled])
            self._post(
                link, "Command.Feedback.EquilibriumDistance", [float(d) for d in fb.equilibrium_distance]
            )
        else:
            self._post(link, "Command.Feedback.Progress", float(fb.progress))
            self._post(link, "Command.Feedback.Stable", bool(fb.stable))
            self._post(link, "Command.Feedback.Margin", float(fb.margin))

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
        kind = link.entry.kind
        if kind == "throwing_arm":
            self._post(link, "Command.Result.Throws", int(result.throws))
            self._post(link, "Command.Result.SensorAtRest", bool(result.sensor_at_rest))
            self._post(link, "Command.Result.Edge", int(result.edge))
        elif kind == "mems_field_array":
            self._post(link, "Command.Result.Settled", bool(result.settled))
            self._post(link, "Command.Result.Equilibrium", [int(e) for e in result.equilibrium])
            self._post(
                link, "Command.Result.EquilibriumDistance", [float(d) for d in result.equilibrium_distance]
            )
        else:
            self._post(link, "Command.Result.Tilt", [float(t) for t in result.tilt])
            self._post(link, "Command.Result.FirstUnstableSample", int(result.first_unstable_sample))
            self._post(link, "Command.Result.UnbalancedBodies", list(result.unbalanced_bodies))
        self._post(link, "Command.Result.FaultCode", int(result.fault_code))
        self._finish(link, result.outcome_name, int(result.outcome), result.message)

    def _finish(self, link: DeviceLink, outcome: str, code: int, message: str) -> None:
        with link.lock:
            link.results += 1
            results = link.results
        self._post(link, "Command.LastOutcome", outcome)
        self._post(link, "Command.LastOutcomeCode", code)
        self._post(link, "Command.LastMessage", message)
        self._post(link, "Command.ResultCount", results)
        self._post(link, "Command.Busy", False)


def _remedy(state: int, fault_text: str) -> str:
    """Return what brings a device that is not ready back, as the refusal's parenthesis."""
    if state == DeviceStatus.FAULT:
        return f" ({fault_text}; Reset clears it)"
    if state == DeviceStatus.STOPPED:
        return " (Reset returns it to IDLE)"
    return " (not active: its lifecycle must configure and activate it)"


def _goal_msg(goal: Any) -> Any:
    """Return the action goal message of a checked method call."""
    if isinstance(goal, FeedPartGoal):
        return FeedPart.Goal(max_throws=goal.max_throws, timeout=goal.timeout)
    if isinstance(goal, RunProgramGoal):
        program = FieldProgram(name=goal.name, steps=[fill_field_spec(FieldSpec(), s) for s in goal.steps])
        return RunProgram.Goal(
            program=program, timeout=goal.timeout, tolerance=goal.tolerance, dwell=goal.dwell
        )
    if isinstance(goal, FollowPathGoal):
        return FollowPath.Goal(
            tilt_waypoints=list(goal.tilt),
            gravity_waypoints=[Vector3(x=g[0], y=g[1], z=g[2]) for g in goal.gravity],
        )
    raise TypeError(f"not a goal: {goal!r}")
