"""feeder launch: a scene starts only its nodes, records them, and ends every one by pid."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import ros_harness

ROOT = Path(__file__).resolve().parents[2]
FEEDER = [sys.executable, "-m", "feeder_cell.cli.main"]


@pytest.mark.ros
def test_scene_runs_its_nodes_records_them_and_ends_them(ros_domain: int, tmp_path: Path) -> None:
    bag = tmp_path / "scene-bag"
    result = subprocess.run(
        [
            *FEEDER,
            "launch",
            str(ROOT / "feeder_cell/scenes/mems_only.yaml"),
            "--duration",
            "4",
            "--record",
            str(bag),
            "--log-dir",
            str(tmp_path / "logs"),
            "--json",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    summary = json.loads(result.stdout)
    assert [n["executable"] for n in summary["nodes"]] == ["mems_field_array", "field_equilibria_planner"]
    for node in summary["nodes"]:
        assert not node["died_early"] and node["exit_code"] in (0, -2)
        with pytest.raises(ProcessLookupError):
            os.kill(node["pid"], 0)
    topics = summary["bag"]["topics"]
    assert topics["/mems_field_array/part_states"]["count"] > 0
    # Only the models the scene names run: nothing of the other devices is on the graph.
    assert not any(name.startswith(("/throwing_arm", "/assembly_fixture")) for name in topics)
    assert (bag / "metadata.yaml").is_file()
    # Recorded from before the first lifecycle transition: the device's bring-up is in the bag, each
    # transition event with its stamp and transition (rcl_lifecycle's own carry neither).
    events = _recorded(bag, "/mems_field_array/transition_event")
    steps = [(e.transition.label, e.start_state.label, e.goal_state.label) for e in events]
    assert steps == [
        ("configure", "unconfigured", "configuring"),
        ("transition_success", "configuring", "inactive"),
        ("activate", "inactive", "activating"),
        ("transition_success", "activating", "active"),
    ]
    assert [e.transition.id for e in events] == [1, 10, 3, 30]
    stamps = [e.timestamp for e in events]
    assert stamps == sorted(stamps) and abs(stamps[0] - time.time_ns()) < 600e9
    assert _recorded(bag, "/mems_field_array/status")[0].state_name == "UNCONFIGURED"


def _recorded(bag: Path, topic: str) -> list:
    """The messages of ``topic`` in a bag, in log time order."""
    from mcap.reader import make_reader
    from rclpy.serialization import deserialize_message

    from feeder_cell.bag.types import message_class

    messages = []
    for path in sorted(bag.glob("*.mcap")):
        with open(path, "rb") as handle:
            for schema, channel, message in make_reader(handle).iter_messages(log_time_order=True):
                if channel.topic == topic:
                    messages.append(deserialize_message(message.data, message_class(schema.name)))
    return messages


def test_bad_scene_file_names_the_field(tmp_path: Path) -> None:
    scene = tmp_path / "scene.yaml"
    scene.write_text("name: bad\nnodes:\n  - package: feeder_sim\n    parameters: {}\n")
    result = subprocess.run(
        [*FEEDER, "launch", str(scene), "--duration", "1"], capture_output=True, text=True, timeout=60
    )
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1
    assert "nodes[0].executable" in result.stderr and str(scene) in result.stderr


_node_pids = ros_harness.launched_node_pids


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return not Path(f"/proc/{pid}/status").read_text().count("State:\tZ")


@pytest.mark.ros
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGHUP, signal.SIGKILL])
def test_launch_never_orphans_its_nodes(ros_domain: int, tmp_path: Path, sig: signal.Signals) -> None:
    logs = tmp_path / "logs"
    launch = subprocess.Popen(
        [*FEEDER, "launch", str(ROOT / "feeder_cell/scenes/mems_only.yaml"), "--log-dir", str(logs)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        deadline = time.monotonic() + 60
        while len(_node_pids(launch.pid)) < 2 and time.monotonic() < deadline:
            time.sleep(0.2)
        pids = _node_pids(launch.pid)
        assert len(pids) == 2, f"scene nodes not started: {pids}"
        time.sleep(3.0)  # in the graph and past start-up
        launch.send_signal(sig)
        _, err = launch.communicate(timeout=60)
    finally:
        if launch.poll() is None:  # a failed assertion above must not leave the scene running
            launch.kill()
            launch.communicate(timeout=30)
    if sig != signal.SIGKILL:
        assert launch.returncode == 0 and "Traceback" not in err, err
    deadline = time.monotonic() + 15
    while any(_alive(p) for p in pids) and time.monotonic() < deadline:
        time.sleep(0.2)
    assert [p for p in pids if _alive(p)] == []


@pytest.mark.ros
def test_an_interrupt_during_start_up_ends_cleanly(ros_domain: int, tmp_path: Path) -> None:
    logs = tmp_path / "logs"
    launch = subprocess.Popen(
        [*FEEDER, "launch", str(ROOT / "feeder_cell/scenes/mems_only.yaml"), "--log-dir", str(logs)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        deadline = time.monotonic() + 60
        while not _node_pids(launch.pid) and time.monotonic() < deadline:
            time.sleep(0.05)
        pids = _node_pids(launch.pid)
        assert pids, "no node process started"
        launch.send_signal(signal.SIGINT)
        _, err = launch.communicate(timeout=60)
    finally:
        if launch.poll() is None:
            launch.kill()
            launch.communicate(timeout=30)
    assert launch.returncode == 0 and "Traceback" not in err, err
    time.sleep(1.0)
    assert [p for p in pids if _alive(p)] == []


def _scene(tmp_path: Path, nodes: list[dict]) -> Path:
    import yaml

    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump({"name": "lifecycle", "nodes": nodes}))
    return path


@pytest.mark.ros
def test_a_scene_can_leave_a_device_inactive_or_unconfigured(ros_domain: int, tmp_path: Path) -> None:
    part = str(ROOT / "examples/mems/bracket.yaml")
    scene = _scene(
        tmp_path,
        [
            {
                "package": "feeder_sim",
                "executable": "mems_field_array",
                "name": "array_a",
                "lifecycle": "inactive",
                "parameters": {"part_files": [part]},
            },
            {
                "package": "feeder_sim",
                "executable": "mems_field_array",
                "name": "array_b",
                "lifecycle": "unconfigured",
                "parameters": {"part_files": [part]},
            },
            {
                "package": "feeder_sim",
                "executable": "mems_field_array",
                "name": "array_c",
                "parameters": {"part_files": [part]},
            },
        ],
    )
    result = subprocess.run(
        [*FEEDER, "launch", str(scene), "--duration", "2", "--json"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    states = {n["name"]: n["lifecycle"] for n in json.loads(result.stdout)["nodes"]}
    assert states == {"/array_a": "inactive", "/array_b": "unconfigured", "/array_c": "active"}


@pytest.mark.ros
def test_a_device_that_fails_to_configure_stops_the_launch_with_its_reason(
    ros_domain: int, tmp_path: Path
) -> None:
    scene = _scene(
        tmp_path,
        [
            {
                "package": "feeder_sim",
                "executable": "mems_field_array",
                "parameters": {"part_files": [str(tmp_path / "missing.yaml")]},
            }
        ],
    )
    result = subprocess.run(
        [*FEEDER, "launch", str(scene), "--duration", "2"], capture_output=True, text=True, timeout=120
    )
    assert result.returncode == 1
    assert result.stderr.count("\n") == 1, result.stderr
    assert "configure refused" in result.stderr and "missing.yaml" in result.stderr


def test_set_overrides_a_parameter_for_the_run_and_names_set_when_refused() -> None:
    from feeder_cell.launcher import load_scene, with_overrides
    from feeder_planner.errors import InputError

    scene = load_scene(ROOT / "feeder_cell/scenes/cell.yaml")
    changed = with_overrides(scene, ["cell_controller.cycles=1", "/cell/throwing_arm.release_speed=5.0"])
    by_name = {n.node_name: n.parameters for n in changed.nodes}
    assert by_name["cell_controller"]["cycles"] == 1 and by_name["throwing_arm"]["release_speed"] == 5.0
    assert {n.node_name: n.parameters for n in scene.nodes}["cell_controller"]["cycles"] == 3  # a copy
    for bad, problem in (
        ("cell_controller.cycles=one", "is declared integer"),
        ("cell_controller.cycles=-1", ">= 0"),
        ("nobody.cycles=1", "names 0 nodes"),
        ("cell_controller.cycles", "NODE.PARAM=VALUE"),
        ("cell_controller.cycles=[1, a]", "one type"),
    ):
        with pytest.raises(InputError, match=problem) as caught:
            with_overrides(scene, [bad])
        assert caught.value.field.startswith("--set"), caught.value
