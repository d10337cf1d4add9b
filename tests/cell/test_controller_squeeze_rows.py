"""The controller's rows for the squeeze gripper as the orienting station (``orienter: squeeze``), no ROS.

A run_plan that completes every squeeze (DONE) ends ORIENT; a dropped part (FAULT 402) resets the gripper
and runs the plan again on a new part; a jaw stall (FAULT 401) stops the cell naming it; RECOVER resets
the gripper, not the MEMS array. The parameter naming the station is checked where a scene is.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from feeder_cell.controller import ORIENTERS, CellMachine, Outcome, Policy, State, policy_for, policy_table
from feeder_cell.controller.parameters import PARAMETERS
from feeder_cell.launcher import load_scene, scene_copy
from feeder_planner.errors import FeederError, InputError
from feeder_planner.parameter_specs import check_value

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "feeder_cell" / "scenes" / "cell_squeeze.yaml"
DONE = Outcome("DONE")
CYCLE = [DONE, DONE, Outcome("PRESENTED"), Outcome("REACHED"), Outcome("REACHED")]  # ORIENT ends DONE


def run(machine: CellMachine, outcomes: list[Outcome]) -> None:
    for i, outcome in enumerate(outcomes):
        machine.advance(outcome, float(i + 1))


def test_a_plan_done_ends_orient_and_cycles_finish_with_their_parts() -> None:
    machine = CellMachine(cycles=2, orienter="squeeze")
    run(machine, [DONE, *CYCLE * 2])
    assert machine.state is State.FINISHED
    targets = [t.target.value for t in machine.history]
    assert targets[:3] == ["ORIENT", "INFEED", "FEED"] and targets.count("ORIENT") == 2
    assert (machine.metrics.cycles_completed, machine.metrics.parts_presented) == (2, 2)


def test_a_dropped_part_resets_the_gripper_and_runs_the_plan_again() -> None:
    machine = CellMachine(cycles=1, orienter="squeeze")
    run(machine, [DONE])
    t = machine.advance(Outcome("FAULT", 402, "the part dropped from the jaws"), 2.0)
    assert (t.policy, t.target) == (Policy.RESET_RETRY, State.RECOVER)
    assert machine.device == "squeeze" and t.note == "reset squeeze, then retry 1 of 2"
    t = machine.advance(DONE, 3.0)  # the gripper reset and a new part placed
    assert (t.target, t.note) == (State.ORIENT, "squeeze reset")
    machine.advance(DONE, 4.0)  # the plan, again
    assert machine.state is State.INFEED
    m = machine.metrics
    assert (m.faults_seen, m.faults_handled, m.retries) == (1, 1, 1)


def test_dropped_parts_past_the_budget_stop_the_cell() -> None:
    machine = CellMachine(cycles=1, max_retries=1, orienter="squeeze")
    run(machine, [DONE, Outcome("FAULT", 402), DONE])
    t = machine.advance(Outcome("FAULT", 402, "dropped again"), 4.0)
    assert t.target is State.STOPPED
    assert machine.stop_reason == "ORIENT: FAULT 402 (dropped again); retry budget of 1 spent in cycle 1"


def test_a_jaw_stall_stops_the_cell_naming_it() -> None:
    assert policy_for(State.ORIENT, Outcome("FAULT", 401)) is Policy.STOP
    machine = CellMachine(cycles=3, orienter="squeeze")
    run(machine, [DONE])
    t = machine.advance(Outcome("FAULT", 401, "injected fault jaw_stall"), 2.0)
    assert (t.policy, t.target) == (Policy.STOP, State.STOPPED)
    assert machine.stop_reason == "ORIENT: FAULT 401 (injected fault jaw_stall)"


def test_a_plan_timeout_runs_it_again_and_a_canceled_plan_stops() -> None:
    machine = CellMachine(cycles=1, orienter="squeeze")
    run(machine, [DONE])
    t = machine.advance(Outcome("TIMEOUT"), 2.0)
    assert (t.policy, t.target) == (Policy.RETRY, State.ORIENT)
    assert policy_for(State.ORIENT, Outcome("CANCELED")) is Policy.STOP


def test_the_rows_are_in_the_tables_and_the_mems_cell_is_unchanged() -> None:
    rows = policy_table()
    assert ("ORIENT", "FAULT", "402", "RESET_RETRY") in rows and ("ORIENT", "FAULT", "401", "STOP") in rows
    machine = CellMachine(cycles=1)  # the default station: the MEMS array, reset as before
    run(machine, [DONE, Outcome("TIMEOUT")])
    assert machine.device == "mems" and machine.device_of(State.FEED) == "arm"


def test_an_unknown_orienter_is_refused_naming_the_field() -> None:
    assert ORIENTERS == ("mems", "squeeze")
    with pytest.raises(InputError, match="^orienter: must be one of mems, squeeze, got 'gripper'"):
        CellMachine(orienter="gripper")
    spec = next(s for s in PARAMETERS if s.name == "orienter")
    with pytest.raises(InputError, match="^parameter orienter: must be one of mems, squeeze"):
        check_value(spec, "array")


def test_the_scene_orients_on_the_gripper_and_a_bad_orienter_is_named(tmp_path: Path) -> None:
    scene = load_scene(SCENE)
    controller = next(n for n in scene.nodes if n.executable == "cell_controller")
    assert controller.parameters["orienter"] == "squeeze"
    assert str(controller.parameters["squeeze_part_file"]).endswith("examples/squeeze/rectangle.yaml")
    copy = scene_copy(SCENE, tmp_path, {"cell_controller": {"orienter": "gripper"}})
    with pytest.raises(FeederError) as refused:
        load_scene(copy)
    assert "nodes[5].parameters.orienter: must be one of mems, squeeze" in str(refused.value)
