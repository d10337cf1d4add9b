"""Recover a bag whose recording ended without closing it: ``feeder bag-reindex`` (as ``ros2 bag reindex``).

A killed recorder leaves the MCAP file without its summary (schemas, channels, chunk indexes,
statistics, footer) and the bag without ``metadata.yaml``; a truncated copy cuts a chunk in two. The
records before the damage are intact: this module scans the file record by record, keeps every complete
chunk (and any top-level schema, channel and message records) up to the first incomplete or unreadable
one, and writes them again as a complete bag, summary and ``metadata.yaml`` included.
"""

from __future__ import annotations

import os
import shutil
import struct
from dataclasses import dataclass, field
from io import BytesIO
from pathlib import Path
from typing import Any, BinaryIO, Iterator

from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Channel, Chunk, Message, Schema
from mcap.stream_reader import get_chunk_data_stream
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.rosbag2.metadata import parse_qos

from feeder_cell.bag.types import type_hash
from feeder_planner.errors import InputError

MAGIC = b"\x89MCAP0\r\n"
_RECORD_HEAD = struct.Struct("<BQ")
MESSAGE_HEADER_SIZE = 22  # channel id, sequence, log time, publish time

# A type missing from our typestore (a bag recorded elsewhere) keeps its schema text; its rosbag2 type
# hash cannot be computed without the type, and rosbag2 treats this all-zero value as unknown.
UNKNOWN_TYPE_HASH = "RIHS01_" + "0" * 64


@dataclass
class FileReport:
    """What was recovered from one MCAP file."""

    name: str
    size: int
    recovered_bytes: int  # end of the last complete record kept
    chunks: int = 0
    messages: int = 0
    complete: bool = False  # the file had its footer: nothing was lost
    stopped_by: str = ""  # why the scan ended before the footer


@dataclass
class ReindexReport:
    """The result of :func:`reindex`."""

    path: Path
    files: list[FileReport] = field(default_factory=list)
    topics: dict[str, dict[str, Any]] = field(default_factory=dict)


def is_complete(mcap_file: Path) -> bool:
    """Return whether an MCAP file ends with its closing magic (its summary and footer were written)."""
    try:
        size = mcap_file.stat().st_size
        if size < 2 * len(MAGIC):
            return False
        with mcap_file.open("rb") as stream:
            stream.seek(size - len(MAGIC))
            return stream.read(len(MAGIC)) == MAGIC
    except OSError:
        return False


def _scan(stream: BinaryIO, size: int, report: FileReport) -> Iterator[Any]:
    """Yield the schema, channel and message records of the intact part of an MCAP file, in order."""
    magic = stream.read(len(MAGIC))
    if magic != MAGIC:
        report.stopped_by = (
            "empty file (nothing reached the disk)" if not magic else "no MCAP magic at the start"
        )
        return
    position = len(MAGIC)
    report.recovered_bytes = position
    while True:
        head = stream.read(_RECORD_HEAD.size)
        if not head:
            report.stopped_by = f"file ends at byte {position} after a complete record, without a summary"
            return
        if len(head) < _RECORD_HEAD.size:
            report.stopped_by = f"file ends inside a record header at byte {position}"
            return
        opcode, length = _RECORD_HEAD.unpack(head)
        if opcode == 0:
            # Opcode 0 is reserved: zeros where a power loss left allocated but unwritten blocks.
            report.stopped_by = f"zeros (no record) at byte {position}"
            return
        if length > size - position - _RECORD_HEAD.size:
            report.stopped_by = f"record at byte {position} is cut off ({length} bytes announced)"
            return
        body = stream.read(length)
        records: list[Any] = []
        try:
            data = ReadDataStream(BytesIO(body))
            if opcode == Opcode.CHUNK:
                records = _chunk_records(Chunk.read(data), data.count, length)
                report.chunks += 1
            elif opcode == Opcode.SCHEMA:
                records = [Schema.read(data)]
            elif opcode == Opcode.CHANNEL:
                records = [Channel.read(data)]
            elif opcode == Opcode.MESSAGE:
                if length < MESSAGE_HEADER_SIZE:
                    raise DamagedChunkError(f"a message record of {length} bytes")
                records = [Message.read(data, length)]
            elif opcode in (Opcode.DATA_END, Opcode.FOOTER):
                report.complete = True  # the summary follows: everything before it is data
        except Exception as exc:  # noqa: BLE001 -- any decoding error marks the end of the intact part
            report.stopped_by = f"unreadable record at byte {position}: {type(exc).__name__} {exc}"
            return
        yield from records
        position += _RECORD_HEAD.size + length
        report.recovered_bytes = position
        if report.complete:
            return


class DamagedChunkError(ValueError):
    """A chunk record whose fields or contents do not add up (zeros or garbage where data should be)."""


