"""bag-reindex on bags written here (no ROS): a zero-filled tail, cuts at every kind of place, an empty
file, a complete bag rebuilt unchanged; split bags keep their files in numeric order and their chunk
compression; an independent reader (the `mcap` package) checks each result."""

from __future__ import annotations

import shutil
from pathlib import Path

import bag_procs as bp
import pytest
from mcap.reader import make_reader
from rosbags.rosbag2 import CompressionFormat, CompressionMode, Reader, StoragePlugin, Writer

from feeder_cell.bag.qos import to_bag_qos
from feeder_cell.bag.reindex import LEFT_OUT_SUFFIX, MAGIC, is_complete, reindex
from feeder_cell.bag.types import typestore
from feeder_planner.errors import InputError

CHUNKS, PER_CHUNK = 6, 25


def _cdr(text: str) -> bytes:
    raw = text.encode() + b"\0"
    return b"\0\1\0\0" + len(raw).to_bytes(4, "little") + raw


def _write_bag(bag: Path) -> list[tuple[int, int]]:
    """A bag of CHUNKS chunks of PER_CHUNK numbered messages; returns each chunk's (start, end) offsets."""
    writer = Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP)
    writer.open()
    connection = writer.add_connection(
        "/seq", "std_msgs/msg/String", typestore=typestore(), offered_qos_profiles=[to_bag_qos(True, True)]
    )
    seq = 0
    for _ in range(CHUNKS):
        for _ in range(PER_CHUNK):
            writer.write(connection, 1_000_000_000 + seq, _cdr(f"{seq} 0"))
            seq += 1
        writer.storage.close_chunk()  # type: ignore[union-attr]  -- as the recorder's flush does
    writer.close()
    with bp.mcap_file(bag).open("rb") as stream:
        indexes = make_reader(stream).get_summary().chunk_indexes  # type: ignore[union-attr]
    return [(c.chunk_start_offset, c.chunk_start_offset + c.chunk_length) for c in indexes]


def _seqs(bag: Path) -> list[int]:
    return [bp.seq_and_sent(data)[0] for _, data in bp.read_messages(bag, "/seq")]


@pytest.mark.parametrize(
    "where", ["mid-chunk", "in-a-record-header", "at-a-chunk-end", "zero-filled", "zero-filled-mid-chunk"]
)
def test_a_cut_bag_is_recovered_up_to_its_last_complete_chunk(tmp_path: Path, where: str) -> None:
    bag = tmp_path / "bag"
    chunks = _write_bag(bag)
    mcap = bp.mcap_file(bag)
    start, end = chunks[3]
    cut = {
        "mid-chunk": (start + end) // 2,
        "in-a-record-header": start + 4,
        "at-a-chunk-end": end,
        "zero-filled": start + 10,
        "zero-filled-mid-chunk": (start + end) // 2,
    }[where]
    data = mcap.read_bytes()[:cut]
    if where.startswith("zero-filled"):
        data += bytes(4096)  # a power loss can leave allocated blocks never written
    mcap.write_bytes(data)
    assert not is_complete(mcap)
    report = reindex(bag)
    complete_chunks = 4 if where == "at-a-chunk-end" else 3
    assert report.files[0].chunks == complete_chunks and not report.files[0].complete
    assert report.files[0].stopped_by
    assert _seqs(bag) == list(range(complete_chunks * PER_CHUNK))
    assert is_complete(bp.mcap_file(bag)) and not (bag / ".reindex").exists()
    with Reader(bag) as reader:
        assert reader.message_count == complete_chunks * PER_CHUNK
        (connection,) = reader.connections
        assert connection.ext.offered_qos_profiles == [to_bag_qos(True, True)]  # type: ignore[union-attr]


def test_a_complete_bag_is_rebuilt_unchanged(tmp_path: Path) -> None:
    bag = tmp_path / "bag"
    _write_bag(bag)
    before = [(t, d) for t, d in bp.read_messages(bag, "/seq")]
    report = reindex(bag)
    assert report.files[0].complete and report.topics == {
        "/seq": {"type": "std_msgs/msg/String", "count": CHUNKS * PER_CHUNK}
    }
    assert bp.read_messages(bag, "/seq") == before


def test_an_empty_file_gives_an_empty_bag_and_bad_paths_are_named(tmp_path: Path) -> None:
    bag = tmp_path / "bag"
    _write_bag(bag)
    bp.mcap_file(bag).write_bytes(b"")
    (bag / "metadata.yaml").unlink()
    report = reindex(bag)
    assert report.files[0].messages == 0 and "empty file" in report.files[0].stopped_by
    with Reader(bag) as reader:
        assert reader.message_count == 0
    assert not report.files[0].kept_as and sorted(p.name for p in bag.iterdir()) == [
        "bag.mcap",
        "metadata.yaml",
    ]
    # Nothing readable at all: the bag still opens, empty, and the unreadable bytes are kept aside.
    bp.mcap_file(bag).write_bytes(b"garbage")
    report = reindex(bag)
    assert (
        "no MCAP magic" in report.files[0].stopped_by
        and report.files[0].kept_as == "bag.mcap" + LEFT_OUT_SUFFIX
    )
    assert (bag / report.files[0].kept_as).read_bytes() == b"garbage" and is_complete(bag / "bag.mcap")
    with Reader(bag) as reader:
        assert reader.message_count == 0
    with pytest.raises(InputError, match="not a bag directory"):
        reindex(tmp_path / "absent")
    (tmp_path / "empty").mkdir()
    with pytest.raises(InputError, match="no .mcap file"):
        reindex(tmp_path / "empty")


