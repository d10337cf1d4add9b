"""The cell: several instances in namespaces that never cross; a launch on the cell clock keeps its pace.

Everything runs as real node processes over DDS, through `feeder launch`, as a user would. Stepping a
held clock by exact quanta, and the same run again after a reset, is the simulation_interfaces harness's
(tests/cell/test_simulation_interfaces_ros.py); the same run at every pace the lockstep test's.
"""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import pytest
import ros_harness
import yaml

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
FEEDER = [sys.executable, "-m", "feeder_cell.cli.main"]

ARMS = {
    "/cell/feeder_a": EXAMPLES / "throwing/triangle.yaml",
    "/cell/feeder_b": EXAMPLES / "throwing/bracket.yaml",
}
ARRAYS = {"/cell/array_a": EXAMPLES / "mems/plus.yaml", "/cell/array_b": EXAMPLES / "mems/bracket.yaml"}
# Parameters of each arm's part for a feeder that throws (the part files' own examples).
ARM_PARAMETERS = {
    "/cell/feeder_a": {"gravity": -9.66, "offset": -0.005, "release_speed": 5.585053606381854},
    "/cell/feeder_b": {"gravity": -2.2, "offset": -0.0025, "release_speed": 5.585053606381854},
}
STANDARD_TOPICS = {"/diagnostics", "/rosout", "/parameter_events", "/clock", "/tf", "/tf_static"}


def multi_instance_scene(path: Path) -> Path:
    nodes: list[dict[str, Any]] = []
    for namespace, part in ARMS.items():
        nodes.append(
            {
                "package": "feeder_sim",
                "executable": "throwing_arm",
                "namespace": namespace,
                "parameters": {
                    "part_file": str(part),
                    "autostart": True,
                    "period": 0.4,
                    **ARM_PARAMETERS[namespace],
                },
            }
        )
        nodes.append({"package": "feeder_planner", "executable": "throw_planner", "namespace": namespace})
    for namespace, part in ARRAYS.items():
        nodes.append(
            {
                "package": "feeder_sim",
                "executable": "mems_field_array",
                "namespace": namespace,
                "parameters": {"part_files": [str(part)], "fidelity": "ideal", "seed": 5},
            }
        )
        nodes.append(
            {"package": "feeder_planner", "executable": "field_equilibria_planner", "namespace": namespace}
        )
    path.write_text(yaml.safe_dump({"name": "two_of_each", "nodes": nodes}))
    return path


class Launch:
    """`feeder launch` running in the background; ended by SIGINT, its JSON summary kept."""

    def __init__(self, scene: Path, log_dir: Path, *extra: str) -> None:
        self.process = subprocess.Popen(
            [*FEEDER, "launch", str(scene), "--log-dir", str(log_dir), "--json", *extra],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )

    def stop(self) -> dict[str, Any]:
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)
        out, err = self.process.communicate(timeout=60)
        assert self.process.returncode == 0, err
        return json.loads(out)


def _log_tails(log_dir: Path, characters: int = 1500) -> str:
    """The end of each log a launch wrote, for a failure's message (what the nodes said they did)."""
    return "\n".join(
        f"--- {path.name}\n{path.read_text(errors='replace')[-characters:]}"
        for path in sorted(log_dir.rglob("*.log"))
    )


def wait_for_status(client: Any, node_name: str, state: str, timeout: float = 60.0) -> Any:
    from feeder_msgs.msg import DeviceStatus
    from feeder_planner.node_kit import LATCHED

    seen: list[Any] = []
    done = threading.Event()

    def on_status(msg: Any) -> None:
        seen.append(msg)
        if msg.state_name == state:
            done.set()

    sub = client.create_subscription(DeviceStatus, f"{node_name}/status", on_status, LATCHED)
    try:
        done.wait(timeout)
    finally:
        client.destroy_subscription(sub)
    assert done.is_set(), f"{node_name} not {state} within {timeout} s; last: {seen[-1] if seen else None}"
    return seen[-1]


