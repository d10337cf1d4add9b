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

Selection (:class:`Selection`) follows ``ros2 bag record``: explicit topics, all topics, a regex, an
exclude regex, topic types, hidden topics, service events (``<service>/_service_event``) and action
feedback and status (``<action>/_action/feedback``, ``<action>/_action/status``). Splitting
(``max_bag_size``, ``max_bag_duration``) closes the current MCAP file with its summary and goes on in
``<bag>_<n>.mcap``; ``metadata.yaml`` lists every file. Compression is MCAP chunk compression (zstd or
lz4): each chunk is compressed, so any MCAP reader decodes the files and crash safety is unchanged.
The files are written as rosbag2 writes them (:mod:`feeder_cell.bag.writer`).

Clock: log times are receive times on ``clock`` (wall time by default). With a node clock on sim time
(``feeder record --use-sim-time``) they are cell times from ``/clock``, and nothing is subscribed, so
nothing written, before the first ``/clock`` message, as rosbag2 does; each message gets the cell time
of its arrival in the process, not of its callback (``stamp``, :mod:`feeder_cell.bag.receipt_clock`).

Snapshot mode (``snapshot``): nothing is written as it arrives; messages go to a bounded cache and are
written as a bag of their own under ``path`` on :meth:`Recorder.snapshot` or, with ``snapshot_on_fault``,
when a device's ``~/status`` enters FAULT (:mod:`feeder_cell.bag.snapshot`).

