"""The MEMS array's station without ROS: whole steps per tick with the remainder owed, the cap, a goal.

The station is what the mems_field_array node and the ROS-free cell loop both tick (docs/devices.md,
"The station").
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from feeder_device.declarations import ActiveFault
from feeder_planner.mems import ProgramStep, field_from_mapping
from feeder_sim.mems.fault_specs import fault_specs
from feeder_sim.mems.parameters import MemsParameters
from feeder_sim.mems.settling import settling_criterion
from feeder_sim.mems.station import MemsStation

PLUS = Path(__file__).resolve().parents[2] / "examples" / "mems" / "plus.yaml"
START = 1_000_000_000
TICK = 50_000_000  # ns: 20 Hz


def cell_array(**extra: object) -> MemsStation:
    """The cell scene's array: the ideal model, the plus, a 2.5 ms step."""
    values: dict[str, object] = {
        "fidelity": "ideal",
        "part_files": [str(PLUS)],
        "seed": 7,
        "time_step": 2.5e-3,
    }
    values.update(extra)
    return MemsStation(MemsParameters(**values))  # type: ignore[arg-type]


def combined() -> tuple[ProgramStep, ...]:
    mapping = {"type": "combined", "delta": 0.0, "center": [0.0, 0.0], "strength": 1.0}
    return (ProgramStep(field_from_mapping(mapping, "program"), math.inf),)


def test_a_tick_simulates_whole_steps_and_owes_the_rest() -> None:
    array = cell_array()
    ticked = array.tick(TICK + 1_000_000)  # 51 ms: 20 steps of 2.5 ms, 1 ms owed
    assert (ticked.steps, ticked.dropped, array.owed_ns) == (20, 0, 1_000_000)
    ticked = array.tick(1_500_000)  # 1 + 1.5 ms: one more step, nothing owed
    assert (ticked.steps, ticked.dropped, array.owed_ns) == (1, 0, 0)
    assert math.isclose(array.scene.time, 21 * 2.5e-3, rel_tol=1e-12)


def test_steps_past_the_cap_are_dropped_not_simulated_late() -> None:
    array = cell_array(max_steps_per_tick=8)
    ticked = array.tick(TICK)  # 20 steps due, 8 allowed
    assert (ticked.steps, ticked.dropped, array.owed_ns) == (8, 12, 0)
    assert math.isclose(array.scene.time, 8 * 2.5e-3, rel_tol=1e-12)


def test_a_program_goal_settles_the_plus_and_a_stopped_array_pushes_nothing() -> None:
    array = cell_array()
    start = array.scene.bodies[0].pose.copy()
    goal = array.start_program(combined(), settling_criterion(1e-4, 0.5), 45.0, START)
    now = START
    while not goal.done and now < START + 50 * 10**9:
        now += TICK
        array.tick(TICK)
        array.advance_goal(goal, now, None, False, None)
    assert goal.outcome is not None and goal.outcome.name == "SETTLED", goal.outcome
    assert now - START < 45 * 10**9
    # The combined field centres the plus (seed 7 drops it 0.79 mm off centre) to within a nanometre.
    assert np.hypot(*start[:2]) > 5e-4 and np.hypot(*array.scene.bodies[0].pose[:2]) < 1e-9
    assert not array.moving()  # the last step holds and every part is at rest
    array.stop()
    assert not array.scene.switched_on and not array.moving()
    array.reset()
    assert array.scene.switched_on


def test_power_loss_goes_into_the_force_model_and_out_again() -> None:
    array = cell_array()
    spec = fault_specs({"power_loss": 201})["power_loss"]
    array.install(combined())
    array.apply_fault(ActiveFault(spec, 0.0, False, (), 0.0, 0))
    assert array.scene.faults.power_loss
    before = array.scene.bodies[0].pose.copy()
    array.tick(TICK)
    assert np.array_equal(array.scene.bodies[0].pose, before)  # no power: the cells push nothing
    array.clear_fault("power_loss")
    assert not array.scene.faults.power_loss
    array.tick(TICK)
    assert not np.array_equal(array.scene.bodies[0].pose, before)
