"""What rosbag2_storage_mcap (ros2/rosbag2, Jazzy) writes into an MCAP file, checked field by field.

From the plugin's writer (``rosbag2_storage_mcap/src/mcap_storage.cpp``) and the encoders it calls
(``rosbag2_storage/yaml.hpp``, ``rosbag2_storage/src/rosbag2_storage/qos.cpp``):

- header: ``McapWriterOptions("ros2")``: profile ``ros2``; library: the writing library's name and
  version (libmcap's there; any non-empty identification is what readers accept);
- schema per type: name the type (``pkg/msg/Type``), encoding ``ros2msg`` (or ``ros2idl``), data the
  full definition text;
- channel per topic (``create_topic``): topic, message encoding the serialization format (``cdr``), and
  metadata ``offered_qos_profiles`` (``serialize_rclcpp_qos_vector``, version 9: a YAML sequence of maps
  with history/reliability/durability/liveliness as strings, deadline/lifespan/lease as sec/nsec, depth,
  avoid_ros_namespace_conventions) and ``topic_type_hash`` (``type_description_hash``, ``RIHS01_`` + 64 hex);
- message (``write_lock_free``): sequence 0, log time the receive time, publish time the send time;
- ``update_metadata`` (called at open, on split and at close): a metadata record named ``rosbag2`` with
  one key ``serialized_metadata``, the ``BagMetadata`` encoding, which ``read_metadata`` decodes (every
  key below is read with ``.as<>()``, so a missing one makes ``ros2 bag info FILE.mcap`` fail);
- chunks: no CRC (``noChunkCRC = true``), compression none unless configured; a summary with statistics
  (``read_metadata`` takes counts and times from it) and the metadata index (how it finds ``rosbag2``).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from mcap.reader import make_reader
from ruamel.yaml import YAML

QOS_KEYS = {
    "history",
    "depth",
    "reliability",
    "durability",
    "deadline",
    "lifespan",
    "liveliness",
    "liveliness_lease_duration",
    "avoid_ros_namespace_conventions",
}
BAG_METADATA_KEYS = {
    "version",
    "storage_identifier",
    "duration",
    "starting_time",
    "message_count",
    "topics_with_message_count",
    "compression_format",
    "compression_mode",
    "relative_file_paths",
    "files",
    "custom_data",
    "ros_distro",
}
TOPIC_METADATA_KEYS = {
    "name",
    "type",
    "serialization_format",
    "offered_qos_profiles",
    "type_description_hash",
}
HASH = re.compile(r"RIHS01_[0-9a-f]{64}")


def check_qos_list(profiles: Any) -> None:
    """A version 9 offered QoS list, as ``convert<std::vector<rclcpp::QoS>>`` encodes it."""
    assert isinstance(profiles, list) and profiles, profiles
    for profile in profiles:
        assert set(profile) == QOS_KEYS, set(profile) ^ QOS_KEYS
        assert profile["history"] in ("keep_last", "keep_all")
        assert profile["reliability"] in ("reliable", "best_effort")
        assert profile["durability"] in ("volatile", "transient_local")
        assert profile["liveliness"] in ("automatic", "manual_by_topic")
        for key in ("deadline", "lifespan", "liveliness_lease_duration"):
            assert set(profile[key]) == {"sec", "nsec"}
        assert isinstance(profile["depth"], int) and isinstance(
            profile["avoid_ros_namespace_conventions"], bool
        )


def check_bag_metadata(metadata: Any, file_names: list[str]) -> None:
    """A ``BagMetadata`` as rosbag2 encodes it, for a bag of ``file_names``."""
    assert isinstance(metadata, dict) and set(metadata) == BAG_METADATA_KEYS, (
        set(metadata) ^ BAG_METADATA_KEYS
    )
    assert metadata["version"] == 9 and metadata["storage_identifier"] == "mcap"
    assert metadata["ros_distro"] == "jazzy"
    assert set(metadata["duration"]) == {"nanoseconds"}
    assert set(metadata["starting_time"]) == {"nanoseconds_since_epoch"}
    assert metadata["compression_mode"] in ("", "file") and isinstance(metadata["compression_format"], str)
    assert metadata["custom_data"] is None or all(
        isinstance(v, str) for v in metadata["custom_data"].values()
    )
    assert metadata["relative_file_paths"] == file_names
    assert [f["path"] for f in metadata["files"]] == file_names
    for entry in metadata["files"]:
        assert set(entry) == {"path", "starting_time", "duration", "message_count"}
    total = 0
    for topic in metadata["topics_with_message_count"]:
        assert set(topic) == {"topic_metadata", "message_count"}
        assert set(topic["topic_metadata"]) == TOPIC_METADATA_KEYS
        assert HASH.fullmatch(topic["topic_metadata"]["type_description_hash"])
        assert topic["topic_metadata"]["serialization_format"] == "cdr"
        check_qos_list(topic["topic_metadata"]["offered_qos_profiles"])
        total += topic["message_count"]
    assert total == metadata["message_count"] == sum(f["message_count"] for f in metadata["files"])


def check_file(path: Path, bag_files: list[str]) -> dict[str, Any]:
    """Check one MCAP file of a bag field by field; return its serialized rosbag2 metadata."""
    from feeder_cell.bag.types import type_hash

    yaml = YAML(typ="safe")
    with path.open("rb") as stream:
        reader = make_reader(stream)
        header = reader.get_header()
        assert header.profile == "ros2"
        assert header.library, "the library field names the writer"
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None, "a summary with statistics"
        for schema in summary.schemas.values():
            assert schema.encoding in ("ros2msg", "ros2idl") and schema.data
            assert len(schema.name.split("/")) == 3
        assert summary.channels, "a file declares its topics"
        for channel in summary.channels.values():
            schema = summary.schemas[channel.schema_id]
            assert channel.message_encoding == "cdr"
            assert set(channel.metadata) == {"offered_qos_profiles", "topic_type_hash"}, channel.metadata
            check_qos_list(yaml.load(channel.metadata["offered_qos_profiles"]))
            assert HASH.fullmatch(channel.metadata["topic_type_hash"])
            known = type_hash(schema.name)
            assert known is None or channel.metadata["topic_type_hash"] == known
        for index in summary.chunk_indexes:
            assert index.compression in ("", "zstd", "lz4")
        assert "rosbag2" in {index.name for index in summary.metadata_indexes}
        records = [m for m in reader.iter_metadata() if m.name == "rosbag2"]
        assert records and set(records[-1].metadata) == {"serialized_metadata"}
        metadata = yaml.load(records[-1].metadata["serialized_metadata"])
        check_bag_metadata(metadata, bag_files[: bag_files.index(path.name) + 1])
        count = 0
        for _, _, message in reader.iter_messages():
            assert message.sequence == 0
            assert message.log_time > 0 and message.publish_time > 0
            count += 1
        assert count == summary.statistics.message_count
    return metadata


def check_bag(bag: Path) -> dict[str, Any]:
    """Check metadata.yaml and every MCAP file of a bag; return metadata.yaml's bag information."""
    info = YAML(typ="safe").load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    names = info["relative_file_paths"]
    check_bag_metadata(info, names)
    for name in names:
        check_file(bag / name, names)
    return dict(info)
