"""The squeeze station's scene in lockstep: `feeder launch cell_squeeze.yaml --real-time-factor 5`.

The gripper joins the cell clock's lockstep as the other devices do; a plan from the planner runs to DONE
on cell time (its streams stamped from the fixed start, not the wall clock) and ends at the plan's final
orientation modulo its symmetry period (ideal fidelity, within 1e-7 rad).
"""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import threading
from pathlib import Path
from typing import Any

import pytest
import yaml

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[2]
START_S = 1000.0


def wait(future: Any, timeout: float, what: str) -> Any:
    done = threading.Event()
    future.add_done_callback(lambda _: done.set())
    assert done.wait(timeout), f"{what} did not come within {timeout:.0f} s"
    return future.result()


def call_until_answered(node: Any, srv: Any, name: str, request: Any, timeout: float = 60.0) -> Any:
    """Call a service, sending the request again every 2 s until one answer comes.

    A server drops its reply to a client whose reply reader it has not matched yet (a fresh launch's
    planner did, once); the plan request is idempotent, so sending it again is safe.
    """
    client = node.create_client(srv, name)
    try:
        assert client.wait_for_service(timeout_sec=timeout), f"{name} not available"
        for _ in range(int(timeout / 2.0)):
            done = threading.Event()
            future = client.call_async(request)
            future.add_done_callback(lambda _, answered=done: answered.set())
            if done.wait(2.0):
                return future.result()
        raise AssertionError(f"{name} did not answer within {timeout:.0f} s")
    finally:
        node.destroy_client(client)


def test_a_plan_runs_on_the_cell_clock_in_lockstep(tmp_path: Path, ros_domain: int, ros_client: Any) -> None:
    from feeder_cell.launcher import scene_copy
    from feeder_msgs.action import RunPlan
    from feeder_msgs.msg import DeviceStatus, SqueezeState
    from feeder_msgs.srv import SqueezePlanCompute
    from feeder_planner.node_kit import LATCHED, STREAM_DEPTH
    from feeder_planner.node_kit.action_client import ActionClient
    from feeder_planner.node_kit.msg_parts import part_to_msg

    scene = scene_copy(ROOT / "feeder_cell" / "scenes" / "cell_squeeze.yaml", tmp_path, {})
    # The gripper and its planner alone, the gripper brought up by the launch: the scene's controller
    # would run its own plans on the gripper (tests/cell/test_squeeze_cell_ros.py runs it).
    document = yaml.safe_load(scene.read_text())
    document["nodes"] = [
        {k: v for k, v in node.items() if k != "lifecycle"}
        for node in document["nodes"]
        if node["executable"] in ("squeeze_gripper", "squeeze_planner")
    ]
    scene.write_text(yaml.safe_dump(document))
    stamps: list[float] = []
    subscription = ros_client.create_subscription(
        SqueezeState,
        "/cell/squeeze_gripper/state",
        lambda m: stamps.append(m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec),
        STREAM_DEPTH,
    )
    ready = threading.Event()
    status = ros_client.create_subscription(
        DeviceStatus, "/cell/squeeze_gripper/status", lambda m: m.ready and ready.set(), LATCHED
    )
    env = dict(os.environ, ROS_DOMAIN_ID=str(ros_domain))
    command = [sys.executable, "-m", "feeder_cell.cli.main", "launch", str(scene), "--real-time-factor", "5"]
    command += ["--start-time", str(START_S), "--duration", "60", "--log-dir", str(tmp_path / "logs")]
    launch = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    client = ActionClient(ros_client, RunPlan, "/cell/squeeze_gripper/run_plan")
    try:
        document = yaml.safe_load((ROOT / "examples" / "squeeze" / "rectangle.yaml").read_text())
        request = SqueezePlanCompute.Request(part=part_to_msg(document))
        plan = call_until_answered(ros_client, SqueezePlanCompute, "/cell/squeeze_planner/plan", request)
        assert plan.ok, plan.error
        assert ready.wait(60.0), "the launch did not bring the gripper to a ready state"
        assert client.wait_for_server(timeout_sec=60.0)
        handle = wait(
            client.send_goal_async(RunPlan.Goal(angles=list(plan.angles))), 60.0, "the goal response"
        )
        assert handle.accepted
        result = wait(handle.get_result_async(), 120.0, "the result").result
        assert result.outcome_name == "DONE", result.message
        error = math.remainder(result.part_orientation - plan.final_orientation, plan.symmetry_period)
        assert abs(error) < 1e-7 and len(result.jaw_widths) == 2
        # Stamped on the cell clock from the fixed start, never the wall clock (years later).
        assert stamps and all(START_S <= s < START_S + 60.0 for s in stamps), (stamps[:3], stamps[-3:])
    finally:
        client.destroy()
        ros_client.destroy_subscription(subscription)
        ros_client.destroy_subscription(status)
        if launch.poll() is None:
            launch.send_signal(signal.SIGINT)
        out, err = launch.communicate(timeout=60)
    assert launch.returncode in (0, 130), err[-1500:]