This module wires the parts and holds the recording's one lock (see ``Recorder.__post_init__``):
``selection`` (which topics), ``topic_readers`` (readers matching their publishers, repeats dropped),
``topic_table`` (each topic's declaration and count), ``disk_bag`` (writing, splitting, pushing to disk),
``flusher`` (the flush thread), ``snapshot_mode`` and ``fault_captures`` (snapshot mode).
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable

from rclpy.node import Node
from rclpy.qos import QoSProfile

from feeder_cell.bag.disk_bag import DiskBag
from feeder_cell.bag.flusher import Flusher
from feeder_cell.bag.qos import to_bag_qos
from feeder_cell.bag.recording_options import COMPRESSIONS, check_recording_options
from feeder_cell.bag.selection import (
    ACTION_TOPIC_SUFFIXES,
    DEFAULT_EXCLUDED,
    SERVICE_EVENT_SUFFIX,
    Selection,
    action_of,
    is_hidden,
    service_of,
)
from feeder_cell.bag.snapshot import Entry, SnapshotCache, WrittenBag
from feeder_cell.bag.snapshot_mode import SnapshotMode
from feeder_cell.bag.topic_readers import SUBSCRIPTION_DEPTH, Offer, Repeats, TopicReaders
from feeder_cell.bag.topic_table import TopicStats, TopicTable
from feeder_cell.bag.types import is_known
from feeder_cell.bag.writer import FileStats

__all__ = [
    "ACTION_TOPIC_SUFFIXES",
    "COMPRESSIONS",
    "DEFAULT_EXCLUDED",
    "DEFAULT_FLUSH_INTERVAL",
    "DEVICE_STATUS_TYPE",
    "SERVICE_EVENT_SUFFIX",
    "SUBSCRIPTION_DEPTH",
    "Recorder",
    "Selection",
    "TopicStats",
    "action_of",
    "is_hidden",
    "missing_topics",
    "service_of",
]

DEFAULT_FLUSH_INTERVAL = 1.0

DEVICE_STATUS_TYPE = "feeder_msgs/msg/DeviceStatus"


@dataclass
class Recorder:
    """Subscribes raw to topics as they are discovered and writes every message it receives.

    Parameters
    ----------
    node
        The node to subscribe with; the caller spins it (the flusher does not need it spun).
    path
        Bag directory to create (in snapshot mode: the directory of the snapshot bags); an existing bag
        is refused.
    topics
        Topics to record when no ``selection`` is given; empty: every topic except ``DEFAULT_EXCLUDED``
        and hidden ones (action internals, service events).
    flush_interval
        Seconds (> 0): the longest a received message stays in memory before it is on disk.
    selection
        Which topics to record (overrides ``topics``).
    compression
        MCAP chunk compression: ``none``, ``zstd`` or ``lz4``.
    max_bag_size
        Bytes (0: no limit): a file reaching this size is closed and the next one started.
    max_bag_duration
        Seconds (0: no limit): a file spanning this long is closed and the next one started.
    qos_overrides
        Per topic the subscription profile to use instead of the one learned from the publishers.
    paused
        Start paused: messages are received and dropped until :meth:`resume`.
    clock
        Log time source (ns); default wall time.
    wait_for_clock
        Subscribe only once ``clock`` reads more than 0: on sim time, after the first ``/clock`` message.
    stamp
        A message's log time from its receipt info (ns); default ``clock`` when its callback runs. On sim
        time, the cell time when it reached the process (:mod:`feeder_cell.bag.receipt_clock`).
    snapshot
        Snapshot mode: cache messages (bounded by ``max_cache_size`` bytes and ``max_cache_duration``
        seconds, 0 = that bound off) and write them as bags under ``path`` on :meth:`snapshot_now`.
    snapshot_on_fault
        Snapshot mode, and also write a bag when a device's ``~/status`` enters FAULT, with the messages
        of the next ``post_fault`` seconds (on ``clock``).
    """

    node: Node
    path: Path
    topics: tuple[str, ...] = ()
    stats: dict[str, TopicStats] = field(default_factory=dict)
    flush_interval: float = DEFAULT_FLUSH_INTERVAL
    selection: Selection | None = None
    compression: str = "none"
    max_bag_size: int = 0
    max_bag_duration: float = 0.0
    qos_overrides: dict[str, QoSProfile] = field(default_factory=dict)
    paused: bool = False
    clock: Callable[[], int] = time.time_ns
    wait_for_clock: bool = False
    stamp: Callable[[dict[str, int]], int] | None = None
    snapshot: bool = False
    max_cache_size: int = 0
    max_cache_duration: float = 0.0
    snapshot_on_fault: bool = False
    post_fault: float = 5.0

    def __post_init__(self) -> None:
        check_recording_options(
            self.flush_interval, self.compression, self.max_bag_size, self.max_bag_duration, self.post_fault
        )
        if self.selection is None:
            self.selection = Selection(topics=self.topics, all_topics=not self.topics)
        # One lock guards what the executor's writes, the flush thread and the snapshot and fault
        # callbacks share: the bag on disk or the snapshot cache and captures (each given this lock), the
        # topic declarations, the readers' offers, the repeats and the counters.
        self._lock = threading.Lock()
        self._topics = TopicTable(self.stats, self._lock)
        self._readers = TopicReaders(self.node, self.qos_overrides)
        self._repeats = Repeats()
        self.dropped_paused = 0  # messages received while paused (not written)
        self.dropped_clock = 0  # messages received while the clock read 0 (a sim clock restarted)
        self._disk: DiskBag | None = None
        self._snapshot_mode: SnapshotMode | None = None
        self.files: list[FileStats] = []
        if self.snapshot or self.snapshot_on_fault:
            self.snapshot = True
            self._snapshot_mode = SnapshotMode(
                self.node,
                self.path,
                self._lock,
                self.clock,
                self._topics.known,
                self._readers.offer,
                compression=self.compression,
                max_cache_size=self.max_cache_size,
                max_cache_duration=self.max_cache_duration,
                post_fault=self.post_fault,
            )
        else:
            self._disk = DiskBag(
                self.path, self.compression, self.max_bag_size, self.max_bag_duration, self._lock
            )
            self.files = self._disk.files
        # Half the interval between flushes: a message waits at most that plus one flush's duration. In
        # snapshot mode the loop closes fault captures whose post-fault time passed with no new message.
        period = 0.1 if self.snapshot else self.flush_interval / 2
        self._flusher = Flusher(period, self._flush_turn, self._flush_failed)
        self._flusher.start()

    # --- pause and resume ------------------------------------------------------------------------------

    def pause(self) -> None:
        """Stop writing: messages received from now on are dropped (subscriptions stay, as rosbag2)."""
        self.paused = True

    def resume(self) -> None:
        """Write received messages again."""
        self.paused = False

    def toggle_paused(self) -> None:
        """Pause when writing, resume when paused."""
        self.paused = not self.paused

    # --- discovery and subscriptions (``topic_readers``) -----------------------------------------------

    def clock_started(self) -> bool:
        """Return whether the log-time clock runs (always, unless waiting for the first /clock)."""
        return not self.wait_for_clock or self.clock() > 0

    def discover(self) -> list[str]:
        """Subscribe to matching topics that have publishers now; re-check those already subscribed.

        Returns
        -------
        list[str]
            The topics newly subscribed or subscribed again with another profile.
        """
        changed: list[str] = []
        assert self.selection is not None
        if not self.clock_started():
            return changed  # as rosbag2 on sim time: nothing is subscribed before the first /clock
        for name, types in self.node.get_topic_names_and_types():
            if len(types) != 1:
                continue
            type_name = types[0]
            if self.snapshot_on_fault and type_name == DEVICE_STATUS_TYPE and name.endswith("/status"):
                assert self._snapshot_mode is not None
                self._snapshot_mode.faults.watch(name)
            if not self.selection.wants(name, type_name):
                continue
            if not is_known(type_name):
                continue  # a type we cannot describe in the bag's schema is not silently half-recorded
            offer = self._readers.offer(name)
            if offer is None or offer == self._readers.offers.get(name):
                continue
            self._subscribe(name, type_name, offer)
            changed.append(name)
        return changed

    def subscriptions(self) -> dict[str, Any]:
        """Return the readers by topic (the lockstep observer checks that they matched their publishers)."""
        return dict(self._readers.readers)

    def _subscribe(self, name: str, type_name: str, offer: Offer) -> None:
        qos = self._readers.qos(name, offer)
        profile = to_bag_qos(offer.reliable, offer.latched)
        with self._lock:
            if self._closed():
                return  # closed
            self._topics.declare(name, type_name, profile, self._disk)
            self._readers.offers[name] = offer
        self._readers.replace(name, type_name, qos, self._callback_for(name))

    # --- receiving -------------------------------------------------------------------------------------

    def _callback_for(self, topic: str) -> Callable[[bytes, dict[str, int]], None]:
        def callback(data: bytes, info: dict[str, int]) -> None:
            self._write(topic, data, info)

        return callback

    def _closed(self) -> bool:
        """Whether :meth:`close` ran: neither a bag nor a snapshot cache takes messages (the lock held)."""
        disk_closed = self._disk is None or self._disk.writer is None
        return disk_closed and (self._snapshot_mode is None or self._snapshot_mode.cache is None)

    def _write(self, topic: str, data: bytes, info: dict[str, int]) -> None:
        # A sample is known by its writer's timestamp and sequence number: a replacement reader's
        # transient-local history repeats samples the reader it replaced may have received live.
        source = info.get("source_timestamp", 0)
        key = (source, info.get("publication_sequence_number", 0))
        with self._lock:
            if self._closed():
                return
            if self.paused:
                self.dropped_paused += 1
                return
            if key != (0, 0) and self._repeats.seen(topic, key):
                return
            now = self.clock() if self.stamp is None else self.stamp(info)
            if now <= 0:
                # A sim clock that went back to its start: no cell time to stamp the message with.
                self.dropped_clock += 1
                return
            self.stats[topic].count += 1
            # The publish time is the writer's source timestamp, as rosbag2's send_timestamp.
            publish = source or now
            if self._snapshot_mode is not None:
                self._snapshot_mode.add(Entry(topic, now, publish, bytes(data)), now)
                return
            assert self._disk is not None
            self._disk.write(topic, now, data, publish)

    # --- snapshot mode (``snapshot_mode``, ``fault_captures``) -------------------------------------------

    def snapshot_now(self) -> bool:
        """Write the whole cache as a bag and empty it (``~/snapshot``); False if there is nothing to write.

        The bag is written on the snapshot writer's thread; :attr:`written` lists it once complete.
        """
        return self._snapshot_mode.snapshot_now() if self._snapshot_mode is not None else False

    @property
    def written(self) -> list[WrittenBag]:
        """Return the snapshot bags written so far (snapshot mode)."""
        return self._snapshot_mode.written if self._snapshot_mode is not None else []

    @property
    def cache(self) -> SnapshotCache | None:
        """Return the snapshot cache (snapshot mode), else None."""
        return self._snapshot_mode.cache if self._snapshot_mode is not None else None

    @property
    def skipped_faults(self) -> int:
        """Faults not captured: MAX_PENDING captures were pending already (snapshot mode)."""
        return self._snapshot_mode.faults.skipped if self._snapshot_mode is not None else 0

    @property
    def cache_stats(self) -> dict[str, float]:
        """The snapshot cache's bounds and peak, once closed (snapshot mode)."""
        return self._snapshot_mode.cache_stats if self._snapshot_mode is not None else {}

    # --- disk (``disk_bag``, ``flusher``) --------------------------------------------------------------

    def flush(self) -> None:
        """Close the pending chunk (if it holds a message) and push the file to disk."""
        if self._disk is not None:
            self._disk.flush()

    def _flush_turn(self) -> None:
        if self._snapshot_mode is not None:
            self._snapshot_mode.tick()
        else:
            self.flush()

    def _flush_failed(self, exc: OSError) -> None:
        self.node.get_logger().error(f"bag {self.path}: writing to disk failed: {exc}")

    def close(self) -> dict[str, TopicStats]:
        """Stop recording, finish the bag (summary and metadata.yaml) and return what was recorded.

        In snapshot mode, fault captures still collecting are written with what they hold, and the cache
        itself is dropped, as rosbag2 drops its snapshot buffer at the end.
        """
        self._flusher.stop(timeout=10.0)
        self._readers.close()
        if self._snapshot_mode is not None:
            self._snapshot_mode.faults.unwatch()
            self._snapshot_mode.close()
        if self._disk is not None:
            self._disk.close()
        return self.stats


def missing_topics(stats: dict[str, TopicStats], wanted: Iterable[str]) -> list[str]:
    """Return the wanted topics of which no message was recorded."""
    return sorted(set(wanted) - set(stats))
