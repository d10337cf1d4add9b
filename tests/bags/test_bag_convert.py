"""``feeder bag-convert`` with rosbag2's convert YAML: merge, split, filter, cut and recompress.

Two input bags are written with the project's bag writer (numbered std_msgs messages on three topics and
a service-event topic, interleaved in time); ``feeder bag-convert`` runs as a user runs it, and every
output is read back with the independent ``mcap`` reader: the message counts add up (per topic, per
output, against what the inputs hold and the options select), the merge is in log-time order, and each
output carries what rosbag2_storage_mcap writes. A bad option is refused in one line naming the field.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
import rosbag2_fields
from mcap.reader import make_reader
from ruamel.yaml import YAML

from feeder_cell.bag.convert import parse_output_options
from feeder_cell.bag.qos import to_bag_qos
from feeder_cell.bag.types import connection_definition
from feeder_cell.bag.writer import BagWriter
from feeder_planner.errors import InputError

FEEDER = [sys.executable, "-m", "feeder_cell.cli.main"]
SECOND = 1_000_000_000
START = 1_700_000_000 * SECOND


def _string(text: str) -> bytes:
    """CDR of a std_msgs/String."""
    data = text.encode() + b"\x00"
    return b"\x00\x01\x00\x00" + len(data).to_bytes(4, "little") + data


def _int32(value: int) -> bytes:
    return b"\x00\x01\x00\x00" + value.to_bytes(4, "little", signed=True)


def _make_bag(path: Path, offset: int, count: int) -> dict[str, list[int]]:
    """Write ``count`` messages per topic, 10 ms apart from START + offset ns; return log times per topic."""
    writer = BagWriter(path)
    writer.open()
    reliable = [to_bag_qos(True, False)]
    topics = {
        "/a": "std_msgs/msg/String",
        "/b": "std_msgs/msg/Int32",
        "/ns/_hidden": "std_msgs/msg/String",
        "/arm/place_part/_service_event": "feeder_msgs/srv/ArmPlacePart_Event",
    }
    connections = {}
    for topic, type_name in topics.items():
        msgdef, rihs01 = connection_definition(type_name)
        connections[topic] = writer.add_connection(
            topic, type_name, msgdef=msgdef, rihs01=rihs01, offered_qos_profiles=reliable
        )
    times: dict[str, list[int]] = {t: [] for t in topics}
    for i in range(count):
        for k, topic in enumerate(topics):
            stamp = START + offset + i * 10_000_000 + k
            data = _int32(i) if topic == "/b" else _string(f"{path.name} {i}")
            if topic.endswith("_service_event"):
                data = b"\x00\x01\x00\x00" + bytes(64)  # an all-zero event: its bytes are only copied
            writer.write(connections[topic], stamp, data, stamp - 1000)
            times[topic].append(stamp)
    writer.close()
    return times


@pytest.fixture(scope="module")
def inputs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    root = tmp_path_factory.mktemp("convert_inputs")
    # The second bag starts 5 ms after the first: their messages interleave.
    first = _make_bag(root / "run1", 0, 200)
    second = _make_bag(root / "run2", 5_000_000, 100)
    return {"root": root, "bags": [root / "run1", root / "run2"], "times": [first, second]}


def _convert(tmp_path: Path, inputs: list[Path], options: Any) -> subprocess.CompletedProcess:
    path = tmp_path / "out.yaml"
    yaml = YAML(typ="safe")
    yaml.default_flow_style = False
    with path.open("w") as stream:
        yaml.dump(options, stream)
    return subprocess.run(
        [*FEEDER, "bag-convert", *map(str, inputs), "-o", str(path), "--json"],
        capture_output=True,
        text=True,
        timeout=120,
    )


def _read(bag: Path) -> list[tuple[str, int, int, bytes]]:
    """(topic, log time, publish time, data) over the bag's files in metadata order, with the mcap reader."""
    info = YAML(typ="safe").load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    found = []
    for name in info["relative_file_paths"]:
        with (bag / name).open("rb") as stream:
            for _, channel, message in make_reader(stream).iter_messages(log_time_order=True):
                found.append((channel.topic, message.log_time, message.publish_time, message.data))
    return found