def _write_split_bag(bag: Path, files: int, per_file: int, compression: str = "none") -> None:
    """A split bag without metadata.yaml: ``files`` files ``<bag>_<i>.mcap`` of ``per_file`` messages."""
    bag.mkdir()
    seq = 0
    for index in range(files):
        part = bag.parent / f"{bag.name}_{index}"
        writer = Writer(part, version=9, storage_plugin=StoragePlugin.MCAP)
        if compression == "zstd":
            writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
        writer.open()
        if compression == "lz4":
            import lz4.frame  # type: ignore[import-untyped]

            writer.storage.compression = "lz4"  # type: ignore[union-attr]  -- as the recorder sets it
            writer.storage.compressor = lz4.frame.compress  # type: ignore[union-attr]
        connection = writer.add_connection(
            "/seq",
            "std_msgs/msg/String",
            typestore=typestore(),
            offered_qos_profiles=[to_bag_qos(True, False)],
        )
        for _ in range(per_file):
            writer.write(connection, 1_000_000_000 + seq, _cdr(f"{seq} 0"))
            seq += 1
        writer.close()
        (part / f"{part.name}.mcap").rename(bag / f"{part.name}.mcap")
        shutil.rmtree(part)


def _listed(bag: Path) -> list[str]:
    from ruamel.yaml import YAML

    info = YAML(typ="safe").load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    return [str(name) for name in info["relative_file_paths"]]


def _chunk_compressions(path: Path) -> set[str]:
    with path.open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    return {index.compression for index in summary.chunk_indexes}


def test_split_files_keep_their_numeric_order_and_names(tmp_path: Path) -> None:
    bag = tmp_path / "run"
    _write_split_bag(bag, 12, 3)  # run_10 and run_11 sort after run_9, as numbers
    report = reindex(bag)
    names = [f"run_{i}.mcap" for i in range(12)]
    assert [f.name for f in report.files] == names
    with Reader(bag) as reader:
        assert [bp.seq_and_sent(data)[0] for _, _, data in reader.messages()] == list(range(36))
    assert _listed(bag) == names
    assert sorted(p.name for p in bag.iterdir()) == sorted([*names, "metadata.yaml"])


@pytest.mark.parametrize("compression", ["zstd", "lz4"])
def test_reindexed_files_keep_their_chunk_compression(tmp_path: Path, compression: str) -> None:
    bag = tmp_path / "run"
    _write_split_bag(bag, 2, 5, compression)
    reindex(bag)
    for index in range(2):
        assert _chunk_compressions(bag / f"run_{index}.mcap") == {compression}
    with Reader(bag) as reader:
        assert reader.message_count == 10


def test_a_split_bag_with_no_message_keeps_one_empty_file(tmp_path: Path) -> None:
    bag = tmp_path / "run"
    _write_split_bag(bag, 2, 0)
    (bag / "run_1.mcap").write_bytes(b"")
    report = reindex(bag)
    assert not report.files[0].left_out and "empty file" in report.files[1].left_out
    assert sorted(p.name for p in bag.iterdir()) == ["metadata.yaml", "run_0.mcap"]
    with Reader(bag) as reader:
        assert reader.message_count == 0
    assert _listed(bag) == ["run_0.mcap"]


def test_files_holding_no_message_are_removed_and_garbage_is_kept_aside(tmp_path: Path) -> None:
    bag = tmp_path / "run"
    _write_split_bag(bag, 2, 3)
    _write_split_bag(tmp_path / "more", 2, 0)  # complete files without a message
    (tmp_path / "more" / "more_0.mcap").rename(bag / "run_2.mcap")
    header_only = (tmp_path / "more" / "more_1.mcap").read_bytes()
    header_end = len(MAGIC) + 9 + int.from_bytes(header_only[len(MAGIC) + 1 : len(MAGIC) + 9], "little")
    (bag / "run_3.mcap").write_bytes(header_only[:header_end])  # as a kill right after a split leaves
    (bag / "run_4.mcap").write_bytes(MAGIC + bytes(100))
    report = reindex(bag)
    assert [bool(f.left_out) for f in report.files] == [False, False, True, True, True]
    assert "zeros" in report.files[4].left_out and report.files[4].kept_as == "run_4.mcap" + LEFT_OUT_SUFFIX
    assert not report.files[2].kept_as and not report.files[3].kept_as
    assert sorted(p.name for p in bag.iterdir()) == [
        "metadata.yaml",
        "run_0.mcap",
        "run_1.mcap",
        "run_4.mcap" + LEFT_OUT_SUFFIX,
    ]
    assert _listed(bag) == ["run_0.mcap", "run_1.mcap"]
    with Reader(bag) as reader:
        assert [bp.seq_and_sent(data)[0] for _, _, data in reader.messages()] == list(range(6))
