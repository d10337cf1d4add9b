"""A harness written only against the ROS 2 simulation standard drives the cell (real processes, DDS).

It knows ``simulation_interfaces`` and the standard ROS types (``rosgraph_msgs/Clock`` for cell time),
no ``feeder_msgs`` type: what a harness written for another simulator would do. One launch of the devices
scene at ``max``, shared by the module's tests, in this order: features and state, steps, entities and
spawning, settling with SimulateSteps, setting the arm's part, hostile requests, reset, stop and play.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any, Iterator

import pytest
import ros_harness

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "feeder_cell" / "scenes" / "devices.yaml"
NS = "/cell_simulation"
QUANTUM_NS = 100_000_000  # the launch's --quantum 0.1
ARRAY, ARM = "cell/mems_field_array", "cell/throwing_arm"
SQUARE = "name: sq\nlength_unit: um\nvertices: [[0, 0], [400, 0], [400, 400], [0, 400]]\n"

pytestmark = pytest.mark.ros


class Harness:
    """Calls of the standard's services and action, from a test client node."""

    def __init__(self, node: Any) -> None:
        from rosgraph_msgs.msg import Clock

        self.node = node
        self.clock_ns = 0
        node.create_subscription(Clock, "/clock", self._on_clock, 10)

    def _on_clock(self, msg: Any) -> None:
        # The latest, not the largest: a reset of time (STOPPED too) sets the clock back.
        self.clock_ns = int(msg.clock.sec) * 1_000_000_000 + int(msg.clock.nanosec)

    def call(self, srv: Any, name: str, **fields: Any) -> Any:
        request = srv.Request(**fields)
        return ros_harness.call_service(self.node, srv, f"{NS}/{name}", request, timeout=60.0)

    def ok(self, srv: Any, name: str, **fields: Any) -> Any:
        response = self.call(srv, name, **fields)
        assert response.result.result == 1, (
            f"{name}: {response.result.result} {response.result.error_message}"
        )
        return response

    def code(self, srv: Any, name: str, **fields: Any) -> tuple[int, str]:
        response = self.call(srv, name, **fields)
        assert response.result.error_message or response.result.result == 1
        return int(response.result.result), str(response.result.error_message)

    def settled_clock(self, timeout: float = 10.0) -> int:
        """Cell time once /clock has stopped moving (the clock publishes where it holds)."""
        deadline = time.monotonic() + timeout
        last = -1
        while time.monotonic() < deadline:
            time.sleep(0.3)
            if self.clock_ns == last:
                return last
            last = self.clock_ns
        raise AssertionError("/clock kept moving while the simulation was paused")

    def state(self, entity: str) -> Any:
        from simulation_interfaces.srv import GetEntityState

        return self.ok(GetEntityState, "get_entity_state", entity=entity).state


