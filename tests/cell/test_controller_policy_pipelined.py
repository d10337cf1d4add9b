"""The controller's ``policy``: the AHEAD rows of the machine, driven by scripted outcomes (no ROS)."""

from __future__ import annotations

import pytest

from feeder_cell.controller.machine import AHEAD, POLICIES, CellMachine, Outcome, State, ahead_table
from feeder_cell.controller.parameters import PARAMETERS
from feeder_cell.experiment.cell_scene import controller_parameters
from feeder_planner.errors import InputError

DONE = Outcome("DONE")
ONE_CYCLE = [Outcome("SETTLED"), DONE, Outcome("PRESENTED"), Outcome("REACHED"), Outcome("REACHED")]


def _aheads(machine: CellMachine, outcomes: list[Outcome]) -> list[tuple[str, str | None]]:
    """Feed the outcomes; return (state left, the state started ahead) of every transition."""
    out = []
    for k, outcome in enumerate(outcomes):
        source = machine.state
        transition = machine.advance(outcome, float(k))
        out.append((source.value, transition.ahead.value if transition.ahead else None))
    return out


def test_sequential_starts_nothing_ahead_and_is_the_default() -> None:
    machine = CellMachine(cycles=2)
    assert machine.policy == "sequential" and AHEAD["sequential"] == {}
    steps = _aheads(machine, [DONE, *ONE_CYCLE, *ONE_CYCLE])
    assert machine.state is State.FINISHED
    assert all(ahead is None for _, ahead in steps)


def test_pipelined_starts_the_next_orient_once_the_part_is_on_the_arm() -> None:
    machine = CellMachine(cycles=3, policy="pipelined")
    steps = _aheads(machine, [DONE, *ONE_CYCLE, *ONE_CYCLE, *ONE_CYCLE])
    assert machine.state is State.FINISHED and machine.metrics.cycles_completed == 3
    started = [(k, source) for k, (source, ahead) in enumerate(steps) if ahead is not None]
    # Cycles 1 and 2 start the next cycle's ORIENT at their INFEED; the last cycle has no next one.
    assert started == [(2, "INFEED"), (7, "INFEED")]
    assert all(ahead in (None, "ORIENT") for _, ahead in steps)


def test_pipelined_until_stopped_starts_ahead_every_cycle() -> None:
    machine = CellMachine(cycles=0, policy="pipelined")
    steps = _aheads(machine, [DONE, *ONE_CYCLE * 4])
    assert sum(ahead == "ORIENT" for _, ahead in steps) == 4


def test_a_failed_infeed_starts_nothing_ahead_its_retry_does() -> None:
    machine = CellMachine(cycles=2, policy="pipelined")
    lost = Outcome("FAULT", 102, "part lost")
    steps = _aheads(machine, [DONE, Outcome("SETTLED"), lost, DONE, DONE])
    assert [s for s, _ in steps] == ["BRING_UP", "ORIENT", "INFEED", "RECOVER", "INFEED"]
    assert [a for _, a in steps] == [None, None, None, None, "ORIENT"]


def test_the_tables_read_as_rows() -> None:
    assert ahead_table() == [("pipelined", "INFEED", "DONE", "ORIENT")]
    assert set(AHEAD) == set(POLICIES) == {"sequential", "pipelined"}
    spec = next(s for s in PARAMETERS if s.name == "policy")
    assert spec.default == "sequential"


@pytest.mark.parametrize("bad", ["parallel", "", "Pipelined"])
def test_an_unknown_policy_names_the_field(bad: str) -> None:
    with pytest.raises(InputError) as caught:
        CellMachine(policy=bad)
    assert caught.value.field == "policy" and repr(bad) in str(caught.value)
    with pytest.raises(InputError) as caught:
        controller_parameters({"policy": bad})
    assert caught.value.field == "cell_controller.parameters.policy"
    assert "sequential, pipelined" in str(caught.value)
