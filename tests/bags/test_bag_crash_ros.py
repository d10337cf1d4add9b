"""Crash-safe recording: kill -9 loses at most the flush interval, a cut bag is recovered, signals close it.

The publisher (scripts/bag_seq_talker.py) numbers its messages and puts its wall-clock send time in each,
so a bag is checked against what was sent; the bags are read back with the `mcap` package's reader.
"""

from __future__ import annotations

import json
import shutil
import signal
import time
from pathlib import Path
from typing import Any

import bag_procs as bp
import pytest
from mcap.data_stream import ReadDataStream
from mcap.reader import make_reader
from mcap.records import Chunk, Message
from mcap.stream_reader import breakup_chunk
from rosbags.rosbag2 import Reader

RATE = 200.0  # messages per second
FLUSH_INTERVAL = 1.0
# What the test's own clock readings add to the bound: the kill is timed here, a message's send time
# in the publisher, and a loaded machine delays the recorder's receive and flush threads a little.
MEASUREMENT_SLACK = 0.3


def _recording(client: Any, bag: Path, *args: str) -> tuple[Any, Any]:
    """Start the numbered publisher and a recorder of it; return once they are matched."""
    talker = bp.start_script("bag_seq_talker.py", str(RATE))
    recorder = bp.start_recorder(bag, "--topics", "/bag_seq", *args)
    try:
        bp.wait_for_line(talker, "matched", 90)
    except BaseException:
        _end(recorder, talker)
        raise
    return talker, recorder


def _end(recorder: Any, talker: Any) -> None:
    bp.end(recorder)
    bp.end(talker, signal.SIGINT)


def _sequence(bag: Path) -> list[tuple[int, int]]:
    messages = [bp.seq_and_sent(data) for _, data in bp.read_messages(bag, "/bag_seq")]
    seqs = [seq for seq, _ in messages]
    first = seqs[0] if seqs else 0
    assert seqs == list(range(first, first + len(seqs))), "a gap inside the bag"
    return messages


@pytest.mark.ros
@pytest.mark.parametrize("moment", [0.6, 5.0])  # within the first flush interval, and after several
def test_kill_9_loses_at_most_the_flush_interval(
    ros_domain: int, ros_client: Any, tmp_path: Path, moment: float
) -> None:
    bag = tmp_path / "killed"
    talker, recorder = _recording(ros_client, bag, "--flush-interval", str(FLUSH_INTERVAL))
    try:
        matched_ns = time.time_ns()
        time.sleep(moment)
        killed_ns = time.time_ns()
        bp.end(recorder, signal.SIGKILL)
    finally:
        _end(recorder, talker)
    assert not (bag / "metadata.yaml").exists()
    for command in ("bag-info", "play"):
        refused = bp.run_feeder(command, str(bag))
        assert refused.returncode == 2 and "bag-reindex" in refused.stderr, refused.stderr
        assert "metadata.yaml" in refused.stderr and "Traceback" not in refused.stderr

    result = bp.run_feeder("bag-reindex", str(bag), "--json")
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert not report["files"][0]["complete"]

    messages = _sequence(bag)
    count = report["topics"].get("/bag_seq", {"count": 0})["count"]
    assert count == len(messages)
    # Everything sent before the last flush interval (and after the recorder matched) is in the bag.
    due_ns = killed_ns - int((FLUSH_INTERVAL + MEASUREMENT_SLACK) * 1e9)
    lost = (killed_ns - messages[-1][1]) / 1e9 if messages else moment
    print(f"kill at {moment} s: {len(messages)} messages kept, the last sent {lost:.3f} s before the kill")
    if due_ns > matched_ns:
        assert messages, f"nothing recorded although the recorder ran {moment} s"
        last_sent = messages[-1][1]
        assert last_sent >= due_ns, f"lost {lost:.3f} s, more than the {FLUSH_INTERVAL} s flush interval"
    # The recovered bag is a complete rosbag2 bag for every reader.
    with Reader(bag) as reader:
        assert reader.message_count == len(messages)
    assert bp.run_feeder("bag-info", str(bag)).returncode == 0


