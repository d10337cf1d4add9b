"""Record live topics into a rosbag2 MCAP bag, byte for byte (raw CDR), with their publishers' QoS."""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable

from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rosbags.rosbag2 import StoragePlugin, Writer

from feeder_cell.bag.qos import to_bag_qos
from feeder_cell.bag.types import message_class, typestore
from feeder_planner.errors import InputError

# Infrastructure topics every node has; recording them by default only adds noise.
DEFAULT_EXCLUDED = ("/rosout", "/parameter_events")


@dataclass
class TopicStats:
    """Messages and bytes recorded on one topic."""

    type_name: str
    count: int = 0


@dataclass
class Recorder:
    """Subscribes raw to topics as they are discovered and writes every message it receives."""

    node: Node
    path: Path
    topics: tuple[str, ...] = ()  # empty: every topic except DEFAULT_EXCLUDED
    stats: dict[str, TopicStats] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.path.exists():
            raise InputError("output", f"{self.path} already exists; bags are never overwritten")
        self._writer = Writer(self.path, version=9, storage_plugin=StoragePlugin.MCAP)
        self._writer.open()
        self._lock = threading.Lock()
        self._connections: dict[str, object] = {}
        self._subscriptions: list = []

    def discover(self) -> list[str]:
        """Subscribe to matching topics that appeared since the last call; returns the new ones."""
        added = []
        for name, types in self.node.get_topic_names_and_types():
            if name in self._connections or not self._wanted(name) or len(types) != 1:
                continue
            type_name = types[0]
            if type_name not in typestore().fielddefs:
                continue  # a type we cannot describe in the bag's schema is not silently half-recorded
            self._subscribe(name, type_name)
            added.append(name)
        return added

    def _wanted(self, name: str) -> bool:
        if self.topics:
            return name in self.topics
        return name not in DEFAULT_EXCLUDED and "/_action/" not in name

    def _subscribe(self, name: str, type_name: str) -> None:
        publishers = self.node.get_publishers_info_by_topic(name)
        reliable = (
            all(p.qos_profile.reliability == ReliabilityPolicy.RELIABLE for p in publishers)
            if publishers
            else True
        )
        latched = any(p.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for p in publishers)
        qos = QoSProfile(
            depth=100,
            reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
            durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE,
        )
        with self._lock:
            self._connections[name] = self._writer.add_connection(
                name, type_name, typestore=typestore(), offered_qos_profiles=[to_bag_qos(reliable, latched)]
            )
            self.stats[name] = TopicStats(type_name)
        callback = lambda data, topic=name: self._write(topic, data)  # noqa: E731
        self._subscriptions.append(
            self.node.create_subscription(message_class(type_name), name, callback, qos, raw=True)
        )

    def _write(self, topic: str, data: bytes) -> None:
        with self._lock:
            if self._writer is None:
                return
            self._writer.write(self._connections[topic], time.time_ns(), data)
            self.stats[topic].count += 1

    def close(self) -> dict[str, TopicStats]:
        """Stop recording, finish the bag and return what was recorded per topic."""
        for subscription in self._subscriptions:
            self.node.destroy_subscription(subscription)
        with self._lock:
            if self._writer is not None:
                self._writer.close()
                self._writer = None
        return self.stats


def missing_topics(stats: dict[str, TopicStats], wanted: Iterable[str]) -> list[str]:
    """Return the wanted topics of which no message was recorded."""
    return sorted(set(wanted) - set(stats))
