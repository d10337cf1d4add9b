"""Recover a bag whose recording ended without closing it: ``feeder bag-reindex`` (as ``ros2 bag reindex``).

A killed recorder leaves the MCAP file without its summary (schemas, channels, chunk indexes,
statistics, footer) and the bag without ``metadata.yaml``; a truncated copy cuts a chunk in two. The
records before the damage are intact: this module scans each file record by record, keeps every complete
chunk (and any top-level schema, channel and message records) up to the first incomplete or unreadable
one, and writes them again as a complete bag, summary and ``metadata.yaml`` included, with what
rosbag2 writes into its files (:mod:`feeder_cell.bag.writer`). A split bag
(``<bag>_0.mcap``, ``<bag>_1.mcap``...) keeps its files: each is recovered on its own.
"""

from __future__ import annotations

import os
import re
import shutil
import struct
from dataclasses import dataclass, field
from io import BytesIO
from pathlib import Path
from typing import BinaryIO, Iterator, TypeAlias, TypedDict

from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Channel, Chunk, Message, Schema
from mcap.stream_reader import get_chunk_data_stream
from rosbags.interfaces import Connection
from rosbags.rosbag2.metadata import parse_qos

from feeder_cell.bag.types import type_hash
from feeder_cell.bag.writer import BagWriter
from feeder_planner.errors import InputError

MAGIC = b"\x89MCAP0\r\n"
_RECORD_HEAD = struct.Struct("<BQ")
MESSAGE_HEADER_SIZE = 22  # channel id, sequence, log time, publish time

# A type missing from our typestore (a bag recorded elsewhere) keeps its schema text; its rosbag2 type
# hash cannot be computed without the type, and rosbag2 treats this all-zero value as unknown.
UNKNOWN_TYPE_HASH = "RIHS01_" + "0" * 64

# A file from which nothing could be recovered is renamed with this suffix, out of the bag's file set.
LEFT_OUT_SUFFIX = ".left-out"


# The records of an MCAP file a bag is rebuilt from.
McapRecord: TypeAlias = Schema | Channel | Message


class TopicCount(TypedDict):
    """A recovered topic: its type and message count."""

    type: str
    count: int


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
    compression: str = ""  # chunk compression of its first chunk ("" none, "zstd", "lz4")
    left_out: str = ""  # why the file is not in metadata.yaml ("" when it is)
    kept_as: str = ""  # the name a left-out file with bytes in it was renamed to


@dataclass
class ReindexReport:
    """The result of :func:`reindex`."""

    path: Path
    files: list[FileReport] = field(default_factory=list)
    topics: dict[str, TopicCount] = field(default_factory=dict)


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


def _scan(stream: BinaryIO, size: int, report: FileReport) -> Iterator[McapRecord]:
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
        records: list[McapRecord] = []
        try:
            data = ReadDataStream(BytesIO(body))
            if opcode == Opcode.CHUNK:
                chunk = Chunk.read(data)
                records = _chunk_records(chunk, data.count, length)
                report.compression = report.compression or chunk.compression
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


def _chunk_records(chunk: Chunk, consumed: int, length: int) -> list[McapRecord]:
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
    records: list[McapRecord] = []
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


def _file_order(path: Path) -> tuple[int | str, ...]:
    """Sort key putting ``<bag>_2.mcap`` before ``<bag>_10.mcap`` (numbers compared as numbers)."""
    return tuple(int(part) if part.isdigit() else part for part in re.split(r"(\d+)", path.name))


def _all_read(file_report: FileReport) -> bool:
    """Whether the scan read the whole file (to its summary, or every byte as complete records)."""
    return file_report.complete or file_report.recovered_bytes == file_report.size


def _leave_out(path: Path, file_report: FileReport) -> None:
    """Take a file with no recoverable message out of the bag's file set, keeping any bytes it has."""
    file_report.left_out = file_report.stopped_by or "it holds no message"
    if _all_read(file_report):
        # Every byte was read and none was a message (an empty file, or the header, schemas and channels
        # a recorder killed just after a split leaves): nothing to keep.
        path.unlink()
        return
    kept = path.with_name(path.name + LEFT_OUT_SUFFIX)
    os.replace(path, kept)
    file_report.kept_as = kept.name


