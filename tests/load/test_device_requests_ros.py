"""Over DDS: the devices' known accepts refused by name, and one node per fully qualified name.

The arm refuses a placement beyond its length (R = 10 m or 1e308 on a 0.4 m arm) and a throw count that
would wrap its uint32 queue; the MEMS array refuses a pose at 1e308 (it used to fill every part state
with NaN). A second throw_planner under the name of a running one logs why and exits 1, and the first
goes on serving.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Callable

import pytest
import ros_harness
import yaml

from feeder_msgs.srv import ArmCommand, ArmPlacePart, GraspRadii, MemsPlaceParts
from feeder_planner.node_kit.msg_parts import part_to_msg

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[2]
TRIANGLE = ROOT / "examples" / "throwing" / "triangle.yaml"
SQUARE = ROOT / "examples" / "mems" / "square.yaml"
ARM = "/throwing_arm"
SIM = "/mems_field_array"


@pytest.fixture(scope="module")
def devices(launch_module_node: Callable[..., Any]) -> None:
    launch_module_node(
        "feeder_sim",
        "throwing_arm",
        {"part_file": str(TRIANGLE), "initial_edge": 1, "initial_radius": 0.12, "arm_length": 0.4},
        wait_services=(f"{ARM}/place_part", f"{ARM}/command"),
    )
    launch_module_node(
        "feeder_sim",
        "mems_field_array",
        {"part_files": [str(SQUARE)], "seed": 7, "placement_radius": 1e-3},
        wait_services=(f"{SIM}/place_parts",),
    )


def call(client: Any, srv_type: Any, name: str, request: Any) -> Any:
    return ros_harness.call_service(client, srv_type, name, request)


def test_arm_refuses_placements_off_the_arm_and_a_wrapping_queue(ros_client: Any, devices: None) -> None:
    for radius in (10.0, 1e308, -10.0):
        answer = call(
            ros_client, ArmPlacePart, f"{ARM}/place_part", ArmPlacePart.Request(edge=1, radius=radius)
        )
        assert not answer.ok and "radius" in answer.error and "arm_length" in answer.error, answer.error
    assert call(ros_client, ArmPlacePart, f"{ARM}/place_part", ArmPlacePart.Request(edge=1, radius=0.12)).ok
    huge = ArmCommand.Request(command="throw", count=2**32 - 1)
    answer = call(ros_client, ArmCommand, f"{ARM}/command", huge)
    assert not answer.ok and "count" in answer.error, answer.error
    stop = call(ros_client, ArmCommand, f"{ARM}/command", ArmCommand.Request(command="stop"))
    assert stop.ok and stop.pending == 0


def test_mems_refuses_poses_far_off_the_array(ros_client: Any, devices: None) -> None:
    for key in ("x", "y"):
        fields = {"x": [0.0], "y": [0.0], "theta": [0.0], key: [1e308]}
        request = MemsPlaceParts.Request(names=["square"], **fields)
        answer = call(ros_client, MemsPlaceParts, f"{SIM}/place_parts", request)
        assert not answer.ok and f"{key}[0]" in answer.error, answer.error
    request = MemsPlaceParts.Request(names=["square"], x=[0.0], y=[0.0], theta=[math.inf])
    assert "theta[0]" in call(ros_client, MemsPlaceParts, f"{SIM}/place_parts", request).error
    ok = MemsPlaceParts.Request(names=["square"], x=[1e-4], y=[0.0], theta=[0.0])
    answer = call(ros_client, MemsPlaceParts, f"{SIM}/place_parts", ok)
    assert answer.ok, answer.error


def test_a_namesake_exits_1_and_the_first_serves_on(
    ros_client: Any, launch_node: Callable[..., Any], tmp_path: Path
) -> None:
    first = launch_node(
        "feeder_planner", "throw_planner", {}, namespace="/dup", wait_services=("/dup/throw_planner/throw",)
    )
    second = ros_harness.start_node("feeder_planner", "throw_planner", {}, tmp_path, namespace="/dup")
    try:
        second.process.wait(timeout=30.0)
    finally:
        second.stop()
    assert second.process.returncode == 1, second.output()[-2000:]
    assert "another node named /dup/throw_planner is already running" in second.output()
    assert first.alive()

    request = GraspRadii.Request(
        part=part_to_msg(yaml.safe_load(TRIANGLE.read_text())), offset=-0.005, mu=0.5
    )
    assert call(ros_client, GraspRadii, "/dup/throw_planner/grasp_radii", request).ok
    assert first.alive()
