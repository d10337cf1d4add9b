"""``feeder bag-convert``: rosbag2's ``ros2 bag convert`` (merge, split, filter, cut, recompress).

The output options are rosbag2's YAML (``ros2 bag convert -o OUTPUT_OPTIONS.yaml``): one top-level key
``output_bags``, a list of rosbag2 ``StorageOptions`` merged with ``RecordOptions`` per output bag, with
the keys and meanings of Jazzy's ``rosbag2_storage/storage_options.cpp`` and
``rosbag2_transport/record_options.cpp``. Every input is read in log-time order and merged (as
``bag_rewrite``'s ``get_next``: the earliest message of all inputs next); each output takes the topics its
options select, the way rosbag2's ``TopicFilter`` selects them for a rewrite:

- a topic is taken by ``all_topics`` (``all`` is all_topics plus all_services), by name in ``topics``, by
  type in ``topic_types`` or by ``regex`` (a search in the name); then dropped by ``exclude_topic_types``,
  ``exclude_topics``, ``exclude_regex`` (``exclude`` is its older name) and, unless
  ``include_hidden_topics``, when a name part starts with ``_``;
- a service's events (``<service>/_service_event``) by ``all_services``, ``services`` (event topic names;
  a plain service name is taken as its event topic) or ``regex`` on the service name; dropped by
  ``exclude_services`` and ``exclude_regex``;
- messages whose log time is outside [``start_time_ns``, ``end_time_ns``] (inclusive; a negative value is
  no bound) are not written; ``max_bagfile_size`` (bytes) and ``max_bagfile_duration`` (seconds) split;
- ``compression_mode`` (file or message) with ``compression_format`` (zstd, lz4), or the
  ``storage_preset_profile`` zstd_fast / zstd_small, compress the MCAP chunks (as ``feeder record`` maps
  them: every MCAP reader decodes them); ``custom_data`` goes into the metadata.

Differences, each refused in one line naming the field rather than ignored: ``storage_id`` other than
``mcap``, a ``storage_config_uri``, ``snapshot_mode: true`` and a ``rmw_serialization_format`` other than
``cdr``; an output whose options select nothing (rosbag2 writes an empty bag); an unknown key (rosbag2
ignores it, which hides a typo). Options that only a live recording uses (``is_discovery_disabled``,
``topic_polling_interval``, ``node_prefix``, ``topic_qos_profile_overrides``, ``include_unpublished_topics``,
``ignore_leaf_topics``, ``start_paused``, ``use_sim_time``, ``disable_keyboard_controls``, the compression
queue and threads, ``max_cache_size``) are checked for their type and have no effect, as in rosbag2's
rewrite. A topic that has two types among the inputs is left out and reported, as rosbag2 leaves it out.
"""

from __future__ import annotations

import heapq
import math
import re
import shutil
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterator, TypedDict

from feeder_cell.bag.recorder import SERVICE_EVENT_SUFFIX, is_hidden
from feeder_cell.bag.writer import BagWriter
from feeder_planner.errors import InputError

if TYPE_CHECKING:
    from rosbags.interfaces import Connection, Qos

    from feeder_cell.bag.reindex import TopicCount

__all__ = ["ConvertResult", "OutputBag", "convert", "load_output_options", "parse_output_options"]

_BOOLS = (
    "all",
    "all_topics",
    "all_services",
    "include_hidden_topics",
    "include_unpublished_topics",
    "ignore_leaf_topics",
    "is_discovery_disabled",
    "start_paused",
    "use_sim_time",
    "disable_keyboard_controls",
    "snapshot_mode",
)
_LISTS = ("topics", "topic_types", "services", "exclude_topics", "exclude_topic_types", "exclude_services")
_STRINGS = (
    "uri",
    "storage_id",
    "storage_preset_profile",
    "storage_config_uri",
    "regex",
    "exclude",
    "exclude_regex",
    "rmw_serialization_format",
    "compression_mode",
    "compression_format",
    "node_prefix",
)
_WHOLE = (
    "max_bagfile_size",
    "max_cache_size",
    "compression_queue_size",
    "compression_threads",
)
_SIGNED = ("start_time_ns", "end_time_ns", "compression_threads_priority")
_NUMBERS = ("max_bagfile_duration",)
_OTHER = ("custom_data", "topic_polling_interval", "topic_qos_profile_overrides")
KNOWN_KEYS = (*_BOOLS, *_LISTS, *_STRINGS, *_WHOLE, *_SIGNED, *_NUMBERS, *_OTHER)