def _compressions(bag: Path) -> set[str]:
    found = set()
    for path in bag.glob("*.mcap"):
        with path.open("rb") as stream:
            summary = make_reader(stream).get_summary()
        assert summary is not None
        found |= {index.compression for index in summary.chunk_indexes}
    return found


def test_merge_split_filter_cut_and_recompress_add_up(inputs: dict[str, Any], tmp_path: Path) -> None:
    first, second = inputs["times"]
    window = (START + 500_000_000, START + 1_200_000_000)
    options = {
        "output_bags": [
            # Merge: every topic and service of both runs, one zstd-compressed bag.
            {"uri": str(tmp_path / "merged"), "storage_id": "mcap", "all": True,
             "include_hidden_topics": True, "compression_mode": "file", "compression_format": "zstd"},
            # Split by size; hidden topics and services left out, as rosbag2 leaves them out by default.
            {"uri": str(tmp_path / "split"), "all_topics": True, "max_bagfile_size": 8000,
             "storage_preset_profile": "zstd_fast"},
            # Filter by name and by regex with the rosbag2 exclude names, lz4 chunks.
            {"uri": str(tmp_path / "filtered"), "topics": ["/a"], "regex": "^/b", "exclude_topics": ["/a"],
             "compression_mode": "message", "compression_format": "lz4"},
            # Cut to a time window, one topic type, the older name `exclude` for exclude_regex.
            {"uri": str(tmp_path / "window"), "topic_types": ["std_msgs/msg/String"], "exclude": "hidden",
             "start_time_ns": window[0], "end_time_ns": window[1], "custom_data": {"cut": "first second"}},
            # Services only, by event topic and by plain service name.
            {"uri": str(tmp_path / "services"), "services": ["/arm/place_part"]},
        ]
    }  # fmt: skip
    done = _convert(tmp_path, inputs["bags"], options)
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout)
    assert result["inputs"] == {str(inputs["bags"][0]): 800, str(inputs["bags"][1]): 400}
    outputs = {Path(o["uri"]).name: o for o in result["outputs"]}

    merged = _read(tmp_path / "merged")
    assert len(merged) == 1200 == outputs["merged"]["messages"]
    assert [t for _, t, _, _ in merged] == sorted(t for _, t, _, _ in merged), "merged in log-time order"
    counts: dict[str, int] = {}
    for topic, _, _, _ in merged:
        counts[topic] = counts.get(topic, 0) + 1
    assert counts == {topic: len(first[topic]) + len(second[topic]) for topic in first}
    # Log and publish times and bytes are copied as they are.
    assert all(publish == log - 1000 for _, log, publish, _ in merged)
    assert _compressions(tmp_path / "merged") == {"zstd"}

    split = tmp_path / "split"
    info = rosbag2_fields.check_bag(split)
    assert len(info["relative_file_paths"]) >= 3
    assert info["relative_file_paths"] == [f"split_{i}.mcap" for i in range(len(info["relative_file_paths"]))]
    split_messages = _read(split)
    assert len(split_messages) == 600 == sum(f["message_count"] for f in info["files"])
    assert {t for t, _, _, _ in split_messages} == {"/a", "/b"}
    assert _compressions(split) == {"zstd"}

    filtered = _read(tmp_path / "filtered")
    assert {t for t, _, _, _ in filtered} == {"/b"} and len(filtered) == 300
    assert sorted(int.from_bytes(d[4:8], "little") for _, _, _, d in filtered) == sorted(
        [*range(200), *range(100)]
    )
    assert _compressions(tmp_path / "filtered") == {"lz4"}

    cut = _read(tmp_path / "window")
    expected = [t for t in first["/a"] + second["/a"] if window[0] <= t <= window[1]]
    assert sorted(t for _, t, _, _ in cut) == sorted(expected) and {t for t, _, _, _ in cut} == {"/a"}
    window_info = rosbag2_fields.check_bag(tmp_path / "window")
    assert window_info["custom_data"] == {"cut": "first second"}

    services = _read(tmp_path / "services")
    assert {t for t, _, _, _ in services} == {"/arm/place_part/_service_event"} and len(services) == 300
    # Every output adds up with its JSON report, and carries what rosbag2 writes.
    for name, output in outputs.items():
        bag = rosbag2_fields.check_bag(tmp_path / name)
        assert (
            bag["message_count"] == output["messages"] == sum(t["count"] for t in output["topics"].values())
        )


