"""A device's streams: the publishers its model needs, made at configure and destroyed at cleanup."""

from __future__ import annotations

from typing import Any

from rclpy.lifecycle import LifecycleNode
from rclpy.publisher import Publisher
from rclpy.qos import QoSProfile

__all__ = ["Streams"]


class Streams:
    """The publishers a device made in ``configure_device``, each remembered with its kind.

    A lifecycle publisher (live only while active) is destroyed as one: ``destroy_lifecycle_publisher`` also
    drops it from the node's managed entities, which would otherwise keep it past its model.
    """

    def __init__(self, node: LifecycleNode) -> None:
        self.node = node
        self._made: list[tuple[Publisher, bool]] = []

    def make(self, msg_type: Any, topic: str, qos: QoSProfile | int, *, lifecycle: bool = True) -> Publisher:
        """Create a publisher (a lifecycle one unless ``lifecycle`` is False) and remember it."""
        make = self.node.create_lifecycle_publisher if lifecycle else self.node.create_publisher
        publisher = make(msg_type, topic, qos)
        self._made.append((publisher, lifecycle))
        return publisher

    def destroy_all(self) -> None:
        """Destroy every publisher made here (cleanup, a failed configure, error, shutdown)."""
        for publisher, lifecycle in self._made:
            if lifecycle:
                self.node.destroy_lifecycle_publisher(publisher)
            else:
                self.node.destroy_publisher(publisher)
        self._made.clear()
