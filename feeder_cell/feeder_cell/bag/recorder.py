"""Record live topics into a rosbag2 MCAP bag, byte for byte (raw CDR), with their publishers' QoS.

Crash safety: the MCAP writer of rosbags keeps its current chunk in memory until it holds 1 MiB, so a
killed recorder would lose everything since the last full chunk. A flusher thread closes the pending
chunk and flushes (and fsyncs) the file at least every ``flush_interval`` seconds, whatever the data
rate; a killed recording then loses at most that interval and ``feeder bag-reindex`` rebuilds its
summary and ``metadata.yaml`` from the chunks on disk.

Durability: a topic is subscribed only once it has a publisher (a subscriber alone makes a topic name
visible, with no QoS to learn from), with the publishers' reliability and durability, and re-checked on
every :meth:`Recorder.discover`: a newly appeared latched or best-effort publisher makes the recorder
subscribe again with a profile that matches it.
"""

from __future__ import annotations

import math
import os
import threading
import time
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable

from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rosbags.rosbag2 import StoragePlugin, Writer

from feeder_cell.bag.qos import to_bag_qos
from feeder_cell.bag.types import message_class, typestore
from feeder_planner.errors import InputError

# Infrastructure topics every node has; recording them by default only adds noise.
DEFAULT_EXCLUDED = ("/rosout", "/parameter_events")

DEFAULT_FLUSH_INTERVAL = 1.0

# Subscription depth: a backlog larger than this between two executor turns (a slow disk, a loaded
# machine) would be dropped by DDS; only a backlog costs its memory.
SUBSCRIPTION_DEPTH = 1000


@dataclass
class TopicStats:
    """Messages recorded on one topic."""

    type_name: str
    count: int = 0


@dataclass(frozen=True)
class _Offer:
    """What a topic's publishers offer, as far as a subscription must match it."""

    reliable: bool  # every publisher reliable (one best-effort publisher needs a best-effort reader)
    latched: bool  # any publisher transient-local (its stored samples are wanted)


