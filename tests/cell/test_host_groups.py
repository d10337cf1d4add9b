"""Which process each scene node runs in: the cell host by default on the cell clock, or as the scene asks."""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import pytest

from feeder_cell.cli.launch import CLOCK_NODE, SIMULATION_NODE, host_groups
from feeder_cell.launcher import NodeSpec, joins_lockstep, load_scene, scene_from_mapping
from feeder_planner.errors import InputError

ROOT = Path(__file__).resolve().parents[2]


def _cell(**flags: object) -> tuple[list[NodeSpec], list[NodeSpec], argparse.Namespace]:
    scene = load_scene(ROOT / "feeder_cell" / "scenes" / "cell.yaml")
    specs = [CLOCK_NODE, SIMULATION_NODE, *scene.nodes]
    participants = [s for s in specs if joins_lockstep(s.package, s.executable)]
    args = {"one_process_per_node": False, "real_time_factor": 0.0, "host_controller": False, **flags}
    return specs, participants, argparse.Namespace(**args)


def _names(groups: dict[str, list[NodeSpec]]) -> dict[str, list[str]]:
    return {name: [s.executable for s in members] for name, members in groups.items()}


def test_on_the_cell_clock_the_clock_simulation_and_devices_share_the_cell_host() -> None:
    devices = ["cell_clock", "cell_simulation", "mems_field_array", "throwing_arm", "assembly_fixture"]
    assert _names(host_groups(*_cell())) == {"cell_host": devices}
    assert _names(host_groups(*_cell(host_controller=True))) == {"cell_host": [*devices, "cell_controller"]}
    assert host_groups(*_cell(one_process_per_node=True)) == {}
    assert host_groups(*_cell(real_time_factor=None)) == {}  # on wall time every node runs alone


def test_a_scene_node_asks_for_its_host_or_for_a_process_of_its_own() -> None:
    specs, participants, args = _cell()
    asked = [
        dataclasses.replace(s, host="planners" if "planner" in s.executable else "none")
        if s.package == "feeder_planner" or s.executable == "throwing_arm"
        else s
        for s in specs
    ]
    groups = _names(host_groups(asked, participants, args))
    assert groups["planners"] == ["field_equilibria_planner", "throw_planner", "stable_region_planner"]
    assert "throwing_arm" not in groups["cell_host"]


def test_a_node_no_host_can_take_is_refused_naming_it() -> None:
    specs, participants, args = _cell()
    second_arm = next(s for s in specs if s.executable == "throwing_arm")
    specs.append(dataclasses.replace(second_arm, namespace="/spare", host="cell_host"))
    with pytest.raises(InputError, match=r"node /spare/throwing_arm: host: .*cannot run in host cell_host"):
        host_groups(specs, participants, args)


def test_a_bad_host_name_in_a_scene_is_one_line_naming_the_field(tmp_path: Path) -> None:
    document = {"nodes": [{"package": "feeder_sim", "executable": "throwing_arm", "host": "9 lives"}]}
    with pytest.raises(InputError, match=r"nodes\[0\]\.host"):
        scene_from_mapping(document, tmp_path)
