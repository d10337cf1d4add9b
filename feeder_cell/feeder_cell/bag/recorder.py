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
nothing written, before the first ``/clock`` message, as rosbag2 does.

Snapshot mode (``snapshot``): nothing is written as it arrives; messages go to a bounded cache and are
written as a bag of their own under ``path`` on :meth:`Recorder.snapshot` or, with ``snapshot_on_fault``,
when a device's ``~/status`` enters FAULT (:mod:`feeder_cell.bag.snapshot`).
"""

from __future__ import annotations

import math
import os
import re
import threading
import time
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable

from rclpy.node import Node
from rclpy.qos import QoSProfile
from rosbags.interfaces import Connection

from feeder_cell.bag.qos import matching_qos, offered_qos, to_bag_qos
from feeder_cell.bag.snapshot import (
    MAX_PENDING,
    Capture,
    Entry,
    FaultEdge,
    SnapshotCache,
    SnapshotWriter,
    TopicInfo,
    WrittenBag,
    capture_name,
)
from feeder_cell.bag.types import connection_definition, is_known, message_class
from feeder_cell.bag.writer import CHUNK_COMPRESSIONS, BagWriter, FileStats
from feeder_planner.errors import InputError

# Infrastructure topics every node has; recording them by default only adds noise.
DEFAULT_EXCLUDED = ("/rosout", "/parameter_events")

DEFAULT_FLUSH_INTERVAL = 1.0

# Subscription depth: a backlog larger than this between two executor turns (a slow disk, a loaded
# machine) would be dropped by DDS; only a backlog costs its memory.
SUBSCRIPTION_DEPTH = 1000

SERVICE_EVENT_SUFFIX = "/_service_event"
ACTION_TOPIC_SUFFIXES = ("/_action/feedback", "/_action/status")

# MCAP chunk compressions the recorder writes (the names MCAP readers know).
COMPRESSIONS = CHUNK_COMPRESSIONS

DEVICE_STATUS_TYPE = "feeder_msgs/msg/DeviceStatus"


def service_of(topic: str) -> str | None:
    """Return the service whose events ``topic`` carries, or None for any other topic."""
    return topic[: -len(SERVICE_EVENT_SUFFIX)] if topic.endswith(SERVICE_EVENT_SUFFIX) else None


def action_of(topic: str) -> str | None:
    """Return the action whose feedback or status ``topic`` carries, or None for any other topic."""
    for suffix in ACTION_TOPIC_SUFFIXES:
        if topic.endswith(suffix):
            return topic[: -len(suffix)]
    return None


def is_hidden(topic: str) -> bool:
    """Return whether a name component starts with an underscore (ROS 2 hides such topics)."""
    return any(part.startswith("_") for part in topic.split("/"))


def _compile(flag: str, pattern: str | None) -> re.Pattern[str] | None:
    if pattern is None:
        return None
    try:
        return re.compile(pattern)
    except re.error as exc:
        raise InputError(flag, f"is not a valid regular expression ({exc}): {pattern!r}") from None


@dataclass(frozen=True)
class Selection:
    """Which topics a recording takes, as ``ros2 bag record`` selects them.

    Parameters
    ----------
    topics
        Topics recorded whatever the other rules say (except ``exclude`` and ``topic_types``).
    all_topics
        Every topic except ``DEFAULT_EXCLUDED``, hidden topics (unless ``include_hidden``) and
        service events.
    regex
        Topics whose name matches this regular expression (``re.search``) are recorded.
    exclude
        Topics (service events and action topics included) matching this regex are never recorded.
    topic_types
        When not empty, only topics of these types (``pkg/msg/Type``); service events are not affected.
    include_hidden
        Hidden topics (a name component starting with ``_``) may be taken by ``all_topics`` and ``regex``.
    services
        None: no service events; empty: every service's; else these services' (names, no suffix).
    actions
        None: no action topics; empty: every action's feedback and status; else these actions'.
    """

    topics: tuple[str, ...] = ()
    all_topics: bool = False
    regex: str | None = None
    exclude: str | None = None
    topic_types: tuple[str, ...] = ()
    include_hidden: bool = False
    services: tuple[str, ...] | None = None
    actions: tuple[str, ...] | None = None

    def __post_init__(self) -> None:
        _compile("--regex", self.regex)
        _compile("--exclude", self.exclude)
        for type_name in self.topic_types:
            if len(type_name.split("/")) != 3:
                raise InputError("--topic-types", f"must name types as pkg/msg/Type, got {type_name!r}")

    def wants(self, topic: str, type_name: str) -> bool:
        """Return whether ``topic`` (of type ``type_name``) is recorded."""
        exclude = _compile("--exclude", self.exclude)
        if exclude is not None and exclude.search(topic):
            return False
        service = service_of(topic)
        if service is not None:
            return self.services is not None and (not self.services or service in self.services)
        action = action_of(topic)
        if action is not None and self.actions is not None and (not self.actions or action in self.actions):
            return True
        if self.topic_types and type_name not in self.topic_types:
            return False
        if topic in self.topics:
            return True
        if is_hidden(topic) and not self.include_hidden:
            return False
        regex = _compile("--regex", self.regex)
        if regex is not None and regex.search(topic):
            return True
        return self.all_topics and topic not in DEFAULT_EXCLUDED


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
    snapshot: bool = False
    max_cache_size: int = 0
    max_cache_duration: float = 0.0
    snapshot_on_fault: bool = False
    post_fault: float = 5.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.flush_interval) and self.flush_interval > 0):
            raise InputError(
                "flush_interval", f"must be a finite number of seconds > 0, got {self.flush_interval}"
            )
        if self.compression not in COMPRESSIONS:
            raise InputError(
                "compression", f"must be one of {', '.join(COMPRESSIONS)}, got {self.compression!r}"
            )
        if not (isinstance(self.max_bag_size, int) and self.max_bag_size >= 0):
            raise InputError(
                "max_bag_size", f"must be a whole number of bytes >= 0, got {self.max_bag_size!r}"
            )
        if not (math.isfinite(self.max_bag_duration) and self.max_bag_duration >= 0):
            raise InputError(
                "max_bag_duration", f"must be a finite number of seconds >= 0, got {self.max_bag_duration}"
            )
        if not (math.isfinite(self.post_fault) and self.post_fault >= 0):
            raise InputError("post_fault", f"must be a finite number of seconds >= 0, got {self.post_fault}")
        if self.selection is None:
            self.selection = Selection(topics=self.topics, all_topics=not self.topics)
        self._lock = threading.Lock()
        self._sync_lock = threading.Lock()
        self._synced = 0  # file position the last fsync covered
        self._connections: dict[str, Connection] = {}
        self._topic_info: dict[str, TopicInfo] = {}
        self._offers: dict[str, _Offer] = {}
        self._subscriptions: dict[str, Any] = {}
        # Per topic the keys of the last SUBSCRIPTION_DEPTH samples written (oldest first, and as a set).
        self._seen: dict[str, tuple[deque[tuple[int, int]], set[tuple[int, int]]]] = {}
        self.dropped_paused = 0  # messages received while paused (not written)
        self.dropped_clock = 0  # messages received while the clock read 0 (a sim clock restarted)
        self._writer: BagWriter | None = None
        self._cache: SnapshotCache | None = None
        self._snapshots: SnapshotWriter | None = None
        self._captures: list[Capture] = []  # fault captures still collecting their post-fault seconds
        self._fault_edge = FaultEdge()
        self._status_subscriptions: dict[str, Any] = {}
        self.skipped_faults = 0  # faults not captured: MAX_PENDING captures were pending already
        self._snapshot_count = 0
        self.cache_stats: dict[str, float] = {}  # the snapshot cache's bounds and peak, once closed
        self.files: list[FileStats] = []
        if self.snapshot or self.snapshot_on_fault:
            self.snapshot = True
            self._cache = SnapshotCache(self.max_cache_size, self.max_cache_duration)
            if self.path.exists() and not self.path.is_dir():
                raise InputError("output", f"{self.path} exists and is not a directory")
            self.path.mkdir(parents=True, exist_ok=True)
            self._snapshots = SnapshotWriter(
                self.path,
                self._known_topics,
                self.compression,
                lambda line: self.node.get_logger().error(line),
            )
        else:
            if self.path.exists():
                raise InputError("output", f"{self.path} already exists; bags are never overwritten")
            self._writer = BagWriter(self.path, self.compression)
            self._writer.open()
            # The header on disk at once: a recorder killed before its first flush leaves an MCAP file.
            self._writer.file.bio.flush()
            self.files = self._writer.files
        self._stop = threading.Event()
        self._flusher = threading.Thread(target=self._flush_loop, name="bag-flusher", daemon=True)
        self._flusher.start()

    def pause(self) -> None:
        """Stop writing: messages received from now on are dropped (subscriptions stay, as rosbag2)."""
        self.paused = True

    def resume(self) -> None:
        """Write received messages again."""
        self.paused = False

    def toggle_paused(self) -> None:
        """Pause when writing, resume when paused."""
        self.paused = not self.paused

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
                self._watch_status(name)
            if not self.selection.wants(name, type_name):
                continue
            if not is_known(type_name):
                continue  # a type we cannot describe in the bag's schema is not silently half-recorded
            offer = self._offer(name)
            if offer is None or offer == self._offers.get(name):
                continue
            self._subscribe(name, type_name, offer)
            changed.append(name)
        return changed

    def subscriptions(self) -> dict[str, Any]:
        """Return the readers by topic (the lockstep observer checks that they matched their publishers)."""
        return dict(self._subscriptions)

    def _offer(self, name: str) -> _Offer | None:
        """Return what a subscription must match now, or None while the topic has no publisher."""
        publishers = self.node.get_publishers_info_by_topic(name)
        if not publishers:
            return None
        offer = _Offer(*offered_qos(publishers))
        previous = self._offers.get(name)
        if previous is not None:
            # Never step back: a latched publisher that went away leaves its samples recorded, and a
            # best-effort reader still matches reliable publishers. Only widening needs a new reader.
            offer = _Offer(previous.reliable and offer.reliable, previous.latched or offer.latched)
        return offer

    def _subscribe(self, name: str, type_name: str, offer: _Offer) -> None:
        qos = self.qos_overrides.get(name) or matching_qos(offer.reliable, offer.latched, SUBSCRIPTION_DEPTH)
        profile = to_bag_qos(offer.reliable, offer.latched)
        with self._lock:
            if self._writer is None and self._cache is None:
                return  # closed
            info = self._topic_info.get(name)
            if info is None:
                msgdef, rihs01 = connection_definition(type_name)
                self._topic_info[name] = TopicInfo(type_name, msgdef, rihs01, (profile,))
                if self._writer is not None:
                    self._connections[name] = self._writer.add_connection(
                        name, type_name, msgdef=msgdef, rihs01=rihs01, offered_qos_profiles=[profile]
                    )
                self.stats[name] = TopicStats(type_name)
            elif profile not in info.profiles:
                # The MCAP channel keeps the profile it was created with; metadata.yaml, written at
                # close, lists every profile the topic's publishers offered, as rosbag2 does.
                self._topic_info[name] = TopicInfo(
                    info.type_name, info.msgdef, info.rihs01, (*info.profiles, profile)
                )
                if name in self._connections:
                    self._connections[name].ext.offered_qos_profiles.append(profile)
            self._offers[name] = offer
        old = self._subscriptions.pop(name, None)
        if old is not None and name in self.qos_overrides:
            self._subscriptions[name] = old  # an overridden profile does not follow the publishers
            return
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
        source = info.get("source_timestamp", 0)
        key = (source, info.get("publication_sequence_number", 0))
        with self._lock:
            if self._writer is None and self._cache is None:
                return
            if self.paused:
                self.dropped_paused += 1
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
            now = self.clock()
            if now <= 0:
                # A sim clock that went back to its start: no cell time to stamp the message with.
                self.dropped_clock += 1
                return
            self.stats[topic].count += 1
            # The publish time is the writer's source timestamp, as rosbag2's send_timestamp.
            publish = source or now
            if self._cache is not None:
                entry = Entry(topic, now, publish, bytes(data))
                self._cache.add(entry)
                for capture in self._captures:
                    if capture.deadline is not None and now <= capture.deadline:
                        capture.post.append(entry)
                if self._captures:
                    self._close_due_captures(now)
                return
            assert self._writer is not None
            if self._split_due(now):
                self._writer.split()
                self._synced = 0
            self._writer.write(self._connections[topic], now, data, publish)

    def _split_due(self, now: int) -> bool:
        current = self.files[-1]
        if not current.count:
            return False  # a file holds at least one message, whatever the limits
        assert self._writer is not None
        if self.max_bag_size and self._writer.file.size() >= self.max_bag_size:
            return True
        # As rosbag2: a file's duration runs from its first message.
        return bool(self.max_bag_duration) and now - current.start >= self.max_bag_duration * 1e9

    # --- snapshot mode -------------------------------------------------------------------------------

    def snapshot_now(self) -> bool:
        """Write the whole cache as a bag and empty it (``~/snapshot``); False if there is nothing to write.

        The bag is written on the snapshot writer's thread; :attr:`written` lists it once complete.
        """
        if self._cache is None or self._snapshots is None:
            return False
        with self._lock:
            if self._pending() >= MAX_PENDING:
                self.node.get_logger().warning(f"snapshot refused: {MAX_PENDING} snapshots are pending")
                return False
            entries = self._cache.take()
            if not entries:
                return False
            self._snapshot_count += 1
            name = capture_name("service", self.clock(), index=self._snapshot_count)
            self._snapshots.submit(Capture(self._snapshots.unique(name), "service", entries))
        return True

    def _known_topics(self) -> dict[str, TopicInfo]:
        """Every subscribed topic's declaration (for the snapshot writer's thread)."""
        with self._lock:
            return dict(self._topic_info)

    def _pending(self) -> int:
        assert self._snapshots is not None
        return len(self._captures) + self._snapshots.pending

    def _watch_status(self, topic: str) -> None:
        if topic in self._status_subscriptions:
            return
        offer = self._offer(topic)
        if offer is None:
            return
        from feeder_msgs.msg import DeviceStatus

        device = topic[: -len("/status")]
        self._status_subscriptions[topic] = self.node.create_subscription(
            DeviceStatus,
            topic,
            lambda msg: self._on_status(device, msg),
            matching_qos(offer.reliable, offer.latched, 10),
        )

    def _on_status(self, device: str, status: Any) -> None:
        if not self._fault_edge.entered_fault(device, int(status.state)):
            return
        if self._cache is None or self._snapshots is None:
            return  # closed
        code, text = int(status.fault_code), str(status.fault_text)
        stamp = status.header.stamp.sec * 1_000_000_000 + status.header.stamp.nanosec
        with self._lock:
            if self._pending() >= MAX_PENDING:
                self.skipped_faults += 1
                self.node.get_logger().warning(
                    f"{device} entered FAULT {code}: not captured, {MAX_PENDING} snapshots are pending"
                )
                return
            name = capture_name("fault", stamp, device=device, fault_code=code)
            self._captures.append(
                Capture(
                    self._snapshots.unique(name),
                    "fault",
                    self._cache.copy(),
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

    def _close_due_captures(self, now: int | None) -> None:
        """Queue captures whose post-fault time has passed (every one if ``now`` is None); lock held."""
        assert self._snapshots is not None
        keep = []
        for capture in self._captures:
            if now is None or capture.deadline is None or now > capture.deadline:
                capture.deadline = None
                self._snapshots.submit(capture)
            else:
                keep.append(capture)
        self._captures = keep

    @property
    def written(self) -> list[WrittenBag]:
        """Return the snapshot bags written so far (snapshot mode)."""
        return list(self._snapshots.written) if self._snapshots is not None else []

    @property
    def cache(self) -> SnapshotCache | None:
        """Return the snapshot cache (snapshot mode), else None."""
        return self._cache

    # --- disk -----------------------------------------------------------------------------------------

    def flush(self) -> None:
        """Close the pending chunk (if it holds a message) and push the file to disk."""
        with self._sync_lock:
            with self._lock:
                if self._writer is None or self._writer.storage is None:
                    return
                storage = self._writer.file
                if storage.chunk.msgs:
                    storage.close_chunk()
                written = storage.bio.tell()
                if written == self._synced:
                    return  # nothing new since the last sync (an idle topic costs no disk writes)
                storage.bio.flush()
                # A duplicate: a split may close the file's own descriptor while this one syncs.
                descriptor = os.dup(storage.bio.fileno())
            # fsync outside the write lock: on a busy disk it takes a while, and the executor writing
            # received messages must not wait on it (its reader queue would overflow).
            try:
                os.fsync(descriptor)
            finally:
                os.close(descriptor)
            with self._lock:
                if self._writer is not None and self._writer.storage is storage:
                    self._synced = written

    def _flush_loop(self) -> None:
        # Half the interval between flushes: a message waits at most that plus one flush's duration. In
        # snapshot mode the loop closes fault captures whose post-fault time passed with no new message.
        period = 0.1 if self.snapshot else self.flush_interval / 2
        while not self._stop.wait(period):
            try:
                if self.snapshot:
                    with self._lock:
                        if self._captures:
                            self._close_due_captures(self.clock())
                else:
                    self.flush()
            except OSError as exc:
                # A full or failing disk: logged at each failed turn, and the next one tries again (the data
                # stays in the writer's buffer), rather than the thread dying with a traceback.
                self.node.get_logger().error(f"bag {self.path}: writing to disk failed: {exc}")

    def close(self) -> dict[str, TopicStats]:
        """Stop recording, finish the bag (summary and metadata.yaml) and return what was recorded.

        In snapshot mode, fault captures still collecting are written with what they hold, and the cache
        itself is dropped, as rosbag2 drops its snapshot buffer at the end.
        """
        self._stop.set()
        self._flusher.join(timeout=10.0)
        for subscription in [*self._subscriptions.values(), *self._status_subscriptions.values()]:
            self.node.destroy_subscription(subscription)
        self._subscriptions.clear()
        self._status_subscriptions.clear()
        if self._snapshots is not None:
            with self._lock:
                self._close_due_captures(None)
                if self._cache is not None:
                    self.cache_stats = {
                        "max_bytes": self._cache.max_bytes,
                        "max_duration": self._cache.max_duration_ns / 1e9,
                        "peak_bytes": self._cache.peak_bytes,
                        "evicted": self._cache.evicted,
                    }
                self._cache = None
            self._snapshots.close()
        with self._sync_lock, self._lock:
            if self._writer is not None:
                self._writer.close()
                self._writer = None
        return self.stats


def missing_topics(stats: dict[str, TopicStats], wanted: Iterable[str]) -> list[str]:
    """Return the wanted topics of which no message was recorded."""
    return sorted(set(wanted) - set(stats))
