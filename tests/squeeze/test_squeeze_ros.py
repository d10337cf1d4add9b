"""Over DDS: the squeeze_planner plans a part, the squeeze_gripper runs the plan, and bad requests refused.

The plan the planner answers goes unchanged to the gripper's ~/run_plan; the part ends at the plan's final
orientation modulo its symmetry period (ideal fidelity, within 1e-7 rad), from two starts.
"""

from __future__ import annotations

import math
import threading
from pathlib import Path
from typing import Any

import pytest
import ros_harness
import yaml

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[2]
RECTANGLE = ROOT / "examples" / "squeeze" / "rectangle.yaml"


def part_msg(document: dict) -> Any:
    from feeder_planner.node_kit.msg_parts import part_to_msg

    return part_to_msg(document)


def wait(future: Any, timeout: float, what: str) -> Any:
    done = threading.Event()
    future.add_done_callback(lambda _: done.set())
    assert done.wait(timeout), f"{what} did not come within {timeout:.0f} s"
    return future.result()


@pytest.fixture(scope="module")
def nodes(launch_module_node: Any) -> None:
    launch_module_node(
        "feeder_planner",
        "squeeze_planner",
        {},
        wait_services=("/squeeze_planner/plan", "/squeeze_planner/functions"),
    )
    launch_module_node(
        "feeder_sim",
        "squeeze_gripper",
        {"part_file": str(RECTANGLE), "jaw_speed": 0.5, "turn_speed": 30.0, "initial_orientation": 0.3},
        wait_services=("/squeeze_gripper/place_part",),
    )


def test_the_planners_plan_run_by_the_gripper_orients_the_part(nodes: None, ros_client: Any) -> None:
    from feeder_msgs.action import RunPlan
    from feeder_msgs.srv import SqueezePlacePart, SqueezePlanCompute
    from feeder_planner.node_kit.action_client import ActionClient

    request = SqueezePlanCompute.Request(
        part=part_msg(yaml.safe_load(RECTANGLE.read_text())), first_angle=0.0
    )
    plan = ros_harness.call_service(ros_client, SqueezePlanCompute, "/squeeze_planner/plan", request)
    assert plan.ok, plan.error
    assert len(plan.angles) == 2 and plan.steps_per_period == 2
    assert plan.symmetry_period == pytest.approx(math.pi) and plan.margin > 0.3
    assert len(plan.interval_starts) == len(plan.interval_finals) == 4
    client = ActionClient(ros_client, RunPlan, "/squeeze_gripper/run_plan")
    try:
        assert client.wait_for_server(timeout_sec=30.0)
        for start in (0.3, 2.0):
            placed = ros_harness.call_service(
                ros_client,
                SqueezePlacePart,
                "/squeeze_gripper/place_part",
                SqueezePlacePart.Request(orientation=start),
            )
            assert placed.ok and placed.orientation == pytest.approx(start), placed.error
            handle = wait(
                client.send_goal_async(RunPlan.Goal(angles=list(plan.angles))), 30.0, "the goal response"
            )
            assert handle.accepted
            result = wait(handle.get_result_async(), 60.0, "the result").result
            assert result.outcome_name == "DONE", result.message
            assert result.squeezes == 2 and len(result.jaw_widths) == 2
            error = math.remainder(result.part_orientation - plan.final_orientation, plan.symmetry_period)
            assert abs(error) < 1e-7, (start, result.part_orientation, plan.final_orientation)
            # The second reading: the short side between the jaws after the last squeeze.
            assert result.jaw_widths[-1] == pytest.approx(0.01, abs=1e-9)
    finally:
        client.destroy()