_PRESETS = {"": "none", "none": "none", "fastwrite": "none", "zstd_fast": "zstd", "zstd_small": "zstd"}


@dataclass(frozen=True)
class OutputBag:
    """One entry of ``output_bags``: where to write and what to take (see the module docstring)."""

    uri: Path
    compression: str = "none"  # MCAP chunk compression: none, zstd, lz4
    max_bagfile_size: int = 0
    max_bagfile_duration: float = 0.0
    start_time_ns: int = -1
    end_time_ns: int = -1
    all_topics: bool = False
    all_services: bool = False
    topics: tuple[str, ...] = ()
    topic_types: tuple[str, ...] = ()
    services: tuple[str, ...] = ()
    exclude_topics: tuple[str, ...] = ()
    exclude_topic_types: tuple[str, ...] = ()
    exclude_services: tuple[str, ...] = ()
    regex: str = ""
    exclude_regex: str = ""
    include_hidden_topics: bool = False
    custom_data: tuple[tuple[str, str], ...] = ()

    def takes(self, topic: str, type_name: str) -> bool:
        """Return whether this output takes ``topic`` (rosbag2's TopicFilter for a rewrite)."""
        if topic.endswith(SERVICE_EVENT_SUFFIX) and type_name.endswith("_Event"):
            service = topic[: -len(SERVICE_EVENT_SUFFIX)]
            if not self.all_services and topic not in self.services:
                if not (self.regex and re.search(self.regex, service)):
                    return False
            if topic in self.exclude_services:
                return False
            return not (self.exclude_regex and re.search(self.exclude_regex, service))
        if not self.all_topics and topic not in self.topics and type_name not in self.topic_types:
            if not (self.regex and re.search(self.regex, topic)):
                return False
        if type_name in self.exclude_topic_types or topic in self.exclude_topics:
            return False
        if self.exclude_regex and re.search(self.exclude_regex, topic):
            return False
        return self.include_hidden_topics or not is_hidden(topic)

    def in_window(self, log_time: int) -> bool:
        """Return whether a message at ``log_time`` is within [start_time_ns, end_time_ns]."""
        if self.start_time_ns >= 0 and log_time < self.start_time_ns:
            return False
        return not (self.end_time_ns >= 0 and log_time > self.end_time_ns)


def _check_type(where: str, key: str, value: Any) -> None:
    """Refuse a value of the wrong YAML type for ``key``, naming it."""
    if key in _BOOLS and not isinstance(value, bool):
        raise InputError(where, f"must be true or false, got {value!r:.80}")
    if key in _LISTS and not (isinstance(value, list) and all(isinstance(v, str) and v for v in value)):
        raise InputError(where, f"must be a list of names, got {value!r:.80}")
    if key in _STRINGS and not isinstance(value, str):
        raise InputError(where, f"must be a string, got {value!r:.80}")
    integer = isinstance(value, int) and not isinstance(value, bool)
    if key in _WHOLE and not (integer and value >= 0):
        raise InputError(where, f"must be a whole number >= 0, got {value!r:.80}")
    if key in _SIGNED and not integer:
        raise InputError(where, f"must be a whole number, got {value!r:.80}")
    if key in _NUMBERS and not (
        isinstance(value, (int, float))
        and not isinstance(value, bool)
        and math.isfinite(value)
        and value >= 0
    ):
        raise InputError(where, f"must be a number of seconds >= 0, got {value!r:.80}")
    if key == "custom_data" and not (
        value is None or (isinstance(value, dict) and all(isinstance(k, str) for k in value))
    ):
        raise InputError(where, f"must map names to values, got {value!r:.80}")


def _regex(where: str, pattern: str) -> str:
    try:
        re.compile(pattern)
    except re.error as exc:
        raise InputError(where, f"is not a valid regular expression ({exc}): {pattern!r:.80}") from None
    return pattern


