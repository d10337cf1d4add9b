"""The recorder's snapshot mode: messages go to a bounded cache, written as bags of their own when asked.

Nothing is written as it arrives: every message goes to the cache (:class:`SnapshotCache`), and a bag is
written under the recording's path on ``~/snapshot`` (:meth:`SnapshotMode.snapshot_now`, the whole cache)
or, with ``snapshot_on_fault``, when a device enters FAULT (``fault_captures``). The bags are written on
the snapshot writer's thread (:mod:`feeder_cell.bag.snapshot`). Separate from the recorder, which decides
what is recorded; this holds where it goes in snapshot mode.

Locking: ``lock`` is the recorder's (the same object); it guards the cache, the captures and the snapshot
count as it did when they were the recorder's own. ``add`` expects the caller to hold it.
"""

from __future__ import annotations

import threading
from pathlib import Path
from typing import Callable

from rclpy.node import Node

from feeder_cell.bag.fault_captures import FaultCaptures
from feeder_cell.bag.snapshot import (
    MAX_PENDING,
    Capture,
    Entry,
    SnapshotCache,
    SnapshotWriter,
    TopicInfo,
    WrittenBag,
    capture_name,
)
from feeder_cell.bag.topic_readers import Offer
from feeder_planner.errors import InputError

__all__ = ["SnapshotMode"]


class SnapshotMode:
    """The snapshot cache, the bags written from it on demand, and the fault captures (``faults``)."""

    def __init__(
        self,
        node: Node,
        path: Path,
        lock: threading.Lock,
        clock: Callable[[], int],
        known_topics: Callable[[], dict[str, TopicInfo]],
        offer_of: Callable[[str], Offer | None],
        *,
        compression: str,
        max_cache_size: int,
        max_cache_duration: float,
        post_fault: float,
    ) -> None:
        self.node = node
        self.lock = lock
        self.clock = clock
        self._snapshot_count = 0
        self.cache_stats: dict[str, float] = {}  # the snapshot cache's bounds and peak, once closed
        self.cache: SnapshotCache | None = SnapshotCache(max_cache_size, max_cache_duration)
        if path.exists() and not path.is_dir():
            raise InputError("output", f"{path} exists and is not a directory")
        path.mkdir(parents=True, exist_ok=True)
        self.snapshots = SnapshotWriter(
            path,
            known_topics,
            compression,
            lambda line: self.node.get_logger().error(line),
        )
        self.faults = FaultCaptures(node, lock, self, self.snapshots, clock, post_fault, offer_of)

    def add(self, entry: Entry, now: int) -> None:
        """Cache a received message and give it to the captures still collecting (the lock held, open)."""
        assert self.cache is not None  # the recorder checked that the recording is not closed
        self.cache.add(entry)
        self.faults.collect(entry, now)

    def snapshot_now(self) -> bool:
        """Write the whole cache as a bag and empty it (``~/snapshot``); False if there is nothing to write.

        The bag is written on the snapshot writer's thread; :attr:`written` lists it once complete.
        """
        if self.cache is None:
            return False
        with self.lock:
            if self.faults.pending() >= MAX_PENDING:
                self.node.get_logger().warning(f"snapshot refused: {MAX_PENDING} snapshots are pending")
                return False
            entries = self.cache.take()
            if not entries:
                return False
            self._snapshot_count += 1
            name = capture_name("service", self.clock(), index=self._snapshot_count)
            self.snapshots.submit(Capture(self.snapshots.unique(name), "service", entries))
        return True

    def tick(self) -> None:
        """Queue the fault captures whose post-fault time passed with no new message (the flush thread)."""
        with self.lock:
            if self.faults.captures:
                self.faults.close_due(self.clock())

    @property
    def written(self) -> list[WrittenBag]:
        """Return the snapshot bags written so far."""
        return list(self.snapshots.written)

    def close(self) -> None:
        """Write the fault captures still collecting with what they hold; drop the cache, as rosbag2 does."""
        with self.lock:
            self.faults.close_due(None)
            if self.cache is not None:
                self.cache_stats = {
                    "max_bytes": self.cache.max_bytes,
                    "max_duration": self.cache.max_duration_ns / 1e9,
                    "peak_bytes": self.cache.peak_bytes,
                    "evicted": self.cache.evicted,
                }
            self.cache = None
        self.snapshots.close()
