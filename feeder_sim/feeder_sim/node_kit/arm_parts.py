"""The throwing arm's part services: ~/place_part and ~/load_part.

Where the part is and which part it is are the model's (``throwing.cycle``, ``throwing.loading``;
docs/throwing.md); this is the ROS side of changing them: when they are accepted (ready, or in FAULT
when the only cause is a part lost, which placing ends; never while a ~/feed_part goal executes), the
request limits, the counters and the log line. The node serves them (``ArmPartServices(node)``).
"""

from __future__ import annotations

from typing import Protocol

from rclpy.impl.rcutils_logger import RcutilsLogger

from feeder_device.declarations import ActiveFault, Counters, DeviceError
from feeder_msgs.msg import DeviceStatus, ThrowEvent
from feeder_msgs.srv import ArmLoadPart, ArmPlacePart
from feeder_planner.node_kit.request_limits import MAX_YAML_CHARS, check_text
from feeder_sim.throwing.cycle import Pose, ThrowCycle
from feeder_sim.throwing.feeding import FeedGoal
from feeder_sim.throwing.loading import HeldPart, load_arm_part
from feeder_sim.throwing.parameters import ArmParameters
from feeder_sim.throwing.station import ArmStation

__all__ = ["ArmPartServices", "PartsArm"]


class PartsArm(Protocol):
    """What the part services need of the arm node (a protocol: no import of the node module)."""

    faults: dict[str, ActiveFault]
    model_fault: tuple[int, str] | None
    count: Counters
    held: HeldPart | None
    shown: tuple[Pose, float] | None
    stopped: bool

    @property
    def p(self) -> ArmParameters:
        """The node's parameters."""
        ...

    @property
    def active(self) -> bool:
        """Whether the lifecycle state is active."""
        ...

    @property
    def feed(self) -> FeedGoal[ThrowEvent] | None:
        """The ~/feed_part goal executing, if any."""
        ...

    def model_cycle(self) -> ThrowCycle:
        """Return the throw cycle (DeviceError when unconfigured)."""
        ...

    def model_station(self) -> ArmStation[ThrowEvent]:
        """Return the station (DeviceError when unconfigured)."""
        ...

    def stopping_fault(self) -> tuple[int, str] | None:
        """(code, text) of the fault that stops the device, or None."""
        ...

    def require_ready(self, what: str) -> None:
        """Raise DeviceError naming ``what`` unless the device is ready."""
        ...

    def publish_part(self) -> None:
        """Publish ~/part (latched)."""
        ...

    def publish_status(self, force: bool = False) -> None:
        """Publish ~/status."""
        ...

    def get_logger(self) -> RcutilsLogger:
        """Return the node's logger."""
        ...


class ArmPartServices:
    """The handlers of the arm's two part services (the node serves them)."""

    def __init__(self, node: PartsArm) -> None:
        self.node = node

    def on_place_part(
        self, request: ArmPlacePart.Request, response: ArmPlacePart.Response
    ) -> ArmPlacePart.Response:
        """Put the part at rest at (edge, R), ending any throw being shown; this ends FAULT_PART_LOST."""
        node = self.node
        self._require_place_ready("place_part")
        node.model_station().place(request.edge, request.radius)
        self._part_back()
        node.publish_status()
        return response

    def on_load_part(
        self, request: ArmLoadPart.Request, response: ArmLoadPart.Response
    ) -> ArmLoadPart.Response:
        """Replace the part the arm holds, at rest at (edge, R); ends FAULT_PART_LOST (docs/throwing.md)."""
        node = self.node
        self._require_place_ready("load_part")
        cycle = node.model_cycle()
        if cycle.running or cycle.pending:
            raise DeviceError(
                f"load_part refused: ~/command keeps the arm busy ({cycle.doing()}); ~/command stop first"
            )
        check_text(request.part_yaml, MAX_YAML_CHARS, "part_yaml")
        start = (int(request.edge), float(request.radius))
        held = load_arm_part(cycle, request.part_yaml, request.name, request.source, start, node.p.arm_length)
        node.held = held
        node.shown = None  # the last pose shown was the former part's
        self._part_back()
        node.count.add("parts_loaded")
        source = f" from {held.source}" if held.source else ""
        node.get_logger().info(
            f"load_part: {held.name!r}{source} on edge {cycle.arm.edge} at R {cycle.arm.radius:.6g} m"
        )
        node.publish_part()
        node.publish_status()
        response.name = held.name
        return response

    def _part_back(self) -> None:
        """End FAULT_PART_LOST, injected or raised by the model: a part is on the arm again."""
        self.node.faults.pop("part_lost", None)
        self.node.model_fault = None

    def _require_place_ready(self, what: str) -> None:
        """Accept when ready, or in FAULT when every cause is a part lost (placing ends it); no feed goal."""
        node = self.node
        lost_only = ArmStation.lost_only(node.stopping_fault(), node.faults, DeviceStatus.FAULT_PART_LOST)
        if not (lost_only and node.active and not node.stopped):
            node.require_ready(what)
        if node.feed is not None:
            raise DeviceError(f"{what} refused: a ~/feed_part goal is executing (cancel it first)")