@pytest.mark.ros
def test_two_arms_and_two_arrays_in_namespaces_never_cross(ros_client: Any, tmp_path: Path) -> None:
    from feeder_msgs.msg import EquilibriaPrediction, MemsPartStates, ThrowEvent
    from feeder_planner.node_kit import LATCHED

    launch = Launch(multi_instance_scene(tmp_path / "scene.yaml"), tmp_path / "logs")
    try:
        for namespace in (*ARMS, *ARRAYS):
            device = "throwing_arm" if namespace in ARMS else "mems_field_array"
            wait_for_status(ros_client, f"{namespace}/{device}", "IDLE" if namespace in ARRAYS else "RUNNING")
        events = {
            ns: ros_harness.collect(
                ros_client, ThrowEvent, f"{ns}/throwing_arm/throw_events", count=2, timeout=60
            )
            for ns in ARMS
        }
        states = {
            ns: ros_harness.collect(ros_client, MemsPartStates, f"{ns}/mems_field_array/part_states", count=1)
            for ns in ARRAYS
        }
        predictions = {
            ns: ros_harness.collect(
                ros_client,
                EquilibriaPrediction,
                f"{ns}/field_equilibria_planner/predicted_poses",
                count=1,
                qos=LATCHED,
                timeout=60,
            )
            for ns in ARRAYS
        }
        topics = {name for name, _ in ros_client.get_topic_names_and_types()}
    finally:
        summary = launch.stop()

    part_names = {ns: yaml.safe_load(path.read_text())["name"] for ns, path in ARRAYS.items()}
    for ns in ARMS:
        # Each arm's events carry its own frame and come from its own part (the triangle has 3 hull edges).
        assert all(e.header.frame_id == f"{ns.strip('/')}/arm_pivot" for e in events[ns])
    assert max(e.edge_after for e in events["/cell/feeder_a"]) < 3
    for ns in ARRAYS:
        assert [s.name for s in states[ns][0].parts] == [part_names[ns]]
        assert states[ns][0].header.frame_id == f"{ns.strip('/')}/mems_array"
        assert list(predictions[ns][0].names) == [part_names[ns]]
    # Every topic of the cell lives under one instance's namespace (or is a standard one).
    stray = sorted(
        t for t in topics - STANDARD_TOPICS if not t.startswith(tuple(f"{ns}/" for ns in (*ARMS, *ARRAYS)))
    )
    assert stray == []
    assert sorted(n["name"] for n in summary["nodes"]) == sorted(
        [f"{ns}/throwing_arm" for ns in ARMS]
        + [f"{ns}/throw_planner" for ns in ARMS]
        + [f"{ns}/mems_field_array" for ns in ARRAYS]
        + [f"{ns}/field_equilibria_planner" for ns in ARRAYS]
    )
    assert all(n["lifecycle"] in ("active", "unmanaged") and not n["died_early"] for n in summary["nodes"])


@pytest.mark.ros
def test_launch_real_time_factor_runs_every_device_on_the_cell_clock(ros_client: Any, tmp_path: Path) -> None:
    from feeder_msgs.msg import DeviceStatus

    scene = tmp_path / "fast.yaml"
    scene.write_text(
        yaml.safe_dump(
            {
                "name": "fast",
                "nodes": [
                    {
                        "package": "feeder_sim",
                        "executable": "throwing_arm",
                        "parameters": {
                            "part_file": str(EXAMPLES / "throwing/triangle.yaml"),
                            "autostart": True,
                            "period": 0.5,
                            **ARM_PARAMETERS["/cell/feeder_a"],
                        },
                    },
                ],
            }
        )
    )
    launch = Launch(scene, tmp_path / "logs", "--real-time-factor", "4")
    try:
        wait_for_status(ros_client, "/throwing_arm", "RUNNING")
        first = wait_for_status(ros_client, "/throwing_arm", "RUNNING")
        time.sleep(6.0)
        last = ros_harness.collect(ros_client, DeviceStatus, "/throwing_arm/status", count=1, timeout=10)[-1]
    finally:
        summary = launch.stop()
    # On the cell clock the launch adds the clock and the simulation_interfaces node beside the scene's.
    assert [n["executable"] for n in summary["nodes"]] == ["cell_clock", "cell_simulation", "throwing_arm"]
    assert summary["real_time_factor"] == 4.0
    throws, before = ros_harness.counters(last)["throws"], ros_harness.counters(first)["throws"]
    # A 0.5 s throw period at 4x: about 8 throws per wall second, far more than at real time (2 per second).
    assert throws - before >= 6.0 * 4, (
        f"{throws - before} throws; cell time {ros_harness.stamp_ns(first) / 1e9:.3f} -> "
        f"{ros_harness.stamp_ns(last) / 1e9:.3f} s; {last.state_name} {last.fault_text!r}; logs:\n"
        + _log_tails(tmp_path / "logs")
    )
    assert last.configured_real_time_factor == 4.0
    assert abs(last.achieved_real_time_factor - 4.0) < 0.4