def _chunk_records(chunk: Chunk, consumed: int, length: int) -> list[Any]:
    """Return a chunk's schema, channel and message records, or raise DamagedChunkError.

    rosbags writes no chunk CRC, so consistency is what tells a whole chunk from one whose blocks were
    never written (zeros): the fields must fill the record exactly, the contents must have the stated
    size, and every inner record must have a real opcode and fit.
    """
    if consumed != length:
        raise DamagedChunkError(f"its fields take {consumed} of the record's {length} bytes")
    stream, size = get_chunk_data_stream(chunk, validate_crc=True)
    if size != chunk.uncompressed_size:
        raise DamagedChunkError(f"{size} bytes of contents, {chunk.uncompressed_size} stated")
    records: list[Any] = []
    while stream.count < size:
        opcode, inner = stream.read1(), stream.read8()
        if opcode == 0 or inner > size - stream.count:
            raise DamagedChunkError(f"no record at byte {stream.count - 9} of its contents")
        start = stream.count
        if opcode == Opcode.SCHEMA:
            records.append(Schema.read(stream))
        elif opcode == Opcode.CHANNEL:
            records.append(Channel.read(stream))
        elif opcode == Opcode.MESSAGE:
            if inner < MESSAGE_HEADER_SIZE:
                raise DamagedChunkError(f"a message record of {inner} bytes at byte {start - 9}")
            records.append(Message.read(stream, inner))
        else:
            stream.read(inner)
        if stream.count - start != inner:
            raise DamagedChunkError(f"a record at byte {start - 9} of its contents does not fill its length")
    return records


def _type_hash(msgtype: str) -> str:
    # Service events and action parts included (their hashes come from rosidl's type descriptions).
    return type_hash(msgtype) or UNKNOWN_TYPE_HASH


def reindex(bag: Path) -> ReindexReport:
    """Rebuild a bag's MCAP summary and ``metadata.yaml`` from the complete records it holds.

    Parameters
    ----------
    bag
        The bag directory (with one or more ``.mcap`` files, ``metadata.yaml`` optional).

    Returns
    -------
    ReindexReport
        Per file what was kept and why the scan stopped; per topic type and message count.

    Raises
    ------
    InputError
        The path is not a directory holding MCAP files.
    """
    if not bag.is_dir():
        raise InputError("BAG", f"{bag} is not a bag directory")
    files = sorted(bag.glob("*.mcap"))
    if not files:
        raise InputError("BAG", f"{bag} holds no .mcap file to reindex")
    work = bag / ".reindex"
    if work.exists():
        shutil.rmtree(work)  # left by an interrupted reindex: the originals are still in place
    work.mkdir()
    report = ReindexReport(bag)
    writer = Writer(work / bag.name, version=9, storage_plugin=StoragePlugin.MCAP)
    writer.open()
    try:
        schemas: dict[int, Any] = {}
        connections: dict[tuple[str, str, str], Any] = {}
        for path in files:
            size = path.stat().st_size
            file_report = FileReport(path.name, size, 0)
            report.files.append(file_report)
            # Channel ids are per file: map them to this bag's connections by topic, type and QoS.
            channel_map: dict[int, Any] = {}
            with path.open("rb") as stream:
                for record in _scan(stream, size, file_report):
                    if isinstance(record, Schema):
                        schemas[record.id] = record
                    elif isinstance(record, Channel):
                        schema = schemas.get(record.schema_id)
                        if schema is None:
                            continue  # a channel without its schema cannot be described in the bag
                        qos = record.metadata.get("offered_qos_profiles", "")
                        key = (record.topic, schema.name, qos)
                        if key not in connections:
                            connections[key] = writer.add_connection(
                                record.topic,
                                schema.name,
                                msgdef=schema.data.decode(),
                                rihs01=_type_hash(schema.name),
                                serialization_format=record.message_encoding,
                                offered_qos_profiles=parse_qos(qos),
                            )
                        channel_map[record.id] = connections[key]
                    elif isinstance(record, Message) and record.channel_id in channel_map:
                        connection = channel_map[record.channel_id]
                        writer.write(connection, record.log_time, record.data)
                        file_report.messages += 1
                        topic = report.topics.setdefault(
                            connection.topic, {"type": connection.msgtype, "count": 0}
                        )
                        topic["count"] += 1
    except BaseException:
        writer.close()
        shutil.rmtree(work, ignore_errors=True)
        raise
    writer.close()
    rebuilt = work / bag.name
    new_file = rebuilt / f"{bag.name}.mcap"
    # Replace, never delete first: a crash in between leaves either the old file or the new one.
    os.replace(new_file, bag / new_file.name)
    for path in files:
        if path.name != new_file.name:
            path.unlink()
    os.replace(rebuilt / "metadata.yaml", bag / "metadata.yaml")
    shutil.rmtree(work)
    return report
