"""Snapshots a device's FAULT triggers: its ``~/status`` watched, the cache copied, the next seconds added.

With ``snapshot_on_fault`` the recorder watches every device's ``~/status`` it discovers; when one enters
FAULT, the snapshot cache is copied into a capture that collects the messages of the next ``post_fault``
seconds (on the recorder's clock) and is then handed to the snapshot writer. At most ``MAX_PENDING``
captures are open or waiting; a fault beyond that is counted (``skipped``) and logged, not captured.
Separate from the snapshot mode's cache and its on-demand snapshots (``snapshot_mode``): this is the
watch that triggers captures and the captures still collecting.

Locking: ``lock`` is the recorder's (the same object); it guards ``captures`` (and the cache it copies),
as it did when they were the recorder's own. Methods marked "the lock held" expect the caller to hold it.
"""

from __future__ import annotations

import threading
from typing import Any, Callable, Protocol

from rclpy.node import Node

from feeder_cell.bag.qos import matching_qos
from feeder_cell.bag.snapshot import (
    MAX_PENDING,
    Capture,
    Entry,
    FaultEdge,
    SnapshotCache,
    SnapshotWriter,
    capture_name,
)
from feeder_cell.bag.topic_readers import Offer

__all__ = ["CacheHolder", "FaultCaptures"]


class CacheHolder(Protocol):
    """Who holds the snapshot cache: None once the recording is closed."""

    cache: SnapshotCache | None


class FaultCaptures:
    """The status watch and the fault captures still collecting their post-fault seconds."""

    def __init__(
        self,
        node: Node,
        lock: threading.Lock,
        holder: CacheHolder,
        snapshots: SnapshotWriter,
        clock: Callable[[], int],
        post_fault: float,
        offer_of: Callable[[str], Offer | None],
    ) -> None:
        self.node = node
        self.lock = lock
        self.holder = holder
        self.snapshots = snapshots
        self.clock = clock
        self.post_fault = post_fault
        self.offer_of = offer_of
        self.captures: list[Capture] = []  # fault captures still collecting their post-fault seconds
        self._fault_edge = FaultEdge()
        self.subscriptions: dict[str, Any] = {}
        self.skipped = 0  # faults not captured: MAX_PENDING captures were pending already

    def pending(self) -> int:
        """Return the captures open or waiting to be written (the lock held)."""
        return len(self.captures) + self.snapshots.pending

    def watch(self, topic: str) -> None:
        """Subscribe to a device's ``~/status`` (once it has a publisher; once per topic)."""
        if topic in self.subscriptions:
            return
        offer = self.offer_of(topic)
        if offer is None:
            return
        from feeder_msgs.msg import DeviceStatus

        device = topic[: -len("/status")]
        self.subscriptions[topic] = self.node.create_subscription(
            DeviceStatus,
            topic,
            lambda msg: self._on_status(device, msg),
            matching_qos(offer.reliable, offer.latched, 10),
        )

    def unwatch(self) -> None:
        """Destroy the status subscriptions."""
        for subscription in self.subscriptions.values():
            self.node.destroy_subscription(subscription)
        self.subscriptions.clear()

    def _on_status(self, device: str, status: Any) -> None:
        if not self._fault_edge.entered_fault(device, int(status.state)):
            return
        if self.holder.cache is None:
            return  # closed
        code, text = int(status.fault_code), str(status.fault_text)
        stamp = status.header.stamp.sec * 1_000_000_000 + status.header.stamp.nanosec
        with self.lock:
            if self.pending() >= MAX_PENDING:
                self.skipped += 1
                self.node.get_logger().warning(
                    f"{device} entered FAULT {code}: not captured, {MAX_PENDING} snapshots are pending"
                )
                return
            name = capture_name("fault", stamp, device=device, fault_code=code)
            self.captures.append(
                Capture(
                    self.snapshots.unique(name),
                    "fault",
                    self.holder.cache.copy(),
                    deadline=self.clock() + round(self.post_fault * 1e9),
                    device=device,
                    fault_code=code,
                    fault_text=text,
                    stamp_ns=stamp,
                )
            )
        self.node.get_logger().info(
            f"{device} entered FAULT {code} ({text}): keeping {self.post_fault:g} s more for its snapshot"
        )

    def collect(self, entry: Entry, now: int) -> None:
        """Add a received message to every capture still collecting; queue those now due (the lock held)."""
        for capture in self.captures:
            if capture.deadline is not None and now <= capture.deadline:
                capture.post.append(entry)
        if self.captures:
            self.close_due(now)

    def close_due(self, now: int | None) -> None:
        """Queue captures whose post-fault time has passed (every one if ``now`` is None); lock held."""
        keep = []
        for capture in self.captures:
            if now is None or capture.deadline is None or now > capture.deadline:
                capture.deadline = None
                self.snapshots.submit(capture)
            else:
                keep.append(capture)
        self.captures = keep