def _compression(where: str, options: dict[str, Any]) -> str:
    """Return the MCAP chunk compression the output's compression keys ask for."""
    mode = options.get("compression_mode", "") or "none"
    fmt = options.get("compression_format", "")
    preset = options.get("storage_preset_profile", "")
    if mode not in ("none", "file", "message"):
        raise InputError(f"{where}.compression_mode", f"must be none, file or message, got {mode!r:.80}")
    if fmt not in ("", "zstd", "lz4"):
        raise InputError(f"{where}.compression_format", f"must be zstd or lz4, got {fmt!r:.80}")
    if preset not in _PRESETS:
        raise InputError(
            f"{where}.storage_preset_profile",
            f"must be one of none, fastwrite, zstd_fast, zstd_small, got {preset!r:.80}",
        )
    if mode == "none":
        if fmt:
            raise InputError(f"{where}.compression_format", "needs compression_mode file or message")
        return _PRESETS[preset]
    if _PRESETS[preset] != "none":
        raise InputError(
            f"{where}.storage_preset_profile", "give either a compressing preset or compression_mode"
        )
    return fmt or "zstd"


def _output(where: str, options: Any) -> OutputBag:
    if not isinstance(options, dict):
        raise InputError(where, f"must be a mapping of storage and record options, got {options!r:.80}")
    for key, value in options.items():
        if key not in KNOWN_KEYS:
            raise InputError(
                f"{where}.{key}", f"is not a rosbag2 output option (known: {', '.join(KNOWN_KEYS)})"
            )
        _check_type(f"{where}.{key}", key, value)
    uri = options.get("uri")
    if not uri:
        raise InputError(f"{where}.uri", "is required: the output bag's directory")
    storage = options.get("storage_id", "") or "mcap"
    if storage != "mcap":
        raise InputError(
            f"{where}.storage_id", f"must be mcap (the only storage written here), got {storage!r:.80}"
        )
    if options.get("storage_config_uri"):
        raise InputError(
            f"{where}.storage_config_uri",
            "storage config files are not read; compress with compression_mode/compression_format",
        )
    if options.get("snapshot_mode"):
        raise InputError(f"{where}.snapshot_mode", "has no meaning for a conversion (it is for recording)")
    if options.get("rmw_serialization_format", "") not in ("", "cdr"):
        raise InputError(f"{where}.rmw_serialization_format", "must be cdr (messages are copied as they are)")
    every = bool(options.get("all", False))
    services = tuple(
        name if name.endswith(SERVICE_EVENT_SUFFIX) else name.rstrip("/") + SERVICE_EVENT_SUFFIX
        for name in options.get("services", ())
    )
    exclude_services = tuple(
        name if name.endswith(SERVICE_EVENT_SUFFIX) else name.rstrip("/") + SERVICE_EVENT_SUFFIX
        for name in options.get("exclude_services", ())
    )
    # exclude_regex wins over the older name exclude when both are given (rosbag2 reads exclude first).
    exclude = str(options.get("exclude_regex", options.get("exclude", "")))
    output = OutputBag(
        uri=Path(uri),
        compression=_compression(where, options),
        max_bagfile_size=options.get("max_bagfile_size", 0),
        max_bagfile_duration=float(options.get("max_bagfile_duration", 0)),
        start_time_ns=options.get("start_time_ns", -1),
        end_time_ns=options.get("end_time_ns", -1),
        all_topics=every or bool(options.get("all_topics", False)),
        all_services=every or bool(options.get("all_services", False)),
        topics=tuple(options.get("topics", ())),
        topic_types=tuple(options.get("topic_types", ())),
        services=services,
        exclude_topics=tuple(options.get("exclude_topics", ())),
        exclude_topic_types=tuple(options.get("exclude_topic_types", ())),
        exclude_services=exclude_services,
        regex=_regex(f"{where}.regex", options.get("regex", "")),
        exclude_regex=_regex(
            f"{where}.{'exclude_regex' if 'exclude_regex' in options else 'exclude'}", exclude
        ),
        include_hidden_topics=bool(options.get("include_hidden_topics", False)),
        custom_data=tuple((k, str(v)) for k, v in (options.get("custom_data") or {}).items()),
    )
    selects = (
        output.all_topics
        or output.all_services
        or output.topics
        or output.topic_types
        or output.services
        or output.regex
        or output.include_hidden_topics
    )
    if not selects:
        raise InputError(
            where,
            "selects nothing: give all, all_topics, all_services, topics, topic_types, services or regex",
        )
    if 0 <= output.end_time_ns < output.start_time_ns:
        raise InputError(f"{where}.end_time_ns", f"is before start_time_ns ({output.start_time_ns})")
    return output


