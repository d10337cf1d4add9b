"""ROS-free: parts spawned onto and removed from the MEMS array at runtime (feeder_sim.mems.spawning).

At every fidelity: a part spawned before the first step gives the run of a scene configured with it, and
a part spawned or removed later leaves the others' motion as it was (the quasi-static models: each part
moves alone; the dynamic one: the new body collides, a removed one is gone). Names, refusals naming the
field, the cap, and ``~/place_parts`` reset (the array as configured) are checked here too.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from feeder_device.declarations import DeviceError
from feeder_planner.errors import InputError
from feeder_planner.fields_io import load_yaml_mapping
from feeder_planner.mems import CombinedField, ConstantField, ProgramStep
from feeder_planner.parts import load_part
from feeder_sim.mems import FIDELITIES, Body, Scene
from feeder_sim.mems.drawing import ArrayDrawing
from feeder_sim.mems.placing import placement_reach
from feeder_sim.mems.spawning import MAX_PARTS, ArrayParts

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "mems"
SQUARE, PLUS = EXAMPLES / "square.yaml", EXAMPLES / "plus.yaml"
COMBINED = (ProgramStep(CombinedField(0.2), math.inf),)
DOWN = (ProgramStep(ConstantField((0.0, -1.0)), math.inf),)
REACH = placement_reach((100, 100), 1e-4)
DT = 5e-4
A_POSE, B_POSE = (1.5e-3, 0.0, 0.0), (-1.5e-3, 0.2e-3, 0.3)


def array_of(
    paths: list[Path],
    poses: list[tuple[float, float, float]],
    fidelity: str,
    program: tuple[ProgramStep, ...] = COMBINED,
    names: list[str] | None = None,
) -> tuple[Scene, ArrayParts]:
    """A scene of the parts at their poses, as configure builds it, and its parts."""
    initial = np.array(poses, float).reshape(-1, 3)
    scene = Scene(
        [Body(load_part(p), pose.copy()) for p, pose in zip(paths, initial, strict=True)],
        program,
        fidelity,
        array=(100, 100, 1e-4),
    )
    documents = [load_yaml_mapping(p) for p in paths]
    names = names or [d["name"] for d in documents]
    return scene, ArrayParts(scene, names, documents, initial, [str(p) for p in paths])


def poses(scene: Scene) -> list[np.ndarray]:
    return [b.pose.copy() for b in scene.bodies]


@pytest.mark.parametrize("fidelity", FIDELITIES)
def test_a_part_spawned_before_the_first_step_runs_as_if_configured(fidelity: str) -> None:
    configured, _ = array_of([SQUARE, PLUS], [A_POSE, B_POSE], fidelity)
    spawned, parts = array_of([SQUARE], [A_POSE], fidelity)
    entry = parts.spawn("", PLUS.read_text(), str(PLUS), B_POSE, REACH)
    assert entry.name == "plus" and parts.names == ["square", "plus"] and entry.spawned
    configured.run(0.1, DT)
    spawned.run(0.1, DT)
    for want, got in zip(poses(configured), poses(spawned), strict=True):
        np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("fidelity", ["ideal", "array"])
def test_quasi_static_parts_move_alone_whatever_is_spawned_or_removed(fidelity: str) -> None:
    scene, parts = array_of([SQUARE], [A_POSE], fidelity)
    alone, _ = array_of([SQUARE], [A_POSE], fidelity)
    scene.run(0.05, DT)
    alone.run(0.05, DT)
    parts.spawn("p", PLUS.read_text(), "", B_POSE, REACH)
    assert np.array_equal(scene.bodies[1].pose, B_POSE) and not scene.bodies[1].velocity.any()  # at rest
    plus, _ = array_of([PLUS], [B_POSE], fidelity)  # the spawned part alone, from the spawn on
    scene.run(0.05, DT)
    alone.run(0.05, DT)
    plus.run(0.05, DT)
    np.testing.assert_array_equal(scene.bodies[0].pose, alone.bodies[0].pose)
    np.testing.assert_array_equal(scene.bodies[1].pose, plus.bodies[0].pose)
    assert not np.array_equal(scene.bodies[1].pose, B_POSE)  # it moved with the field
    parts.remove("square")
    assert parts.names == ["p"] and len(scene.bodies) == 1
    scene.run(0.05, DT)
    plus.run(0.05, DT)
    np.testing.assert_array_equal(scene.bodies[0].pose, plus.bodies[0].pose)


def test_the_dynamic_world_takes_spawned_bodies_into_its_collisions_and_lets_removed_ones_go() -> None:
    # The radial field pulls every square to the origin: without collisions they would all end there.
    radial = (ProgramStep(CombinedField(0.0), math.inf),)
    scene, parts = array_of([SQUARE], [(-3e-3, 0.0, 0.0)], "dynamic", radial)
    scene.set_damping(300.0)
    world = scene._dynamic
    assert world is not None
    parts.spawn("b", SQUARE.read_text(), "", (3e-3, 0.0, 0.0), REACH)  # two parts: the space is built
    assert world.space is not None and len(world.handles) == 2
    scene.run(0.2, 1e-4)
    parts.spawn("c", SQUARE.read_text(), "", (0.0, 5e-3, 0.0), REACH)  # into the space there is
    assert len(world.handles) == 3
    scene.run(0.2, 1e-4)
    centres = [b.pose[:2] for b in scene.bodies]
    gaps = [math.dist(centres[i], centres[j]) for i, j in ((0, 1), (0, 2), (1, 2))]
    assert min(gaps) >= 1.5e-3, gaps  # 2 mm squares: side by side, not on top of each other
    parts.remove("c")
    assert len(world.handles) == 2 and world.space is not None
    parts.remove("square")
    assert world.space is None and world.handles == []  # one part: integrated directly again
    before = math.hypot(*scene.bodies[0].pose[:2])
    scene.run(0.2, 1e-4)
    assert math.hypot(*scene.bodies[0].pose[:2]) < before - 0.5e-3  # nothing in its way: on to the origin


def test_a_placement_moves_a_body_of_the_dynamic_world() -> None:
    scene, parts = array_of([SQUARE, PLUS], [A_POSE, B_POSE], "dynamic")
    scene.run(0.02, DT)
    scene.place_body(0, np.array([2e-3, 2e-3, 0.0]))
    scene.step(DT)
    assert np.linalg.norm(scene.bodies[0].pose[:2] - [2e-3, 2e-3]) < 1e-5  # not back where it was
    assert parts.reset() is False
    np.testing.assert_array_equal(scene.bodies[0].pose, A_POSE)
    scene.step(DT)
    assert np.linalg.norm(scene.bodies[0].pose[:2] - A_POSE[:2]) < 1e-5


@pytest.mark.parametrize("fidelity", FIDELITIES)
def test_reset_gives_the_array_as_configured(fidelity: str) -> None:
    scene, parts = array_of([SQUARE, PLUS], [A_POSE, B_POSE], fidelity)
    configured_bodies = list(scene.bodies)
    scene.run(0.02, DT)
    parts.spawn("extra", SQUARE.read_text(), "", (0.0, 3e-3, 0.0), REACH)
    parts.remove("square")
    scene.run(0.02, DT)
    assert parts.names == ["plus", "extra"]
    assert parts.reset() is True
    assert parts.names == ["square", "plus"] and parts.as_configured()
    assert scene.bodies == configured_bodies
    for body, pose in zip(scene.bodies, (A_POSE, B_POSE), strict=True):
        np.testing.assert_array_equal(body.pose, pose)
        assert not body.velocity.any()
    again, _ = array_of([SQUARE, PLUS], [A_POSE, B_POSE], fidelity)
    scene.run(0.05, DT)
    again.run(0.05, DT)
    for want, got in zip(poses(again), poses(scene), strict=True):
        np.testing.assert_allclose(got, want, atol=1e-12)


def test_names_given_derived_from_the_document_or_part_i() -> None:
    scene, parts = array_of([SQUARE], [A_POSE], "ideal")
    nameless = "vertices: [[0, 0], [1, 0], [1, 1]]\nlength_unit: mm\n"
    assert parts.spawn("", nameless, "", (0, 0, 0), REACH).name == "part1"
    parts.spawn("part2", nameless, "", (0, 0, 0), REACH)
    assert parts.spawn("", nameless, "", (0, 0, 0), REACH).name == "part3"
    parts.remove("part1")
    assert parts.spawn("", nameless, "", (0, 0, 0), REACH).name == "part4"  # 4 parts: part3 is taken
    assert parts.spawn("ünïcode name", nameless, "", (0, 0, 0), REACH).name == "ünïcode name"
    described = parts.documents()
    assert [d["name"] for d in described] == parts.names and described[0]["vertices"][0] == [-1, -1]


@pytest.mark.parametrize(
    "change,named",
    [
        ({"name": "square"}, "name: a part named 'square' is on the array already (parts: 'square')"),
        (
            {"name": "", "text": SQUARE.read_text()},
            "name: a part named 'square' is on the array already (the",
        ),
        ({"name": " padded"}, "name: expected a part name"),
        ({"name": "tab\there"}, "name: expected a part name"),
        ({"name": "x" * 300}, "name: expected a part name"),
        ({"source": "two\nlines"}, "source"),
        ({"text": "vertices: ["}, "part_yaml: not valid YAML"),
        ({"text": "[1, 2]"}, "part_yaml: expected a mapping"),
        (
            {"text": "name: p\nvertices: [[0, 0], [1, 0], [1, 1]]\nlength_unit: furlong"},
            "part_yaml.length_unit",
        ),
        ({"text": "vertices: [[0, 0], [1, 0], [0, 1], [1, 1]]\nlength_unit: mm"}, "part_yaml.vertices"),
        ({"source": "bin/3", "text": "vertices: [[0, 0]]"}, "bin/3: part_yaml.vertices"),
        ({"pose": (math.nan, 0.0, 0.0)}, "x: must be finite"),
        ({"pose": (0.0, math.inf, 0.0)}, "y: must be finite"),
        ({"pose": (0.0, 0.2, 0.0)}, "y: must be within +-0.1 m (the array's extent)"),
        ({"pose": (0.0, 0.0, 1e7)}, "theta: must be within"),
    ],
)
def test_a_refused_spawn_names_the_field_and_changes_nothing(change: dict, named: str) -> None:
    scene, parts = array_of([SQUARE], [A_POSE], "dynamic")
    request = {"name": "new", "text": PLUS.read_text(), "source": "", "pose": B_POSE, **change}
    with pytest.raises(InputError) as raised:
        parts.spawn(request["name"], request["text"], request["source"], request["pose"], REACH)
    assert str(raised.value).startswith(named), str(raised.value)
    assert "\n" not in str(raised.value)
    assert parts.names == ["square"] and len(scene.bodies) == 1


def test_the_array_holds_at_most_max_parts_and_an_unknown_removal_lists_the_names() -> None:
    scene, parts = array_of([SQUARE], [A_POSE], "ideal")
    for index in range(MAX_PARTS - 1):
        parts.spawn(f"s{index}", SQUARE.read_text(), "", (0.0, 0.0, 0.0), REACH)
    with pytest.raises(DeviceError, match=f"the array holds {MAX_PARTS} parts"):
        parts.spawn("one more", SQUARE.read_text(), "", (0.0, 0.0, 0.0), REACH)
    assert len(scene.bodies) == MAX_PARTS
    with pytest.raises(
        InputError, match=r"^name: no part named 'nope' on the array \(parts: 'square', 's0', "
    ):
        parts.remove("nope")
    assert len(scene.bodies) == MAX_PARTS


def test_the_drawing_follows_the_parts() -> None:
    scene, parts = array_of([SQUARE], [A_POSE], "ideal")
    drawing, layout = ArrayDrawing(), (10, 10, 1e-3, 0)
    forces = np.zeros((10, 10, 2))
    _, one = drawing.shapes(scene, forces, layout)
    parts.spawn("p", PLUS.read_text(), "", B_POSE, REACH)
    _, two = drawing.shapes(scene, forces, layout)
    parts.remove("square")
    _, left = drawing.shapes(scene, forces, layout)
    assert len(two) > len(one) and 0 < len(left) < len(two)
