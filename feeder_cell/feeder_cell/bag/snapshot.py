"""Snapshot mode and the flight recorder: a bounded in-memory cache of recent messages, written out on demand.

rosbag2's snapshot mode (``ros2 bag record --snapshot-mode --max-cache-size B --max-cache-duration S``)
keeps the newest messages in a ring buffer and writes it when the recorder's ``~/snapshot`` service is
called. Here the cache is :class:`SnapshotCache`, bounded by both limits at once (0 turns one off):

- bytes: every message costs its CDR bytes plus :data:`ENTRY_OVERHEAD`, what Python keeps per message
  beside them (measured with tracemalloc: about 200 bytes for a tuple of topic, two times and the data),
  so that the bound is one on memory even for a topic of 5-byte Bools; rosbag2 counts the data only;
- duration: messages older than the newest one's log time minus the duration are dropped (log time is
  the recorder's clock: cell time with ``--use-sim-time``).

A snapshot (:class:`Capture`) is written as a bag of its own (:class:`SnapshotWriter`, a background
thread, so that the executor keeps receiving): ``~/snapshot`` takes the whole cache and empties it, as
rosbag2's double buffer does. A fault capture (``--snapshot-on-fault``) copies the cache when a device's
``~/status`` enters FAULT (the messages are shared, not copied) and adds every message of the next
``post_fault`` seconds before it is written; the cache goes on unchanged, so two faults close together
each get a complete bag. At most :data:`MAX_PENDING` captures are open or waiting to be written at once;
a fault beyond that is counted and logged, not captured, so that a device flapping in and out of FAULT
cannot hold unbounded memory. A bag being written is ``.NAME.partial`` until it is complete.
"""

from __future__ import annotations

import math
import os
import queue
import re
import shutil
import threading
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, NamedTuple

from feeder_planner.errors import InputError

if TYPE_CHECKING:
    from rosbags.interfaces import Connection, Qos

__all__ = [
    "ENTRY_OVERHEAD",
    "MAX_PENDING",
    "Capture",
    "Entry",
    "FaultEdge",
    "SnapshotCache",
    "SnapshotWriter",
    "TopicInfo",
    "capture_name",
    "check_cache_limits",
]

# Bytes of Python bookkeeping per cached message beside its data (tuple, two ints, the bytes header and
# the deque slot; tracemalloc over 100,000 entries: 201 bytes with 8 data bytes).
ENTRY_OVERHEAD = 200

# Captures open (collecting their post-fault seconds) or queued for writing, at most.
MAX_PENDING = 8

# rosbag2's default --max-cache-size (100 MiB).
DEFAULT_MAX_CACHE_SIZE = 100 * 1024 * 1024

# feeder_msgs/msg/DeviceStatus.FAULT
FAULT_STATE = 4


class Entry(NamedTuple):
    """One cached message: its topic, log time and publish time (ns) and CDR bytes."""

    topic: str
    log_time: int
    publish_time: int
    data: bytes


@dataclass(frozen=True)
class TopicInfo:
    """What a bag needs to declare a topic: type, definition, type hash and the offered QoS profiles."""

    type_name: str
    msgdef: str
    rihs01: str
    profiles: tuple[Qos, ...]


def check_cache_limits(max_bytes: int, max_duration: float) -> None:
    """Refuse limits that are negative, not finite or both off (naming the flag)."""
    if not (isinstance(max_bytes, int) and max_bytes >= 0):
        raise InputError("--max-cache-size", f"must be a whole number of bytes >= 0, got {max_bytes!r}")
    if not (math.isfinite(max_duration) and max_duration >= 0):
        raise InputError(
            "--max-cache-duration", f"must be a finite number of seconds >= 0, got {max_duration}"
        )
    if max_bytes == 0 and max_duration == 0:
        raise InputError(
            "--max-cache-size",
            "and --max-cache-duration are both 0: the snapshot cache would grow without bound; give one",
        )


