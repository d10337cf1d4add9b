"""bag-reindex on a split bag written by the recorder over DDS: every file kept and recovered on its own.

One recording (the Recorder's public API in this process, a publisher on the test client, a small
``max_bag_size``) makes a bag of several files with several chunks each; each test works on a copy:
metadata lost, one file cut at 50 %, files empty or unreadable. The `mcap` package's reader checks the
files; then bag-info (the CLI) and the player read the reindexed bag, every file in order.
"""

from __future__ import annotations

import json
import shutil
import time
from pathlib import Path
from typing import Any

import bag_procs as bp
import pytest
from mcap.data_stream import ReadDataStream
from mcap.reader import make_reader
from mcap.records import Chunk, Message
from mcap.stream_reader import breakup_chunk
from rclpy.qos import QoSProfile, ReliabilityPolicy
from ruamel.yaml import YAML
from std_msgs.msg import String

from feeder_cell.bag.player import Player, PlayOptions
from feeder_cell.bag.recorder import Recorder
from feeder_cell.bag.reindex import LEFT_OUT_SUFFIX, is_complete, reindex

TOPIC = "/h11_reindex/seq"
COUNT = 600
PAD = "x" * 200  # a few hundred bytes a message: a 40 kB limit splits the bag into several files


def _metadata(bag: Path) -> dict[str, Any]:
    return YAML(typ="safe").load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]


def _file_seqs(path: Path) -> list[int]:
    """The sequence numbers in one MCAP file, in file order, read with the mcap reader (summary needed)."""
    with path.open("rb") as stream:
        reader = make_reader(stream)
        assert reader.get_summary() is not None, f"{path.name} has no summary"
        return [
            int(bp.string_data(m.data).split()[0]) for _, _, m in reader.iter_messages(log_time_order=False)
        ]


def _bag_seqs(bag: Path) -> list[int]:
    """Sequence numbers over the files metadata.yaml lists, in its order."""
    return [seq for name in _metadata(bag)["relative_file_paths"] for seq in _file_seqs(bag / name)]


def _chunks_before(path: Path, cut: int) -> tuple[int, list[int]]:
    """How many chunks of a complete file end at or before byte ``cut``, and their sequence numbers."""
    with path.open("rb") as stream:
        indexes = make_reader(stream).get_summary().chunk_indexes  # type: ignore[union-attr]
        kept = [c for c in indexes if c.chunk_start_offset + c.chunk_length <= cut]
        seqs = []
        for index in kept:
            stream.seek(index.chunk_start_offset + 9)  # past the record's opcode and length
            records = breakup_chunk(Chunk.read(ReadDataStream(stream)))
            seqs += [int(bp.string_data(r.data).split()[0]) for r in records if isinstance(r, Message)]
    return len(kept), seqs


