"""Over DDS: the planner's safe path keeps the fixture stable; the interlock refuses unstable commands."""

from __future__ import annotations

import math

import numpy as np
import pytest
import ros_harness

pytestmark = pytest.mark.ros

PLANNER = (
    "/stable_region_planner/stable_region",
    "/stable_region_planner/check_stability",
    "/stable_region_planner/safe_path",
)
FIXTURE_TOPICS = (
    "/assembly_fixture/joint_states",
    "/assembly_fixture/gravity",
    "/assembly_fixture/stability",
)


@pytest.fixture(scope="module")
def nodes(launch_module_node):
    launch_module_node(
        "feeder_planner",
        "stable_region_planner",
        wait_services=PLANNER,
        wait_topics=("/stable_region_planner/region",),
    )
    launch_module_node(
        "feeder_sim",
        "assembly_fixture",
        wait_topics=FIXTURE_TOPICS,
        wait_services=("/assembly_fixture/move",),
    )
    return True


def _v(x: float, y: float, z: float):
    from geometry_msgs.msg import Vector3

    return Vector3(x=float(x), y=float(y), z=float(z))


def _arr(v) -> np.ndarray:
    return np.array([v.x, v.y, v.z])


def _status(ros_client, prefix: str = "", count: int = 1):
    from feeder_msgs.msg import StabilityStatus

    return ros_harness.collect(
        ros_client, StabilityStatus, f"{prefix}/assembly_fixture/stability", count=count
    )


def _move(ros_client, waypoints, prefix: str = ""):
    from feeder_msgs.srv import FixtureMove

    return ros_harness.call_service(
        ros_client, FixtureMove, f"{prefix}/assembly_fixture/move", FixtureMove.Request(waypoints=waypoints)
    )


def _path_request(start, goal, **extra):
    from feeder_msgs.srv import StablePath

    return StablePath.Request(start=_v(*start), goal=_v(*goal), step=math.radians(1.0), **extra)


def test_latched_region_matches_the_mechanics(nodes, ros_client) -> None:
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    from feeder_msgs.msg import StabilityRegion
    from feeder_planner.assembly.default import DEFAULT_ASSEMBLY_YAML
    from feeder_planner.assembly.model import assembly_from_text
    from feeder_planner.assembly.planner import prepare

    qos = QoSProfile(
        depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
    )
    message = ros_harness.collect(
        ros_client, StabilityRegion, "/stable_region_planner/region", count=1, qos=qos
    )[0]
    local = prepare(assembly_from_text(DEFAULT_ASSEMBLY_YAML)).region
    assert message.kind == local.kind == "region"
    assert message.area_sr == pytest.approx(local.area_sr, rel=1e-12)
    assert np.allclose([_arr(v) for v in message.vertices], local.vertices)


def test_fixture_follows_the_planners_safe_path_and_stays_stable(nodes, ros_client) -> None:
    from feeder_msgs.srv import StablePath

    start = _arr(_status(ros_client)[0].gravity)
    goal = np.array([-1.0, 0.15, -0.4])
    goal /= np.linalg.norm(goal)
    plan = ros_harness.call_service(
        ros_client, StablePath, "/stable_region_planner/safe_path", _path_request(start, goal)
    )
    assert plan.ok, plan.error
    assert len(plan.path) > 10 and plan.min_margin > 0
    move = _move(ros_client, list(plan.path))
    assert move.ok, move.error
    assert move.first_unstable_sample == -1 and move.duration > 0.2
    statuses = _status(ros_client, count=int((move.duration + 0.6) * 20))
    assert any(s.moving for s in statuses)
    assert all(s.stable and s.margin > -1e-9 for s in statuses)
    assert all(len(s.forces) == 8 for s in statuses)
    final = _arr(_status(ros_client)[0].gravity)
    assert final == pytest.approx(goal, abs=1e-9)


def test_commanded_outside_the_region_the_interlock_refuses(nodes, ros_client) -> None:
    before = _arr(_status(ros_client)[0].gravity)
    outside = [_v(1.0, 0.0, -0.3)]
    response = _move(ros_client, outside)
    assert not response.ok
    assert "refused by the interlock" in response.error and "block" in response.error
    assert response.unbalanced_bodies == ["block"] and response.first_unstable_sample > 0
    later = _status(ros_client, count=5)
    assert all(np.allclose(_arr(s.gravity), before, atol=1e-12) and s.stable and not s.moving for s in later)


def test_bad_requests_name_the_field_and_the_nodes_keep_serving(nodes, ros_client) -> None:
    from feeder_msgs.srv import StabilityCheck, StableRegion

    check = ros_harness.call_service(
        ros_client,
        StabilityCheck,
        "/stable_region_planner/check_stability",
        StabilityCheck.Request(gravity=_v(math.nan, 0, -1)),
    )
    assert not check.ok and "gravity" in check.error and "finite" in check.error
    region = ros_harness.call_service(
        ros_client,
        StableRegion,
        "/stable_region_planner/stable_region",
        StableRegion.Request(override_mu=True, mu=-0.1),
    )
    assert not region.ok and "mu" in region.error
    overlapping = (
        "bodies:\n  - {name: g, grounded: true, boxes: [{min: [0,0,0], max: [2,2,1]}]}\n"
        "  - {name: b, boxes: [{min: [0,0,0.5], max: [1,1,2]}]}\n"
    )
    region = ros_harness.call_service(
        ros_client,
        StableRegion,
        "/stable_region_planner/stable_region",
        StableRegion.Request(assembly_yaml=overlapping),
    )
    assert (
        not region.ok and "'g'" in region.error and "'b'" in region.error and "interpenetrate" in region.error
    )
    no_ground = "bodies:\n  - {name: a, boxes: [{min: [0,0,0], max: [1,1,1]}]}\n"
    region = ros_harness.call_service(
        ros_client,
        StableRegion,
        "/stable_region_planner/stable_region",
        StableRegion.Request(assembly_yaml=no_ground),
    )
    assert not region.ok and "no grounded body" in region.error
    move = _move(ros_client, [_v(0, 0, 0)])
    assert not move.ok and "waypoints[0]" in move.error
    # Still serving: a good request right after.
    good = ros_harness.call_service(
        ros_client,
        StabilityCheck,
        "/stable_region_planner/check_stability",
        StabilityCheck.Request(gravity=_v(-1, 0, -1), override_mu=True, mu=0.4),
    )
    assert good.ok and good.stable and good.margin > 0
    assert _status(ros_client)[0].stable


def test_with_the_interlock_off_it_moves_and_reports_who_falls(nodes, launch_node, ros_client) -> None:
    launch_node(
        "feeder_sim",
        "assembly_fixture",
        {"interlock": False, "max_rate_x": 3.0, "max_rate_y": 3.0},
        wait_services=("/alt/assembly_fixture/move",),
        wait_topics=("/alt/assembly_fixture/stability",),
        namespace="/alt",
    )
    response = _move(ros_client, [_v(1.0, 0.0, -0.3)], prefix="/alt")
    assert response.ok and "interlock off" in response.warning and response.unbalanced_bodies == ["block"]
    statuses = _status(ros_client, prefix="/alt", count=int((response.duration + 0.5) * 20))
    fallen = [s for s in statuses if not s.stable]
    assert fallen and all(list(s.unbalanced_bodies) == ["block"] and s.margin < 0 for s in fallen)