def reindex(bag: Path) -> ReindexReport:
    """Rebuild a bag's MCAP summaries and ``metadata.yaml`` from the complete records it holds.

    Each MCAP file is recovered on its own, as ``ros2 bag reindex`` does: a split bag keeps its files
    (same names, same order), each rewritten up to its last complete chunk, and ``metadata.yaml`` lists
    them in order with their own message counts and times. A file from which no message can be
    recovered (empty, no MCAP magic, damaged from its first chunk) is left out of the metadata, its
    reason in the report; one whose bytes all read as records without a message is removed, any other
    renamed ``<name>.left-out`` so that no byte is destroyed. When no file holds a message, the first
    stays as an empty file so that the bag still opens.

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
    files = _mcap_files(bag)
    work = _fresh_work_dir(bag)
    rebuilt = work / bag.name
    report = ReindexReport(bag)
    writer = BagWriter(rebuilt)
    written: list[FileReport] = []  # files rewritten into the work directory, in order
    try:
        connections: dict[tuple[str, str, str], Connection] = {}
        for path in files:
            file_report = _start_file(writer, path, report, first=not written)
            written.append(file_report)
            _copy_records(writer, path, file_report, connections, report.topics)
        listed = [f for f in written if f.messages] or written[:1]
        # metadata.yaml lists the kept files only, in order, each with its own count and times.
        names = {f.name for f in listed}
        writer.close(files=[f for f in writer.files if f.name in names])
    except BaseException:
        writer.abort()
        shutil.rmtree(work, ignore_errors=True)
        raise
    _install(bag, rebuilt, written, listed)
    os.replace(rebuilt / "metadata.yaml", bag / "metadata.yaml")
    shutil.rmtree(work)
    return report


def _mcap_files(bag: Path) -> list[Path]:
    """Return the bag's MCAP files in split order, or raise InputError when ``bag`` holds none.

    The order is the bag's file order, so each file is rewritten where it was in the bag.
    """
    if not bag.is_dir():
        raise InputError("BAG", f"{bag} is not a bag directory")
    files = sorted(bag.glob("*.mcap"), key=_file_order)
    if not files:
        raise InputError("BAG", f"{bag} holds no .mcap file to reindex")
    return files


def _fresh_work_dir(bag: Path) -> Path:
    """Create the empty ``.reindex`` work directory the bag is rebuilt in, beside the originals.

    Rebuilding aside keeps the originals untouched until every file has been rewritten.
    """
    work = bag / ".reindex"
    if work.exists():
        shutil.rmtree(work)  # left by an interrupted reindex: the originals are still in place
    work.mkdir()
    return work


def _start_file(writer: BagWriter, path: Path, report: ReindexReport, *, first: bool) -> FileReport:
    """Open the rebuilt file for ``path`` under its own name and return its report (added to ``report``).

    Each file under its own name; a topic is declared in a file where it has a message there.
    """
    size = path.stat().st_size
    file_report = FileReport(path.name, size, 0)
    report.files.append(file_report)
    if first:
        writer.open(first_file=path.name)
    else:
        writer.start_file(path.name, declare_all=False)
    return file_report


def _copy_records(
    writer: BagWriter,
    path: Path,
    file_report: FileReport,
    connections: dict[tuple[str, str, str], Connection],
    topics: dict[str, TopicCount],
) -> None:
    """Write the messages of the intact part of ``path`` into the writer's current file, counting them.

    Schema and channel ids are per file: they are mapped to this bag's connections by topic, type and
    QoS, so a topic recorded in several files is one connection of the rebuilt bag.
    """
    storage = writer.file
    schemas: dict[int, Schema] = {}
    channel_map: dict[int, Connection] = {}
    with path.open("rb") as stream:
        for record in _scan(stream, file_report.size, file_report):
            if isinstance(record, Schema):
                schemas[record.id] = record
            elif isinstance(record, Channel):
                schema = schemas.get(record.schema_id)
                if schema is None:
                    continue  # a channel without its schema cannot be described in the bag
                channel_map[record.id] = _connect(writer, connections, record, schema)
            elif isinstance(record, Message) and record.channel_id in channel_map:
                if not file_report.messages:
                    storage.use_compression(file_report.compression or "none")
                connection = channel_map[record.channel_id]
                writer.write(connection, record.log_time, record.data, record.publish_time)
                file_report.messages += 1
                topic = topics.setdefault(connection.topic, {"type": connection.msgtype, "count": 0})
                topic["count"] += 1


def _install(bag: Path, rebuilt: Path, written: list[FileReport], listed: list[FileReport]) -> None:
    """Move the rebuilt files over the originals; leave out (or set aside) the files not listed.

    Runs only once every file is rebuilt and closed, so a failure before leaves the bag as it was.
    """
    for file_report in written:
        path = bag / file_report.name
        if file_report not in listed:
            _leave_out(path, file_report)
            continue
        if not file_report.messages and not _all_read(file_report):
            # The empty file that keeps a bag of no message openable: bytes it could not read kept aside.
            kept = path.with_name(path.name + LEFT_OUT_SUFFIX)
            os.replace(path, kept)
            file_report.kept_as = kept.name
        # Replace, never delete first: a crash in between leaves either the old file or the new one.
        os.replace(rebuilt / file_report.name, path)


def _connect(
    writer: BagWriter,
    connections: dict[tuple[str, str, str], Connection],
    channel: Channel,
    schema: Schema,
) -> Connection:
    """Return the bag's connection for a file's channel (the writer declares it in each file it is used)."""
    qos = channel.metadata.get("offered_qos_profiles", "")
    key = (channel.topic, schema.name, qos)
    connection = connections.get(key)
    if connection is None:
        connection = connections[key] = writer.add_connection(
            channel.topic,
            schema.name,
            msgdef=schema.data.decode(),
            # The recorded hash when the channel has one (a bag from another machine's types).
            rihs01=channel.metadata.get("topic_type_hash") or _type_hash(schema.name),
            serialization_format=channel.message_encoding,
            offered_qos_profiles=parse_qos(qos),
        )
    return connection
