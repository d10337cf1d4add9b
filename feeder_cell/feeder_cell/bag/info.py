"""What ``feeder bag-info`` reports about a bag: what ``ros2 bag info`` prints, as a dict and as text.

Files, bag size, storage id, duration, start and end (wall time to the nanosecond), message count,
compression (rosbag2's file or message compression from ``metadata.yaml``, and the MCAP chunk
compression the files use), and per topic its type, count, serialization format and offered QoS.
Service-event topics (``<service>/_service_event``) are listed as services, with their request and
response event counts, as ``ros2 bag info`` lists them under "Services".
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING, Any, Sequence

from feeder_cell.bag.recorder import service_of

if TYPE_CHECKING:
    from rosbags.interfaces import Qos

# service_msgs/msg/ServiceEventInfo event_type: the first byte after the 4-byte CDR encapsulation.
_REQUEST_EVENTS = (0, 1)  # REQUEST_SENT, REQUEST_RECEIVED
_EVENT_TYPE_OFFSET = 4


def wall_time(nanoseconds: int) -> str:
    """Return ``Mon DD YYYY HH:MM:SS.nnnnnnnnn`` (local time) as ``ros2 bag info`` writes times."""
    seconds, fraction = divmod(nanoseconds, 1_000_000_000)
    return time.strftime("%b %e %Y %H:%M:%S", time.localtime(seconds)) + f".{fraction:09d}"


def _chunk_compressions(path: Path) -> list[str]:
    from mcap.reader import make_reader

    with path.open("rb") as stream:
        summary = make_reader(stream).get_summary()
    if summary is None:
        return []
    return sorted({index.compression or "none" for index in summary.chunk_indexes})


def _qos_dicts(profiles: Sequence[Qos]) -> list[dict[str, Any]]:
    from rosbags.rosbag2.metadata import dump_qos_v9

    return [dict(p) for p in dump_qos_v9(list(profiles))]


def bag_info(path: Path) -> dict[str, Any]:
    """Describe the bag at ``path`` (see the module docstring); bad or unclosed bags raise InputError."""
    from ruamel.yaml import YAML

    from feeder_cell.bag.player import open_bag

    reader = open_bag(path)
    try:
        metadata = YAML(typ="safe").load((path / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
        files = []
        for entry in metadata.get("files") or [{"path": p} for p in metadata["relative_file_paths"]]:
            file_path = path / entry["path"]
            files.append(
                {
                    "path": entry["path"],
                    "size": file_path.stat().st_size,
                    "message_count": entry.get("message_count"),
                    "starting_time_ns": (entry.get("starting_time") or {}).get("nanoseconds_since_epoch"),
                    "duration": (entry.get("duration") or {}).get("nanoseconds", 0) / 1e9,
                    "chunk_compression": _chunk_compressions(file_path),
                }
            )
        empty = reader.message_count == 0  # rosbags reports the "no message yet" sentinel as the start
        start = None if empty else reader.start_time
        # rosbags' end_time is one past the last message (end exclusive); the last message is at end - 1.
        end = None if empty else reader.end_time - 1
        topics: dict[str, Any] = {}
        services: dict[str, Any] = {}
        for connection in reader.connections:
            entry = {
                "type": connection.msgtype,
                "count": connection.msgcount,
                "serialization_format": connection.ext.serialization_format,
                "offered_qos_profiles": _qos_dicts(connection.ext.offered_qos_profiles),
                "type_description_hash": connection.digest,
            }
            service = service_of(connection.topic)
            if service is None:
                topics[connection.topic] = entry
                continue
            requests = sum(
                1
                for _, _, data in reader.messages(connections=[connection])
                if len(data) > _EVENT_TYPE_OFFSET and data[_EVENT_TYPE_OFFSET] in _REQUEST_EVENTS
            )
            services[service] = {
                "type": connection.msgtype.removesuffix("_Event"),
                "event_type": connection.msgtype,
                "topic": connection.topic,
                "event_count": connection.msgcount,
                "request_count": requests,
                "response_count": connection.msgcount - requests,
                "serialization_format": connection.ext.serialization_format,
            }
        chunk = sorted({c for f in files for c in f["chunk_compression"]})
        return {
            "path": str(path.resolve()),
            "files": files,
            "bag_size": sum(f["size"] for f in files),
            "storage_identifier": metadata.get("storage_identifier", ""),
            "ros_distro": metadata.get("ros_distro", ""),
            "duration": 0.0 if empty else (end - start) / 1e9,  # type: ignore[operator]
            "start_time": None if empty else start / 1e9,  # type: ignore[operator]
            "end_time": None if empty else end / 1e9,  # type: ignore[operator]
            "start_time_ns": start,
            "end_time_ns": end,
            "start": None if start is None else wall_time(start),
            "end": None if end is None else wall_time(end),
            "message_count": reader.message_count,
            "compression_mode": metadata.get("compression_mode", ""),
            "compression_format": metadata.get("compression_format", ""),
            "chunk_compression": ",".join(c for c in chunk if c != "none") or "none",
            "topics": dict(sorted(topics.items())),
            "services": dict(sorted(services.items())),
        }
    finally:
        reader.close()


def _size(size: int) -> str:
    for unit in ("B", "KiB", "MiB", "GiB"):
        if size < 1024 or unit == "GiB":
            return f"{size} {unit}" if unit == "B" else f"{size:.1f} {unit}"
        size /= 1024  # type: ignore[assignment]
    return str(size)


def _qos_yaml(profile: dict[str, Any]) -> list[str]:
    lines = []
    for key, value in profile.items():
        if isinstance(value, dict):
            value = "{" + ", ".join(f"{k}: {v}" for k, v in value.items()) + "}"
        lines.append(f"{key}: {str(value).lower() if isinstance(value, bool) else value}")
    return lines


def info_text(info: dict[str, Any]) -> str:
    """Return ``info`` laid out as ``ros2 bag info`` prints it (offered QoS as YAML under each topic)."""
    label = "{:<19}".format
    lines = [label("Files:") + (info["files"][0]["path"] if info["files"] else "")]
    lines += [" " * 19 + f["path"] for f in info["files"][1:]]
    lines.append(label("Bag size:") + _size(info["bag_size"]))
    lines.append(label("Storage id:") + info["storage_identifier"])
    lines.append(label("ROS Distro:") + info["ros_distro"])
    lines.append(label("Duration:") + f"{info['duration']:.9f}s")
    for key in ("start", "end"):
        if info[key] is not None:
            ns = info[f"{key}_time_ns"]
            lines.append(label(f"{key.capitalize()}:") + f"{info[key]} ({ns // 10**9}.{ns % 10**9:09d})")
    lines.append(label("Messages:") + str(info["message_count"]))
    compression = info["compression_format"] or info["chunk_compression"]
    mode = info["compression_mode"] or ("MCAP chunks" if info["chunk_compression"] != "none" else "")
    lines.append(label("Compression:") + compression + (f" ({mode})" if mode else ""))
    first = True
    for name, topic in info["topics"].items():
        lines.append(
            label("Topic information:" if first else "")
            + f"Topic: {name} | Type: {topic['type']} | Count: {topic['count']} | "
            f"Serialization Format: {topic['serialization_format']}"
        )
        first = False
        if topic["offered_qos_profiles"]:
            lines.append(" " * 21 + "Offered QoS Profiles:")
        for profile in topic["offered_qos_profiles"]:
            items = _qos_yaml(profile)
            lines.append(" " * 23 + "- " + items[0])
            lines += [" " * 25 + item for item in items[1:]]
    if not info["topics"]:
        lines.append(label("Topic information:"))
    lines.append(label("Service:") + str(len(info["services"])))
    first = True
    for name, service in info["services"].items():
        lines.append(
            label("Service information:" if first else "")
            + f"Service: {name} | Type: {service['type']} | Request Count: {service['request_count']} | "
            f"Response Count: {service['response_count']} | "
            f"Serialization Format: {service['serialization_format']}"
        )
        first = False
    return "\n".join(lines)
