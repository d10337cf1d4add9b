"""The simulation node's rules, ROS-free: states, steps and scopes; entity filters; what a spawn accepts."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from feeder_cell.simulation import control, results
from feeder_cell.simulation.entities import CATEGORY_OBJECT, CATEGORY_ROBOT, Entity, select
from feeder_cell.simulation.results import SimulationError
from feeder_cell.simulation.spawning import arm_rest, check_at_rest, check_name, planar_pose, read_spawnable
from feeder_planner.parts import load_part
from feeder_planner.throwing.flight import rest_pose
from feeder_planner.throwing.geometry import arm_part

ROOT = Path(__file__).resolve().parents[2]
TRIANGLE = ROOT / "examples" / "throwing" / "triangle.yaml"


def code_of(call: object, *args: object) -> int:
    with pytest.raises(SimulationError) as caught:
        call(*args)  # type: ignore[operator]
    assert caught.value.message  # every refusal says why
    return caught.value.code


def test_the_standards_state_transitions_and_their_result_codes() -> None:
    P, Q, S = control.PLAYING, control.PAUSED, control.STOPPED
    assert control.transition(P, Q) == ["pause"]
    assert control.transition(Q, P) == ["resume"]
    assert control.transition(P, S) == ["pause", "stop"]
    assert control.transition(S, P) == ["start", "resume"]
    assert control.transition(S, Q) == ["start"]
    for state in (P, Q, S):
        assert code_of(control.transition, state, state) == results.ALREADY_IN_TARGET_STATE
    assert code_of(control.transition, P, 3) == results.FEATURE_UNSUPPORTED  # QUITTING
    assert code_of(control.transition, P, 4) == results.INCORRECT_TRANSITION  # NO_WORLD
    assert code_of(control.transition, P, 77) == results.INCORRECT_TRANSITION


def test_steps_only_while_paused_and_within_bounds() -> None:
    assert control.check_steps(5, control.PAUSED) == 5
    assert code_of(control.check_steps, 5, control.PLAYING) == results.OPERATION_FAILED
    assert code_of(control.check_steps, 0, control.PAUSED) == results.OPERATION_FAILED
    assert code_of(control.check_steps, 2**64 - 1, control.PAUSED) == results.OPERATION_FAILED
    assert control.check_steps(control.MAX_STEPS, control.PAUSED) == control.MAX_STEPS


def test_reset_scopes_state_and_spawned_and_never_time() -> None:
    assert control.reset_of_scope(control.SCOPE_STATE) == control.Reset(state=True, spawned=False)
    assert control.reset_of_scope(control.SCOPE_SPAWNED) == control.Reset(state=False, spawned=True)
    assert control.reset_of_scope(6) == control.Reset(state=True, spawned=True)
    for scope in (0, 1, 3, 255):  # DEFAULT and ALL include time
        assert code_of(control.reset_of_scope, scope) == results.FEATURE_UNSUPPORTED
    assert code_of(control.reset_of_scope, 8) == results.FEATURE_UNSUPPORTED  # no such scope bit


ENTITIES = [
    Entity("cell/mems_field_array", CATEGORY_ROBOT, "", "/cell/mems_field_array", "device"),
    Entity("cell/mems_field_array/plus", CATEGORY_OBJECT, "", "/cell/mems_field_array", "array_part", "plus"),
    Entity("cell/throwing_arm", CATEGORY_ROBOT, "", "/cell/throwing_arm", "device"),
    Entity("cell/throwing_arm/triangle", CATEGORY_OBJECT, "", "/cell/throwing_arm", "arm_part", "triangle"),
]


def test_entity_filters_regex_and_categories() -> None:
    names = [e.name for e in select(ENTITIES, "", [], [], False)]
    assert names == sorted(e.name for e in ENTITIES)
    assert [e.name for e in select(ENTITIES, "^cell/throwing_arm", [], [], False)] == [
        "cell/throwing_arm",
        "cell/throwing_arm/triangle",
    ]
    assert [e.name for e in select(ENTITIES, "(plus|triangle)$", [CATEGORY_ROBOT], [], False)] == []
    robots = select(ENTITIES, "", [CATEGORY_ROBOT], [], False)
    assert {e.kind for e in robots} == {"device"}
    assert code_of(select, ENTITIES, "([", [], [], False) == results.OPERATION_FAILED
    assert code_of(select, ENTITIES, "x" * 5000, [], [], False) == results.OPERATION_FAILED
    assert code_of(select, ENTITIES, "", [], ["red"], False) == results.FEATURE_UNSUPPORTED
    assert code_of(select, ENTITIES, "", [], [], True) == results.FEATURE_UNSUPPORTED


def test_spawnable_parts_from_files_and_strings_with_the_standards_codes(tmp_path: Path) -> None:
    spawnable = read_spawnable(str(TRIANGLE), "")
    assert spawnable.part.name and spawnable.source == str(TRIANGLE)
    assert read_spawnable(f"file://{TRIANGLE}", "ignored").text == TRIANGLE.read_text()
    inline = read_spawnable("", "name: sq\nvertices: [[0, 0], [0.001, 0], [0.001, 0.001], [0, 0.001]]\n")
    assert inline.part.name == "sq"
    assert code_of(read_spawnable, "", "") == results.NO_RESOURCE
    assert code_of(read_spawnable, str(tmp_path / "none.yaml"), "") == results.NOT_FOUND
    assert code_of(read_spawnable, "package://x/part.yaml", "") == results.UNSUPPORTED_FORMAT
    assert code_of(read_spawnable, str(tmp_path / "robot.urdf"), "") == results.UNSUPPORTED_FORMAT
    (tmp_path / "dir.yaml").mkdir()
    assert code_of(read_spawnable, str(tmp_path / "dir.yaml"), "") == results.RESOURCE_PARSE_ERROR
    bombs = "a: &a [x, x, x, x, x, x, x, x, x]\n" + "".join(
        f"{c}: &{c} [*{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}]\n"
        for p, c in zip("abcdefgh", "bcdefghi", strict=True)
    )
    assert code_of(read_spawnable, "", bombs) == results.RESOURCE_PARSE_ERROR
    with pytest.raises(SimulationError, match=r"vertices"):
        read_spawnable("", "name: bad\nvertices: [[0, 0], [1, 0]]\n")


def test_names_poses_and_rest() -> None:
    assert check_name("plus_2") == "plus_2"
    for bad in ("", "2plus", "a/b", "x" * 65, "a b"):
        assert code_of(check_name, bad) == results.NAME_INVALID
    half = math.sqrt(0.5)
    x, y, yaw = planar_pose((0.001, 0.002, 0.0), (0.0, 0.0, half, half), "pose", 109)
    assert (x, y) == (0.001, 0.002) and yaw == pytest.approx(math.pi / 2, abs=1e-12)
    assert code_of(planar_pose, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 2.0), "pose", 109) == 109  # not unit
    assert code_of(planar_pose, (math.nan, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0), "pose", 109) == 109
    assert code_of(planar_pose, (0.0, 0.0, 0.01), (0.0, 0.0, 0.0, 1.0), "pose", 109) == 109  # off the plane
    tilted = (math.sin(0.05), 0.0, 0.0, math.cos(0.05))
    assert code_of(planar_pose, (0.0, 0.0, 0.0), tilted, "pose", 109) == 109
    check_at_rest((0.0,) * 3, (0.0,) * 3, (0.0,) * 6)
    assert code_of(check_at_rest, (0.1, 0.0, 0.0), (0.0,) * 3, (0.0,) * 6) == results.OPERATION_FAILED


def test_an_arm_rest_pose_gives_back_its_edge_and_radius() -> None:
    part = arm_part(load_part(TRIANGLE))
    offset = -0.005
    for edge in part.stable_edges:
        x, y, theta = rest_pose(part, edge, 0.12, offset)
        assert arm_rest(float(x), float(y), float(theta), part.edge_angle, part.d, offset, "pose", 101) == (
            edge,
            pytest.approx(0.12),
        )
        wrong_height = float(y) + 1e-3
        assert code_of(
            arm_rest, float(x), wrong_height, float(theta), part.edge_angle, part.d, offset, "p", 101
        )
    assert code_of(arm_rest, 0.1, 0.0, 0.123, part.edge_angle, np.asarray(part.d), offset, "pose", 101) == 101
