"""The snapshot cache's bounds, the fault edge, snapshot bag names and the writer, without ROS processes.

Also: a bag written by the project's writer (one file and split) carries what rosbag2_storage_mcap
writes, field by field (``rosbag2_fields``), and a damaged ``metadata.yaml`` is refused by bag-info and
play in one line naming the file, the YAML line and column, and bag-reindex, which repairs it.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
import rosbag2_fields
from mcap.reader import make_reader

from feeder_cell.bag.qos import to_bag_qos
from feeder_cell.bag.reindex import reindex
from feeder_cell.bag.snapshot import (
    ENTRY_OVERHEAD,
    Capture,
    Entry,
    FaultEdge,
    SnapshotCache,
    SnapshotWriter,
    TopicInfo,
    capture_name,
)
from feeder_cell.bag.types import connection_definition
from feeder_cell.bag.writer import BagWriter
from feeder_planner.errors import InputError

FEEDER = [sys.executable, "-m", "feeder_cell.cli.main"]
SECOND = 1_000_000_000
STRING = "std_msgs/msg/String"


def _entry(i: int, size: int = 100, topic: str = "/a") -> Entry:
    return Entry(topic, i * SECOND // 10, i * SECOND // 10 - 5, bytes(size))


def test_the_cache_keeps_the_newest_within_its_byte_bound() -> None:
    cache = SnapshotCache(max_bytes=10 * (100 + ENTRY_OVERHEAD), max_duration=0)
    for i in range(50):
        cache.add(_entry(i))
    assert len(cache) == 10 and cache.size <= cache.max_bytes
    assert [e.log_time for e in cache.copy()] == [i * SECOND // 10 for i in range(40, 50)]
    assert cache.evicted == 40 and cache.peak_bytes <= cache.max_bytes


def test_the_cache_keeps_the_newest_within_its_duration() -> None:
    cache = SnapshotCache(max_bytes=0, max_duration=1.0)
    for i in range(50):  # ten a second
        cache.add(_entry(i))
    times = [e.log_time for e in cache.copy()]
    assert times[-1] - times[0] <= SECOND and times[0] == 39 * SECOND // 10
    # Both bounds: whichever is tighter holds.
    both = SnapshotCache(max_bytes=5 * (100 + ENTRY_OVERHEAD), max_duration=1.0)
    for i in range(50):
        both.add(_entry(i))
    assert len(both) == 5


def test_take_empties_the_cache_and_copy_does_not() -> None:
    cache = SnapshotCache(max_bytes=10**6, max_duration=0)
    for i in range(5):
        cache.add(_entry(i))
    assert len(cache.copy()) == 5 and len(cache) == 5
    assert len(cache.take()) == 5 and len(cache) == 0 and cache.size == 0


@pytest.mark.parametrize(
    ("size", "duration", "named"),
    [(0, 0.0, "--max-cache-size"), (-1, 1.0, "--max-cache-size"), (10, float("nan"), "--max-cache-duration")],
)
def test_unusable_cache_bounds_are_refused_by_flag(size: int, duration: float, named: str) -> None:
    with pytest.raises(InputError) as caught:
        SnapshotCache(size, duration)
    assert caught.value.field == named


def test_a_fault_is_an_entry_into_fault_not_a_first_sight_or_a_stay() -> None:
    edge = FaultEdge()
    assert not edge.entered_fault("/arm", 4), "found in FAULT: it entered before anything was cached"
    assert not edge.entered_fault("/arm", 4)
    assert not edge.entered_fault("/arm", 1)
    assert edge.entered_fault("/arm", 4)
    assert not edge.entered_fault("/arm", 4), "staying in FAULT is not a new fault"
    assert not edge.entered_fault("/mems", 2) and edge.entered_fault("/mems", 4)


def test_capture_names_say_device_code_and_time() -> None:
    assert capture_name("fault", 12 * SECOND + 345_678_901, "/cell/feeder_a/throwing_arm", 101) == (
        "cell-feeder_a-throwing_arm_fault101_t12.345"
    )
    assert capture_name("service", 7 * SECOND, index=3) == "snapshot_3_t7.000"


def _topics() -> dict[str, TopicInfo]:
    msgdef, rihs01 = connection_definition(STRING)
    return {"/a": TopicInfo(STRING, msgdef, rihs01, (to_bag_qos(True, True),))}


def test_a_capture_is_written_as_a_complete_rosbag2_bag(tmp_path: Path) -> None:
    data = b"\x00\x01\x00\x00\x02\x00\x00\x00x\x00"
    writer = SnapshotWriter(tmp_path, _topics, "zstd", lambda line: pytest.fail(line))
    before = [Entry("/a", (10 + i) * SECOND, (10 + i) * SECOND - 7, data) for i in range(3)]
    after = [Entry("/a", 20 * SECOND, 20 * SECOND - 7, data)]
    capture = Capture(writer.unique("arm_fault101_t12.000"), "fault", before, device="/arm", fault_code=101)
    capture.post = after
    writer.submit(capture)
    writer.close()
    [written] = writer.written
    assert written.path == tmp_path / "arm_fault101_t12.000" and written.messages == 4
    info = rosbag2_fields.check_bag(written.path)
    assert info["custom_data"]["device"] == "/arm" and info["custom_data"]["fault_code"] == "101"
    with (written.path / "arm_fault101_t12.000.mcap").open("rb") as stream:
        reader = make_reader(stream)
        messages = [(m.log_time, m.publish_time) for _, _, m in reader.iter_messages()]
        assert {c.compression for c in reader.get_summary().chunk_indexes} == {"zstd"}  # type: ignore[union-attr]
    assert messages == [(e.log_time, e.publish_time) for e in before + after]
    assert not list(tmp_path.glob(".*")), "no partial directory left"


def _written_bag(path: Path, split_every: int = 0) -> Path:
    writer = BagWriter(path, "lz4")
    writer.open()
    msgdef, rihs01 = connection_definition(STRING)
    latched = writer.add_connection(
        "/latched", STRING, msgdef=msgdef, rihs01=rihs01, offered_qos_profiles=[to_bag_qos(True, True)]
    )
    plain = writer.add_connection(
        "/plain", STRING, msgdef=msgdef, rihs01=rihs01, offered_qos_profiles=[to_bag_qos(False, False)]
    )
    for i in range(30):
        if split_every and i and i % split_every == 0:
            writer.split()
        writer.write(plain if i % 3 else latched, SECOND + i, b"\x00\x01\x00\x00\x01\x00\x00\x00\x00", SECOND)
    writer.close()
    return path


def test_our_files_carry_what_rosbag2_storage_mcap_writes(tmp_path: Path) -> None:
    one = rosbag2_fields.check_bag(_written_bag(tmp_path / "one"))
    assert one["relative_file_paths"] == ["one.mcap"] and one["message_count"] == 30
    split = rosbag2_fields.check_bag(_written_bag(tmp_path / "split", split_every=10))
    assert split["relative_file_paths"] == ["split_0.mcap", "split_1.mcap", "split_2.mcap"]
    # Each file's serialized metadata lists the files up to it (as rosbag2 updates it at each split).
    with (tmp_path / "split" / "split_1.mcap").open("rb") as stream:
        record = next(m for m in make_reader(stream).iter_metadata() if m.name == "rosbag2")
    assert "split_1.mcap" in record.metadata["serialized_metadata"]
    assert "split_2.mcap" not in record.metadata["serialized_metadata"]
    # A reindexed bag too.
    (tmp_path / "split" / "metadata.yaml").unlink()
    reindex(tmp_path / "split")
    assert rosbag2_fields.check_bag(tmp_path / "split")["message_count"] == 30


@pytest.mark.parametrize(
    ("text", "where"),
    [
        ("rosbag2_bagfile_information:\n  version: 9\n  files: [a, b\n  x: 1\n", "line 4 column 4"),
        ("rosbag2_bagfile_information:\n\tversion: 9\n", "line 2 column 1"),
        ("- a list\n", "line 1 column 1"),
    ],
)
def test_a_damaged_metadata_yaml_is_one_line_with_line_and_column(
    tmp_path: Path, text: str, where: str
) -> None:
    bag = _written_bag(tmp_path / "bag")
    (bag / "metadata.yaml").write_text(text)
    # bag-info for each damage; play (the same check) for the first.
    commands = [["bag-info", str(bag)], *([["play", str(bag)]] if "files" in text else [])]
    for command in commands:
        done = subprocess.run([*FEEDER, *command], capture_output=True, text=True, timeout=60)
        assert done.returncode == 2
        lines = done.stderr.strip().splitlines()
        assert len(lines) == 1, done.stderr
        assert f"{bag / 'metadata.yaml'}: {where}" in lines[0] and f"feeder bag-reindex {bag}" in lines[0]
    reindex(bag)  # the hint works: the metadata is written again from the MCAP file
    assert rosbag2_fields.check_bag(bag)["message_count"] == 30
