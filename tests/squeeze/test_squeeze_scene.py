"""The squeeze station's scene: validated against the gripper's declarations, bad values named."""

from __future__ import annotations

from pathlib import Path

import pytest

from feeder_cell.launcher import load_scene, scene_copy
from feeder_planner.errors import FeederError

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "feeder_cell" / "scenes" / "cell_squeeze.yaml"


def test_the_scene_names_the_gripper_and_its_planner() -> None:
    scene = load_scene(SCENE)
    executables = [n.executable for n in scene.nodes]
    # The gripper first (the refusals below name nodes[0]), its planner, the cell the controller drives.
    assert executables[:2] == ["squeeze_gripper", "squeeze_planner"]
    assert "cell_controller" in executables and "mems_field_array" not in executables


@pytest.mark.parametrize(
    ("parameters", "named"),
    [
        ({"friction": 5.0}, "nodes[0].parameters.friction: must be a finite number in [0, 2]"),
        ({"fidelity": "paper"}, "nodes[0].parameters.fidelity: must be one of ideal, dynamic"),
        ({"jaw_speed": 0.0}, "nodes[0].parameters.jaw_speed"),
    ],
)
def test_a_bad_gripper_parameter_is_refused_naming_it(tmp_path: Path, parameters: dict, named: str) -> None:
    copy = scene_copy(SCENE, tmp_path, {"squeeze_gripper": parameters})
    with pytest.raises(FeederError) as refused:
        load_scene(copy)
    assert named in str(refused.value)
