"""Record controls over DDS, as ``ros2 bag record`` has them: one talker, six recorders at once.

The talker publishes /ctl/a (String), /ctl/b (Int32) and the hidden /ctl/_hidden/c (String), numbered,
at 100 Hz. Recorders run side by side, each with other flags: --regex with --exclude, --topic-types,
--include-hidden-topics, splitting by size (zstd chunks) and by duration (lz4 chunks), --start-paused
with the ~/resume, ~/toggle_paused and ~/is_paused services, and a QoS override file (on the --regex
recorder).
Every bag is read back with the independent ``mcap`` reader; split bags also through bag-info and
bag-reindex.
"""

from __future__ import annotations

import shutil
import signal
import subprocess
from pathlib import Path
from typing import Any, Iterator

import bag_procs as bp
import pytest
import ros_harness
from mcap.reader import make_reader
from rclpy.qos import ReliabilityPolicy

from feeder_cell.bag.info import bag_info
from feeder_cell.bag.reindex import is_complete, reindex

WAIT = 60.0
RECORDERS = {
    # node name: (flags, topics it must subscribe to before the test goes on)
    "rec_regex": (["--regex", "^/ctl/", "--exclude", "/b$"], ["/ctl/a"]),
    "rec_types": (["--topic-types", "std_msgs/msg/Int32"], ["/ctl/b"]),
    "rec_hidden": (["--regex", "^/ctl/", "--include-hidden-topics"], ["/ctl/a", "/ctl/b", "/ctl/_hidden/c"]),
    "rec_size": (
        ["--topics", "/ctl/a", "/ctl/b", "--max-bag-size", "6000", "--compression", "zstd"],
        ["/ctl/a", "/ctl/b"],
    ),
    "rec_duration": (
        [
            "--topics",
            "/ctl/a",
            "--max-bag-duration",
            "1",
            "--compression-mode",
            "file",
            "--compression-format",
            "lz4",
        ],
        ["/ctl/a"],
    ),
    "rec_paused": (["--topics", "/ctl/a", "--start-paused"], ["/ctl/a"]),
}


def _paused(client: Any, node: str) -> bool:
    from feeder_msgs.srv import IsPaused

    return bool(ros_harness.call_service(client, IsPaused, f"/{node}/is_paused", IsPaused.Request()).paused)


def _files_on_disk(bag: Path) -> int:
    return len(list(bag.glob("*.mcap")))


def _int32s(bag: Path, topic: str) -> list[int]:
    """The Int32 values on ``topic`` over the bag's files in order, read with the mcap reader."""
    values = []
    for path in _files(bag):
        with path.open("rb") as stream:
            for _, channel, message in make_reader(stream).iter_messages():
                if channel.topic == topic:
                    values.append(int.from_bytes(message.data[4:8], "little", signed=True))
    return values


def _files(bag: Path) -> list[Path]:
    """The bag's files in the order metadata.yaml lists them."""
    from ruamel.yaml import YAML

    info = YAML(typ="safe").load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    return [bag / name for name in info["relative_file_paths"]]


def _counts(bag: Path) -> dict[str, int]:
    counts: dict[str, int] = {}
    for path in _files(bag):
        with path.open("rb") as stream:
            for _, channel, _ in make_reader(stream).iter_messages():
                counts[channel.topic] = counts.get(channel.topic, 0) + 1
    return counts


def _compressions(path: Path) -> set[str]:
    with path.open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    return {index.compression for index in summary.chunk_indexes}


@pytest.fixture(scope="module")
def runs(ros_client: Any, tmp_path_factory: pytest.TempPathFactory) -> Iterator[dict[str, Any]]:
    """Every recorder's bag and JSON summary, and what was seen while they ran."""
    root = tmp_path_factory.mktemp("controls")
    overrides = root / "overrides.yaml"
    overrides.write_text("/ctl/a:\n  reliability: best_effort\n  depth: 7\n  durability: volatile\n")
    talker = bp.start_script("bag_mixed_talker.py", "100")
    processes: dict[str, subprocess.Popen] = {}
    seen: dict[str, Any] = {}
    try:
        for name, (flags, _) in RECORDERS.items():
            extra = ["--qos-profile-overrides-path", str(overrides)] if name == "rec_regex" else []
            processes[name] = bp.start_recorder(root / name, *flags, *extra, "--node-name", name)
        for name, (_, topics) in RECORDERS.items():
            bp.wait_until(
                lambda: all(bp.subscribed(ros_client, t, name) for t in topics),  # noqa: B023
                WAIT,
                f"{name} subscribed to {topics}",
            )
        seen["qos"] = [s.qos_profile for s in bp.subscribed(ros_client, "/ctl/a", "rec_regex")]
        seen["paused_at_start"] = _paused(ros_client, "rec_paused")
        # Data flows to every recorder; splitting by size and duration needs a few seconds of it.
        bp.wait_until(lambda: _files_on_disk(root / "rec_size") >= 2, WAIT, "two files of rec_size")
        bp.wait_until(lambda: _files_on_disk(root / "rec_duration") >= 2, WAIT, "two files of rec_duration")
        seen["written_while_paused"] = len(bp.flushed_messages(root / "rec_paused", "/ctl/a"))
        from feeder_msgs.srv import Resume, TogglePaused

        ros_harness.call_service(ros_client, Resume, "/rec_paused/resume", Resume.Request())
        seen["paused_after_resume"] = _paused(ros_client, "rec_paused")
        bp.wait_until(
            lambda: len(bp.flushed_messages(root / "rec_paused", "/ctl/a")) > 0, WAIT, "rec_paused writing"
        )
        ros_harness.call_service(
            ros_client, TogglePaused, "/rec_paused/toggle_paused", TogglePaused.Request()
        )
        seen["paused_after_toggle"] = _paused(ros_client, "rec_paused")
        summaries = {name: bp.finish(process, signal.SIGINT) for name, process in processes.items()}
    finally:
        for process in processes.values():
            bp.end(process)
        bp.end(talker, signal.SIGINT)
    yield {"root": root, "summaries": summaries, "seen": seen}


