"""What the devices say, mirrored into their OPC UA variables: status, goal status, topics, rejections.

Separate from the method calls because it only listens: every callback here runs in the rclpy executor's
thread, records what it heard in the device's ``DeviceLink`` (under the link's lock, and only there) and
posts the values to the server (``GatewayServer.post_all`` is thread-safe). The device's topics and the
variables they set are read from its kind's profile (``kinds.KINDS``).
"""

from __future__ import annotations

import math
import time
from typing import Any

# Generated, untyped, and not in pyproject's list of ROS message modules (outside this change's reach).
from action_msgs.msg import GoalStatus, GoalStatusArray  # type: ignore[import-untyped]
from diagnostic_msgs.msg import DiagnosticArray
from rcl_interfaces.msg import Log
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy

from feeder_cell.gateway.config import is_warning, packml_state
from feeder_cell.gateway.device_link import DeviceLink, executing
from feeder_cell.gateway.layout import UINT32_MODULUS, counter32_path, counter_path
from feeder_cell.gateway.server import GatewayServer
from feeder_cell.gateway.spec import KindProfile, StreamLink, Values
from feeder_msgs.msg import DeviceStatus
from feeder_planner.node_kit import LATCHED, STREAM_DEPTH

__all__ = ["DeviceListener", "status_values"]


def _ns(stamp: Any) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


class DeviceListener:
    """The gateway's subscriptions: each device's status, goal status and topics; /rosout, /diagnostics."""

    def __init__(self, node: Node, server: GatewayServer, links: dict[str, DeviceLink]) -> None:
        self.node, self.server = node, server
        self.links = links  # the ROS link's own dict, filled as the devices are linked
        self.sim_time = bool(node.get_parameter("use_sim_time").value)

    def subscribe(self, link: DeviceLink) -> None:
        """Subscribe to the device's status, its action's goal status and the topics of its profile."""
        node, name = self.node, link.entry.node
        action = link.profile.action
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

    def subscribe_cell(self) -> None:
        """Subscribe to /rosout and /diagnostics: the devices' reasons for a rejected goal."""
        rosout_qos = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
        self.node.create_subscription(Log, "/rosout", self._on_rosout, rosout_qos)
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self._on_diagnostics, 10)

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

    def _post_all(self, link: DeviceLink, values: Values, stamp_ns: int = 0) -> None:
        self.server.post_all(link.entry.key, values, stamp_ns)

    def _on_status(self, link: DeviceLink, msg: DeviceStatus) -> None:
        stamp = _ns(msg.header.stamp)
        back, show_busy = _record_status(link, msg)
        if back:
            self.node.get_logger().info(f"{link.entry.node}: reporting again ({msg.state_name})")
        values = status_values(link.profile, msg)
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


def _record_status(link: DeviceLink, msg: DeviceStatus) -> tuple[bool, bool]:
    """Record a status in the link; return (the device is back after silence, show the goal's Busy now)."""
    is_executing = executing(int(msg.state), bool(msg.busy))
    with link.lock:
        link.state, link.ready, link.state_name = int(msg.state), bool(msg.ready), msg.state_name
        link.busy = bool(msg.busy)
        link.fault_code = int(msg.fault_code)
        link.fault_text = msg.fault_text
        back = not link.online and link.heard > -math.inf
        link.heard = time.monotonic()
        link.online = True
        show_busy = link.goal is not None and not link.busy_shown and is_executing
        if show_busy:
            link.busy_shown = True
    return back, show_busy


def status_values(profile: KindProfile, msg: DeviceStatus) -> Values:
    """Return the Status variables (and the kind's known counters) a DeviceStatus sets."""
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
    known = profile.counter_names
    for name, value in zip(msg.counter_names, msg.counter_values, strict=False):
        if name in known:
            values[counter_path(name)] = int(value)
            values[counter32_path(name)] = int(value) % UINT32_MODULUS
    return values