def test_a_single_mcap_file_and_the_rosbag2_input_flag(inputs: dict[str, Any], tmp_path: Path) -> None:
    single = inputs["bags"][1] / "run2.mcap"
    options = {"output_bags": [{"uri": str(tmp_path / "copy"), "all_topics": True}]}
    path = tmp_path / "o.yaml"
    YAML(typ="safe").dump(options, path)
    done = subprocess.run(
        [*FEEDER, "bag-convert", "-i", str(single), "mcap", "-o", str(path), "--json"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert len(_read(tmp_path / "copy")) == 200


@pytest.mark.parametrize(
    ("output", "named"),
    [
        ({"uri": "x", "all_topics": "always"}, "output_bags[0].all_topics: must be true or false"),
        (
            {"uri": "x", "all": True, "exclude_topic": ["/a"]},
            "output_bags[0].exclude_topic: is not a rosbag2",
        ),
        ({"uri": "x", "all": True, "storage_id": "sqlite3"}, "output_bags[0].storage_id: must be mcap"),
        ({"uri": "x", "all": True, "regex": "(["}, "output_bags[0].regex: is not a valid regular expression"),
        ({"uri": "x", "all": True, "compression_format": "zstd"}, "output_bags[0].compression_format: needs"),
        (
            {"uri": "x", "all": True, "max_bagfile_size": -1},
            "output_bags[0].max_bagfile_size: must be a whole",
        ),
        (
            {"uri": "x", "all": True, "start_time_ns": 5, "end_time_ns": 1},
            "output_bags[0].end_time_ns: is before",
        ),
        ({"uri": "x", "topics": []}, "output_bags[0]: selects nothing"),
        ({"all": True}, "output_bags[0].uri: is required"),
    ],
)
def test_a_bad_option_names_the_field(tmp_path: Path, output: dict[str, Any], named: str) -> None:
    output = {**output, **({"uri": str(tmp_path / output["uri"])} if "uri" in output else {})}
    with pytest.raises(InputError) as caught:
        parse_output_options({"output_bags": [output]}, "out.yaml")
    assert str(caught.value).startswith(f"out.yaml: {named}"), str(caught.value)


def test_a_bad_option_is_one_line_and_exit_2_before_anything_is_written(
    inputs: dict[str, Any], tmp_path: Path
) -> None:
    done = _convert(tmp_path, inputs["bags"], {"output_bags": [{"uri": str(tmp_path / "x"), "regex": "(["}]})
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "out.yaml: output_bags[0].regex: is not a valid regular expression" in lines[0]
    assert "Traceback" not in done.stderr and not (tmp_path / "x").exists()


def test_bad_inputs_and_existing_outputs_are_refused_in_one_line(
    inputs: dict[str, Any], tmp_path: Path
) -> None:
    existing = {"output_bags": [{"uri": str(inputs["bags"][0]), "all": True}]}
    done = _convert(tmp_path, inputs["bags"], existing)
    assert done.returncode == 2 and "already exists" in done.stderr and len(done.stderr.splitlines()) == 1
    options = {"output_bags": [{"uri": str(tmp_path / "o"), "all": True}]}
    done = _convert(tmp_path, [tmp_path / "nothing_here"], options)
    assert done.returncode == 2 and "nothing_here" in done.stderr and len(done.stderr.splitlines()) == 1
    (tmp_path / "list.yaml").write_text("- just a list\n")
    done = subprocess.run(
        [*FEEDER, "bag-convert", str(inputs["bags"][0]), "-o", str(tmp_path / "list.yaml")],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 2 and "output_bags: is required" in done.stderr, done.stderr
    assert not (tmp_path / "o").exists()