@dataclass
class Recorder:
    """Subscribes raw to topics as they are discovered and writes every message it receives.

    Parameters
    ----------
    node
        The node to subscribe with; the caller spins it (the flusher does not need it spun).
    path
        Bag directory to create; an existing path is refused.
    topics
        Topics to record; empty: every topic except ``DEFAULT_EXCLUDED`` and action internals.
    flush_interval
        Seconds (> 0): the longest a received message stays in memory before it is on disk.
    """

    node: Node
    path: Path
    topics: tuple[str, ...] = ()
    stats: dict[str, TopicStats] = field(default_factory=dict)
    flush_interval: float = DEFAULT_FLUSH_INTERVAL

    def __post_init__(self) -> None:
        if not (math.isfinite(self.flush_interval) and self.flush_interval > 0):
            raise InputError(
                "flush_interval", f"must be a finite number of seconds > 0, got {self.flush_interval}"
            )
        if self.path.exists():
            raise InputError("output", f"{self.path} already exists; bags are never overwritten")
        self._writer: Writer | None = Writer(self.path, version=9, storage_plugin=StoragePlugin.MCAP)
        self._writer.open()
        # The chunk boundary is forced through the storage's own close_chunk (rosbags 0.11): fail here,
        # not after a crash, if a rosbags version no longer has it.
        storage = self._writer.storage
        if not (hasattr(storage, "close_chunk") and hasattr(storage, "chunk") and hasattr(storage, "bio")):
            self._writer.close()
            raise RuntimeError("this rosbags version's MCAP writer cannot be flushed chunk by chunk")
        # The header on disk at once: a recorder killed before its first flush leaves an MCAP file.
        storage.bio.flush()
        self._lock = threading.Lock()
        self._sync_lock = threading.Lock()
        self._synced = 0  # file position the last fsync covered
        self._connections: dict[str, Any] = {}
        self._offers: dict[str, _Offer] = {}
        self._subscriptions: dict[str, Any] = {}
        # Per topic the keys of the last SUBSCRIPTION_DEPTH samples written (oldest first, and as a set).
        self._seen: dict[str, tuple[deque[tuple[int, int]], set[tuple[int, int]]]] = {}
        self._stop = threading.Event()
        self._flusher = threading.Thread(target=self._flush_loop, name="bag-flusher", daemon=True)
        self._flusher.start()

    def discover(self) -> list[str]:
        """Subscribe to matching topics that have publishers now; re-check those already subscribed.

        Returns
        -------
        list[str]
            The topics newly subscribed or subscribed again with another profile.
        """
        changed = []
        for name, types in self.node.get_topic_names_and_types():
            if not self._wanted(name) or len(types) != 1:
                continue
            type_name = types[0]
            if type_name not in typestore().fielddefs:
                continue  # a type we cannot describe in the bag's schema is not silently half-recorded
            offer = self._offer(name)
            if offer is None or offer == self._offers.get(name):
                continue
            self._subscribe(name, type_name, offer)
            changed.append(name)
        return changed

    def _wanted(self, name: str) -> bool:
        if self.topics:
            return name in self.topics
        return name not in DEFAULT_EXCLUDED and "/_action/" not in name

    def _offer(self, name: str) -> _Offer | None:
        """Return what a subscription must match now, or None while the topic has no publisher."""
        publishers = self.node.get_publishers_info_by_topic(name)
        if not publishers:
            return None
        offer = _Offer(
            reliable=all(p.qos_profile.reliability == ReliabilityPolicy.RELIABLE for p in publishers),
            latched=any(p.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for p in publishers),
        )
        previous = self._offers.get(name)
        if previous is not None:
            # Never step back: a latched publisher that went away leaves its samples recorded, and a
            # best-effort reader still matches reliable publishers. Only widening needs a new reader.
            offer = _Offer(previous.reliable and offer.reliable, previous.latched or offer.latched)
        return offer

    def _subscribe(self, name: str, type_name: str, offer: _Offer) -> None:
        qos = QoSProfile(
            depth=SUBSCRIPTION_DEPTH,
            reliability=ReliabilityPolicy.RELIABLE if offer.reliable else ReliabilityPolicy.BEST_EFFORT,
            durability=DurabilityPolicy.TRANSIENT_LOCAL if offer.latched else DurabilityPolicy.VOLATILE,
        )
        profile = to_bag_qos(offer.reliable, offer.latched)
        with self._lock:
            if self._writer is None:
                return
            if name not in self._connections:
                self._connections[name] = self._writer.add_connection(
                    name, type_name, typestore=typestore(), offered_qos_profiles=[profile]
                )
                self.stats[name] = TopicStats(type_name)
            else:
                # The MCAP channel keeps the profile it was created with; metadata.yaml, written at
                # close, lists every profile the topic's publishers offered, as rosbag2 does.
                profiles = self._connections[name].ext.offered_qos_profiles
                if profile not in profiles:
                    profiles.append(profile)
            self._offers[name] = offer
        old = self._subscriptions.pop(name, None)
        if old is not None:
            # Replaced before the new reader exists: a gap of a few milliseconds for volatile samples;
            # a latched publisher's samples come again from its history (repeats are dropped by key).
            self.node.destroy_subscription(old)
        self._subscriptions[name] = self.node.create_subscription(
            message_class(type_name), name, self._callback_for(name), qos, raw=True
        )

    def _callback_for(self, topic: str) -> Callable[[bytes, dict[str, int]], None]:
        def callback(data: bytes, info: dict[str, int]) -> None:
            self._write(topic, data, info)

        return callback

    def _write(self, topic: str, data: bytes, info: dict[str, int]) -> None:
        # A sample is known by its writer's timestamp and sequence number: a replacement reader's
        # transient-local history repeats samples the reader it replaced may have received live.
        key = (info.get("source_timestamp", 0), info.get("publication_sequence_number", 0))
        with self._lock:
            if self._writer is None:
                return
            if key != (0, 0):
                seen = self._seen.setdefault(topic, (deque(maxlen=SUBSCRIPTION_DEPTH), set()))
                recent, keys = seen
                if key in keys:
                    return
                if len(recent) == recent.maxlen:
                    keys.discard(recent[0])
                recent.append(key)
                keys.add(key)
            self._writer.write(self._connections[topic], time.time_ns(), data)
            self.stats[topic].count += 1

    def flush(self) -> None:
        """Close the pending chunk (if it holds a message) and push the file to disk."""
        with self._sync_lock:
            with self._lock:
                if self._writer is None:
                    return
                storage = self._writer.storage
                if storage.chunk.msgs:
                    storage.close_chunk()
                written = storage.bio.tell()
                if written == self._synced:
                    return  # nothing new since the last sync (an idle topic costs no disk writes)
                storage.bio.flush()
                descriptor = storage.bio.fileno()
            # fsync outside the write lock: on a busy disk it takes a while, and the executor writing
            # received messages must not wait on it (its reader queue would overflow). The sync lock
            # keeps close() from closing the descriptor meanwhile.
            os.fsync(descriptor)
            self._synced = written

    def _flush_loop(self) -> None:
        # Half the interval between flushes: a message waits at most that plus one flush's duration.
        while not self._stop.wait(self.flush_interval / 2):
            try:
                self.flush()
            except OSError as exc:
                # A full or failing disk: logged at each failed turn, and the next one tries again (the data
                # stays in the writer's buffer), rather than the thread dying with a traceback.
                self.node.get_logger().error(f"bag {self.path}: writing to disk failed: {exc}")

    def close(self) -> dict[str, TopicStats]:
        """Stop recording, finish the bag (summary and metadata.yaml) and return what was recorded."""
        self._stop.set()
        self._flusher.join(timeout=10.0)
        for subscription in self._subscriptions.values():
            self.node.destroy_subscription(subscription)
        self._subscriptions.clear()
        with self._sync_lock, self._lock:
            if self._writer is not None:
                self._writer.close()
                self._writer = None
        return self.stats


def missing_topics(stats: dict[str, TopicStats], wanted: Iterable[str]) -> list[str]:
    """Return the wanted topics of which no message was recorded."""
    return sorted(set(wanted) - set(stats))
