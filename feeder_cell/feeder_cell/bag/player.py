"""Replay a rosbag2 bag onto live topics at the recorded pace (scaled by a rate), raw CDR bytes."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Callable

from rclpy.node import Node
from rosbags.rosbag2 import Reader, ReaderError

from feeder_cell.bag.qos import from_bag_qos
from feeder_cell.bag.reindex import is_complete
from feeder_cell.bag.types import message_class
from feeder_planner.errors import InputError


def _reindex_hint(path: Path) -> str:
    return f"`feeder bag-reindex {path}` recovers it up to its last complete chunk"


def open_bag(path: Path) -> Reader:
    """Open a rosbag2 MCAP bag for reading; errors name the bag, and bag-reindex where it helps.

    A bag whose recording was killed has no ``metadata.yaml``, and an MCAP file cut short (killed,
    truncated copy) has no summary: both are refused with what is wrong, never read half-way.
    """
    if path.is_dir() and not (path / "metadata.yaml").exists() and any(path.glob("*.mcap")):
        raise InputError(
            "bag",
            f"{path} has no metadata.yaml (its recording did not end cleanly); {_reindex_hint(path)}",
        )
    incomplete = sorted(p.name for p in path.glob("*.mcap") if not is_complete(p)) if path.is_dir() else []
    if incomplete:
        raise InputError(
            "bag",
            f"{path}: {', '.join(incomplete)} ends without its MCAP summary (cut short while recording "
            f"or copying); {_reindex_hint(path)}",
        )
    try:
        reader = Reader(path)
        reader.open()
    except Exception as exc:  # rosbags raises several error types for unreadable bags
        hint = f"; {_reindex_hint(path)}" if path.is_dir() and any(path.glob("*.mcap")) else ""
        raise InputError("bag", f"{path} is not a readable rosbag2 bag: {exc}{hint}") from None
    return reader


def play(
    node: Node,
    path: Path,
    rate: float = 1.0,
    topics: tuple[str, ...] = (),
    keep_going: Callable[[], bool] = lambda: True,
    wait_for_subscribers: float = 0.0,
) -> dict[str, int]:
    """Publish every message of the bag; returns messages published per topic.

    ``wait_for_subscribers`` > 0: before the first message, wait up to that many seconds until every
    topic has a matched subscriber (volatile messages published earlier would reach nobody).
    """
    if not rate > 0:
        raise InputError("rate", f"must be > 0, got {rate}")
    reader = open_bag(path)
    try:
        connections = [c for c in reader.connections if not topics or c.topic in topics]
        publishers = {}
        for connection in connections:
            qos = from_bag_qos(getattr(connection.ext, "offered_qos_profiles", ()))
            publishers[connection.id] = node.create_publisher(
                message_class(connection.msgtype), connection.topic, qos
            )
        if wait_for_subscribers > 0:
            deadline = time.monotonic() + wait_for_subscribers
            while (
                keep_going()
                and time.monotonic() < deadline
                and any(p.get_subscription_count() == 0 for p in publishers.values())
            ):
                time.sleep(0.05)
        else:
            time.sleep(0.5)  # DDS discovery is not instant; give existing subscribers a moment to match
        counts = {c.topic: 0 for c in connections}
        first_stamp: int | None = None
        started = time.monotonic()
        try:
            for connection, stamp, data in reader.messages(connections=connections):
                if not keep_going():
                    break
                first_stamp = stamp if first_stamp is None else first_stamp
                due = started + (stamp - first_stamp) / 1e9 / rate
                delay = due - time.monotonic()
                if delay > 0:
                    time.sleep(delay)
                publishers[connection.id].publish(bytes(data))
                counts[connection.topic] += 1
        except ReaderError as exc:
            published = sum(counts.values())
            raise InputError(
                "bag", f"{path} is damaged after {published} messages: {exc}; {_reindex_hint(path)}"
            ) from None
        return counts
    finally:
        reader.close()