def parse_output_options(document: Any, source: str) -> list[OutputBag]:
    """Return the output bags of a rosbag2 convert options document; errors name ``source`` and the field."""
    try:
        if not isinstance(document, dict) or "output_bags" not in document:
            raise InputError("output_bags", "is required: the top-level key listing the output bags")
        extra = sorted(str(k) for k in document if k != "output_bags")
        if extra:
            raise InputError(extra[0], "is not a top-level key (only output_bags)")
        bags = document["output_bags"]
        if not isinstance(bags, list) or not bags:
            raise InputError("output_bags", f"must be a non-empty list of output bags, got {bags!r:.80}")
        outputs = [_output(f"output_bags[{i}]", options) for i, options in enumerate(bags)]
        uris = [o.uri.resolve() for o in outputs]
        for i, uri in enumerate(uris):
            if uri in uris[:i]:
                raise InputError(
                    f"output_bags[{i}].uri", f"{outputs[i].uri} is also output_bags[{uris.index(uri)}]"
                )
    except InputError as error:
        raise error.with_source(source) from None
    return outputs


def load_output_options(path: Path) -> list[OutputBag]:
    """Read an output options YAML file through the bounded reading layer (:func:`parse_output_options`)."""
    from feeder_planner.reading import load_yaml_file

    try:
        document = load_yaml_file(path)
    except InputError as error:
        if error.field == "<file>":
            raise InputError("-o", f"{path}: {error.problem}") from None
        raise
    return parse_output_options(document, str(path))


@dataclass
class _Topic:
    """A topic as the inputs declare it."""

    type_name: str
    msgdef: str
    type_hash: str
    encoding: str
    profiles: list[Qos] = field(default_factory=list)
    profile_keys: set[str] = field(default_factory=set)


@dataclass
class InputFile:
    """One MCAP file of an input bag."""

    path: Path
    bag: str


