"""The simulation node's rules, ROS-free: states, steps and scopes; entity filters; what a spawn accepts."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from feeder_cell.simulation import control, results
from feeder_cell.simulation.entities import CATEGORY_OBJECT, CATEGORY_ROBOT, Entity, Sphere, select
from feeder_cell.simulation.frames import Frames
from feeder_cell.simulation.posix import CLASSES, PosixError, compile_ere, translate
from feeder_cell.simulation.results import SimulationError
from feeder_cell.simulation.spawning import (
    arm_rest,
    check_at_rest,
    check_name,
    check_namespace,
    planar_pose,
    read_spawnable,
)
from feeder_cell.simulation.support import FEATURES, SUPPORT, custom_info
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


def test_reset_scopes_default_and_all_reset_everything_and_time_goes_back_with_state() -> None:
    assert control.reset_of_scope(control.SCOPE_STATE) == control.Reset(state=True, spawned=False)
    assert control.reset_of_scope(control.SCOPE_SPAWNED) == control.Reset(state=False, spawned=True)
    assert control.reset_of_scope(6) == control.Reset(state=True, spawned=True)
    everything = control.Reset(state=True, spawned=True, time=True)
    for scope in (0, 255, 7):  # DEFAULT ("same as ALL"), ALL, and TIME | STATE | SPAWNED
        assert control.reset_of_scope(scope) == everything
    assert control.reset_of_scope(3) == control.Reset(state=True, spawned=False, time=True)
    for scope in (1, 5):  # time without the devices' state, whose goals and grids are in cell time
        assert code_of(control.reset_of_scope, scope) == results.FEATURE_UNSUPPORTED
    assert code_of(control.reset_of_scope, 8) == results.FEATURE_UNSUPPORTED  # no such scope bit


def test_no_state_change_while_the_world_loads() -> None:
    for target in (control.PLAYING, control.PAUSED, control.STOPPED):
        assert code_of(control.transition, control.LOADING_WORLD, target) == results.INCORRECT_TRANSITION
    assert code_of(control.check_steps, 1, control.LOADING_WORLD) == results.OPERATION_FAILED


ENTITIES = [
    Entity("cell/mems_field_array", CATEGORY_ROBOT, "", "/cell/mems_field_array", "device"),
    Entity("cell/mems_field_array/plus", CATEGORY_OBJECT, "", "/cell/mems_field_array", "array_part", "plus"),
    Entity("cell/throwing_arm", CATEGORY_ROBOT, "", "/cell/throwing_arm", "device"),
    Entity("cell/throwing_arm/triangle", CATEGORY_OBJECT, "", "/cell/throwing_arm", "arm_part", "triangle"),
]


def test_entity_filters_regex_and_categories() -> None:
    names = [e.name for e in select(ENTITIES, "", [], [])]
    assert names == sorted(e.name for e in ENTITIES)
    assert [e.name for e in select(ENTITIES, "^cell/throwing_arm", [], [])] == [
        "cell/throwing_arm",
        "cell/throwing_arm/triangle",
    ]
    assert [e.name for e in select(ENTITIES, "(plus|triangle)$", [CATEGORY_ROBOT], [])] == []
    robots = select(ENTITIES, "", [CATEGORY_ROBOT], [])
    assert {e.kind for e in robots} == {"device"}
    assert code_of(select, ENTITIES, "([", [], []) == results.OPERATION_FAILED
    assert code_of(select, ENTITIES, "x" * 5000, [], []) == results.OPERATION_FAILED
    assert code_of(select, ENTITIES, "", [], ["red"]) == results.FEATURE_UNSUPPORTED


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
    check_at_rest("array_part", (0.0,) * 3, (0.0,) * 3, (1.0,) * 6)  # acceleration ignored
    for kind in ("array_part", "arm_part", "fixture_body", "device"):
        code = code_of(check_at_rest, kind, (0.1, 0.0, 0.0), (0.0,) * 3, (0.0,) * 6)
        assert code == results.OPERATION_FAILED
    with pytest.raises(SimulationError, match="velocity state"):
        check_at_rest("array_part", (0.0,) * 3, (0.0, 0.0, 1.0), (0.0,) * 6)
    assert code_of(check_at_rest, "arm_part", (0.0,) * 3, (0.0,) * 3, (math.inf,) * 6) == 4


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


def test_spawn_names_namespaces_and_formats_the_standard_defines() -> None:
    unnamed = read_spawnable("", "vertices: [[0, 0], [0.001, 0], [0.001, 0.001], [0, 0.001]]\n")
    assert not unnamed.named  # the world asks for NAME_INVALID when allow_renaming is false
    assert read_spawnable(str(TRIANGLE), "").named
    for ok in ("", "/", "/harness_robot_1", "robots/r1", "/_a/b2"):
        assert check_namespace(ok) == ok
    for bad in ("//a", "/a/", "1robot", "/a b", "/a/2b", "a-b"):
        assert code_of(check_namespace, bad) == results.NAMESPACE_INVALID
    sdf = '<?xml version="1.0"?>\n<sdf version="1.9"><model name="box"/></sdf>\n'
    for text in (sdf, '<robot name="r"/>', "  <mujoco/>", "#usda 1.0\n"):
        assert code_of(read_spawnable, "", text) == results.UNSUPPORTED_FORMAT


# Every POSIX class against the characters it holds and the ASCII characters it does not (POSIX locale).
POSIX_CLASSES = {
    "alpha": str.isalpha,
    "digit": str.isdigit,
    "alnum": str.isalnum,
    "upper": str.isupper,
    "lower": str.islower,
    "space": lambda c: c in " \t\n\r\f\v",
    "blank": lambda c: c in " \t",
    "punct": lambda c: c.isprintable() and not c.isalnum() and c != " ",
    "print": str.isprintable,
    "graph": lambda c: c.isprintable() and c != " ",
    "cntrl": lambda c: ord(c) < 32 or ord(c) == 127,
    "xdigit": lambda c: c in "0123456789abcdefABCDEF",
}


@pytest.mark.parametrize("name", sorted(POSIX_CLASSES))
def test_each_posix_character_class_selects_exactly_its_ascii_characters(name: str) -> None:
    assert set(CLASSES) == set(POSIX_CLASSES)
    compiled = compile_ere(f"^[[:{name}:]]$")
    negated = compile_ere(f"^[^[:{name}:]]$")
    for code in range(128):
        c = chr(code)
        assert bool(compiled.search(c)) == POSIX_CLASSES[name](c), (name, code)
        assert bool(negated.search(c)) != POSIX_CLASSES[name](c), (name, code)


def test_posix_extended_brackets_and_what_is_not_posix() -> None:
    import warnings

    names = ["cell/mems_field_array", "cell/mems_field_array/plus", "x-y", "a]b", "back\\slash", "[t]"]

    def matches(pattern: str) -> list[str]:
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # Python's FutureWarning on nested sets would fail here
            return [n for n in names if compile_ere(pattern).search(n)]

    assert matches("^[[:alpha:]/_]+$") == ["cell/mems_field_array", "cell/mems_field_array/plus"]
    assert matches("[]]") == ["a]b", "[t]"]  # ']' first is literal
    assert matches("[^]a-z/_\\\\[-]") == []  # every name has only these (or none else)
    assert matches("[x-]y$") == ["x-y"] and matches("x[-]y") == ["x-y"]
    assert matches("[\\\\]") == ["back\\slash"]  # a backslash in brackets is itself
    assert matches("^[[][[:lower:]][]]$") == ["[t]"]
    assert matches("[[.-.]]") == ["x-y"] and matches("[[=a=]][]]b") == ["a]b"]
    assert matches("(plus|slash)$") == ["cell/mems_field_array/plus", "back\\slash"]
    assert matches("a{2}|r{2}") == ["cell/mems_field_array", "cell/mems_field_array/plus"]
    assert translate("a\\.b") == "a\\.b"
    for bad in ("\\d", "(?i)a", "[[:word:]]", "[z-a]", "[abc", "a\\", "[[:alpha:"):
        with pytest.raises(PosixError):
            compile_ere(bad)
    assert code_of(select, ENTITIES, "\\w+", [], []) == results.OPERATION_FAILED


def test_sphere_bounds_and_the_unsupported_bound_types() -> None:
    assert Sphere.of(0, []) is None
    sphere = Sphere.of(3, [(0.3, 0.0, 0.0), (0.1, 9.0, 9.0)])
    assert sphere is not None and sphere.holds((0.3, 0.1, 0.0)) and not sphere.holds((0.3, 0.1001, 0.0))
    assert code_of(Sphere.of, 1, [(0.0, 0.0, 0.0), (1.0, 1.0, 1.0)]) == results.FEATURE_UNSUPPORTED
    assert code_of(Sphere.of, 2, [(0.0, 0.0, 0.0)] * 3) == results.FEATURE_UNSUPPORTED
    for points in ([(0.0, 0.0, 0.0)], [(0.0, 0.0, 0.0), (-1.0, 0.0, 0.0)], [(math.nan, 0, 0), (1.0, 0, 0)]):
        assert code_of(Sphere.of, 3, points) == results.OPERATION_FAILED
    assert code_of(Sphere.of, 9, [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0)]) == results.OPERATION_FAILED


def test_world_is_the_root_frame_and_device_frames_compose_to_it() -> None:
    from feeder_cell.simulation.entities import EntityState
    from feeder_planner.node_kit.tf import quaternion_from_rpy

    # The devices scene: the arm's pivot 0.3 m along x, rolled a quarter turn; the array at the origin.
    roll = quaternion_from_rpy(math.pi / 2, 0.0, 0.0)
    frames = Frames(
        {
            "cell/arm_pivot": EntityState("cell", 0, (0.3, 0.0, 0.0), roll),
            "cell/mems_array": EntityState("cell", 0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0)),
        }
    )
    assert frames.root() == "cell" and all(frames.is_world(f) for f in ("", "world", "cell"))
    assert not frames.is_world("cell/arm_pivot")
    local = ((0.15, 0.02, 0.0), (0.0, 0.0, 0.0, 1.0))
    world = frames.to_world("cell/arm_pivot", local)
    assert world[0] == pytest.approx((0.45, 0.0, 0.02), abs=1e-15)  # the arm's y is the cell's z
    back = frames.from_world("cell/arm_pivot", world)
    assert back[0] == pytest.approx(local[0], abs=1e-15) and back[1] == pytest.approx(local[1], abs=1e-15)
    moving = EntityState("cell/arm_pivot", 5, (0.1, 0.0, 0.0), linear=(0.0, 1.0, 0.0))
    moving.angular = (0.0, 0.0, 2.0)
    seen = frames.state_in_world(moving)
    assert seen.frame_id == "world" and seen.stamp_ns == 5
    assert seen.linear == pytest.approx((0.0, 0.0, 1.0), abs=1e-15)
    assert seen.angular == pytest.approx((0.0, -2.0, 0.0), abs=1e-15)
    assert code_of(frames.in_world, "cell/nowhere") == results.OPERATION_FAILED
    cyclic = Frames({"a": EntityState("b", 0), "b": EntityState("a", 0), "c": EntityState("root", 0)})
    assert code_of(cyclic.in_world, "a") == results.OPERATION_FAILED


def test_the_docs_feature_table_has_the_rows_of_the_features_service() -> None:
    import re

    from simulation_interfaces.msg import SimulatorFeatures

    names = [n for n in dir(SimulatorFeatures) if n.isupper() and n != "SLOT_TYPES"]
    standard = {n: getattr(SimulatorFeatures, n) for n in names}
    assert {row.name: row.value for row in SUPPORT} == standard  # every value of the standard, once
    text = (ROOT / "docs" / "cell.md").read_text()
    rows = re.findall(r"^\| `([A-Z_]+)` \| (\d+) \| (yes|no) \|", text, re.MULTILINE)
    assert [(n, int(v), s == "yes") for n, v, s in rows] == [(r.name, r.value, r.supported) for r in SUPPORT]
    info = custom_info(0.1)
    assert all(row.name in info for row in SUPPORT if not row.supported)
    assert set(FEATURES) == {row.value for row in SUPPORT if row.supported}