class SnapshotCache:
    """The newest messages, bounded by ``max_bytes`` (data + overhead) and ``max_duration`` seconds.

    Thread-safe: the executor adds, the service and fault callbacks take or copy.
    """

    def __init__(self, max_bytes: int, max_duration: float) -> None:
        check_cache_limits(max_bytes, max_duration)
        self.max_bytes = max_bytes
        self.max_duration_ns = round(max_duration * 1e9)
        self._entries: deque[Entry] = deque()
        self._bytes = 0
        self._lock = threading.Lock()
        self.peak_bytes = 0
        self.evicted = 0

    @staticmethod
    def cost(entry: Entry) -> int:
        """Bytes one message counts against the limit."""
        return len(entry.data) + ENTRY_OVERHEAD

    def add(self, entry: Entry) -> None:
        """Append a message, then drop the oldest until both limits hold again."""
        cost = self.cost(entry)
        with self._lock:
            self._entries.append(entry)
            self._bytes += cost
            entries = self._entries
            if self.max_bytes:
                while self._bytes > self.max_bytes and entries:
                    self._bytes -= self.cost(entries.popleft())
                    self.evicted += 1
            if self.max_duration_ns:
                oldest_kept = entry.log_time - self.max_duration_ns
                while entries and entries[0].log_time < oldest_kept:
                    self._bytes -= self.cost(entries.popleft())
                    self.evicted += 1
            self.peak_bytes = max(self.peak_bytes, self._bytes)

    def take(self) -> list[Entry]:
        """Return every cached message (oldest first) and empty the cache."""
        with self._lock:
            entries = list(self._entries)
            self._entries.clear()
            self._bytes = 0
        return entries

    def copy(self) -> list[Entry]:
        """Return every cached message (oldest first); the cache is unchanged."""
        with self._lock:
            return list(self._entries)

    @property
    def size(self) -> int:
        """Bytes counted against the limit now."""
        return self._bytes

    def __len__(self) -> int:
        return len(self._entries)


@dataclass
class Capture:
    """A snapshot on its way to disk: the messages before it and, for a fault, those after it."""

    name: str
    reason: str  # "service" or "fault"
    entries: list[Entry]
    deadline: int | None = None  # log time (ns) until which later messages are added; None: closed
    device: str = ""
    fault_code: int = 0
    fault_text: str = ""
    stamp_ns: int = 0  # the fault's time on the device's clock (its status header)
    post: list[Entry] = field(default_factory=list)

    def all_entries(self) -> list[Entry]:
        """Return the messages before and after the trigger, in order."""
        return self.entries + self.post


def _name_part(text: str) -> str:
    """Make a name safe for a file name: ``/cell/feeder_a/throwing_arm`` -> ``cell-feeder_a-throwing_arm``."""
    return re.sub(r"[^A-Za-z0-9_.]+", "-", text.strip("/")) or "device"


def capture_name(reason: str, stamp_ns: int, device: str = "", fault_code: int = 0, index: int = 0) -> str:
    """Return the bag name of a capture: ``DEVICE_faultCODE_tSEC.MSEC`` or ``snapshot_N_tSEC.MSEC``.

    The time is the fault's stamp on the device's clock (cell time when the cell runs a clock), or the
    recorder's clock for a ``~/snapshot`` call, in seconds with milliseconds.
    """
    seconds, rest = divmod(max(0, stamp_ns), 1_000_000_000)
    when = f"t{seconds}.{rest // 1_000_000:03d}"
    if reason == "fault":
        return f"{_name_part(device)}_fault{fault_code}_{when}"
    return f"snapshot_{index}_{when}"


class FaultEdge:
    """Which ``~/status`` messages are a device entering FAULT (not staying in it, not a first sight)."""

    def __init__(self) -> None:
        self._last: dict[str, int] = {}

    def entered_fault(self, device: str, state: int) -> bool:
        """Record ``state`` for ``device``; return True when it is FAULT and the previous was not.

        The first status seen of a device only sets its state: a device found in FAULT when the recorder
        starts entered it before anything was cached.
        """
        previous = self._last.get(device)
        self._last[device] = state
        return state == FAULT_STATE and previous is not None and previous != FAULT_STATE


