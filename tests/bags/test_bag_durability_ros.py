"""Durability in every start order: a latched publisher, a subscriber and the recorder started in each of
the six orders give the latched sample in the bag and the bag's offered QoS latched; a latched publisher
that joins a topic recorded volatile makes the recorder subscribe again and record its sample."""

from __future__ import annotations

import itertools
import signal
from pathlib import Path
from typing import Any

import bag_procs as bp
import pytest
from mcap.reader import make_reader
from rclpy.qos import DurabilityPolicy
from rosbags.interfaces import QosDurability
from rosbags.rosbag2 import Reader
from rosbags.rosbag2.metadata import parse_qos

TOPIC = "/bag_parts"
NODES = {
    "publisher": "feeder_test_latched_talker",
    "subscriber": "feeder_test_bag_listener",
    "recorder": "feeder_recorder",
}


def _start(kind: str, bag: Path) -> Any:
    if kind == "publisher":
        return bp.start_script("bag_latched_talker.py", "latched", NODES["publisher"], "parts-v1")
    if kind == "subscriber":
        return bp.start_script("bag_listener.py")
    return bp.start_recorder(bag, "--topics", TOPIC)


def _latched_subscription(client: Any) -> bool:
    return any(
        s.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL
        for s in bp.subscribed(client, TOPIC, NODES["recorder"])
    )


def _channel_durabilities(bag: Path) -> list[QosDurability]:
    """The durability the MCAP channel of the topic carries (read with the mcap package)."""
    with bp.mcap_file(bag).open("rb") as stream:
        summary = make_reader(stream).get_summary()
        assert summary is not None
        channels = [c for c in summary.channels.values() if c.topic == TOPIC]
    assert len(channels) == 1
    return [q.durability for q in parse_qos(channels[0].metadata["offered_qos_profiles"])]


def _metadata_durabilities(bag: Path) -> list[QosDurability]:
    """The durabilities metadata.yaml lists for the topic (read with rosbags)."""
    with Reader(bag) as reader:
        (connection,) = [c for c in reader.connections if c.topic == TOPIC]
        return [q.durability for q in connection.ext.offered_qos_profiles]  # type: ignore[union-attr]


@pytest.mark.ros
@pytest.mark.parametrize("order", list(itertools.permutations(NODES)), ids="-".join)
def test_latched_sample_and_durability_in_every_start_order(
    ros_domain: int, ros_client: Any, tmp_path: Path, order: tuple[str, ...]
) -> None:
    bag = tmp_path / "bag"
    processes: dict[str, Any] = {}
    try:
        for kind in order:
            processes[kind] = _start(kind, bag)
            # Each is in the graph before the next starts: the order is the one the graph sees.
            bp.wait_until(lambda k=kind: bp.in_graph(ros_client, NODES[k]), 90, f"the {kind} in the graph")
        bp.wait_until(lambda: _latched_subscription(ros_client), 60, "the recorder's latched subscription")
        bp.wait_until(lambda: bool(bp.flushed_messages(bag, TOPIC)), 60, "the latched sample on disk")
        summary = bp.finish(processes["recorder"], signal.SIGTERM)
    finally:
        for process in processes.values():
            bp.end(process, signal.SIGINT)
    assert summary["topics"][TOPIC]["count"] == 1
    assert [bp.string_data(data) for _, data in bp.read_messages(bag, TOPIC)] == ["parts-v1"]
    assert _channel_durabilities(bag) == [QosDurability.TRANSIENT_LOCAL]
    assert _metadata_durabilities(bag) == [QosDurability.TRANSIENT_LOCAL]


@pytest.mark.ros
def test_a_latched_publisher_joining_a_volatile_topic_is_recorded_latched(
    ros_domain: int, ros_client: Any, tmp_path: Path
) -> None:
    bag = tmp_path / "bag"
    processes: dict[str, Any] = {}
    try:
        processes["volatile"] = bp.start_script(
            "bag_latched_talker.py", "volatile", "feeder_test_volatile", "live"
        )
        processes["recorder"] = bp.start_recorder(bag, "--topics", TOPIC)
        bp.wait_until(lambda: bool(bp.flushed_messages(bag, TOPIC)), 90, "volatile samples on disk")
        assert not _latched_subscription(ros_client)
        processes["latched"] = bp.start_script(
            "bag_latched_talker.py", "latched", "feeder_test_latched", "parts"
        )
        bp.wait_until(
            lambda: _latched_subscription(ros_client), 60, "the recorder subscribing again, latched"
        )
        bp.wait_until(
            lambda: "parts" in map(bp.string_data, bp.flushed_messages(bag, TOPIC)), 60, "the latched sample"
        )
        summary = bp.finish(processes["recorder"], signal.SIGTERM)
    finally:
        for process in processes.values():
            bp.end(process, signal.SIGINT)
    recorded = [bp.string_data(data) for _, data in bp.read_messages(bag, TOPIC)]
    assert recorded.count("parts") == 1 and recorded.count("live") >= 1
    assert summary["topics"][TOPIC]["count"] == len(recorded)
    # The channel keeps the profile it was created with; metadata.yaml lists both, so replay is latched.
    assert _channel_durabilities(bag) == [QosDurability.VOLATILE]
    assert _metadata_durabilities(bag) == [QosDurability.VOLATILE, QosDurability.TRANSIENT_LOCAL]


ARRAY_TOPICS = ("/mems_field_array/parts", "/mems_field_array/field_program")
ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.ros
@pytest.mark.parametrize(
    "recorder_first", [False, True], ids=["planner-array-recorder", "recorder-planner-array"]
)
def test_the_mems_arrays_latched_topics_are_recorded_latched(
    ros_domain: int, ros_client: Any, launch_node: Any, tmp_path: Path, recorder_first: bool
) -> None:
    """The issue's case: the planner (a latched subscriber) makes the array's topic names visible first."""
    bag = tmp_path / "bag"
    recorder = None
    try:
        if recorder_first:
            recorder = bp.start_recorder(bag, "--topics", *ARRAY_TOPICS)
            bp.wait_until(lambda: bp.in_graph(ros_client, NODES["recorder"]), 90, "the recorder in the graph")
        launch_node("feeder_planner", "field_equilibria_planner")
        array = {
            "fidelity": "array",
            "part_files": [str(ROOT / "examples/mems/bracket.yaml")],
            "seed": 3,
        }
        launch_node("feeder_sim", "mems_field_array", array, wait_topics=ARRAY_TOPICS)
        if recorder is None:
            recorder = bp.start_recorder(bag, "--topics", *ARRAY_TOPICS)
        for topic in ARRAY_TOPICS:
            bp.wait_until(lambda t=topic: bool(bp.flushed_messages(bag, t)), 90, f"{topic} on disk")
        summary = bp.finish(recorder, signal.SIGTERM)
    finally:
        if recorder is not None:
            bp.end(recorder)
    with Reader(bag) as reader:
        for connection in reader.connections:
            qos = connection.ext.offered_qos_profiles  # type: ignore[union-attr]
            assert [q.durability for q in qos] == [QosDurability.TRANSIENT_LOCAL], connection.topic
    for topic in ARRAY_TOPICS:
        assert summary["topics"][topic]["count"] >= 1
        assert len(bp.read_messages(bag, topic)) == summary["topics"][topic]["count"]