def test_functions_and_bad_requests_name_their_field(nodes: None, ros_client: Any) -> None:
    from feeder_msgs.srv import SqueezeFunctions, SqueezePlanCompute

    document = yaml.safe_load(RECTANGLE.read_text())
    functions = ros_harness.call_service(
        ros_client,
        SqueezeFunctions,
        "/squeeze_planner/functions",
        SqueezeFunctions.Request(part=part_msg(document), samples=720),
    )
    assert functions.ok, functions.error
    assert len(functions.theta) == len(functions.width) == len(functions.squeezed) == 720
    assert sorted(functions.minima_width) == pytest.approx([0.01, 0.02])
    assert min(functions.width) >= 0.01 - 1e-12 and max(functions.width) <= math.sqrt(5) * 0.01 + 1e-12
    too_many = ros_harness.call_service(
        ros_client,
        SqueezeFunctions,
        "/squeeze_planner/functions",
        SqueezeFunctions.Request(part=part_msg(document), samples=200_000),
    )
    assert not too_many.ok and "samples" in too_many.error and "100000" in too_many.error
    flat = dict(document, vertices=[[0, 0], [1, 0], [2, 0.0000000001]])
    degenerate = ros_harness.call_service(
        ros_client,
        SqueezePlanCompute,
        "/squeeze_planner/plan",
        SqueezePlanCompute.Request(part=part_msg(flat)),
    )
    assert not degenerate.ok and "part.outer: the convex hull is degenerate" in degenerate.error, (
        degenerate.error
    )
    infinite = ros_harness.call_service(
        ros_client,
        SqueezePlanCompute,
        "/squeeze_planner/plan",
        SqueezePlanCompute.Request(part=part_msg(document), first_angle=math.inf),
    )
    assert not infinite.ok and "first_angle: must be finite" in infinite.error, infinite.error


def test_the_dynamic_fidelity_squeezes_once_with_feedback(launch_node: Any, ros_client: Any) -> None:
    from feeder_msgs.action import Squeeze
    from feeder_planner.node_kit.action_client import ActionClient
    from feeder_planner.parts import load_part
    from feeder_sim.squeeze.ideal import ideal_squeeze

    launch_node(
        "feeder_sim",
        "squeeze_gripper",
        {"part_file": str(RECTANGLE), "fidelity": "dynamic", "jaw_speed": 0.2, "initial_orientation": 0.3},
        name="squeeze_dynamic",
        wait_services=("/squeeze_dynamic/place_part",),
    )
    feedback: list[Any] = []
    client = ActionClient(ros_client, Squeeze, "/squeeze_dynamic/squeeze")
    try:
        assert client.wait_for_server(timeout_sec=30.0)
        goal = Squeeze.Goal(angle=1.0)
        handle = wait(
            client.send_goal_async(goal, feedback_callback=feedback.append), 30.0, "the goal response"
        )
        assert handle.accepted
        result = wait(handle.get_result_async(), 60.0, "the result").result
    finally:
        client.destroy()
    assert result.outcome_name == "DONE", result.message
    # Frictionless pymunk against Goldberg's squeeze from 0.3 - 1.0 rad relative to the jaws.
    ideal = ideal_squeeze(load_part(RECTANGLE).outer, 0.3 - 1.0)
    assert result.jaw_width == pytest.approx(ideal.width, abs=5e-5)
    assert abs(math.remainder(result.part_orientation - (1.0 + ideal.orientation), 2 * math.pi)) < 0.02
    phases = [f.feedback.phase for f in feedback]
    # Feedback is a sample of the phases, one a tick: the jaws' closing is long enough to be seen, and what
    # is seen comes in the squeeze's order. A short opening may fall between two samples on a loaded
    # machine (a CI run at load 10 saw IDLE, TURNING, CLOSING, IDLE).
    order = ["IDLE", "TURNING", "CLOSING", "OPENING", "IDLE"]
    assert "CLOSING" in phases, phases
    seen = [p for i, p in enumerate(phases) if i == 0 or p != phases[i - 1]]
    position = 0
    for phase in seen:
        assert phase in order[position:], f"phase {phase} out of the squeeze's order: {seen}"
        position = order.index(phase, position)