@dataclass
class WrittenBag:
    """A snapshot bag on disk."""

    path: Path
    reason: str
    messages: int
    start_ns: int
    end_ns: int
    device: str = ""
    fault_code: int = 0
    fault_text: str = ""

    def to_json(self) -> dict[str, Any]:
        """Return the bag as the record command reports it."""
        return {
            "path": str(self.path),
            "reason": self.reason,
            "messages": self.messages,
            "start_time_ns": self.start_ns,
            "end_time_ns": self.end_ns,
            "device": self.device,
            "fault_code": self.fault_code,
            "fault_text": self.fault_text,
        }


class SnapshotWriter:
    """Writes captures as bags under ``directory``, one at a time, on a thread of its own.

    Parameters
    ----------
    directory
        Where the snapshot bags go (created if missing).
    topics
        Called when a capture is written: per topic, what the bag declares it with.
    compression
        MCAP chunk compression of the bags.
    log
        Called with a line when a bag could not be written (a full disk): the recording goes on.
    """

    def __init__(
        self,
        directory: Path,
        topics: Callable[[], dict[str, TopicInfo]],
        compression: str,
        log: Callable[[str], None],
    ) -> None:
        self.directory = directory
        self.topics = topics
        self.compression = compression
        self.log = log
        self.written: list[WrittenBag] = []
        self._queue: queue.Queue[Capture | None] = queue.Queue()
        self._pending = 0
        self._lock = threading.Lock()
        self._names: set[str] = set()
        self._thread = threading.Thread(target=self._run, name="snapshot-writer", daemon=True)
        self._thread.start()

    def unique(self, name: str) -> str:
        """``name``, or ``name-2``, ``name-3``... if a bag of that name exists or is on its way."""
        with self._lock:
            candidate, n = name, 1
            while candidate in self._names or (self.directory / candidate).exists():
                n += 1
                candidate = f"{name}-{n}"
            self._names.add(candidate)
            return candidate

    def submit(self, capture: Capture) -> None:
        """Queue a closed capture for writing."""
        with self._lock:
            self._pending += 1
        self._queue.put(capture)

    @property
    def pending(self) -> int:
        """Captures queued or being written."""
        return self._pending

    def close(self, timeout: float = 120.0) -> None:
        """Write what is queued, then stop the thread."""
        self._queue.put(None)
        self._thread.join(timeout=timeout)

    def _run(self) -> None:
        while True:
            capture = self._queue.get()
            if capture is None:
                return
            try:
                self.written.append(self.write(capture))
            except (OSError, RuntimeError, ValueError) as exc:
                self.log(f"snapshot {capture.name}: could not be written: {exc}")
            finally:
                with self._lock:
                    self._pending -= 1

    def write(self, capture: Capture) -> WrittenBag:
        """Write one capture as a complete bag (``.NAME.partial`` until its metadata.yaml is in place)."""
        from feeder_cell.bag.writer import BagWriter

        self.directory.mkdir(parents=True, exist_ok=True)
        entries = capture.all_entries()
        final = self.directory / capture.name
        partial = self.directory / f".{capture.name}.partial"
        if partial.exists():
            shutil.rmtree(partial)
        custom = {"snapshot_reason": capture.reason}
        if capture.reason == "fault":
            custom.update(
                device=capture.device,
                fault_code=str(capture.fault_code),
                fault_text=capture.fault_text,
                fault_stamp_ns=str(capture.stamp_ns),
            )
        writer = BagWriter(partial, self.compression, custom_data=custom)
        # The bag's one file is named after the final bag, not the partial directory.
        writer.open(first_file=f"{capture.name}.mcap")
        try:
            known = self.topics()
            connections: dict[str, Connection] = {}
            for topic in sorted({e.topic for e in entries}):
                info = known[topic]
                connections[topic] = writer.add_connection(
                    topic,
                    info.type_name,
                    msgdef=info.msgdef,
                    rihs01=info.rihs01,
                    offered_qos_profiles=info.profiles,
                )
            for entry in entries:
                writer.write(connections[entry.topic], entry.log_time, entry.data, entry.publish_time)
            writer.close()
        except BaseException:
            writer.abort()
            shutil.rmtree(partial, ignore_errors=True)
            raise
        os.replace(partial, final)
        return WrittenBag(
            final,
            capture.reason,
            len(entries),
            min((e.log_time for e in entries), default=0),
            max((e.log_time for e in entries), default=0),
            capture.device,
            capture.fault_code,
            capture.fault_text,
        )
