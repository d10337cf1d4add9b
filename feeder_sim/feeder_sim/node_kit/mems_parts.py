"""The MEMS field array's part services: ~/place_parts, ~/spawn_part and ~/remove_part.

What the parts on the array are is the model's (``mems.placing``, ``mems.spawning``; docs/mems.md, "Parts
at runtime"); this is the ROS side of changing them: the refusals (not ready, a goal executing), the
request limits, the counters and the log lines. The node serves them (``ArrayPartServices(node)``) and
reaches nothing of them otherwise.
"""

from __future__ import annotations

from typing import Protocol

from rclpy.impl.rcutils_logger import RcutilsLogger

from feeder_device.declarations import Counters, DeviceError
from feeder_msgs.srv import MemsPlaceParts, MemsRemovePart, MemsSpawnPart
from feeder_planner.node_kit.request_limits import MAX_NAMES, MAX_YAML_CHARS, check_count, check_text
from feeder_sim.mems import Scene
from feeder_sim.mems.parameters import MemsParameters
from feeder_sim.mems.spawning import ArrayParts
from feeder_sim.mems.station import MemsStation

__all__ = ["ArrayPartServices", "PartsArray"]


class PartsArray(Protocol):
    """What the part services need of the MEMS node (a protocol: no import of the node module)."""

    scene: Scene | None
    station: MemsStation | None
    array_parts: ArrayParts | None
    count: Counters

    @property
    def p(self) -> MemsParameters:
        """The node's parameters."""
        ...

    @property
    def names(self) -> list[str]:
        """The names of the parts on the array, in the order of the scene's bodies."""
        ...

    def goal_executing(self) -> bool:
        """Whether a ~/run_program goal executes."""
        ...

    def require_ready(self, what: str) -> None:
        """Raise DeviceError naming ``what`` unless the device is ready."""
        ...

    def parts_changed(self) -> None:
        """Forget per-index work and republish ~/parts after the parts changed."""
        ...

    def publish_status(self, force: bool = False) -> None:
        """Publish ~/status."""
        ...

    def get_logger(self) -> RcutilsLogger:
        """Return the node's logger."""
        ...


class ArrayPartServices:
    """The handlers of the array's three part services (the node serves them, refused unless ready)."""

    def __init__(self, node: PartsArray) -> None:
        self.node = node

    def on_place_parts(
        self, request: MemsPlaceParts.Request, response: MemsPlaceParts.Response
    ) -> MemsPlaceParts.Response:
        """Put named parts at requested poses at rest, or reset: the array as configured (docs/mems.md)."""
        node = self.node
        node.require_ready("place_parts")
        station = node.station
        assert station is not None and node.array_parts is not None  # ready implies configured
        parts = node.array_parts
        if request.reset:
            if node.goal_executing() and not parts.as_configured():
                raise DeviceError(
                    "place_parts reset refused: a ~/run_program goal is executing, and the reset would take "
                    "spawned parts off the array or bring removed ones back; cancel the goal first"
                )
            if parts.reset():
                node.parts_changed()
        else:
            check_count(len(request.names), MAX_NAMES, "names", "names")
            station.place(list(request.names), list(request.x), list(request.y), list(request.theta))
        node.count.add("placements")
        node.publish_status()
        return response

    def on_spawn_part(
        self, request: MemsSpawnPart.Request, response: MemsSpawnPart.Response
    ) -> MemsSpawnPart.Response:
        """Add a part at rest at a pose; it moves with the field from the next tick (docs/mems.md)."""
        node = self.node
        self._require_no_goal("spawn_part")
        assert node.array_parts is not None and node.station is not None  # ready implies configured
        check_text(request.part_yaml, MAX_YAML_CHARS, "part_yaml")
        reach = node.station.reach()
        pose = (request.x, request.y, request.theta)
        entry = node.array_parts.spawn(request.name, request.part_yaml, request.source, pose, reach)
        node.parts_changed()
        node.count.add("spawned")
        source = f" from {entry.source}" if entry.source else ""
        node.get_logger().info(
            f"spawn_part: {entry.name!r}{source} at x {pose[0]:.6g} m, y {pose[1]:.6g} m, "
            f"theta {pose[2]:.6g} rad"
        )
        node.publish_status()
        response.name = entry.name
        return response

    def on_remove_part(
        self, request: MemsRemovePart.Request, response: MemsRemovePart.Response
    ) -> MemsRemovePart.Response:
        """Take a part (configured or spawned) off the array by name."""
        node = self.node
        self._require_no_goal("remove_part")
        assert node.array_parts is not None  # ready implies configured
        entry = node.array_parts.remove(request.name)
        node.parts_changed()
        node.count.add("removed")
        node.get_logger().info(f"remove_part: {entry.name!r} taken off the array")
        node.publish_status()
        return response

    def _require_no_goal(self, what: str) -> None:
        """Refuse ``what`` unless the device is ready and no ~/run_program goal executes."""
        self.node.require_ready(what)
        if self.node.goal_executing():
            raise DeviceError(f"{what} refused: a ~/run_program goal is executing; cancel it first")
