"""Scene files are validated before any node starts (issue 16 item 4)."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from feeder_cell.launcher import load_scene
from feeder_planner.errors import InputError

ROOT = Path(__file__).resolve().parents[2]
PART = str(ROOT / "examples" / "throwing" / "triangle.yaml")
ARM = {"package": "feeder_sim", "executable": "throwing_arm", "parameters": {"part_file": PART}}


def scene_file(tmp_path: Path, **changes) -> Path:
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump({"name": "s", "nodes": [{**ARM, **changes}]}))
    return path


def with_parameters(**changes) -> dict:
    return {"parameters": {**ARM["parameters"], **changes}}


@pytest.mark.parametrize(
    ("changes", "field", "words"),
    [
        ({"name": "my arm"}, "nodes[0].name", "not a valid ROS node name"),
        ({"name": "1arm"}, "nodes[0].name", "not starting with a digit"),
        ({"namespace": "/cell/1x"}, "nodes[0].namespace", "not a valid ROS namespace"),
        ({"namespace": "/a//b"}, "nodes[0].namespace", "not a valid ROS namespace"),
        ({"package": [1]}, "nodes[0].package", "a string"),
        ({"executable": "../bin/sh"}, "nodes[0].executable", "not an executable name"),
        ({"parameters": {}}, "nodes[0].parameters.part_file", "is required"),
        (with_parameters(gravity=-9), "nodes[0].parameters.gravity", "declared double, got integer"),
        (with_parameters(gravity=9.66), "nodes[0].parameters.gravity", "< 0"),
        (with_parameters(offset={"value": 1.0}), "nodes[0].parameters.offset", "got a mapping"),
        (with_parameters(offset=None), "nodes[0].parameters.offset", "got NoneType"),
        (with_parameters(part_files=[1, "a"]), "nodes[0].parameters.part_files", "mixed"),
        (with_parameters(part_files=[]), "nodes[0].parameters.part_files", "empty list"),
        (with_parameters(seed=2**70), "nodes[0].parameters.seed", "64-bit"),
        (with_parameters(**{"bad name": 1}), "nodes[0].parameters", "not a valid parameter name"),
        (with_parameters(part_file=["a"]), "nodes[0].parameters.part_file", "declared a single value"),
    ],
)
def test_a_bad_scene_is_one_error_naming_the_file_node_and_field(
    tmp_path: Path, changes: dict, field: str, words: str
) -> None:
    path = scene_file(tmp_path, **changes)
    with pytest.raises(InputError) as caught:
        load_scene(path)
    error = caught.value
    assert error.source == str(path) and error.field == field and words in error.problem, str(error)
    assert "\n" not in str(error)


def test_the_shipped_scenes_pass() -> None:
    for path in sorted((ROOT / "feeder_cell" / "scenes").glob("*.yaml")):
        assert load_scene(path).nodes


def test_feeder_launch_starts_nothing_for_a_bad_scene(tmp_path: Path, capsys) -> None:
    from feeder_cell.cli.main import main

    path = scene_file(tmp_path, **with_parameters(gravity=-9))
    logs = tmp_path / "logs"
    assert main(["launch", str(path), "--log-dir", str(logs)]) == 2
    assert capsys.readouterr().err.splitlines() == [
        f"feeder launch: {path}: nodes[0].parameters.gravity: is declared double, got integer -9 (write -9.0)"
    ]
    assert not logs.exists()  # no node was started: the launcher creates the log folder first


def test_an_output_directory_under_a_file_is_refused_before_any_work(tmp_path: Path, capsys) -> None:
    from feeder_cell.cli.common import output_directory
    from feeder_cell.cli.main import main

    blocker = tmp_path / "not_a_dir"
    blocker.write_text("x")
    with pytest.raises(InputError, match=r"--record: cannot create .*: .*not_a_dir is not a directory"):
        output_directory(blocker / "bags" / "run1", "--record", must_be_new=True)
    with pytest.raises(InputError, match="already exists"):
        output_directory(tmp_path, "output", must_be_new=True)
    assert output_directory(tmp_path / "new" / "run", "output") == tmp_path / "new" / "run"
    scene = tmp_path / "scene.yaml"
    scene.write_text(yaml.safe_dump({"name": "s", "nodes": [ARM]}))
    assert (
        main(["launch", str(scene), "--record", str(blocker / "bag"), "--log-dir", str(tmp_path / "l")]) == 2
    )
    assert capsys.readouterr().err.count("\n") == 1
    assert not (tmp_path / "l").exists()