@pytest.mark.ros
def test_topic_selection(runs: dict[str, Any]) -> None:
    topics = {name: set(summary["topics"]) for name, summary in runs["summaries"].items()}
    assert topics["rec_regex"] == {"/ctl/a"}  # /ctl/b excluded, the hidden topic not taken by a regex
    assert topics["rec_types"] == {"/ctl/b"}  # the only Int32 topic
    assert topics["rec_hidden"] == {"/ctl/a", "/ctl/b", "/ctl/_hidden/c"}
    for name in ("rec_regex", "rec_types", "rec_hidden"):
        assert _counts(runs["root"] / name) == {
            t: s["count"] for t, s in runs["summaries"][name]["topics"].items()
        }


@pytest.mark.ros
def test_split_by_size_lists_every_file_and_loses_nothing(runs: dict[str, Any]) -> None:
    bag = runs["root"] / "rec_size"
    summary = runs["summaries"]["rec_size"]
    files = _files(bag)
    assert [f.name for f in files] == [f"rec_size_{i}.mcap" for i in range(len(files))] == summary["files"]
    assert len(files) >= 2 and sorted(bag.glob("*.mcap")) == sorted(files)
    for path in files:
        assert is_complete(path) and _compressions(path) == {"zstd"}
    for path in files[:-1]:
        assert path.stat().st_size < 6000 + 4000  # closed at the limit (plus its last chunk and summary)
    values = _int32s(bag, "/ctl/b")
    assert values == list(range(values[0], values[0] + len(values)))  # no gap at any split
    assert _counts(bag) == {t: s["count"] for t, s in summary["topics"].items()}
    info = bag_info(bag)
    assert [f["path"] for f in info["files"]] == summary["files"]
    assert info["message_count"] == sum(_counts(bag).values())
    assert sum(f["message_count"] for f in info["files"]) == info["message_count"]
    assert info["chunk_compression"] == "zstd" and info["storage_identifier"] == "mcap"
    assert info["bag_size"] == sum(f.stat().st_size for f in files)
    # A split bag whose metadata is lost: bag-reindex recovers every message and keeps every file.
    copy = runs["root"] / "rec_size_copy"
    shutil.copytree(bag, copy)
    (copy / "metadata.yaml").unlink()
    report = reindex(copy)
    assert [f.complete for f in report.files] == [True] * len(files)
    assert [f.name for f in _files(copy)] == summary["files"]
    assert _counts(copy) == _counts(bag)


@pytest.mark.ros
def test_split_by_duration_with_lz4_chunks(runs: dict[str, Any]) -> None:
    bag = runs["root"] / "rec_duration"
    files = _files(bag)
    assert len(files) >= 2 and runs["summaries"]["rec_duration"]["compression"] == "lz4"
    for path in files:
        assert is_complete(path) and _compressions(path) == {"lz4"}
    info = bag_info(bag)
    for entry in info["files"][:-1]:
        assert 0.5 < entry["duration"] < 2.5  # about one second of data per closed file
    assert info["message_count"] == runs["summaries"]["rec_duration"]["topics"]["/ctl/a"]["count"]


@pytest.mark.ros
def test_start_paused_resume_and_toggle(runs: dict[str, Any]) -> None:
    seen, summary = runs["seen"], runs["summaries"]["rec_paused"]
    assert seen["paused_at_start"] is True
    assert seen["written_while_paused"] == 0
    assert seen["paused_after_resume"] is False and seen["paused_after_toggle"] is True
    assert summary["dropped_while_paused"] > 0  # messages arrived while paused and were not written
    count = summary["topics"]["/ctl/a"]["count"]
    assert count > 0 and _counts(runs["root"] / "rec_paused") == {"/ctl/a": count}


@pytest.mark.ros
def test_qos_override_is_the_subscription_profile(runs: dict[str, Any]) -> None:
    (profile,) = runs["seen"]["qos"]
    assert profile.reliability == ReliabilityPolicy.BEST_EFFORT
    assert runs["summaries"]["rec_regex"]["topics"]["/ctl/a"]["count"] > 0
    # The bag keeps what the publisher offered (reliable), as rosbag2 does.
    info = bag_info(runs["root"] / "rec_regex")
    assert info["topics"]["/ctl/a"]["offered_qos_profiles"][0]["reliability"] == "reliable"