@pytest.mark.ros
def test_a_bag_cut_at_half_is_recovered_up_to_the_cut(
    ros_domain: int, ros_client: Any, tmp_path: Path
) -> None:
    bag = tmp_path / "whole"
    # A short flush interval makes many chunks: the cut falls among them.
    talker, recorder = _recording(ros_client, bag, "--flush-interval", "0.2")
    try:
        bp.wait_until(lambda: (bag / "whole.mcap").stat().st_size > 60_000, 90, "60 kB recorded")
        summary = bp.finish(recorder, signal.SIGINT)
    finally:
        _end(recorder, talker)
    assert (bag / "metadata.yaml").is_file()
    total = summary["topics"]["/bag_seq"]["count"]
    assert len(_sequence(bag)) == total

    cut = tmp_path / "cut"
    shutil.copytree(bag, cut)
    mcap = bp.mcap_file(cut)
    size = mcap.stat().st_size
    with mcap.open("r+b") as stream:
        stream.truncate(size // 2)
    # What must come back: every message of the chunks that end before the cut, read chunk by chunk.
    with bp.mcap_file(bag).open("rb") as stream:
        chunk_indexes = make_reader(stream).get_summary().chunk_indexes  # type: ignore[union-attr]
        kept = [c for c in chunk_indexes if c.chunk_start_offset + c.chunk_length <= size // 2]
        assert 3 <= len(kept) < len(chunk_indexes)
        expected = []
        for index in kept:
            stream.seek(index.chunk_start_offset + 9)  # past the record's opcode and length
            records = breakup_chunk(Chunk.read(ReadDataStream(stream)))
            expected += [bp.seq_and_sent(r.data)[0] for r in records if isinstance(r, Message)]

    for command in ("bag-info", "play"):
        refused = bp.run_feeder(command, str(cut))
        assert refused.returncode == 2, refused.stderr
        assert "without its MCAP summary" in refused.stderr and "bag-reindex" in refused.stderr
        assert "Traceback" not in refused.stderr

    result = bp.run_feeder("bag-reindex", str(cut), "--json")
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert report["files"][0]["chunks"] == len(kept)
    recovered = [seq for seq, _ in _sequence(cut)]
    assert recovered == expected
    assert 0 < len(recovered) < total
    info = bp.run_feeder("bag-info", str(cut), "--json")
    assert info.returncode == 0, info.stderr
    assert json.loads(info.stdout)["topics"]["/bag_seq"]["count"] == len(recovered)


@pytest.mark.ros
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGHUP, signal.SIGINT], ids=lambda s: s.name)
def test_stop_signals_close_the_bag(
    ros_domain: int, ros_client: Any, tmp_path: Path, sig: signal.Signals
) -> None:
    bag = tmp_path / sig.name.lower()
    talker, recorder = _recording(ros_client, bag)
    try:
        bp.wait_until(lambda: (bag / f"{bag.name}.mcap").stat().st_size > 5_000, 90, "messages recorded")
        summary = bp.finish(recorder, sig)
    finally:
        _end(recorder, talker)
    assert (bag / "metadata.yaml").is_file()
    count = summary["topics"]["/bag_seq"]["count"]
    assert count > 0
    # Complete: the summary is there and holds every message the recorder counted.
    assert len(_sequence(bag)) == count
    info = bp.run_feeder("bag-info", str(bag), "--json")
    assert info.returncode == 0, info.stderr
    assert json.loads(info.stdout)["topics"]["/bag_seq"]["count"] == count


def test_bad_flush_interval_and_reindex_arguments_are_named(tmp_path: Path) -> None:
    for value in ("0", "-1", "nan"):
        result = bp.run_feeder("record", str(tmp_path / "new"), "--flush-interval", value)
        assert result.returncode == 2 and "--flush-interval" in result.stderr, result.stderr
        assert "Traceback" not in result.stderr
    assert not (tmp_path / "new").exists()
    empty = tmp_path / "empty"
    empty.mkdir()
    for path in (empty, tmp_path / "absent"):
        result = bp.run_feeder("bag-reindex", str(path))
        assert result.returncode == 2 and "BAG" in result.stderr and "Traceback" not in result.stderr