@pytest.fixture(scope="module")
def split_bag(ros_client: Any, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A bag of COUNT numbered messages split into several files by the recorder (kept pristine)."""
    bag = tmp_path_factory.mktemp("split") / "run"
    qos = QoSProfile(depth=COUNT, reliability=ReliabilityPolicy.RELIABLE)
    publisher = ros_client.create_publisher(String, TOPIC, qos)
    # A short flush interval closes a chunk every few messages: each file holds several chunks.
    recorder = Recorder(ros_client, bag, topics=(TOPIC,), flush_interval=0.05, max_bag_size=40_000)
    try:
        bp.wait_until(lambda: bool(recorder.discover()), 20, f"the recorder subscribed to {TOPIC}")
        bp.wait_until(lambda: publisher.get_subscription_count() > 0, 20, "the recorder matched")
        for seq in range(COUNT):
            publisher.publish(String(data=f"{seq} {time.time_ns()} {PAD}"))
            # Batches of 25 a flush interval apart: several chunks per file. (A sleep after every message
            # took a minute: each waits for the GIL behind the executor that records in this process.)
            if seq % 25 == 24:
                time.sleep(0.05)
        bp.wait_until(lambda: recorder.stats[TOPIC].count == COUNT, 20, f"{COUNT} messages recorded")
    finally:
        recorder.close()
        ros_client.destroy_publisher(publisher)
    files = _metadata(bag)["relative_file_paths"]
    assert files == [f"run_{i}.mcap" for i in range(len(files))] and len(files) >= 4, files
    assert _bag_seqs(bag) == list(range(COUNT))
    return bag


def _copy(split_bag: Path, tmp_path: Path) -> Path:
    copy = tmp_path / "run"
    shutil.copytree(split_bag, copy)
    (copy / "metadata.yaml").unlink()  # as a killed recording leaves it
    return copy


@pytest.mark.ros
def test_a_split_bag_keeps_its_files_each_with_its_own_counts_and_times(
    split_bag: Path, tmp_path: Path
) -> None:
    bag = _copy(split_bag, tmp_path)
    original = _metadata(split_bag)
    report = reindex(bag)
    assert [f.name for f in report.files] == original["relative_file_paths"]
    assert all(f.complete and not f.left_out for f in report.files)
    rebuilt = _metadata(bag)
    assert rebuilt["relative_file_paths"] == original["relative_file_paths"]
    assert sorted(p.name for p in bag.glob("*.mcap")) == sorted(original["relative_file_paths"])
    # Each file's own count and times: the recorder's from the recording, the mcap reader's from the file.
    for entry, recorded in zip(rebuilt["files"], original["files"], strict=True):
        assert entry == recorded
        with (bag / entry["path"]).open("rb") as stream:
            stats = make_reader(stream).get_summary().statistics  # type: ignore[union-attr]
        assert stats.message_count == entry["message_count"]
        assert stats.message_start_time == entry["starting_time"]["nanoseconds_since_epoch"]
        assert stats.message_end_time - stats.message_start_time == entry["duration"]["nanoseconds"]
    assert _bag_seqs(bag) == list(range(COUNT))  # none lost, none repeated, files in order
    assert rebuilt["message_count"] == COUNT
    assert rebuilt["topics_with_message_count"][0]["message_count"] == COUNT


@pytest.mark.ros
def test_one_file_cut_at_half_is_recovered_up_to_its_last_complete_chunk(
    split_bag: Path, tmp_path: Path
) -> None:
    bag = _copy(split_bag, tmp_path)
    names = _metadata(split_bag)["relative_file_paths"]
    victim = bag / names[1]
    size = victim.stat().st_size
    chunks, kept = _chunks_before(split_bag / names[1], size // 2)
    assert chunks >= 2 and kept, "the cut falls among several chunks"
    with victim.open("r+b") as stream:
        stream.truncate(size // 2)
    assert not is_complete(victim)
    report = reindex(bag)
    cut = report.files[1]
    assert cut.name == names[1] and not cut.complete and cut.chunks == chunks and cut.stopped_by
    assert cut.messages == len(kept) and not cut.left_out
    assert [f.complete for f in report.files] == [i != 1 for i in range(len(names))]
    assert _metadata(bag)["relative_file_paths"] == names
    assert _file_seqs(victim) == kept
    expected = [s for name in names for s in (kept if name == names[1] else _file_seqs(split_bag / name))]
    assert _bag_seqs(bag) == expected
    assert [e["message_count"] for e in _metadata(bag)["files"]] == [f.messages for f in report.files]


@pytest.mark.ros
def test_empty_and_unreadable_files_are_named_and_left_out(split_bag: Path, tmp_path: Path) -> None:
    bag = _copy(split_bag, tmp_path)
    names = _metadata(split_bag)["relative_file_paths"]
    (bag / names[0]).write_bytes(b"")
    (bag / names[2]).write_bytes(b"not an mcap file at all")
    report = reindex(bag)
    by_name = {f.name: f for f in report.files}
    assert "empty file" in by_name[names[0]].left_out and not (bag / names[0]).exists()
    assert "no MCAP magic" in by_name[names[2]].left_out
    assert by_name[names[2]].kept_as == names[2] + LEFT_OUT_SUFFIX
    assert (bag / (names[2] + LEFT_OUT_SUFFIX)).read_bytes() == b"not an mcap file at all"
    listed = [n for n in names if n not in (names[0], names[2])]
    assert _metadata(bag)["relative_file_paths"] == listed
    assert _bag_seqs(bag) == [s for n in listed for s in _file_seqs(split_bag / n)]
    # The command says which files were left out, and why.
    again = _copy(split_bag, tmp_path / "cli")
    (again / names[1]).write_bytes(b"")
    result = bp.run_feeder("bag-reindex", str(again))
    assert result.returncode == 0, result.stderr
    assert f"{names[1]}: left out of metadata.yaml" in result.stdout and "empty file" in result.stdout


@pytest.mark.ros
def test_bag_info_and_play_read_every_file_of_the_reindexed_bag_in_order(
    ros_client: Any, split_bag: Path, tmp_path: Path
) -> None:
    bag = _copy(split_bag, tmp_path)
    names = _metadata(split_bag)["relative_file_paths"]
    last = bag / names[-1]
    # Cut half way between the end of the last file's first chunk and its end: one chunk at least is
    # whole. (Half the file, as before, was inside the only chunk of a short last file in ci43, and a
    # file with no whole chunk is left out of metadata.yaml, as documented.)
    with last.open("rb") as stream:
        first = min(make_reader(stream).get_summary().chunk_indexes, key=lambda c: c.chunk_start_offset)  # type: ignore[union-attr]
    first_end = first.chunk_start_offset + first.chunk_length
    with last.open("r+b") as stream:
        stream.truncate(first_end + (stream.seek(0, 2) - first_end) // 2)
    report = reindex(bag)
    assert not report.files[-1].complete, "the cut left the last file whole"
    total = sum(f.messages for f in report.files)
    result = bp.run_feeder("bag-info", str(bag), "--json")
    assert result.returncode == 0, result.stderr
    info = json.loads(result.stdout)
    assert [f["path"] for f in info["files"]] == names
    assert [f["message_count"] for f in info["files"]] == [f.messages for f in report.files]
    assert info["message_count"] == total and info["topics"][TOPIC]["count"] == total

    played = "/h11_reindex/played"
    received: list[int] = []
    subscription = ros_client.create_subscription(
        String,
        played,
        lambda msg: received.append(int(msg.data.split()[0])),
        QoSProfile(depth=COUNT, reliability=ReliabilityPolicy.RELIABLE),
    )
    player = Player(ros_client, bag, PlayOptions(rate=20.0, remaps={TOPIC: played}))
    try:
        publisher = player.publishers[next(iter(player.publishers))]
        bp.wait_until(lambda: publisher.get_subscription_count() > 0, 20, "the player matched")
        counts = player.run(wait=False)
        bp.wait_until(lambda: len(received) >= total, 20, f"{total} messages played")
    finally:
        player.close()
        ros_client.destroy_subscription(subscription)
    assert counts == {TOPIC: total}
    assert received == _bag_seqs(bag)  # every file's messages, the files in order
