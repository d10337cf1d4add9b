"""The ROS reference controller refuses ``policy: pipelined`` (the ROS-free cell loop runs it, so far)."""

from __future__ import annotations

from pathlib import Path

import pytest
import ros_harness

pytestmark = pytest.mark.ros


def test_the_ros_controller_refuses_pipelined_naming_the_parameter(ros_domain: int, tmp_path: Path) -> None:
    node = ros_harness.start_node(
        "feeder_cell", "cell_controller", {"policy": "pipelined"}, tmp_path, namespace="/nowhere"
    )
    try:
        assert node.process.wait(timeout=60) == 2
    finally:
        node.stop()
    named = "parameter policy: pipelined runs in the ROS-free loop only, so far"
    assert named in node.output() and "Traceback" not in node.output(), node.output()[-1500:]
