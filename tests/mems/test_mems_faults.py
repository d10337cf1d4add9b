"""Injected faults of the MEMS array, without ROS: what the cells push with, seeded draws, refusals."""

from __future__ import annotations

import math

import numpy as np
import pytest
from shapes import bracket

from feeder_planner.errors import InputError
from feeder_planner.mems.fields import CombinedField, ConstantField, ProgramStep
from feeder_sim.mems.faults import NO_FAULTS, ArrayFaults, check_cells, draw_cells
from feeder_sim.mems.models import ArrayForces, IdealForces
from feeder_sim.mems.scene import Body, Scene


def test_draws_are_deterministic_per_seed_and_differ_between_faults() -> None:
    first = draw_cells("dead_cells", 20, 30, 0.25, seed=4)
    assert first == draw_cells("dead_cells", 20, 30, 0.25, seed=4)
    assert len(first) == 150 and len(set(first)) == 150 and all(0 <= i < 600 for i in first)
    assert first != draw_cells("dead_cells", 20, 30, 0.25, seed=5)
    assert first != draw_cells("stuck_cells", 20, 30, 0.25, seed=4)


@pytest.mark.parametrize("fraction", [0.0, -0.1, 1.5, float("nan")])
def test_bad_fraction_names_value(fraction: float) -> None:
    with pytest.raises(InputError) as error:
        draw_cells("dead_cells", 4, 4, fraction, seed=0)
    assert error.value.field == "value"


def test_indices_are_checked_against_the_array() -> None:
    assert check_cells([5, 1, 5], 4, 4) == (1, 5)
    with pytest.raises(InputError) as error:
        check_cells([1, 16], 4, 4)
    assert error.value.field == "indices[1]"


def test_cell_faults_change_the_cell_forces() -> None:
    forces = np.zeros((3, 4, 2))
    forces[..., 0] = 3.0
    forces[..., 1] = -4.0  # magnitude 5 everywhere
    faults = ArrayFaults(dead=(0, 7), stuck=(7, 11), stuck_angle=math.pi / 2, strength_error=0.1)
    out = faults.apply_to_cells(forces).reshape(-1, 2)
    assert np.array_equal(out[0], [0.0, 0.0]) and np.array_equal(out[7], [0.0, 0.0])  # dead wins
    assert out[11] == pytest.approx([0.0, 5.5], abs=1e-12)  # stuck: up, at the field's magnitude x 1.1
    assert out[3] == pytest.approx([3.3, -4.4])
    assert np.array_equal(ArrayFaults(power_loss=True).apply_to_cells(forces), np.zeros_like(forces))
    assert NO_FAULTS.apply_to_cells(forces) is forces


def test_with_fault_validates_and_without_clears() -> None:
    faults = NO_FAULTS.with_fault("dead_cells", indices=[3], cells=(4, 4))
    assert faults.dead == (3,)
    faults = faults.with_fault("stuck_cells", value=0.5, angle=1.0, seed=2, cells=(4, 4))
    assert len(faults.stuck) == 8 and faults.stuck_angle == 1.0
    faults = faults.with_fault("field_strength_error", value=-0.5).with_fault("power_loss")
    assert faults.gain == 0.0 and faults.without("power_loss").gain == 0.5
    assert faults.without("dead_cells").without("stuck_cells").without("power_loss") == ArrayFaults(
        strength_error=-0.5
    )
    for name, kwargs, field in [
        ("field_strength_error", {"value": -1.0}, "value"),
        ("field_strength_error", {"value": 0.0}, "value"),
        ("stuck_cells", {"value": 0.1, "angle": math.inf}, "angle"),
        ("dead_cells", {"value": 0.1, "indices": [1]}, "value"),
        ("dead_cells", {"value": 0.1}, "fault"),  # the ideal fidelity has no cells
        ("gremlins", {}, "fault"),
    ]:
        fidelity = "ideal" if field == "fault" else "array"
        with pytest.raises(InputError) as error:
            NO_FAULTS.with_fault(name, cells=(4, 4), fidelity=fidelity, **kwargs)
        assert error.value.field == field, (name, kwargs)
    with pytest.raises(InputError, match="fidelity 'array'.*'ideal'"):
        NO_FAULTS.with_fault("stuck_cells", value=0.1, cells=(4, 4), fidelity="ideal")


