"""Every node the README lists resolves like `ros2 run`, starts, joins the graph and ends by pid."""

from __future__ import annotations

import os
import re
import socket
from pathlib import Path

import pytest
import ros_harness

from feeder_cell.launcher import resolve_executable

ROOT = Path(__file__).resolve().parents[2]


def readme_nodes() -> list[tuple[str, str]]:
    """(package, executable) of each row of the README's node table: `| `node` | `package` | ...`."""
    text = (ROOT / "README.md").read_text()
    section = text.split("## Nodes", 1)[1].split("\n## ", 1)[0]
    return re.findall(r"^\|\s*`([a-z_]+)`\s*\|\s*`(feeder_[a-z]+)`\s*\|", section, flags=re.M)


NODES = readme_nodes()
# The managed devices start, join the graph and are ended by pid (unconfigured and finalized, exit checked)
# in the device conformance suite, tests/devices/test_device_conformance_ros.py.
DEVICES = {"mems_field_array", "throwing_arm", "assembly_fixture", "squeeze_gripper"}


# The least each node needs to start; everything else has a documented default.
def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


START_PARAMETERS = {
    # Not the default 4840: a gateway (or any OPC UA server) of another run may hold it.
    "opcua_gateway": {"endpoint": f"opc.tcp://127.0.0.1:{_free_port()}"},
}


def test_readme_lists_every_node() -> None:
    assert sorted(NODES) == sorted(
        [
            ("mems_field_array", "feeder_sim"),
            ("throwing_arm", "feeder_sim"),
            ("assembly_fixture", "feeder_sim"),
            ("field_equilibria_planner", "feeder_planner"),
            ("throw_planner", "feeder_planner"),
            ("stable_region_planner", "feeder_planner"),
            ("squeeze_gripper", "feeder_sim"),
            ("squeeze_planner", "feeder_planner"),
            ("cell_controller", "feeder_cell"),
            ("opcua_gateway", "feeder_cell"),
            ("cell_clock", "feeder_cell"),
            ("cell_simulation", "feeder_cell"),
        ]
    )


@pytest.mark.parametrize("executable, package", NODES)
def test_readme_node_resolves_through_the_ament_index(executable: str, package: str) -> None:
    path = resolve_executable(package, executable)
    assert path.parent == Path(path.parents[2]) / "lib" / package
    assert os.access(path, os.X_OK)


@pytest.mark.ros
@pytest.mark.parametrize("executable, package", [node for node in NODES if node[0] not in DEVICES])
def test_node_starts_joins_the_graph_and_ends_by_pid(
    executable: str, package: str, ros_client, started_processes, tmp_path: Path
) -> None:
    node = ros_harness.start_node(package, executable, START_PARAMETERS.get(executable), tmp_path)
    started_processes.append(node)
    try:
        ros_harness.wait_for_graph_node(ros_client, node, executable, timeout=30.0)
    finally:
        code = node.stop()
    assert not node.alive()
    with pytest.raises(ProcessLookupError):
        os.kill(node.pid, 0)
    # SIGINT is a clean shutdown for a ROS node: exit 0, or killed by the signal it did not catch.
    assert code in (0, -2, 130), f"{executable} exited with {code}:\n{node.output()[-2000:]}"
