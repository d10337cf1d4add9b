"""feeder launch: a scene starts only its nodes, records them, and ends every one by pid."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
FEEDER = [sys.executable, "-m", "feeder_cell.cli.main"]


@pytest.mark.ros
def test_scene_runs_its_nodes_records_them_and_ends_them(ros_domain: int, tmp_path: Path) -> None:
    bag = tmp_path / "scene-bag"
    result = subprocess.run(
        [
            *FEEDER,
            "launch",
            str(ROOT / "feeder_cell/scenes/mems_only.yaml"),
            "--duration",
            "4",
            "--record",
            str(bag),
            "--log-dir",
            str(tmp_path / "logs"),
            "--json",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    summary = json.loads(result.stdout)
    assert [n["executable"] for n in summary["nodes"]] == ["mems_field_array", "field_equilibria_planner"]
    for node in summary["nodes"]:
        assert not node["died_early"] and node["exit_code"] in (0, -2)
        with pytest.raises(ProcessLookupError):
            os.kill(node["pid"], 0)
    topics = summary["bag"]["topics"]
    assert topics["/mems/part_states"]["count"] > 0
    # Only the models the scene names run: nothing of the other devices is on the graph.
    assert not any(name.startswith(("/throwing_arm", "/assembly_fixture")) for name in topics)
    assert (bag / "metadata.yaml").is_file()


def test_bad_scene_file_names_the_field(tmp_path: Path) -> None:
    scene = tmp_path / "scene.yaml"
    scene.write_text("name: bad\nnodes:\n  - package: feeder_sim\n    parameters: {}\n")
    result = subprocess.run(
        [*FEEDER, "launch", str(scene), "--duration", "1"], capture_output=True, text=True, timeout=60
    )
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1
    assert "nodes[0].executable" in result.stderr and str(scene) in result.stderr