def test_faults_act_on_the_array_wrench() -> None:
    part = bracket(scale=1e-3)
    loops = part.placed(1e-4, -2e-4, 0.3)
    about = np.array([1e-4, -2e-4])
    field = ConstantField((0.0, -1.0))
    model = ArrayForces(60, 60, 1e-4)
    healthy = model.wrench(field, loops, about)
    assert healthy[:2] == pytest.approx([0.0, -part.area], rel=1e-12)
    model.set_faults(ArrayFaults(strength_error=0.25))
    assert model.wrench(field, loops, about) == pytest.approx(1.25 * healthy, rel=1e-12, abs=1e-18)
    model.set_faults(ArrayFaults(dead=tuple(range(3600))))
    assert np.array_equal(model.wrench(field, loops, about), np.zeros(3))
    model.set_faults(ArrayFaults(stuck=tuple(range(3600)), stuck_angle=math.pi / 2))
    assert model.wrench(field, loops, about)[:2] == pytest.approx([0.0, part.area], rel=1e-9, abs=1e-18)
    model.set_faults(NO_FAULTS)
    assert np.array_equal(model.wrench(field, loops, about), healthy)


def test_ideal_model_takes_field_faults_and_refuses_cell_faults() -> None:
    part = bracket(scale=1e-3)
    loops = part.placed(0.0, 0.0, 0.0)
    field = CombinedField(0.3)
    model = IdealForces()
    healthy = model.wrench(field, loops, np.zeros(2))
    model.set_faults(ArrayFaults(strength_error=-0.5))
    assert model.wrench(field, loops, np.zeros(2)) == pytest.approx(0.5 * healthy)
    with pytest.raises(ValueError):
        model.set_faults(ArrayFaults(dead=(1,)))
    scene = Scene([Body(part, np.zeros(3))], (ProgramStep(field, math.inf),), "ideal")
    with pytest.raises(InputError) as error:
        scene.set_faults(ArrayFaults(dead=(1,)))
    assert error.value.field == "fault"


def test_power_loss_and_switching_off_leave_the_part_where_it_is() -> None:
    part = bracket(scale=1e-3)
    program = (ProgramStep(CombinedField(0.3), math.inf),)
    for fidelity in ("ideal", "array"):
        scene = Scene([Body(part, np.array([5e-4, 2e-4, 1.0]))], program, fidelity)
        scene.set_faults(ArrayFaults(power_loss=True))
        scene.run(0.01, 5e-4)
        assert np.array_equal(scene.bodies[0].pose, [5e-4, 2e-4, 1.0]) and all(scene.settled())
        scene.set_faults(NO_FAULTS)
        scene.switched_on = False
        scene.run(0.01, 5e-4)
        assert np.array_equal(scene.bodies[0].pose, [5e-4, 2e-4, 1.0])
        scene.switched_on = True
        scene.run(0.01, 5e-4)
        assert not np.array_equal(scene.bodies[0].pose, [5e-4, 2e-4, 1.0])


def test_runtime_damping_and_friction() -> None:
    part = bracket(scale=1e-3)
    program = (ProgramStep(ConstantField((0.0, -1.0)), math.inf),)
    scene = Scene([Body(part, np.zeros(3))], program, "ideal")
    scene.step(1e-4)
    assert scene.bodies[0].velocity[1] == pytest.approx(-1.0)  # v = f / damping
    scene.set_damping(4.0)
    scene.step(1e-4)
    assert scene.bodies[0].velocity[1] == pytest.approx(-0.25)
    with pytest.raises(InputError, match="dynamic"):
        scene.set_friction(0.2)
    dynamic = Scene([Body(part, np.zeros(3))], program, "dynamic")
    dynamic.set_friction(0.2)
    dynamic.set_damping(3.0)
    assert dynamic._dynamic is not None
    assert (dynamic._dynamic.friction, dynamic._dynamic.damping) == (0.2, 3.0)
    with pytest.raises(InputError):
        dynamic.set_damping(0.0)
