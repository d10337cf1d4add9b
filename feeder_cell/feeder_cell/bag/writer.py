"""Write bags as rosbag2 writes them: the MCAP files rosbag2_storage_mcap (Jazzy) writes, and metadata.yaml.

rosbags' MCAP writer is the base; what it leaves out or writes otherwise than rosbag2 is added here, so
that ``ros2 bag info`` and ``ros2 bag play`` on a full ROS 2 install read our bags as their own:

- every channel carries ``offered_qos_profiles`` (rosbag2's version 9 YAML of the publishers' QoS list)
  and ``topic_type_hash`` (the type's RIHS01 hash); rosbags writes only the first;
- every file ends with a metadata record named ``rosbag2`` whose ``serialized_metadata`` is the bag's
  ``BagMetadata`` in rosbag2's YAML encoding (every key its decoder requires, ``ros_distro: jazzy``);
  rosbags writes an empty one into every file of a split bag but the last, and names itself as distro;
- a message's publish time is its writer's source timestamp (rosbag2's ``send_timestamp``), its log
  time the receive time; rosbags writes the receive time into both;
- the header has profile ``ros2``; its library field names the library that wrote it (rosbags, as
  rosbag2's names libmcap), chunk CRCs are 0 (rosbag2's default ``noChunkCRC``), sequence numbers 0
  (as Jazzy's plugin writes them).

Chunk compression (zstd or lz4) is the MCAP storage's own, which every MCAP reader decodes; rosbag2's
metadata then names no file or message compression, as with rosbag2's ``compression: Zstd`` storage
config. :class:`BagWriter` tracks each file's span and count for ``metadata.yaml`` and can continue a bag
in a next file (:meth:`BagWriter.split`, :meth:`BagWriter.start_file`).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from io import BytesIO, StringIO
from pathlib import Path
from typing import Any, Callable, Sequence

from rosbags.interfaces import Connection
from rosbags.rosbag2 import CompressionMode, StoragePlugin, Writer
from rosbags.rosbag2.errors import WriterError
from rosbags.rosbag2.metadata import dump_qos_v9
from rosbags.rosbag2.storage_mcap import Channel, McapWriter, write_channel, write_record, write_string

__all__ = [
    "CHUNK_COMPRESSIONS",
    "METADATA_VERSION",
    "ROS_DISTRO",
    "BagWriter",
    "FileStats",
    "McapFile",
    "dump_yaml",
    "qos_yaml",
]

# rosbag2's metadata format version (Jazzy writes 9) and the distro its metadata names.
METADATA_VERSION = 9
ROS_DISTRO = "jazzy"

# MCAP chunk compressions (the names MCAP readers know); "none" leaves chunks as they are.
CHUNK_COMPRESSIONS = ("none", "zstd", "lz4")

# A sentinel rosbags (and rosbag2) keep as the start of a bag with no message.
_NO_MESSAGE = 2**63 - 1


def dump_yaml(document: Any) -> str:
    """Return ``document`` as block-style YAML (ruamel's safe dumper, as rosbags writes metadata)."""
    from ruamel.yaml import YAML

    yaml = YAML(typ="safe")
    yaml.default_flow_style = False
    stream = StringIO()
    yaml.dump(document, stream)
    return stream.getvalue()


def qos_yaml(profiles: Sequence[Any]) -> str:
    """Return a channel's ``offered_qos_profiles`` metadata: rosbag2's version 9 YAML list of QoS maps."""
    return dump_yaml(dump_qos_v9(list(profiles))).strip()


def _zstd_compress(data: bytes) -> bytes:
    try:  # the zstd module rosbags itself uses (the standard library's from Python 3.14)
        from compression import zstd  # type: ignore[import-not-found]
    except ImportError:
        from backports import zstd  # type: ignore[no-redef,unused-ignore]
    return bytes(zstd.compress(data))


def chunk_compressor(compression: str) -> tuple[str, Callable[[bytes], bytes]]:
    """Return the MCAP chunk compression name and compressor for ``none``, ``zstd`` or ``lz4``."""
    if compression == "zstd":
        return "zstd", _zstd_compress
    if compression == "lz4":
        import lz4.frame  # type: ignore[import-untyped]

        return "lz4", lz4.frame.compress
    if compression == "none":
        return "", lambda data: data
    raise ValueError(f"unknown chunk compression {compression!r}")


class McapFile(McapWriter):
    """One MCAP file of a bag, ``<directory>/<name>``, with the records rosbag2_storage_mcap writes.

    rosbags' storage names its file after its directory; it is created in a scratch directory of the
    wanted stem and moved beside the bag's other files while open (a rename within one file system: the
    open descriptor follows it).
    """

    # Set by rosbags' storage; typed here for the checker.
    message_start_time: int
    message_end_time: int

    def __init__(self, directory: Path, name: str, compression: str = "none") -> None:
        scratch = directory / Path(name).stem
        scratch.mkdir()
        try:
            super().__init__(scratch, _rosbags_mode())
            target = directory / name
            os.replace(scratch / f"{scratch.name}.mcap", target)
        finally:
            scratch.rmdir()
        self.path = target
        self.use_compression(compression)
        self.types: set[str] = set()  # message types whose schema this file holds
        self.channels_added: set[int] = set()  # connection ids whose channel this file holds

    def use_compression(self, compression: str) -> None:
        """Compress the chunks written from now on with ``none``, ``zstd`` or ``lz4``."""
        self.compression, self.compressor = chunk_compressor(compression)

    def add_msgtype(self, connection: Connection) -> None:
        """Declare the connection's message type (its schema) in this file."""
        super().add_msgtype(connection)
        self.types.add(connection.msgtype)

    def add_connection(self, connection: Connection, offered_qos_profiles: str) -> None:
        """Declare a channel with rosbag2's two metadata entries: the offered QoS and the type hash."""
        metadata = BytesIO()
        for key, value in (
            ("offered_qos_profiles", offered_qos_profiles),
            ("topic_type_hash", connection.digest),
        ):
            write_string(metadata, key)
            write_string(metadata, value)
        ext = connection.ext
        self.channels.append(
            Channel(
                connection.id,
                connection.msgtype,
                connection.topic,
                getattr(ext, "serialization_format", "cdr"),
                metadata.getvalue(),
            )
        )
        self.channel_stats[connection.id] = 0
        self.channels_added.add(connection.id)
        write_channel(self.chunk.bio, self.channels[-1], self.schemas)

    def write(
        self,
        connection: Connection,
        timestamp: int,
        data: bytes | memoryview,
        publish_time: int | None = None,
    ) -> None:
        """Write one message: log time ``timestamp`` (receive), publish time the sender's (or the same)."""
        published = timestamp if publish_time is None else publish_time
        chunk = self.chunk
        self.message_start_time = min(timestamp, self.message_start_time)
        self.message_end_time = max(timestamp, self.message_end_time)
        self.channel_stats[connection.id] += 1
        chunk.message_start_time = min(timestamp, chunk.message_start_time)
        chunk.message_end_time = max(timestamp, chunk.message_end_time)
        chunk.msgs[connection.id].append((timestamp, chunk.bio.tell()))
        record = BytesIO()
        record.write(connection.id.to_bytes(2, "little"))
        record.write((0).to_bytes(4, "little"))  # sequence: 0, as Jazzy's rosbag2_storage_mcap writes
        record.write(timestamp.to_bytes(8, "little"))
        record.write(published.to_bytes(8, "little"))
        record.write(data)
        write_record(chunk.bio, 0x05, record)
        if chunk.bio.tell() > 2**20:
            self.close_chunk()

    def size(self) -> int:
        """Bytes written so far, the open chunk included."""
        return int(self.bio.tell() + self.chunk.bio.tell())


def _rosbags_mode() -> CompressionMode:
    # Chunks are compressed by McapFile.use_compression, never by rosbags' mode.
    return CompressionMode.NONE


@dataclass
class FileStats:
    """One MCAP file of the bag: name, first and last log time (ns) and message count."""

    name: str
    start: int = 0
    end: int = 0
    count: int = 0


class BagWriter(Writer):
    """A rosbag2 bag (MCAP storage, metadata version 9) written as rosbag2 writes it.

    Parameters
    ----------
    path
        The bag directory to create; an existing path is refused (rosbags' WriterError).
    compression
        MCAP chunk compression of every file: ``none``, ``zstd`` or ``lz4``.
    custom_data
        rosbag2's ``custom_data`` (string keys and values) stored in the metadata.
    """

    # Set by rosbags' writer; typed here for the checker (the storage is always one of ours).
    storage: McapFile | None
    min_timestamp: int
    max_timestamp: int

    def __init__(
        self, path: Path, compression: str = "none", custom_data: dict[str, str] | None = None
    ) -> None:
        super().__init__(path, version=METADATA_VERSION, storage_plugin=StoragePlugin.MCAP)
        chunk_compressor(compression)  # an unknown compression fails here, before anything is created
        self.chunk_compression = compression
        for key, value in (custom_data or {}).items():
            self.set_custom_data(key, value)
        self.files: list[FileStats] = []

    def open(self, first_file: str | None = None) -> None:
        """Create the bag directory and its first file (``<bag>.mcap`` unless named)."""
        try:
            self.path.mkdir(mode=0o755, parents=True)
        except FileExistsError:
            raise WriterError(f"{self.path} exists already, not overwriting.") from None
        name = first_file or f"{self.path.name}.mcap"
        self.storage = McapFile(self.path, name, self.chunk_compression)
        self.files.append(FileStats(name))

    @property
    def file(self) -> McapFile:
        """The MCAP file being written."""
        if not isinstance(self.storage, McapFile):
            raise WriterError(f"bag {self.path} is not open")
        return self.storage

    def add_connection(
        self,
        topic: str,
        msgtype: str,
        *,
        msgdef: str,
        rihs01: str,
        serialization_format: str = "cdr",
        offered_qos_profiles: Sequence[Any] = (),
    ) -> Connection:
        """Add a topic (its schema once per file, its channel in the current file)."""
        if msgtype in self.added_types and msgtype not in self.file.types:
            # rosbags declares a type once per bag; a later file of a split bag needs it declared again.
            self.file.add_msgtype(next(c for c in self.connections if c.msgtype == msgtype))
        connection = super().add_connection(
            topic,
            msgtype,
            msgdef=msgdef,
            rihs01=rihs01,
            serialization_format=serialization_format,
            offered_qos_profiles=offered_qos_profiles,
        )
        return connection

    def declare(self, connection: Connection) -> None:
        """Declare an existing connection (and its type) in the current file, if not declared yet."""
        storage = self.file
        if connection.id in storage.channels_added:
            return
        if connection.msgtype not in storage.types:
            storage.add_msgtype(connection)
        storage.add_connection(connection, qos_yaml(getattr(connection.ext, "offered_qos_profiles", [])))

    def write(
        self,
        connection: Connection,
        timestamp: int,
        data: bytes | memoryview,
        publish_time: int | None = None,
    ) -> None:
        """Write one message into the current file (log time ``timestamp``, publish time the sender's)."""
        storage = self.file
        if connection.id not in storage.channels_added:
            self.declare(connection)
        storage.write(connection, timestamp, data, publish_time)
        self.counts[connection.id] += 1
        self.min_timestamp = min(timestamp, self.min_timestamp)
        self.max_timestamp = max(timestamp, self.max_timestamp)
        current = self.files[-1]
        if not current.count:
            current.start = current.end = timestamp
        current.start = min(current.start, timestamp)
        current.end = max(current.end, timestamp)
        current.count += 1

    def start_file(self, name: str, declare_all: bool = True, compression: str | None = None) -> None:
        """Close the current file (its summary and the rosbag2 metadata record) and continue in ``name``.

        ``declare_all``: declare every topic in the new file at once, as rosbag2 does when it splits;
        otherwise each is declared with its first message there.
        """
        self.finish_file()
        self.storage = McapFile(
            self.path, name, self.chunk_compression if compression is None else compression
        )
        self.files.append(FileStats(name))
        if declare_all:
            for connection in self.connections:
                self.declare(connection)
        self.storage.bio.flush()

    def split(self) -> None:
        """Continue in ``<bag>_<n>.mcap``; at the first split the first file is renamed ``<bag>_0.mcap``.

        rosbag2 numbers a split bag's files from 0; a bag that never splits keeps its one file's name.
        """
        if len(self.files) == 1 and self.files[0].name == f"{self.path.name}.mcap":
            first = self.path / f"{self.path.name}_0.mcap"
            os.replace(self.file.path, first)
            self.file.path = first
            self.files[0].name = first.name
        self.start_file(f"{self.path.name}_{len(self.files)}.mcap")

    def finish_file(self) -> Path:
        """Close the current file with its summary and the bag's metadata so far; return its path."""
        storage = self.file
        storage.close(self.version, dump_yaml(self.bag_metadata()).strip())
        _sync(storage.path)
        self.storage = None
        return storage.path

    def bag_metadata(self, files: Sequence[FileStats] | None = None) -> dict[str, Any]:
        """Return the bag's ``BagMetadata`` as rosbag2 encodes it (rosbag2_storage/yaml.hpp), key for key."""
        listed = list(self.files if files is None else files)
        count = sum(f.count for f in listed)
        timed = [f for f in listed if f.count]
        start = min((f.start for f in timed), default=_NO_MESSAGE)
        end = max((f.end for f in timed), default=0)
        return {
            "version": self.version,
            "storage_identifier": "mcap",
            "duration": {"nanoseconds": max(0, end - start) if timed else 0},
            "starting_time": {"nanoseconds_since_epoch": start},
            "message_count": count,
            "topics_with_message_count": [
                {
                    "topic_metadata": {
                        "name": connection.topic,
                        "type": connection.msgtype,
                        "serialization_format": getattr(connection.ext, "serialization_format", "cdr"),
                        "offered_qos_profiles": dump_qos_v9(
                            list(getattr(connection.ext, "offered_qos_profiles", []))
                        ),
                        "type_description_hash": connection.digest,
                    },
                    "message_count": self.counts[connection.id],
                }
                for connection in self.connections
            ],
            "compression_format": "",
            "compression_mode": "",
            "relative_file_paths": [f.name for f in listed],
            "files": [
                {
                    "path": f.name,
                    "starting_time": {"nanoseconds_since_epoch": f.start if f.count else start},
                    "duration": {"nanoseconds": max(0, f.end - f.start) if f.count else 0},
                    "message_count": f.count,
                }
                for f in listed
            ],
            "custom_data": dict(self.custom_data) or None,
            "ros_distro": ROS_DISTRO,
        }

    def close(self, files: Sequence[FileStats] | None = None) -> None:
        """Close the last file and write ``metadata.yaml`` (listing ``files``, by default every file)."""
        if self.storage is not None:
            self.finish_file()
        metapath = self.path / "metadata.yaml"
        temporary = metapath.with_suffix(".yaml.tmp")
        temporary.write_text(dump_yaml({"rosbag2_bagfile_information": self.bag_metadata(files)}), "utf8")
        os.replace(temporary, metapath)

    def abort(self) -> None:
        """Close the current file as it is (no summary, no metadata.yaml)."""
        if self.storage is not None:
            self.storage.bio.close()
            self.storage = None


def _sync(path: Path) -> None:
    descriptor = os.open(path, os.O_RDONLY)
    try:
        os.fsync(descriptor)
    finally:
        os.close(descriptor)
