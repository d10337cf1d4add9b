"""What the simulation node hears of the cell: each device's part list and part states, and ``/tf_static``.

rclpy-facing subscriptions and their callbacks only: a device's latched part list (``~/parts`` of the
array, ``~/part`` of the arm), its state stream taken when a request needs it (``PolledSubscription``:
never a wake-up per sample) and the static frame tree. Separate from ``cell_link``'s calls because it
only listens: what it writes is each ``Device`` and ``cell_frames``, which the link and the world read.
No lock: the callbacks and the requests reading what they wrote run on the node's executor.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from tf2_msgs.msg import TFMessage

from feeder_cell.simulation.entities import EntityState
from feeder_cell.simulation.msgs import nanoseconds
from feeder_msgs.msg import MemsParts, MemsPartStates, Part
from feeder_planner.node_kit import LATCHED
from feeder_planner.node_kit.polled import PolledSubscription
from feeder_planner.node_kit.tf import TF_STATIC_QOS

__all__ = ["Device", "KINDS", "STREAM_QOS", "Observations", "namespace_of"]

# The device kinds the cell simulates: launch parameter name -> (kind, base frame under the namespace).
KINDS = {
    "mems_field_arrays": ("mems_field_array", "mems_array"),
    "throwing_arms": ("throwing_arm", "arm_pivot"),
    "assembly_fixtures": ("assembly_fixture", "fixture_base"),
}
STREAM_QOS = 10


@dataclass
class Device:
    """One device as observed: its part names, the latest state of each, what was set since."""

    fqn: str
    kind: str
    base_frame: str
    parts: list[str] = field(default_factory=list)  # in the device's order
    part_documents: dict[str, Part] = field(default_factory=dict)
    parts_heard: int = 0  # latched part lists heard: a reconfiguration waits for the next one
    states: dict[str, EntityState] = field(default_factory=dict)
    placed: dict[str, EntityState] = field(default_factory=dict)  # set or spawned, not yet ticked
    frame_id: str = ""  # the frame the device's part states are in (from its streams)
    placed_in_cell: bool = False  # its cell_pose read (its base frame known without /tf_static)


def namespace_of(fqn: str) -> str:
    """Return the namespace of a node's fully qualified name, without its slashes ('' at the root)."""
    return fqn.rpartition("/")[0].strip("/")


class Observations:
    """Subscriptions to what the devices publish, and the latest of it: parts, states, static frames."""

    def __init__(self, node: Node) -> None:
        self.node = node
        # A device's state stream, taken when a request needs it (never a wake-up per sample).
        self._streams: dict[str, PolledSubscription] = {}
        self.cell_frames: dict[str, EntityState] = {}  # child frame -> its pose in its parent

    def observe(self, device: Device) -> None:
        """Subscribe to the device's part list and state stream (a fixture has none: its frame is set)."""
        fqn = device.fqn
        if device.kind == "mems_field_array":
            self.node.create_subscription(
                MemsParts, f"{fqn}/parts", lambda m, d=device: self._on_mems_parts(d, m), LATCHED
            )
            self._streams[fqn] = PolledSubscription(
                self.node,
                MemsPartStates,
                f"{fqn}/part_states",
                functools.partial(self._on_part_states, device),
                STREAM_QOS,
            )
        elif device.kind == "throwing_arm":
            self.node.create_subscription(
                Part, f"{fqn}/part", lambda m, d=device: self._on_arm_part(d, m), LATCHED
            )
            self._streams[fqn] = PolledSubscription(
                self.node,
                PoseStamped,
                f"{fqn}/part_pose",
                functools.partial(self._on_part_pose, device),
                STREAM_QOS,
            )
        else:  # the fixture: its bodies are those of the assembly its assembly_file parameter names
            namespace = namespace_of(fqn)
            device.frame_id = f"{namespace}/assembly" if namespace else "assembly"

    def observe_tf_static(self) -> None:
        """Subscribe to ``/tf_static``: every static transform seen is kept in ``cell_frames``."""
        self.node.create_subscription(TFMessage, "/tf_static", self._on_tf_static, TF_STATIC_QOS)

    def _on_tf_static(self, msg: TFMessage) -> None:
        for transform in msg.transforms:
            t, r = transform.transform.translation, transform.transform.rotation
            self.cell_frames[transform.child_frame_id] = EntityState(
                transform.header.frame_id,
                nanoseconds(transform.header.stamp),
                (t.x, t.y, t.z),
                (r.x, r.y, r.z, r.w),
            )

    def _on_mems_parts(self, device: Device, msg: MemsParts) -> None:
        device.parts = [part.name for part in msg.parts]
        device.part_documents = {part.name: part for part in msg.parts}
        device.parts_heard += 1

    def _on_part_states(self, device: Device, msg: MemsPartStates) -> None:
        stamp = nanoseconds(msg.header.stamp)
        device.frame_id = msg.header.frame_id
        for part in msg.parts:
            p, q = part.pose.position, part.pose.orientation
            v, w = part.twist.linear, part.twist.angular
            device.states[part.name] = EntityState(
                msg.header.frame_id,
                stamp,
                (p.x, p.y, p.z),
                (q.x, q.y, q.z, q.w),
                (v.x, v.y, v.z),
                (w.x, w.y, w.z),
            )
            self._forget_placed(device, part.name, stamp)

    def _on_arm_part(self, device: Device, msg: Part) -> None:
        device.parts = [msg.name]
        device.part_documents = {msg.name: msg}

    def _on_part_pose(self, device: Device, msg: PoseStamped) -> None:
        stamp = nanoseconds(msg.header.stamp)
        device.frame_id = msg.header.frame_id
        p, q = msg.pose.position, msg.pose.orientation
        for name in device.parts:
            device.states[name] = EntityState(
                msg.header.frame_id, stamp, (p.x, p.y, p.z), (q.x, q.y, q.z, q.w)
            )
            self._forget_placed(device, name, stamp)

    @staticmethod
    def _forget_placed(device: Device, name: str, stamp: int) -> None:
        placed = device.placed.get(name)
        if placed is not None and stamp > placed.stamp_ns:
            del device.placed[name]

    def refresh(self, device: Device) -> None:
        """Take the device's state samples queued since the last look (its states and frame follow them)."""
        stream = self._streams.get(device.fqn)
        if stream is not None:
            stream.take()

    def state_of(self, device: Device, name: str) -> EntityState | None:
        """Return a part's latest state: what was placed since the last sample, else the last sample."""
        self.refresh(device)
        return device.placed.get(name) or device.states.get(name)
