"""The recording's bag on disk: messages written as they come, split into files, pushed to disk.

Splitting (``max_bag_size``, ``max_bag_duration``) closes the current MCAP file with its summary and goes
on in ``<bag>_<n>.mcap``; ``metadata.yaml`` lists every file. Crash safety: the MCAP writer keeps its
current chunk in memory until it holds 1 MiB, so ``flush`` (the recorder's flush thread calls it) closes
the pending chunk and flushes and fsyncs the file. Separate from the recorder, which decides what is
recorded; this holds how it lands on disk (:mod:`feeder_cell.bag.writer` writes as rosbag2 does).

Locking: ``lock`` is the recorder's (the same object): it guards the writer, its connections and
``_synced`` as it did when they were the recorder's own. ``_sync_lock`` is taken before it by ``flush``
and ``close`` only, so that close never finishes the file while a flush syncs it.
"""

from __future__ import annotations

import os
import threading
from pathlib import Path

from rosbags.interfaces import Connection, Qos

from feeder_cell.bag.writer import BagWriter, FileStats
from feeder_planner.errors import InputError

__all__ = ["DiskBag"]


class DiskBag:
    """The bag a (non-snapshot) recording writes: its files, channels, splits and flushes."""

    def __init__(
        self, path: Path, compression: str, max_bag_size: int, max_bag_duration: float, lock: threading.Lock
    ) -> None:
        self.max_bag_size = max_bag_size
        self.max_bag_duration = max_bag_duration
        self.lock = lock
        self._sync_lock = threading.Lock()
        self._synced = 0  # file position the last fsync covered
        self.connections: dict[str, Connection] = {}
        if path.exists():
            raise InputError("output", f"{path} already exists; bags are never overwritten")
        self.writer: BagWriter | None = BagWriter(path, compression)
        self.writer.open()
        # The header on disk at once: a recorder killed before its first flush leaves an MCAP file.
        self.writer.file.bio.flush()
        self.files: list[FileStats] = self.writer.files

    def add_connection(self, name: str, type_name: str, msgdef: str, rihs01: str, profile: Qos) -> None:
        """Declare a topic's channel, with the first profile its publishers offered (the lock held)."""
        assert self.writer is not None
        self.connections[name] = self.writer.add_connection(
            name, type_name, msgdef=msgdef, rihs01=rihs01, offered_qos_profiles=[profile]
        )

    def add_profile(self, name: str, profile: Qos) -> None:
        """List one more offered profile for a topic's channel in metadata.yaml (the lock held)."""
        if name in self.connections:
            self.connections[name].ext.offered_qos_profiles.append(profile)

    def write(self, topic: str, now: int, data: bytes, publish: int) -> None:
        """Write one message, in the next file when this one is due to be split (the lock held)."""
        assert self.writer is not None
        if self._split_due(now):
            self.writer.split()
            self._synced = 0
        self.writer.write(self.connections[topic], now, data, publish)

    def _split_due(self, now: int) -> bool:
        current = self.files[-1]
        if not current.count:
            return False  # a file holds at least one message, whatever the limits
        assert self.writer is not None
        if self.max_bag_size and self.writer.file.size() >= self.max_bag_size:
            return True
        # As rosbag2: a file's duration runs from its first message.
        return bool(self.max_bag_duration) and now - current.start >= self.max_bag_duration * 1e9

    def flush(self) -> None:
        """Close the pending chunk (if it holds a message) and push the file to disk."""
        with self._sync_lock:
            with self.lock:
                if self.writer is None or self.writer.storage is None:
                    return
                storage = self.writer.file
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
            with self.lock:
                if self.writer is not None and self.writer.storage is storage:
                    self._synced = written

    def close(self) -> None:
        """Finish the bag: the last file's summary and metadata.yaml."""
        with self._sync_lock, self.lock:
            if self.writer is not None:
                self.writer.close()
                self.writer = None
