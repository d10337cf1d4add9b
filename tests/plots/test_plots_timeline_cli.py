"""The bag timeline (a bag written here, no ROS) and the --plot / bag-plot command lines: files and errors."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from rclpy.serialization import serialize_message
from rosbags.rosbag2 import StoragePlugin, Writer

from feeder_cell.bag.types import message_class, typestore
from feeder_cell.cli.main import main
from feeder_cell.plots.timeline import read_timeline, timeline_figure

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
START_NS = 1_700_000_000_000_000_000
SECOND = 1_000_000_000


def message(type_name: str, **fields: Any) -> Any:
    """Return an rclpy message with ``fields`` set and every other field at its default.

    rclpy's classes default every field, so the test bag stays valid when a message gains a field.
    """
    msg = message_class(type_name)()
    for name, value in fields.items():
        setattr(msg, name, value)
    return msg


def _header(t_ns: int) -> Any:
    return message(
        "std_msgs/msg/Header",
        stamp=message("builtin_interfaces/msg/Time", sec=t_ns // SECOND, nanosec=t_ns % SECOND),
    )


def _status(t_ns: int, state: int) -> Any:
    return message("feeder_msgs/msg/DeviceStatus", header=_header(t_ns), state=state, ready=state == 1)


def _throw(t_ns: int, index: int, kind: str) -> Any:
    return message(
        "feeder_msgs/msg/ThrowEvent",
        header=_header(t_ns),
        index=index,
        edge_before=1,
        radius_before=0.15,
        kind=kind,
    )


def _joints(t_ns: int, x: float, y: float) -> Any:
    return message(
        "sensor_msgs/msg/JointState", header=_header(t_ns), name=["tilt_x", "tilt_y"], position=[x, y]
    )


def write_run_bag(bag: Path) -> None:
    """Write a 4 s run: two devices' states, the arm's sensor and throws, the fixture's joints; no MEMS.

    One more topic holds bytes of another ThrowEvent layout.
    """
    store = typestore()
    writer = Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP)
    writer.open()
    status = {
        name: writer.add_connection(f"/cell/{name}/status", "feeder_msgs/msg/DeviceStatus", typestore=store)
        for name in ("throwing_arm", "assembly_fixture")
    }
    sensor = writer.add_connection("/cell/throwing_arm/sensor", "std_msgs/msg/Bool", typestore=store)
    throws = writer.add_connection(
        "/cell/throwing_arm/throw_events", "feeder_msgs/msg/ThrowEvent", typestore=store
    )
    joints = writer.add_connection(
        "/cell/assembly_fixture/joint_states", "sensor_msgs/msg/JointState", typestore=store
    )
    arm_joints = writer.add_connection(
        "/cell/throwing_arm/joint_states", "sensor_msgs/msg/JointState", typestore=store
    )
    messages: list[tuple[int, Any, Any]] = []
    for t, state in ((0.0, 0), (0.5, 1), (1.0, 2), (3.0, 1)):
        messages.append((round(t * SECOND), status["throwing_arm"], _status(round(t * SECOND), state)))
    for t, state in ((0.0, 0), (0.2, 1), (2.0, 4)):
        messages.append((round(t * SECOND), status["assembly_fixture"], _status(round(t * SECOND), state)))
    for i in range(9):
        t = round(i * 0.5 * SECOND)
        messages.append((t, sensor, message("std_msgs/msg/Bool", data=i % 3 == 0)))
        messages.append((t, joints, _joints(t, 0.1 * i, -0.05 * i)))
        messages.append((t, arm_joints, _joints(t, 9.0, 9.0)))  # not the fixture's: not drawn
    for i, (t, kind) in enumerate(((1.2, "jog"), (1.6, "jog"), (2.4, "flip"))):
        messages.append((round(t * SECOND), throws, _throw(round(t * SECOND), i, kind)))
    for t, connection, msg in sorted(messages, key=lambda m: m[0]):
        writer.write(connection, START_NS + t, serialize_message(msg))
    # A topic recorded with another layout of the message (too short for today's ThrowEvent).
    old = writer.add_connection("/cell/old_arm/throw_events", "feeder_msgs/msg/ThrowEvent", typestore=store)
    writer.write(old, START_NS + SECOND, b"\0\1\0\0\1\0\0\0")
    writer.close()


@pytest.fixture(scope="module")
def run_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    bag = tmp_path_factory.mktemp("bags") / "run"
    write_run_bag(bag)
    return bag


def test_timeline_reads_the_run_and_says_which_panels_are_missing(run_bag: Path) -> None:
    timeline = read_timeline(run_bag)
    assert timeline.duration == pytest.approx(4.0)
    assert sorted(timeline.states) == ["assembly_fixture", "throwing_arm"]
    assert timeline.states["throwing_arm"].t == pytest.approx([0.0, 0.5, 1.0, 3.0])
    assert timeline.states["throwing_arm"].v == [0, 1, 2, 1]
    assert timeline.sensor["/cell/throwing_arm/sensor"].v == [1.0 if i % 3 == 0 else 0.0 for i in range(9)]
    assert [k for _, k in timeline.throws["/cell/throwing_arm/throw_events"]] == ["jog", "jog", "flip"]
    assert sorted(timeline.fixture_angles) == [
        "tilt_x",
        "tilt_y",
    ]  # the arm's joint_states are not the fixture's
    assert timeline.fixture_angles["tilt_x"].v == pytest.approx([0.1 * i for i in range(9)])
    assert timeline.part_angles == {} and timeline.margin == {}
    assert timeline.undecodable == ["/cell/old_arm/throw_events"]  # skipped and named, not a traceback
    figure = timeline_figure(timeline, "run")
    states, throwing, mems, fixture = figure.axes[:4]
    assert [t.get_text() for t in states.get_yticklabels()] == ["assembly_fixture", "throwing_arm"]
    assert len(states.collections) == 2  # one bar row per device
    assert len(states.collections[1].get_paths()) == 4  # the arm's four states
    missing = [t.get_text() for t in mems.texts if t.get_gid() == "missing"]
    assert missing and "MEMS part angles" in missing[0] and "MemsPartStates" in missing[0]
    assert not [t for ax in (states, throwing, fixture) for t in ax.texts if t.get_gid() == "missing"]
    labels = throwing.get_legend_handles_labels()[1]
    assert "jog (2)" in labels and "flip (1)" in labels
    assert len(fixture.get_lines()) == 2
    assert np.degrees(0.8) == pytest.approx(fixture.get_lines()[0].get_ydata()[-1])


def test_bag_plot_writes_the_timeline_beside_the_bag(
    run_bag: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["bag-plot", str(run_bag), "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    picture = run_bag.parent / "run-timeline.png"
    assert result["path"] == str(picture) and picture.stat().st_size > 20_000
    assert result["panels"]["MEMS part angles"] == []
    assert result["panels"]["device states"] == ["assembly_fixture", "throwing_arm"]
    assert result["undecodable"] == ["/cell/old_arm/throw_events"]
    svg = run_bag.parent / "t.svg"
    assert main(["bag-plot", str(run_bag), "--output", str(svg)]) == 0
    assert svg.read_text().lstrip().startswith("<?xml") and "<svg" in svg.read_text()[:2000]
    assert capsys.readouterr().out.startswith(f"plot: {svg.resolve()}")


def test_bag_plot_refuses_an_unreadable_bag_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["bag-plot", str(tmp_path / "nothing")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "bag:" in err and "nothing" in err
    assert not (tmp_path / "nothing-timeline.png").exists()


PLANNER_COMMANDS = {
    "equilibria": ["equilibria", str(EXAMPLES / "mems/bracket.yaml"), "--delta", "0.1"],
    "stable-region": ["stable-region", str(EXAMPLES / "assembly/cube_in_corner.yaml"), "--mu", "0"],
    "check-stability": [
        "check-stability",
        str(EXAMPLES / "assembly/cube_in_corner.yaml"),
        "--g",
        "-1",
        "-1",
        "-1",
    ],
}


@pytest.mark.parametrize("command", sorted(PLANNER_COMMANDS))
def test_plot_flag_writes_the_picture_and_keeps_the_json(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], command: str
) -> None:
    picture = tmp_path / f"{command}.PNG"  # the extension's case does not matter
    assert main([*PLANNER_COMMANDS[command], "--json", "--plot", str(picture)]) == 0
    out = capsys.readouterr().out
    assert out.count("\n") == 1 and isinstance(json.loads(out), dict)  # still exactly one JSON object
    assert picture.read_bytes()[:4] == b"\x89PNG" and picture.stat().st_size > 10_000


@pytest.mark.parametrize(
    ("name", "problem"),
    [
        ("result.pdf", "got '.pdf'"),
        ("result", "got no extension"),
        ("no_such_folder/result.png", "does not exist"),
        ("", "empty string"),
    ],
)
def test_bad_plot_paths_are_one_line_errors_before_any_work(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str, problem: str
) -> None:
    target = str(tmp_path / name) if name else ""
    with pytest.raises(SystemExit) as exit_info:
        main([*PLANNER_COMMANDS["equilibria"], "--plot", target])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--plot" in err and problem in err
    assert list(tmp_path.iterdir()) == []


def test_a_folder_as_plot_path_is_refused_by_the_installed_command(tmp_path: Path) -> None:
    # The real command line, a new process: limit-set refuses before computing the limit set.
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "feeder_cell.cli.main",
            "limit-set",
            str(EXAMPLES / "throwing/triangle.yaml"),
            "--offset",
            "-0.5",
            "--release-speed",
            "320deg",
            "--gravity",
            "-966",
            "--mu",
            "0.5",
            "--plot",
            str(tmp_path),
        ],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 2 and done.stdout == ""
    assert done.stderr.count("\n") == 1 and "--plot" in done.stderr and "is a folder" in done.stderr
    assert "Traceback" not in done.stderr
