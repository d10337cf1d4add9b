"""Conversion between rclpy QoS profiles and the rosbags QoS records stored in bag metadata; QoS overrides."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

from rclpy.duration import Duration
from rclpy.qos import DurabilityPolicy, HistoryPolicy, LivelinessPolicy, QoSProfile, ReliabilityPolicy
from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime

from feeder_planner.errors import InputError
from feeder_planner.reading import load_yaml_file

_ZERO = QosTime(0, 0)


def offered_qos(publishers: Sequence[Any]) -> tuple[bool, bool]:
    """Return (reliable, latched) of a topic's publishers (``get_publishers_info_by_topic``).

    Reliable only if every publisher is (one best-effort publisher needs a best-effort reader); latched
    if any is transient-local (its stored samples are wanted).
    """
    reliable = all(p.qos_profile.reliability == ReliabilityPolicy.RELIABLE for p in publishers)
    latched = any(p.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for p in publishers)
    return reliable, latched


def matching_qos(reliable: bool, latched: bool, depth: int) -> QoSProfile:
    """Return the subscription profile that matches publishers offering (reliable, latched)."""
    return QoSProfile(
        depth=depth,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE,
    )


def to_bag_qos(reliable: bool, transient_local: bool, depth: int = 10) -> Qos:
    """Return the bag's QoS record of a publisher with these policies."""
    return Qos(
        QosHistory.KEEP_LAST,
        depth,
        QosReliability.RELIABLE if reliable else QosReliability.BEST_EFFORT,
        QosDurability.TRANSIENT_LOCAL if transient_local else QosDurability.VOLATILE,
        _ZERO,
        _ZERO,
        QosLiveliness.AUTOMATIC,
        _ZERO,
        False,
    )


def from_bag_qos(profiles: list[Qos] | tuple[Qos, ...], depth: int = 10) -> QoSProfile:
    """Return a publisher profile that offers what the recorded publishers offered (latched stays latched)."""
    reliable = not profiles or all(p.reliability != QosReliability.BEST_EFFORT for p in profiles)
    latched = any(p.durability == QosDurability.TRANSIENT_LOCAL for p in profiles)
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=depth,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE,
    )


_HISTORY = {"keep_last": HistoryPolicy.KEEP_LAST, "keep_all": HistoryPolicy.KEEP_ALL}
_RELIABILITY = {"reliable": ReliabilityPolicy.RELIABLE, "best_effort": ReliabilityPolicy.BEST_EFFORT}
_DURABILITY = {"volatile": DurabilityPolicy.VOLATILE, "transient_local": DurabilityPolicy.TRANSIENT_LOCAL}
_LIVELINESS = ("automatic", "manual_by_topic", "system_default")
_DURATIONS = ("deadline", "lifespan", "liveliness_lease_duration")
_KEYS = ("history", "depth", "reliability", "durability", "liveliness", "avoid_ros_namespace_conventions")


def _duration(where: str, value: Any) -> Duration:
    if not isinstance(value, dict) or set(value) - {"sec", "nsec"}:
        raise InputError(where, f"must be a mapping with sec and nsec, got {value!r}")
    sec, nsec = value.get("sec", 0), value.get("nsec", 0)
    if not all(isinstance(v, int) and not isinstance(v, bool) and v >= 0 for v in (sec, nsec)):
        raise InputError(where, f"sec and nsec must be whole numbers >= 0, got {value!r}")
    return Duration(seconds=sec, nanoseconds=nsec)


def _choice(where: str, value: Any, choices: dict[str, Any]) -> Any:
    if value not in choices:
        raise InputError(where, f"must be one of {', '.join(choices)}, got {value!r}")
    return choices[value]


def parse_qos_overrides(document: Any, source: str = "--qos-profile-overrides-path") -> dict[str, QoSProfile]:
    """Return the subscription profiles of a rosbag2 QoS override document (``{topic: {policy: value}}``).

    The format is rosbag2's (``ros2 bag record --qos-profile-overrides-path``): per topic ``history``
    (keep_last, keep_all), ``depth``, ``reliability`` (reliable, best_effort), ``durability`` (volatile,
    transient_local), ``deadline``/``lifespan``/``liveliness_lease_duration`` as ``{sec, nsec}``,
    ``liveliness`` (automatic, manual_by_topic) and ``avoid_ros_namespace_conventions``. A policy left
    out keeps the recorder's default (reliable, volatile, keep_last). ``system_default`` is refused: a
    recording's QoS should not depend on the middleware's defaults.

    Raises
    ------
    InputError
        Naming the topic and policy of the first bad entry.
    """
    if document is None:
        return {}
    if not isinstance(document, dict):
        raise InputError(source, f"must map topic names to QoS policies, got {type(document).__name__}")
    profiles: dict[str, QoSProfile] = {}
    for topic, policies in document.items():
        where = f"{source}: {topic}"
        if not isinstance(topic, str) or not topic.startswith("/"):
            raise InputError(where, "topic names must be absolute (start with /)")
        if not isinstance(policies, dict):
            raise InputError(where, f"must map QoS policies to values, got {policies!r}")
        unknown = set(policies) - set(_KEYS) - set(_DURATIONS)
        if unknown:
            raise InputError(
                where, f"unknown QoS policy {sorted(unknown)[0]!r} (known: {', '.join(_KEYS + _DURATIONS)})"
            )
        depth = policies.get("depth", 10)
        if not (isinstance(depth, int) and not isinstance(depth, bool) and depth >= 0):
            raise InputError(f"{where}: depth", f"must be a whole number >= 0, got {depth!r}")
        liveliness = policies.get("liveliness", "automatic")
        if liveliness not in _LIVELINESS[:2]:
            raise InputError(
                f"{where}: liveliness", f"must be one of automatic, manual_by_topic, got {liveliness!r}"
            )
        avoid = policies.get("avoid_ros_namespace_conventions", False)
        if not isinstance(avoid, bool):
            raise InputError(
                f"{where}: avoid_ros_namespace_conventions", f"must be true or false, got {avoid!r}"
            )
        profile = QoSProfile(
            history=_choice(f"{where}: history", policies.get("history", "keep_last"), _HISTORY),
            depth=depth,
            reliability=_choice(
                f"{where}: reliability", policies.get("reliability", "reliable"), _RELIABILITY
            ),
            durability=_choice(f"{where}: durability", policies.get("durability", "volatile"), _DURABILITY),
            liveliness=LivelinessPolicy.AUTOMATIC
            if liveliness == "automatic"
            else LivelinessPolicy.MANUAL_BY_TOPIC,
            avoid_ros_namespace_conventions=avoid,
        )
        for key in _DURATIONS:
            if key in policies:
                setattr(profile, key, _duration(f"{where}: {key}", policies[key]))
        profiles[topic] = profile
    return profiles


def load_qos_overrides(path: Path) -> dict[str, QoSProfile]:
    """Read a rosbag2 QoS override YAML file (see :func:`parse_qos_overrides`).

    It is read through the project's bounded reading layer, as every other input file: a missing or
    special file (a FIFO, /dev/zero), an oversized file or an alias bomb is refused naming the flag.
    """
    flag = "--qos-profile-overrides-path"
    try:
        document = load_yaml_file(path)
    except InputError as error:
        where = "" if error.field == "<file>" else f" {error.field}:"
        raise InputError(flag, f"{path}:{where} {error.problem}") from None
    return parse_qos_overrides(document, f"{flag} {path}")
