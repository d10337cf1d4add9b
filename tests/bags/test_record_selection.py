"""ROS-free: which topics a recording takes, QoS override files, compression flags, bag types, --help.

The selection rules are ``ros2 bag record``'s (explicit topics, all, regex, exclude, topic types, hidden
topics, service events, action topics); the override format is rosbag2's YAML; service and action
types get definitions the independent mcap_ros2 decoder parses and the rosidl type hashes.
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
from pathlib import Path

import pytest
from rclpy.qos import DurabilityPolicy, HistoryPolicy, ReliabilityPolicy

from feeder_cell.bag.qos import load_qos_overrides, parse_qos_overrides
from feeder_cell.bag.recorder import Selection, action_of, service_of
from feeder_cell.bag.types import connection_definition, is_known, message_class
from feeder_cell.cli.bag import _compression
from feeder_planner.errors import InputError

STRING, INT = "std_msgs/msg/String", "std_msgs/msg/Int32"
EVENT = "std_srvs/srv/Trigger_Event"


def test_default_and_all_topics() -> None:
    default = Selection(all_topics=True)
    assert default.wants("/a", STRING)
    assert not default.wants("/rosout", "rcl_interfaces/msg/Log")
    assert not default.wants("/arm/_action/status", "action_msgs/msg/GoalStatusArray")  # hidden
    assert not default.wants("/arm/stop/_service_event", EVENT)
    everything = Selection(all_topics=True, services=(), actions=())
    assert everything.wants("/arm/stop/_service_event", EVENT)
    assert everything.wants("/arm/feed/_action/feedback", "x/action/Feed_FeedbackMessage")
    assert not everything.wants("/arm/_hidden", STRING)


def test_explicit_regex_exclude_types_hidden() -> None:
    assert Selection(topics=("/a",)).wants("/a", STRING) and not Selection(topics=("/a",)).wants("/b", STRING)
    assert Selection(topics=("/x/_h",)).wants("/x/_h", STRING)  # named explicitly: hidden or not
    regex = Selection(regex="^/ctl/")
    assert regex.wants("/ctl/a", STRING) and not regex.wants("/other", STRING)
    assert not regex.wants("/ctl/_h/c", STRING) and Selection(regex="^/ctl/", include_hidden=True).wants(
        "/ctl/_h/c", STRING
    )
    excluded = Selection(all_topics=True, exclude="/b", services=())
    assert not excluded.wants("/ctl/b", STRING) and not excluded.wants("/b/_service_event", EVENT)
    typed = Selection(all_topics=True, topic_types=(INT,))
    assert typed.wants("/n", INT) and not typed.wants("/s", STRING)
    assert Selection(services=("/arm/stop",)).wants("/arm/stop/_service_event", EVENT)
    assert not Selection(services=("/arm/stop",)).wants("/arm/reset/_service_event", EVENT)
    assert Selection(actions=("/arm/feed",)).wants(
        "/arm/feed/_action/status", "action_msgs/msg/GoalStatusArray"
    )
    assert service_of("/a/b/_service_event") == "/a/b" and service_of("/a/b") is None
    assert action_of("/a/_action/feedback") == "/a" and action_of("/a/_action/other") is None


def test_bad_selections_name_the_flag() -> None:
    with pytest.raises(InputError, match="--regex"):
        Selection(regex="(")
    with pytest.raises(InputError, match="--exclude"):
        Selection(exclude="[")
    with pytest.raises(InputError, match="--topic-types"):
        Selection(topic_types=("String",))


def test_qos_overrides_in_rosbag2_format(tmp_path: Path) -> None:
    path = tmp_path / "overrides.yaml"
    path.write_text(
        "/a:\n  history: keep_all\n  reliability: best_effort\n  durability: transient_local\n"
        "  deadline: {sec: 1, nsec: 500}\n/b:\n  depth: 3\n"
    )
    profiles = load_qos_overrides(path)
    assert profiles["/a"].history == HistoryPolicy.KEEP_ALL
    assert profiles["/a"].reliability == ReliabilityPolicy.BEST_EFFORT
    assert profiles["/a"].durability == DurabilityPolicy.TRANSIENT_LOCAL
    assert profiles["/a"].deadline.nanoseconds == 1_000_000_500
    assert profiles["/b"].depth == 3 and profiles["/b"].reliability == ReliabilityPolicy.RELIABLE
    for document, named in (
        ({"/a": {"reliabilty": "reliable"}}, "unknown QoS policy 'reliabilty'"),
        ({"/a": {"reliability": "system_default"}}, "/a: reliability"),
        ({"/a": {"depth": -1}}, "/a: depth"),
        ({"/a": {"deadline": {"sec": -1}}}, "/a: deadline"),
        ({"a": {}}, "absolute"),
        ([1], "must map topic names"),
    ):
        with pytest.raises(InputError, match=re.escape(named)):
            parse_qos_overrides(document)
    with pytest.raises(InputError, match="--qos-profile-overrides-path"):
        load_qos_overrides(tmp_path / "absent.yaml")


def _flags(**given: object) -> argparse.Namespace:
    values = {"compression": None, "compression_mode": None, "compression_format": None} | given
    return argparse.Namespace(**values)


def test_compression_flags_map_to_mcap_chunk_compression() -> None:
    assert _compression(_flags()) == "none"
    assert _compression(_flags(compression="lz4")) == "lz4"
    assert _compression(_flags(compression_mode="message")) == "zstd"
    assert _compression(_flags(compression_mode="file", compression_format="lz4")) == "lz4"
    with pytest.raises(InputError, match="--compression-format"):
        _compression(_flags(compression_format="zstd"))
    with pytest.raises(InputError, match="--compression"):
        _compression(_flags(compression="zstd", compression_mode="file"))


def test_service_and_action_types_are_described() -> None:
    from mcap.records import Schema
    from mcap_ros2.decoder import DecoderFactory
    from rclpy.serialization import serialize_message

    from feeder_msgs.srv import ArmPlacePart

    for name in (EVENT, "feeder_msgs/srv/ArmPlacePart_Event", "feeder_msgs/action/FeedPart_FeedbackMessage"):
        assert is_known(name)
        text, digest = connection_definition(name)
        assert digest.startswith("RIHS01_") and len(digest) == 7 + 64
    assert not is_known("feeder_msgs/srv/NoSuch_Event") and not is_known("nope/msg/Nope")
    # The rosidl type hash, as the installed type description states it.
    assert connection_definition(EVENT)[1] == (
        "RIHS01_ec4a1d26b0575e61906890342aba9523a2360e9845857c5590fa6e23bc39e1c2"
    )
    # The definition decodes a real event (mcap_ros2 takes no underscore in type names: joined here).
    event_class = message_class("feeder_msgs/srv/ArmPlacePart_Event")
    event = event_class(request=[ArmPlacePart.Request(edge=3, radius=0.25)])
    event.info.event_type = 1
    text, _ = connection_definition("feeder_msgs/srv/ArmPlacePart_Event")
    join = re.compile(r"\b([A-Z][a-z][A-Za-z0-9]*)_([A-Z][A-Za-z0-9]*)\b")
    schema = Schema(
        id=1,
        name="feeder_msgs/srv/ArmPlacePartEvent",
        encoding="ros2msg",
        data=join.sub(r"\1\2", text).encode(),
    )
    decoded = DecoderFactory().decoder_for("cdr", schema)(serialize_message(event))  # type: ignore[misc]
    assert decoded.info.event_type == 1 and decoded.response == []
    assert (decoded.request[0].edge, decoded.request[0].radius) == (3, 0.25)


def test_every_record_flag_is_in_the_help() -> None:
    result = subprocess.run(
        [sys.executable, "-m", "feeder_cell.cli.main", "record", "--help"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 0, result.stderr
    for flag in (
        "--topics", "--all", "--regex", "--exclude", "--topic-types", "--include-hidden-topics", "--services",
        "--actions", "--max-bag-size", "--max-bag-duration", "--compression", "--compression-mode",
        "--compression-format", "--start-paused", "--qos-profile-overrides-path", "--node-name",
        "--duration", "--flush-interval", "--json",
    ):  # fmt: skip
        assert flag in result.stdout, flag


@pytest.mark.parametrize("kind", ["parent_is_a_file", "bag_exists"])
def test_record_refuses_an_unusable_output_before_any_node(tmp_path: Path, kind: str) -> None:
    if kind == "parent_is_a_file":
        (tmp_path / "plain").write_text("not a directory")
        output, reason = tmp_path / "plain" / "bag", "is not a directory"
    else:
        (tmp_path / "bag").mkdir()
        output, reason = tmp_path / "bag", "already exists"
    result = subprocess.run(
        [sys.executable, "-m", "feeder_cell.cli.main", "record", str(output), "--duration", "1"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("feeder record: output:") and reason in lines[0], lines
