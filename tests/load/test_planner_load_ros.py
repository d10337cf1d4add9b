"""Over DDS: throw_planner under bursts, a flood and hostile requests (issue 16 items 5 and 6).

One planner and one arm for the module. A burst of 200 concurrent calls to each service gets 200 answers
(the request queue is 1000 deep, rclpy's default 10); during a flood of 200 calls a small request to
another service is answered within a bound and the arm keeps its publish rate; hostile contents are
answered ``ok: false`` naming the field, and the planner's memory stays flat.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any, Callable

import pytest
import yaml
from load_tools import burst, burst_client, rss_mb, timed_call
from sensor_msgs.msg import JointState

from feeder_msgs.srv import DesignSearch, GraspRadii, LimitSetCompute, SensorTriggerRadii, ThrowCompute
from feeder_planner.node_kit.msg_parts import part_to_msg

pytestmark = pytest.mark.ros

TRIANGLE = Path(__file__).resolve().parents[2] / "examples" / "throwing" / "triangle.yaml"
DESIGN = {"offset": -0.005, "release_speed": math.radians(320), "gravity": -9.66, "mu": 0.5}
BURST = 200
SMALL_BOUND = 3.0  # s: the small request's answer during the flood (a throw takes ~10 ms alone)
ARM_RATE = 50.0


def part() -> Any:
    return part_to_msg(yaml.safe_load(TRIANGLE.read_text()))


@pytest.fixture(scope="module")
def planner(launch_module_node: Callable[..., Any]) -> Any:
    return launch_module_node("feeder_planner", "throw_planner", {}, wait_services=("/throw_planner/throw",))


@pytest.fixture(scope="module")
def arm(launch_module_node: Callable[..., Any]) -> Any:
    return launch_module_node(
        "feeder_sim",
        "throwing_arm",
        {"part_file": str(TRIANGLE), **DESIGN, "sensor_rate": ARM_RATE, "initial_edge": 1},
        wait_topics=("/throwing_arm/joint_states",),
    )


def grasp() -> GraspRadii.Request:
    return GraspRadii.Request(part=part(), offset=DESIGN["offset"], mu=DESIGN["mu"])


def throw(radius: float = 0.12) -> ThrowCompute.Request:
    return ThrowCompute.Request(part=part(), edge=1, radius=radius, **DESIGN)


def test_burst_of_200_to_every_service_gets_200_answers(ros_client: Any, planner: Any) -> None:
    # Cheap requests on every service: valid ones where an answer is quick, and for the long services
    # requests refused at their limits (the queue is what is measured, not the work).
    cases: list[tuple[Any, str, Any, str]] = [
        (GraspRadii, "grasp_radii", grasp(), ""),
        (ThrowCompute, "throw", throw(), ""),
        (LimitSetCompute, "limit_set", LimitSetCompute.Request(part=part(), throws=1, **DESIGN), "throws"),
        (
            SensorTriggerRadii,
            "trigger_radii",
            SensorTriggerRadii.Request(part=part(), goal_edge=-1, **DESIGN),
            "goal_edge",
        ),
        (
            DesignSearch,
            "design_search",
            DesignSearch.Request(part=part(), goal_edge=1, offsets=[0.0] * 100, release_speeds=[1.0]),
            "offsets",
        ),
    ]
    for srv_type, name, request, field in cases:
        service = burst_client(ros_client, srv_type, f"/throw_planner/{name}")
        answers = burst(service, [request] * BURST, timeout=60.0)
        lost = sum(a is None for a in answers)
        assert lost == 0, f"{name}: {lost} of {BURST} calls got no answer"
        if field:
            assert all(not a.ok and field in a.error for a in answers), answers[0].error
        else:
            assert all(a.ok for a in answers), next(a.error for a in answers if not a.ok)


def test_flood_leaves_other_clients_and_the_simulator_served(
    ros_client: Any, planner: Any, arm: Any, listen: Callable[..., Any]
) -> None:
    joints = listen(JointState, "/throwing_arm/joint_states")
    flood = burst_client(ros_client, ThrowCompute, "/throw_planner/throw")
    small = burst_client(ros_client, GraspRadii, "/throw_planner/grasp_radii")
    # A flood of limit sets (each ~0.1-0.5 s of work) on one service...
    heavy = LimitSetCompute.Request(part=part(), goal_edge=1, starts_per_edge=3, throws=30, **DESIGN)
    heavy_service = burst_client(ros_client, LimitSetCompute, "/throw_planner/limit_set")
    futures = [heavy_service.call_async(heavy) for _ in range(20)]
    # ...and 200 throws on another; meanwhile a small request and the arm's stream are measured.
    mark, start = joints.count(), time.monotonic()
    throws = [throw(0.10 + 0.0001 * i) for i in range(BURST)]
    flood_futures = [flood.call_async(r) for r in throws]
    answer, waited = timed_call(small, grasp(), timeout=30.0)
    assert answer is not None and answer.ok, "the small request got no answer during the flood"
    assert waited < SMALL_BOUND, f"the small request waited {waited:.2f} s during the flood"
    deadline = time.monotonic() + 60.0
    while time.monotonic() < deadline and not all(f.done() for f in flood_futures + futures):
        time.sleep(0.05)
    elapsed = time.monotonic() - start
    assert all(f.done() for f in flood_futures), "a flooded request was lost"
    assert all(f.result().ok for f in flood_futures)
    assert all(f.done() and f.result().ok for f in futures), "a limit-set request was lost or refused"
    rate = (joints.count() - mark) / elapsed
    # The arm is another process: a flood of its neighbour must not silence it (2 cores, shared).
    assert rate > 0.5 * ARM_RATE, f"arm published {rate:.1f} Hz of {ARM_RATE:g} during the flood"


def test_hostile_requests_are_refused_by_name_with_flat_memory(ros_client: Any, planner: Any) -> None:
    huge = [0.1] * 100_000
    cases: list[tuple[Any, str, Any, str]] = [
        (ThrowCompute, "throw", throw(math.nan), "radius"),
        (ThrowCompute, "throw", throw(1e308), "radius"),
        (
            ThrowCompute,
            "throw",
            ThrowCompute.Request(part=part(), edge=1, radius=0.12, **{**DESIGN, "release_speed": 1e308}),
            "release_speed",
        ),
        (
            ThrowCompute,
            "throw",
            ThrowCompute.Request(part=part(), edge=1, radius=0.12, **{**DESIGN, "gravity": -1e308}),
            "gravity",
        ),
        (GraspRadii, "grasp_radii", GraspRadii.Request(part=part(), offset=math.inf, mu=0.5), "offset"),
        (
            LimitSetCompute,
            "limit_set",
            LimitSetCompute.Request(part=part(), throws=4294967295, **DESIGN),
            "throws",
        ),
        (
            LimitSetCompute,
            "limit_set",
            LimitSetCompute.Request(part=part(), starts_per_edge=4294967295, **DESIGN),
            "starts_per_edge",
        ),
        (LimitSetCompute, "limit_set", LimitSetCompute.Request(part=part(), throws=1, **DESIGN), "throws"),
        (
            LimitSetCompute,
            "limit_set",
            LimitSetCompute.Request(part=part(), offset=1e308, release_speed=1.0, gravity=-9.8, mu=0.5),
            "offset",
        ),
        (
            SensorTriggerRadii,
            "trigger_radii",
            SensorTriggerRadii.Request(part=part(), goal_edge=1, sensing_height=1e308, **DESIGN),
            "sensing_height",
        ),
        (
            DesignSearch,
            "design_search",
            DesignSearch.Request(part=part(), goal_edge=1, offsets=huge, release_speeds=huge),
            "offsets",
        ),
        (
            DesignSearch,
            "design_search",
            DesignSearch.Request(
                part=part(), goal_edge=1, offsets=[1e308], release_speeds=[1.0], gravity=-9.8, mu=0.5
            ),
            "offsets[0]",
        ),
    ]
    big_part = part()
    big_part.outer.x, big_part.outer.y = huge, huge
    cases.append(
        (GraspRadii, "grasp_radii", GraspRadii.Request(part=big_part, offset=-0.005, mu=0.5), "part.outer")
    )
    named = part()
    named.name = "n" * 10_000_000
    cases.append(
        (ThrowCompute, "throw", ThrowCompute.Request(part=named, edge=1, radius=0.12, **DESIGN), "part.name")
    )
    # Round 1 warms up: every client discovered, every path run, and DDS's payload pools grown to a
    # burst of the largest request (they are kept for reuse). Flat memory: round 2 adds nothing more.
    for srv_type, name, request, _ in cases:
        burst(burst_client(ros_client, srv_type, f"/throw_planner/{name}"), [request] * 10, timeout=30.0)
    before = rss_mb(planner.pid)
    for srv_type, name, request, field in cases:
        start = time.monotonic()
        answers = burst(burst_client(ros_client, srv_type, f"/throw_planner/{name}"), [request] * 10, 30.0)
        assert all(a is not None for a in answers), f"{name}/{field}: a hostile request got no answer"
        assert time.monotonic() - start < 15.0, f"{name}/{field}: 10 refusals took too long"
        for answer in answers:
            assert not answer.ok and field in answer.error, f"{name}/{field}: {answer.error[:200]}"
            assert "internal error" not in answer.error and len(answer.error) <= 1000
    after = rss_mb(planner.pid)
    # a leak would add a round's ~110 MB of requests; allocator and DDS pools may settle by tens of MB
    assert after - before < 50.0, f"planner RSS grew {after - before:.0f} MB over a repeated hostile round"
    # and it still answers a good request
    answer = burst(burst_client(ros_client, ThrowCompute, "/throw_planner/throw"), [throw()], 30.0)[0]
    assert answer is not None and answer.ok