def input_files(path: Path) -> list[InputFile]:
    """Return the MCAP files of an input (a bag directory, in metadata.yaml's order, or one .mcap file)."""
    from feeder_cell.bag.player import check_integrity
    from feeder_cell.bag.reindex import is_complete

    if path.is_file() and path.suffix == ".mcap":
        if not is_complete(path):
            raise InputError(
                "INPUT", f"{path} ends without its MCAP summary; `feeder bag-reindex` its bag first"
            )
        return [InputFile(path, str(path))]
    if not path.is_dir():
        raise InputError("INPUT", f"{path} is neither a bag directory nor an .mcap file")
    check_integrity(path)  # a bag that is not whole is refused, naming the damage and bag-reindex
    from ruamel.yaml import YAML

    info = YAML(typ="safe").load((path / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    return [InputFile(path / name, str(path)) for name in info["relative_file_paths"]]


def _messages(index: int, source: InputFile) -> Iterator[tuple[int, int, int, str, int, bytes]]:
    """(log time, input order, record order, topic, publish time, data) of one file, in log-time order."""
    from mcap.reader import make_reader

    with source.path.open("rb") as stream:
        for order, (_, channel, message) in enumerate(make_reader(stream).iter_messages(log_time_order=True)):
            yield message.log_time, index, order, channel.topic, message.publish_time, message.data


def _declared_topics(files: list[InputFile]) -> tuple[dict[str, _Topic], dict[str, list[str]]]:
    """Every input topic with its type, definition, hash and offered QoS; topics with two types apart."""
    from mcap.reader import make_reader
    from rosbags.rosbag2.metadata import parse_qos

    from feeder_cell.bag.reindex import UNKNOWN_TYPE_HASH
    from feeder_cell.bag.types import type_hash

    topics: dict[str, _Topic] = {}
    types: dict[str, set[str]] = {}
    for source in files:
        with source.path.open("rb") as stream:
            summary = make_reader(stream).get_summary()
        if summary is None:
            raise InputError(
                "INPUT", f"{source.path} has no MCAP summary; `feeder bag-reindex` its bag first"
            )
        for channel in summary.channels.values():
            schema = summary.schemas.get(channel.schema_id)
            if schema is None:
                continue  # a channel without a schema cannot be described in a bag
            types.setdefault(channel.topic, set()).add(schema.name)
            topic = topics.get(channel.topic)
            if topic is None:
                recorded_hash = channel.metadata.get("topic_type_hash", "")
                topic = topics[channel.topic] = _Topic(
                    schema.name,
                    schema.data.decode(),
                    recorded_hash or type_hash(schema.name) or UNKNOWN_TYPE_HASH,
                    channel.message_encoding,
                )
            qos = channel.metadata.get("offered_qos_profiles", "")
            if qos and qos not in topic.profile_keys:
                topic.profile_keys.add(qos)
                # Every profile offered in any input, once each (rosbag2 gathers all inputs' profiles).
                topic.profiles += [p for p in parse_qos(qos) if p not in topic.profiles]
    ambiguous = {name: sorted(found) for name, found in types.items() if len(found) > 1}
    for name in ambiguous:
        topics.pop(name, None)
    return topics, ambiguous


class OutputSummary(TypedDict):
    """One output bag as ``convert`` wrote it: its files, message count, compression and topics."""

    uri: str
    files: list[str]
    messages: int
    compression: str
    topics: dict[str, TopicCount]


@dataclass
class ConvertResult:
    """What ``convert`` wrote: per output its files and per-topic counts; per input its message count."""

    inputs: dict[str, int] = field(default_factory=dict)
    outputs: list[OutputSummary] = field(default_factory=list)
    skipped_topics: dict[str, list[str]] = field(default_factory=dict)


def convert(inputs: list[Path], outputs: list[OutputBag]) -> ConvertResult:
    """Merge ``inputs`` in log-time order and write every output bag as its options say.

    Raises
    ------
    InputError
        An input that is not a whole bag, or an output that exists already. Outputs written before a
        failure are removed: a conversion leaves all its bags or none.
    """
    if not inputs:
        raise InputError("INPUT", "give at least one input bag")
    for i, output in enumerate(outputs):
        if output.uri.exists() or output.uri.is_symlink():
            raise InputError(
                f"output_bags[{i}].uri", f"{output.uri} already exists; bags are never overwritten"
            )
    files = [f for path in inputs for f in input_files(path)]
    topics, ambiguous = _declared_topics(files)
    result = ConvertResult(inputs={str(p): 0 for p in inputs}, skipped_topics=ambiguous)
    taken = [{name for name, t in topics.items() if o.takes(name, t.type_name)} for o in outputs]
    writers: list[BagWriter] = []
    try:
        for output in outputs:
            writer = BagWriter(output.uri, output.compression, custom_data=dict(output.custom_data))
            writer.open()
            writers.append(writer)
        connections: list[dict[str, Connection]] = []
        for writer, names in zip(writers, taken, strict=True):
            made = {}
            for name in sorted(names):
                declared = topics[name]
                made[name] = writer.add_connection(
                    name,
                    declared.type_name,
                    msgdef=declared.msgdef,
                    rihs01=declared.type_hash,
                    serialization_format=declared.encoding,
                    offered_qos_profiles=declared.profiles,
                )
            connections.append(made)
        streams = [_messages(i, f) for i, f in enumerate(files)]
        counts = [dict.fromkeys(names, 0) for names in taken]
        for log_time, index, _, topic, publish_time, data in heapq.merge(*streams):
            result.inputs[files[index].bag] += 1
            for output, writer, made, count in zip(outputs, writers, connections, counts, strict=True):
                connection = made.get(topic)
                if connection is None or not output.in_window(log_time):
                    continue
                if _split_due(output, writer, log_time):
                    writer.split()
                writer.write(connection, log_time, data, publish_time)
                count[topic] += 1
        for output, writer, count in zip(outputs, writers, counts, strict=True):
            writer.close()
            result.outputs.append(
                {
                    "uri": str(output.uri.resolve()),
                    "files": [f.name for f in writer.files],
                    "messages": sum(count.values()),
                    "compression": output.compression,
                    "topics": {
                        name: {"type": topics[name].type_name, "count": n}
                        for name, n in sorted(count.items())
                    },
                }
            )
    except BaseException:
        for writer in writers:
            writer.abort()
            shutil.rmtree(writer.path, ignore_errors=True)
        raise
    return result


def _split_due(output: OutputBag, writer: BagWriter, log_time: int) -> bool:
    current = writer.files[-1]
    if not current.count:
        return False  # a file holds at least one message, whatever the limits
    if output.max_bagfile_size and writer.file.size() >= output.max_bagfile_size:
        return True
    return bool(output.max_bagfile_duration) and log_time - current.start >= output.max_bagfile_duration * 1e9
