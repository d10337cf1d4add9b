"""Compare two recorded bags message by message: on the lockstep clock one seed gives one bag at any pace.

What is compared: on every topic both bags recorded (less the excluded ones), the messages in log-time
order over a span of cell time, each deserialized and compared field by field, its log time included.
What is not, because it follows the wall clock by design:

- topics that run on wall time: ``/rosout``, ``/diagnostics`` (1 Hz heartbeats), ``/parameter_events``,
  ``/clock`` (published at a wall-clock rate for the nodes that do not join the lockstep), the lockstep's
  own topics, lifecycle ``transition_event`` (its ``timestamp`` is the wall clock), and what the viewers
  are drawn from: ``~/markers``, ``/tf`` and ``/tf_static``, redrawn on a wall-clock timer
  (``marker_rate``) whatever the pace of the cell;
- the heartbeat copies of a latched status (``DeviceStatus``, ``CellStatus``: a copy equal to the previous
  message on its topic but for its stamp and wall-clock fields is dropped before comparing);
- a device status's wall-clock figures (achieved rate and real-time factor, and the configured factor,
  which is the pace asked for).

Floats compare exactly (the same computation on the same inputs), NaN equal to NaN. The first difference
is reported with its topic, message index, log time and field path.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, fields, is_dataclass
from pathlib import Path
from typing import Any, Iterable, Iterator

from mcap.reader import make_reader

from feeder_cell.bag.types import typestore
from feeder_planner.errors import InputError

__all__ = ["DEFAULT_EXCLUDED", "Difference", "Recorded", "compare_bags", "read_bag"]

DEFAULT_EXCLUDED = (
    r"/rosout",
    r"/diagnostics",
    r"/parameter_events",
    r"/clock",
    r"/lockstep/.*",
    r".*/transition_event",
    r".*/markers",
    r"/tf",
    r"/tf_static",
)
WALL_FIELDS = {
    "feeder_msgs/msg/DeviceStatus": (
        "achieved_rate",
        "achieved_real_time_factor",
        "configured_real_time_factor",
    ),
}
HEARTBEAT_TYPES = ("feeder_msgs/msg/DeviceStatus", "feeder_msgs/msg/CellStatus")


@dataclass(frozen=True)
class Recorded:
    """One message as compared: its log time (ns), type and fields as plain data."""

    log_time_ns: int
    type_name: str
    data: Any


@dataclass(frozen=True)
class Difference:
    """The first place two bags differ."""

    topic: str
    index: int  # of the message on its topic, after heartbeats were dropped
    log_time_ns: int
    path: str  # field path, e.g. "header.stamp.sec"; "(count)" when one bag has more messages
    left: Any
    right: Any

    def describe(self) -> str:
        """One line naming the topic, the message and the field."""
        return (
            f"{self.topic} message {self.index} (log time {self.log_time_ns / 1e9:.9f} s): "
            f"{self.path}: {self.left!r} != {self.right!r}"
        )


def _plain(value: Any) -> Any:
    """Turn a deserialized message into nested dicts, lists and scalars."""
    if is_dataclass(value):
        return {f.name: _plain(getattr(value, f.name)) for f in fields(value)}
    if hasattr(value, "tolist"):
        return value.tolist()
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def _without(data: dict[str, Any], type_name: str, stamp: bool) -> dict[str, Any]:
    """Return ``data`` less its wall-clock fields (and its header stamp when ``stamp``)."""
    kept = {k: v for k, v in data.items() if k not in WALL_FIELDS.get(type_name, ())}
    if stamp and isinstance(kept.get("header"), dict):
        kept["header"] = {k: v for k, v in kept["header"].items() if k != "stamp"}
    return kept


def _mcap_files(bag: Path) -> list[Path]:
    if not bag.is_dir():
        raise InputError("bag", f"{bag} is not a bag directory")
    files = sorted(bag.glob("*.mcap"))
    if not files:
        raise InputError("bag", f"{bag} holds no .mcap file")
    return files


def read_bag(
    bag: Path, start_ns: int = 0, end_ns: int | None = None, excluded: Iterable[str] = DEFAULT_EXCLUDED
) -> dict[str, list[Recorded]]:
    """Return the compared messages of a bag by topic, log time in [start_ns, end_ns], heartbeats dropped."""
    patterns = [re.compile(p) for p in excluded]
    topics: dict[str, list[Recorded]] = {}
    for path in _mcap_files(bag):
        try:
            _read_file(path, patterns, start_ns, end_ns, topics)
        except InputError:
            raise
        except Exception as error:  # noqa: BLE001 - the mcap reader's and deserializer's many errors
            message = str(error).splitlines()[0] if str(error) else type(error).__name__
            raise InputError(
                "bag", f"{path} cannot be read ({message}); feeder bag-reindex recovers a cut bag"
            ) from None
    return topics


def _read_file(
    path: Path,
    patterns: list[re.Pattern[str]],
    start_ns: int,
    end_ns: int | None,
    topics: dict[str, list[Recorded]],
) -> None:
    """Add the compared messages of one MCAP file to ``topics``."""
    store = typestore()
    with path.open("rb") as stream:
        for schema, channel, message in make_reader(stream).iter_messages(log_time_order=True):
            if any(p.fullmatch(channel.topic) for p in patterns):
                continue
            if message.log_time < start_ns or (end_ns is not None and message.log_time > end_ns):
                continue
            type_name = schema.name if schema is not None else ""
            data = _without(_plain(store.deserialize_cdr(message.data, type_name)), type_name, False)
            kept = topics.setdefault(channel.topic, [])
            if type_name in HEARTBEAT_TYPES and kept:
                previous = _without(kept[-1].data, type_name, True)
                if next(_differences(previous, _without(data, type_name, True), ""), None) is None:
                    continue  # a heartbeat copy (NaN fields equal to NaN, as in every comparison)
            kept.append(Recorded(message.log_time, type_name, data))


def _differences(left: Any, right: Any, path: str) -> Iterator[tuple[str, Any, Any]]:
    if isinstance(left, dict) and isinstance(right, dict):
        for key in left.keys() | right.keys():
            yield from _differences(left.get(key), right.get(key), f"{path}.{key}" if path else key)
    elif isinstance(left, list) and isinstance(right, list):
        if len(left) != len(right):
            yield f"{path} (length)", len(left), len(right)
            return
        for i, (a, b) in enumerate(zip(left, right, strict=True)):
            yield from _differences(a, b, f"{path}[{i}]")
    elif isinstance(left, float) and isinstance(right, float) and math.isnan(left) and math.isnan(right):
        return
    elif left != right or type(left) is not type(right):
        yield path, left, right


def compare_bags(
    left: Path,
    right: Path,
    start_ns: int = 0,
    end_ns: int | None = None,
    excluded: Iterable[str] = DEFAULT_EXCLUDED,
) -> tuple[Difference | None, dict[str, int]]:
    """Compare two bags over a span of log time; return the first difference (None) and counts by topic.

    Topics recorded in only one bag are a difference. Within a topic, messages compare in order.
    """
    a = read_bag(left, start_ns, end_ns, excluded)
    b = read_bag(right, start_ns, end_ns, excluded)
    counts = {topic: len(messages) for topic, messages in sorted(a.items())}
    for topic in sorted(a.keys() | b.keys()):
        ours, theirs = a.get(topic, []), b.get(topic, [])
        for index, (x, y) in enumerate(zip(ours, theirs, strict=False)):
            if x.log_time_ns != y.log_time_ns:
                return Difference(
                    topic, index, x.log_time_ns, "(log time)", x.log_time_ns, y.log_time_ns
                ), counts
            for path, p, q in _differences(x.data, y.data, ""):
                return Difference(topic, index, x.log_time_ns, path, p, q), counts
        if len(ours) != len(theirs):
            index = min(len(ours), len(theirs))
            at = (ours if len(ours) > index else theirs)[index].log_time_ns
            return Difference(topic, index, at, "(count)", len(ours), len(theirs)), counts
    return None, counts