@pytest.fixture(scope="module")
def harness(ros_domain: int, ros_client: Any, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Harness]:
    """The devices scene launched at max on the session's domain (ended by pid), and a harness on it."""
    logs = tmp_path_factory.mktemp("simulation_logs")
    process = subprocess.Popen(
        [sys.executable, "-m", "feeder_cell.cli.main", "launch", str(SCENE), "--real-time-factor", "max"]
        + ["--log-dir", str(logs)],
        env=dict(os.environ),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    harness = Harness(ros_client)
    try:
        from simulation_interfaces.srv import GetEntities

        deadline = time.monotonic() + 90
        while True:  # up when the devices are configured: the array's and the arm's parts listed
            assert process.poll() is None, f"launch ended: {process.communicate()[1][-2000:]}"
            names = list(harness.call(GetEntities, "get_entities").entities)
            if f"{ARRAY}/plus" in names and any(n.startswith(f"{ARM}/") for n in names):
                break
            assert time.monotonic() < deadline, f"entities after 90 s: {names}"
            time.sleep(0.5)
        from simulation_interfaces.msg import SimulationState
        from simulation_interfaces.srv import GetSimulationState

        while True:  # LOADING_WORLD until every lockstep participant has joined
            state = harness.call(GetSimulationState, "get_simulation_state").state.state
            if state != SimulationState.STATE_LOADING_WORLD:
                break
            assert time.monotonic() < deadline, "still LOADING_WORLD after 90 s"
            time.sleep(0.5)
        yield harness
    finally:
        ros_harness.end_launch(process)


def test_features_list_what_works_and_the_state_machine_answers_the_standards_codes(harness: Harness) -> None:
    from simulation_interfaces.msg import SimulationState, SimulatorFeatures
    from simulation_interfaces.srv import GetSimulationState, GetSimulatorFeatures, SetSimulationState

    features = harness.call(GetSimulatorFeatures, "get_simulator_features").features
    F = SimulatorFeatures
    assert set(features.features) == {
        F.SPAWNING, F.DELETING, F.ENTITY_CATEGORIES, F.SPAWNING_RESOURCE_STRING, F.ENTITY_STATE_GETTING,
        F.ENTITY_STATE_SETTING, F.ENTITY_INFO_GETTING, F.SPAWNABLES, F.SIMULATION_RESET,
        F.SIMULATION_RESET_TIME, F.SIMULATION_RESET_STATE, F.SIMULATION_RESET_SPAWNED,
        F.SIMULATION_STATE_GETTING, F.SIMULATION_STATE_SETTING, F.SIMULATION_STATE_PAUSE,
        F.STEP_SIMULATION_SINGLE, F.STEP_SIMULATION_MULTIPLE, F.STEP_SIMULATION_ACTION,
    }  # fmt: skip
    assert features.spawn_formats == ["feeder_part_yaml"]
    assert harness.ok(GetSimulationState, "get_simulation_state").state.state == SimulationState.STATE_PLAYING
    paused = SimulationState(state=SimulationState.STATE_PAUSED)
    harness.ok(SetSimulationState, "set_simulation_state", state=paused)
    code, _ = harness.code(SetSimulationState, "set_simulation_state", state=paused)
    assert code == SetSimulationState.Response.ALREADY_IN_TARGET_STATE
    assert harness.ok(GetSimulationState, "get_simulation_state").state.state == SimulationState.STATE_PAUSED


def test_a_step_advances_cell_time_by_exactly_one_quantum_each(harness: Harness) -> None:
    from simulation_interfaces.srv import StepSimulation

    before = harness.settled_clock()
    harness.ok(StepSimulation, "step_simulation", steps=1)
    harness.ok(StepSimulation, "step_simulation", steps=7)
    assert harness.settled_clock() - before == 8 * QUANTUM_NS


def test_spawn_onto_the_array_and_simulate_steps_until_the_part_has_settled(harness: Harness) -> None:
    from action_msgs.msg import GoalStatus
    from simulation_interfaces.action import SimulateSteps
    from simulation_interfaces.msg import EntityCategory, EntityFilters
    from simulation_interfaces.srv import (
        GetEntities,
        GetEntitiesStates,
        GetEntityInfo,
        GetSpawnables,
        SpawnEntity,
    )

    from feeder_planner.node_kit.action_client import ActionClient  # rclpy's, without ros2/rclpy#1123

    spawnables = harness.ok(GetSpawnables, "get_spawnables").spawnables
    assert any(s.uri.endswith("examples/mems/plus.yaml") for s in spawnables), [s.uri for s in spawnables]
    request = SpawnEntity.Request(
        name="square", resource_string=SQUARE, entity_namespace="/cell/mems_field_array"
    )
    request.initial_pose.pose.position.x, request.initial_pose.pose.position.y = 4e-4, -3e-4
    request.initial_pose.pose.orientation.z = math.sin(0.3)
    request.initial_pose.pose.orientation.w = math.cos(0.3)
    response = ros_harness.call_service(harness.node, SpawnEntity, f"{NS}/spawn_entity", request, 60.0)
    assert response.result.result == 1, response.result.error_message
    assert response.entity_name == f"{ARRAY}/square"
    again = ros_harness.call_service(harness.node, SpawnEntity, f"{NS}/spawn_entity", request, 60.0)
    assert again.result.result == SpawnEntity.Response.NAME_NOT_UNIQUE
    objects = EntityFilters(
        filter="^cell/mems", categories=[EntityCategory(category=EntityCategory.CATEGORY_OBJECT)]
    )
    listed = harness.ok(GetEntities, "get_entities", filters=objects).entities
    assert f"{ARRAY}/square" in listed and ARRAY not in listed
    # The fixture's assembly: its grounded bracket a static object, in the assembly frame that tilts.
    static = EntityFilters(categories=[EntityCategory(category=EntityCategory.CATEGORY_STATIC_OBJECT)])
    held = harness.ok(GetEntities, "get_entities", filters=static).entities
    assert held and all(name.startswith("cell/assembly_fixture/") for name in held), held
    assert harness.state(held[0]).header.frame_id == "cell/assembly"
    info = harness.ok(GetEntityInfo, "get_entity_info", entity=f"{ARRAY}/square").info
    assert info.category.category == EntityCategory.CATEGORY_OBJECT
    start = harness.state(f"{ARRAY}/square")
    assert start.pose.position.x == pytest.approx(4e-4)

    steps = ActionClient(harness.node, SimulateSteps, f"{NS}/simulate_steps")
    assert steps.wait_for_server(timeout_sec=30)
    published = ros_harness.ActionFeedback(harness.node, SimulateSteps, f"{NS}/simulate_steps")
    moved = settled = False
    for _ in range(40):  # 40 x 10 quanta: 40 s of cell time, the plus settles in about 15
        feedback: list[Any] = []
        mark = published.mark()
        goal = steps.send_goal_async(SimulateSteps.Goal(steps=10), feedback_callback=feedback.append)
        handle = _wait(goal)
        result = _wait(handle.get_result_async()).result
        assert result.result.result == 1, result.result.error_message
        sent = published.of(handle.goal_id, 10, mark)  # what the server published: every step's
        assert [f.completed_steps for f in sent] == list(range(1, 11))
        assert all(f.remaining_steps == 10 - f.completed_steps for f in sent)
        seen = [f.feedback.completed_steps for f in feedback]
        assert seen == list(range(1, len(seen) + 1)), seen  # in order; rclpy may drop the last (above)
        state = harness.state(f"{ARRAY}/square")
        moved |= abs(state.pose.position.x - 4e-4) > 1e-6
        # At rest to a harness: under 1 um/s and 0.1 mrad/s (the field's equilibrium is approached
        # exponentially, as the paper's quasi-static model has it).
        speed, spin = math.hypot(state.twist.linear.x, state.twist.linear.y), abs(state.twist.angular.z)
        if moved and speed < 1e-6 and spin < 1e-4:
            settled = True
            break
    assert moved and settled, f"the spawned square did not settle: {state}"
    # A long goal is canceled between two steps: CANCELED, with how far it got.
    feedback = []
    handle = _wait(
        steps.send_goal_async(SimulateSteps.Goal(steps=100_000), feedback_callback=feedback.append)
    )
    deadline = time.monotonic() + 30
    while not feedback and time.monotonic() < deadline:
        time.sleep(0.05)
    _wait(handle.cancel_goal_async())
    canceled = _wait(handle.get_result_async())
    assert canceled.status == GoalStatus.STATUS_CANCELED, canceled
    assert "canceled after" in canceled.result.result.error_message
    steps.destroy()
    # Every part of the array with its state in one call.
    array = harness.ok(GetEntitiesStates, "get_entities_states", filters=EntityFilters(filter=f"^{ARRAY}/"))
    assert len(array.entities) == len(array.states) >= 2
    assert all(s.header.frame_id == "world" for s in array.states)


def test_the_arms_part_is_placed_with_set_entity_state_at_a_rest_pose(harness: Harness) -> None:
    from simulation_interfaces.msg import EntityState
    from simulation_interfaces.srv import SetEntityState, SpawnEntity, StepSimulation

    arm_parts = [n for n in _entities(harness) if n.startswith(f"{ARM}/")]
    assert len(arm_parts) == 1
    now = harness.state(arm_parts[0])
    assert now.header.frame_id == "world"
    target = EntityState()
    target.header.frame_id = "world"
    target.pose = now.pose
    # The arm's pivot sits at x = 0.3 m in the world, rolled a quarter turn: the radius R is along x.
    target.pose.position.x = 0.3 + 0.15
    harness.ok(SetEntityState, "set_entity_state", entity=arm_parts[0], state=target)
    harness.ok(StepSimulation, "step_simulation", steps=1)
    assert harness.state(arm_parts[0]).pose.position.x == pytest.approx(0.45, abs=1e-12)
    # A spawn never removes another entity: the arm holds its one part and refuses a second.
    spawn = SpawnEntity.Request(name="second", uri=f"file://{ROOT}/examples/throwing/triangle.yaml")
    spawn.initial_pose.header.frame_id = "world"
    spawn.initial_pose.pose = harness.state(arm_parts[0]).pose
    response = ros_harness.call_service(harness.node, SpawnEntity, f"{NS}/spawn_entity", spawn, 60.0)
    assert response.result.result == 4 and "holds one part" in response.result.error_message
    assert [n for n in _entities(harness) if n.startswith(f"{ARM}/")] == arm_parts
    off_rest = EntityState()
    off_rest.pose = harness.state(arm_parts[0]).pose
    off_rest.pose.position.z += 0.01  # the arm's y: off the rest height h + d
    code, message = harness.code(SetEntityState, "set_entity_state", entity=arm_parts[0], state=off_rest)
    assert code == SetEntityState.Response.INVALID_POSE and "position.y" in message


def test_hostile_requests_answer_the_standards_codes_and_the_node_serves_on(harness: Harness) -> None:
    from simulation_interfaces.msg import EntityFilters, EntityState, TagsFilter
    from simulation_interfaces.srv import (
        DeleteEntity,
        GetEntities,
        GetEntityBounds,
        GetEntityState,
        GetSimulatorFeatures,
        SetEntityState,
        SpawnEntity,
        StepSimulation,
    )

    assert harness.code(GetEntityState, "get_entity_state", entity="cell/nothing")[0] == 2  # NOT_FOUND
    assert harness.code(GetEntities, "get_entities", filters=EntityFilters(filter="(["))[0] == 4
    tags = EntityFilters(tags=TagsFilter(tags=["red"]))
    assert harness.code(GetEntities, "get_entities", filters=tags)[0] == 0  # FEATURE_UNSUPPORTED
    assert harness.code(GetEntityBounds, "get_entity_bounds", entity=ARRAY)[0] == 0
    nan = EntityState()
    nan.pose.position.x = math.nan
    code, message = harness.code(SetEntityState, "set_entity_state", entity=f"{ARRAY}/plus", state=nan)
    assert code == SetEntityState.Response.INVALID_POSE and "position" in message
    assert harness.code(StepSimulation, "step_simulation", steps=2**63)[0] == 4  # OPERATION_FAILED
    for uri, expected in (("/nonexistent/part.yaml", 2), ("/dev/zero", 103), (str(ROOT / "README.md"), 103)):
        request = SpawnEntity.Request(name="x", uri=uri, entity_namespace="/cell/mems_field_array")
        response = ros_harness.call_service(harness.node, SpawnEntity, f"{NS}/spawn_entity", request)
        assert response.result.result == expected, (uri, response.result.error_message)
    hostile = SpawnEntity.Request(
        name="x", resource_string="a: [" * 10000, entity_namespace="/cell/mems_field_array"
    )
    response = ros_harness.call_service(harness.node, SpawnEntity, f"{NS}/spawn_entity", hostile)
    assert response.result.result == SpawnEntity.Response.RESOURCE_PARSE_ERROR
    assert harness.code(DeleteEntity, "delete_entity", entity=ARM)[0] == 4
    assert harness.call(GetSimulatorFeatures, "get_simulator_features").features.features  # still serving


def test_reset_state_and_spawned_is_deterministic_and_time_goes_back_only_with_state(
    harness: Harness,
) -> None:
    from simulation_interfaces.srv import DeleteEntity, ResetSimulation, SpawnEntity, StepSimulation

    time_only = ResetSimulation.Request.SCOPE_TIME
    code, message = harness.code(ResetSimulation, "reset_simulation", scope=time_only)
    assert code == 0 and "TIME" in message
    # SPAWNED alone removes what was spawned (the configured plus stays); DeleteEntity removes one part.
    for name in ("extra", "gone"):
        request = SpawnEntity.Request(
            name=name, resource_string=SQUARE, entity_namespace="/cell/mems_field_array"
        )
        request.initial_pose.pose.position.x = -5e-4
        response = ros_harness.call_service(harness.node, SpawnEntity, f"{NS}/spawn_entity", request, 60.0)
        assert response.result.result == 1, response.result.error_message
    harness.ok(DeleteEntity, "delete_entity", entity=f"{ARRAY}/gone")
    assert f"{ARRAY}/gone" not in _entities(harness)
    harness.ok(ResetSimulation, "reset_simulation", scope=ResetSimulation.Request.SCOPE_STATE)
    assert f"{ARRAY}/extra" in _entities(harness)  # STATE keeps spawned parts (spawned again)
    harness.ok(ResetSimulation, "reset_simulation", scope=ResetSimulation.Request.SCOPE_SPAWNED)
    assert f"{ARRAY}/extra" not in _entities(harness) and f"{ARRAY}/plus" in _entities(harness)
    runs = []
    arm_part = next(n for n in _entities(harness) if n.startswith(f"{ARM}/"))
    for _ in range(2):
        harness.ok(ResetSimulation, "reset_simulation", scope=6)  # STATE | SPAWNED
        assert f"{ARRAY}/square" not in _entities(harness)
        # Readable at once: the configured initial state. The plus starts within the array's placement
        # radius (1 mm, seed 7); the arm's part rests where it was configured, and a step (no autostart)
        # leaves it there to the last bit, so the state read before the step was the device's own.
        initial = harness.state(f"{ARRAY}/plus").pose.position
        assert math.hypot(initial.x, initial.y) <= 1e-3 and initial.z == 0.0
        resting = harness.state(arm_part).pose
        harness.ok(StepSimulation, "step_simulation", steps=1)
        ticked = harness.state(arm_part).pose
        assert (ticked.position.x, ticked.position.y, ticked.position.z) == pytest.approx(
            (resting.position.x, resting.position.y, resting.position.z), abs=1e-12
        )
        assert (ticked.orientation.x, ticked.orientation.w) == pytest.approx(
            (resting.orientation.x, resting.orientation.w), abs=1e-12
        )
        moved = harness.state(f"{ARRAY}/plus").pose.position
        assert (moved.x, moved.y) != (initial.x, initial.y)  # the field moved it (0.63 mm in x this quantum)
        harness.ok(StepSimulation, "step_simulation", steps=19)
        plus = harness.state(f"{ARRAY}/plus")
        runs.append(
            (plus.pose.position.x, plus.pose.position.y, plus.pose.orientation.z, plus.twist.linear.x)
        )
    assert runs[0] == runs[1]


def test_stop_holds_the_devices_and_play_runs_them_again(harness: Harness) -> None:
    from simulation_interfaces.msg import SimulationState
    from simulation_interfaces.srv import GetSimulationState, SetSimulationState, StepSimulation

    harness.ok(
        SetSimulationState, "set_simulation_state", state=SimulationState(state=SimulationState.STATE_STOPPED)
    )
    assert harness.ok(GetSimulationState, "get_simulation_state").state.state == SimulationState.STATE_STOPPED
    assert harness.code(StepSimulation, "step_simulation", steps=1)[0] == 4  # only while paused
    harness.ok(
        SetSimulationState, "set_simulation_state", state=SimulationState(state=SimulationState.STATE_PLAYING)
    )
    before = harness.clock_ns
    time.sleep(1.0)
    assert harness.clock_ns > before  # playing: the clock runs again
    assert harness.state(f"{ARRAY}/plus").header.stamp.sec > 0  # the array ticks again


def _entities(harness: Harness) -> list[str]:
    from simulation_interfaces.srv import GetEntities

    return list(harness.ok(GetEntities, "get_entities").entities)


def _wait(future: Any, timeout: float = 60.0) -> Any:
    done = threading.Event()
    future.add_done_callback(lambda _: done.set())
    assert done.wait(timeout), "no answer"
    return future.result()
