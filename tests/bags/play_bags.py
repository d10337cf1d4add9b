"""Bags written here (no ROS) for the play tests: numbered std_msgs/String messages at known stamps."""

from __future__ import annotations

from pathlib import Path

from rosbags.rosbag2 import StoragePlugin, Writer

from feeder_cell.bag.qos import to_bag_qos
from feeder_cell.bag.types import typestore

START_NS = 1_700_000_000_000_000_000  # bag times are receive times since the epoch
EVENT_TOPIC = "/some_node/some_service/_service_event"


def cdr_string(text: str) -> bytes:
    """Return the CDR bytes of a std_msgs/String."""
    raw = text.encode() + b"\0"
    return b"\0\1\0\0" + len(raw).to_bytes(4, "little") + raw


def string_data(cdr: bytes) -> str:
    """Decode a std_msgs/String from its CDR bytes."""
    length = int.from_bytes(cdr[4:8], "little")
    return cdr[8 : 8 + length - 1].decode()


def write_seq_bag(bag: Path, count: int, gap_ns: int, events: int = 0, per_chunk: int = 50) -> list[int]:
    """Write ``count`` messages "I" on /seq, ``gap_ns`` apart from START_NS, and ``events`` messages on a
    service-event topic; return the /seq stamps. Chunks are closed every ``per_chunk`` messages."""
    writer = Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP)
    writer.open()
    seq = writer.add_connection(
        "/seq", "std_msgs/msg/String", typestore=typestore(), offered_qos_profiles=[to_bag_qos(True, False)]
    )
    event = writer.add_connection(
        EVENT_TOPIC,
        "std_msgs/msg/String",
        typestore=typestore(),
        offered_qos_profiles=[to_bag_qos(True, False)],
    )
    stamps = [START_NS + i * gap_ns for i in range(count)]
    for i, stamp in enumerate(stamps):
        if i < events:
            writer.write(event, stamp, cdr_string(f"event {i}"))
        writer.write(seq, stamp, cdr_string(str(i)))
        if (i + 1) % per_chunk == 0:
            writer.storage.close_chunk()  # type: ignore[union-attr]  -- several chunks, as a recording has
    writer.close()
    return stamps
