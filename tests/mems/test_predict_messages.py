"""Final-pose prediction (Prop. 5) and the message conversions, without ROS."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from shapes import bracket

from feeder_planner.errors import InputError
from feeder_planner.mems.equilibria import find_equilibria
from feeder_planner.mems.fields import CombinedField, ProgramStep, QuadraticField, SqueezeField
from feeder_planner.mems.predict import final_equilibrium
from feeder_planner.node_kit.msg_fields import fill_field_spec, program_from_msg
from feeder_sim.mems.scene import Body, Scene


def spec(**kw):
    base = dict(
        type="",
        delta=0.0,
        center_x=0.0,
        center_y=0.0,
        strength=0.0,
        angle=0.0,
        k1=0.0,
        k2=0.0,
        force_x=0.0,
        force_y=0.0,
        duration=0.0,
    )
    base.update(kw)
    return SimpleNamespace(**base)


def test_round_trip_of_a_program() -> None:
    program = (
        ProgramStep(SqueezeField((0.1, 0.0), 0.3, 2.0), 0.5),
        ProgramStep(QuadraticField((0.0, 0.2), (1.0, 4.0), 0.1), 1.0),
        ProgramStep(CombinedField(0.25, (0.0, 0.1)), math.inf),
    )
    msg = SimpleNamespace(steps=[fill_field_spec(spec(), s) for s in program])
    assert program_from_msg(msg) == program


@pytest.mark.parametrize(
    "bad,field",
    [
        (spec(type="vortex"), "program.steps[0].type"),
        (spec(type="combined", delta=1.0), "program.steps[0].delta"),
        (spec(type="combined", duration=float("nan")), "program.steps[0].duration"),
        (spec(type="quadratic", k1=-1.0), "program.steps[0].k"),
    ],
)
def test_bad_program_messages_name_the_field(bad, field: str) -> None:
    with pytest.raises(InputError) as info:
        program_from_msg(SimpleNamespace(steps=[bad]))
    assert info.value.field == field


def test_prediction_matches_quasi_static_simulation_from_several_starts() -> None:
    """With two stable equilibria (bracket, delta = 0.5), the predicted basin is the one the part reaches."""
    part = bracket(scale=1e-3)
    result = find_equilibria(part, 0.5, "numeric")
    assert len(result.stable) == 2
    reached = set()
    for start_theta in np.linspace(0.2, 6.0, 6):
        # start on the equilibrium curve so that the 1-D reduction of Prop. 5 applies from the start
        from feeder_planner.mems import lifted
        from feeder_planner.mems.curve import curve

        p = curve(lifted.part_edges(part), part.area, 0.5, np.array([start_theta]))
        scene = Scene(
            [Body(part, np.array([p.x[0], p.y[0], start_theta]))],
            (ProgramStep(CombinedField(0.5), math.inf),),
            "ideal",
        )
        scene.run(1.5, 5e-4)
        predicted = final_equilibrium(result, start_theta)
        assert abs(math.remainder(scene.bodies[0].pose[2] - predicted.theta, 2 * math.pi)) <= 1e-6
        reached.add(round(predicted.theta, 6))
    assert len(reached) == 2
