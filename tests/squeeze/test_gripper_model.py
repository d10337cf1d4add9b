"""The squeeze gripper model and its goal machine, ROS-free: plans run tick by tick, faults act, bad input.

Tolerances: orientations within 1e-7 rad modulo the symmetry period (ideal); the dynamic fidelity without
friction within 0.02 rad (pymunk's contact slop, a few hundredths of a millimetre on a 2 cm part).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from feeder_planner.errors import FeederError, InputError
from feeder_planner.parts import load_part
from feeder_planner.squeeze import plan_squeezes, squeeze_function
from feeder_sim.squeeze.dynamic import dynamic_squeeze
from feeder_sim.squeeze.gripper import GripperFaultError, SqueezeGripper
from feeder_sim.squeeze.ideal import ideal_squeeze
from feeder_sim.squeeze.plan_goal import OUTCOME_CODES, PlanGoal, check_plan_goal

ROOT = Path(__file__).resolve().parents[2]
TICK = 0.02


def outline(name: str) -> np.ndarray:
    return load_part(ROOT / "examples" / "squeeze" / f"{name}.yaml").outer


def run(goal: PlanGoal, gripper: SqueezeGripper, limit: float = 60.0) -> None:
    now = 0
    while not goal.done and gripper.time < limit:
        fault = None
        try:
            gripper.advance(TICK)
        except GripperFaultError as error:
            fault = (400, str(error))
        now += int(TICK * 1e9)
        goal.tick(now, gripper, fault)


@pytest.mark.parametrize("name", ["rectangle", "hexagon6", "shallow"])
def test_plan_run_tick_by_tick_ends_at_the_final_orientation(name: str) -> None:
    part = outline(name)
    sf = squeeze_function(part)
    plan = plan_squeezes(sf)
    for start in np.random.default_rng(1).uniform(0, 2 * math.pi, 12):
        gripper = SqueezeGripper(part, jaw_speed=0.1, turn_speed=6.0)
        gripper.place(float(start))
        goal = PlanGoal(check_plan_goal(list(plan.angles), 0.0), 0)
        run(goal, gripper)
        assert goal.outcome is not None and goal.outcome.name == "DONE", goal.outcome
        assert len(goal.outcome.widths) == len(plan.angles) and gripper.phase == "IDLE"
        assert abs(math.remainder(gripper.orientation - plan.certificate.final, sf.period)) < 1e-7
        # The last width read is the final orientation's width relative to the last jaws.
        last = sf.diameter(plan.certificate.final - plan.angles[-1])
        assert goal.outcome.widths[-1] == pytest.approx(last, abs=1e-12)
        assert gripper.jaw_width == pytest.approx(gripper.open_width)


def test_cancel_and_timeout_end_with_the_jaws_open() -> None:
    gripper = SqueezeGripper(outline("rectangle"), jaw_speed=0.01)
    gripper.place(0.3)
    goal = PlanGoal(check_plan_goal([0.0, 0.8, 1.6], 0.0), 0)
    goal.tick(0, gripper, None)  # starts the first squeeze
    gripper.advance(0.5)
    goal.cancel("canceled by its client")
    run(goal, gripper)
    assert goal.outcome is not None and goal.outcome.name == "CANCELED"
    assert gripper.phase == "IDLE" and gripper.jaw_width == pytest.approx(gripper.open_width)
    gripper2 = SqueezeGripper(outline("rectangle"), jaw_speed=0.01)
    gripper2.place(0.3)
    goal2 = PlanGoal(check_plan_goal([0.0, 0.8, 1.6], 0.3), 0)
    run(goal2, gripper2)
    assert goal2.outcome is not None and goal2.outcome.name == "TIMEOUT" and gripper2.phase == "IDLE"
    assert OUTCOME_CODES == {"DONE": 1, "TIMEOUT": 3, "FAULT": 4, "CANCELED": 5}


def test_faults_stall_drop_and_wear() -> None:
    gripper = SqueezeGripper(outline("rectangle"))
    gripper.place(0.2)
    gripper.faults.inject("jaw_stall")
    gripper.start(0.0)
    with pytest.raises(GripperFaultError, match="stalled"):
        gripper.advance(5.0)
    assert gripper.jaw_width < gripper.open_width and gripper.phase == "IDLE"
    gripper.recover()
    gripper.advance(5.0)
    assert gripper.jaw_width == pytest.approx(gripper.open_width)
    gripper.faults.inject("part_dropped", 1.0, seed=4)
    gripper.start(0.0)
    with pytest.raises(GripperFaultError, match="dropped"):
        gripper.advance(5.0)
    assert not gripper.holding and math.isnan(gripper.orientation)
    gripper.advance(5.0)  # the jaws open
    with pytest.raises(FeederError, match="no part between the jaws"):
        gripper.start(0.0)
    gripper.faults.inject("jaw_worn", 0.4)
    assert gripper.effective_friction == pytest.approx(0.4)
    with pytest.raises(InputError, match=r"^value: part_dropped: a probability in \[0, 1\]"):
        gripper.faults.inject("part_dropped", 1.5)
    with pytest.raises(InputError, match=r"^value: jaw_worn"):
        gripper.faults.inject("jaw_worn", math.nan)


def test_dynamic_without_friction_agrees_with_the_ideal_squeeze() -> None:
    part = outline("rectangle")
    for theta in np.random.default_rng(2).uniform(0, 2 * math.pi, 8):
        dynamic = dynamic_squeeze(part, float(theta), 0.0, 0.1)
        ideal = ideal_squeeze(part, float(theta))
        assert abs(math.remainder(dynamic.orientation - ideal.orientation, 2 * math.pi)) < 0.02
        assert dynamic.width == pytest.approx(ideal.width, abs=5e-5)


def test_bad_goals_and_parameters_are_refused_naming_the_field() -> None:
    with pytest.raises(InputError, match=r"^angles: a plan needs at least one squeeze"):
        check_plan_goal([], 0.0)
    with pytest.raises(InputError, match=r"^angles\[1\]: must be finite"):
        check_plan_goal([0.0, math.inf], 0.0)
    with pytest.raises(InputError, match=r"^timeout: must be finite and >= 0 s"):
        check_plan_goal([0.0], -1.0)
    with pytest.raises(InputError, match=r"^friction: must be in \[0, 2\]"):
        SqueezeGripper(outline("rectangle"), friction=3.0)
    with pytest.raises(InputError, match=r"^open_width: .* narrower than the part"):
        SqueezeGripper(outline("rectangle"), open_width=0.01)
    with pytest.raises(InputError, match=r"^fidelity: must be one of ideal, dynamic"):
        SqueezeGripper(outline("rectangle"), fidelity="paper")
    gripper = SqueezeGripper(outline("rectangle"))
    with pytest.raises(InputError, match=r"^orientation: must be finite"):
        gripper.place(math.nan)
    gripper.place(0.0)
    with pytest.raises(InputError, match=r"^angle: must be finite"):
        gripper.start(math.nan)


@pytest.mark.parametrize("mu", [0.3, 0.6])
def test_dynamic_with_friction_jams_where_the_friction_cone_says(mu: float) -> None:
    # Independent of pymunk: a quasi-static squeeze jams at once when the chord between the two contact
    # vertices lies in the friction cone, |theta - beta| <= atan(mu); else it ends where Goldberg's does.
    from feeder_planner.squeeze import frictional_squeeze, jams

    part = outline("rectangle")
    sf = squeeze_function(part)
    starts = np.random.default_rng(5).uniform(0, 2 * math.pi, 30)
    jammed = 0
    for theta in starts:
        predicted = frictional_squeeze(sf, float(theta), mu)
        dynamic = dynamic_squeeze(part, float(theta), mu, 0.1).orientation
        assert abs(math.remainder(predicted - dynamic, 2 * math.pi)) < 0.05, (theta, predicted, dynamic)
        jammed += jams(sf, float(theta), mu)
    # Some starts jam and some do not: the rectangle's crests take +-atan(mu) each (4 atan(mu) / pi of all
    # starts up to mu 0.5, where a window reaches the flush orientation).
    assert 0 < jammed < len(starts)
