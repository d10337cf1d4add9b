"""One device's ROS endpoints and what the gateway knows of it (``DeviceLink``), and how they are opened.

A record of its own because every part of the ROS side reads it: the subscriptions (``device_listener``)
and the watchdog write it in the executor's thread, the method calls (``ros_link``, ``command_runner``,
``service_calls``, ``goals``) read and write it from the asyncio loop and the executor. Every field after
``action`` is guarded by the link's own ``lock``, and that lock guards nothing else.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass, field

from lifecycle_msgs.srv import ChangeState
from rclpy.action.client import ClientGoalHandle
from rclpy.client import Client
from rclpy.node import Node
from std_srvs.srv import Trigger

from feeder_cell.gateway.commands import FAULT_SERVICES, TRIGGERS
from feeder_cell.gateway.config import DeviceEntry
from feeder_cell.gateway.kinds import KINDS
from feeder_cell.gateway.spec import Availability, KindProfile
from feeder_msgs.msg import DeviceStatus
from feeder_planner.node_kit.action_client import ActionClient

__all__ = ["DeviceLink", "open_link", "executing"]


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
    # The goal whose feedback was posted last (GoalRunner's token of its send): a goal's cleared feedback
    # must not replace feedback of its own that came before the acceptance was handled.
    feedback_of: object | None = None
    # The goal whose result posted its final feedback (ActionLink.final_feedback): its feedback that comes
    # after the result (another DDS writer) is older than what the result settled, and is not posted.
    settled_by_result: object | None = None
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


def open_link(node: Node, entry: DeviceEntry) -> DeviceLink:
    """Create the device's clients (its commands', its methods', its action's) on the gateway's node."""
    name = entry.node
    profile = KINDS[entry.kind]
    action = profile.action
    return DeviceLink(
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


def executing(state: int, busy: bool) -> bool:
    """Whether a DeviceStatus shows the device executing (RUNNING, PackML Execute, or busy)."""
    return busy or state == DeviceStatus.RUNNING
