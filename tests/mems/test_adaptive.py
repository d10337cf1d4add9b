"""The ideal model's adaptive Heun steps and its rest (feeder_sim/mems/stepping.py), ROS-free.

* Error control: the trajectory at every ``dt`` stays within TRAJECTORY_TOLERANCE (pose scale: part radii,
  radians) of a fine fixed-step reference (classical RK4, 32 steps per ``dt``, whose own error is orders
  below), at very low and very high drag, from rest, and across a field switch.
* Rest: a part at rest is not integrated (no velocity evaluation at all), and every change wakes it.
* The examples settle where the planner predicts, as before, and then rest.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from feeder_planner.mems import (
    CombinedField,
    ProgramStep,
    QuadraticField,
    SqueezeField,
    final_equilibrium,
    find_equilibria,
)
from feeder_planner.parts import Part, load_part
from feeder_sim.mems import Body, Scene, random_poses
from feeder_sim.mems.faults import ArrayFaults
from feeder_sim.mems.placing import place_parts, reset_parts
from feeder_sim.mems.settling import match, predict
from feeder_sim.mems.tolerances import REST_TRAVEL, TRAJECTORY_TOLERANCE

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "mems"
PLUS = load_part(EXAMPLES / "plus.yaml")
START = random_poses(1, 1e-3, 7)[0]  # the cell scene's part (seed 7)
TWO_PI = 2 * math.pi


def deviation(part: Part, a: np.ndarray, b: np.ndarray) -> float:
    """Return |a - b| in the pose scale: position in part radii, wrapped orientation in radians."""
    d = np.array(
        [(a[0] - b[0]) / part.radius, (a[1] - b[1]) / part.radius, math.remainder(a[2] - b[2], TWO_PI)]
    )
    return float(np.linalg.norm(d))


def worst_deviation(scene: Scene, dt: float, duration: float, substeps: int = 32) -> float:
    """Advance ``scene`` by ``duration`` in steps of dt beside an RK4 reference; return the worst deviation.

    The reference takes the field the scene takes, the one active at the start of each dt.
    """
    body = scene.bodies[0]
    pose, worst, h = body.pose.copy(), 0.0, dt / substeps
    for _ in range(int(round(duration / dt))):
        field = scene.output_field()

        def rate(p: np.ndarray, field: object = field) -> np.ndarray:
            return scene._rate(body, p, field)[0]  # type: ignore[arg-type]

        for _ in range(substeps):
            a = rate(pose)
            b = rate(pose + 0.5 * h * a)
            c = rate(pose + 0.5 * h * b)
            d = rate(pose + h * c)
            pose = pose + h / 6.0 * (a + 2 * b + 2 * c + d)
        scene.step(dt)
        worst = max(worst, deviation(body.part, body.pose, pose))
    return worst


def combined_scene(damping: float, start: np.ndarray = START, delta: float = 0.2) -> Scene:
    program = (ProgramStep(CombinedField(delta), math.inf),)
    return Scene([Body(PLUS, start.copy())], program, "ideal", damping=damping)


@pytest.mark.parametrize(
    ("damping", "dt", "duration"),
    [(0.05, 1e-3, 0.1), (1.0, 2.5e-3, 0.4), (50.0, 2.5e-3, 1.5)],
    ids=["very-low-drag", "cell-scene", "very-high-drag"],
)
def test_the_adaptive_trajectory_stays_within_its_tolerance_of_a_fine_reference(
    damping: float, dt: float, duration: float
) -> None:
    """At a twentieth of the drag the configured dt is far beyond Heun's stable step (stiff, cut); at 50x
    it is far below what accuracy needs; in between, the cell scene's own step."""
    scene = combined_scene(damping)
    assert worst_deviation(scene, dt, duration) <= TRAJECTORY_TOLERANCE
    assert (scene.stiff_steps > 0) == (damping < 1.0)


def test_a_part_starting_at_rest_stays_on_the_reference() -> None:
    """Placed at its equilibrium (velocity at its rounding floor), then moved by a new field."""
    equilibrium = final_equilibrium(find_equilibria(PLUS, 0.2), START[2])
    at_rest = np.array([equilibrium.x, equilibrium.y, equilibrium.theta])
    scene = combined_scene(1.0, at_rest)
    assert worst_deviation(scene, 2.5e-3, 0.05) <= TRAJECTORY_TOLERANCE
    scene.set_program((ProgramStep(CombinedField(0.5), math.inf),))
    assert worst_deviation(scene, 2.5e-3, 0.3) <= TRAJECTORY_TOLERANCE


def test_a_field_switch_mid_run_stays_on_the_reference() -> None:
    """The demo program's squeeze, then a stiff quadratic field (lambda dt 1.5 at drag 1), then combined."""
    program = (
        ProgramStep(SqueezeField(center=(0.0, 0.0), angle=0.0, strength=1.0), 0.05),
        ProgramStep(QuadraticField(center=(0.0, 0.0), k=(1000.0, 3000.0), angle=0.0), 0.05),
        ProgramStep(CombinedField(0.3), math.inf),
    )
    scene = Scene([Body(PLUS, START.copy())], program, "ideal")
    assert worst_deviation(scene, 5e-4, 0.2) <= TRAJECTORY_TOLERANCE
    assert scene.stiff_steps == 0  # the demo's own step: no false FAULT_TIME_STEP
    assert scene.stiffness_warning(5e-4) == ""


# --- rest ---------------------------------------------------------------------------------------------


def settle(scene: Scene, dt: float = 2.5e-3, limit: float = 60.0) -> None:
    """Step until the stepper rests every part (fails after ``limit`` s)."""
    while scene.stepper.skipped == 0 or any(s.rest_pose is None for s in scene.stepper.states):
        scene.step(dt)
        assert scene.time < limit, "never came to rest"


def resting(scene: Scene, steps: int = 200, dt: float = 2.5e-3) -> bool:
    """Whether ``steps`` steps of dt do no velocity evaluation at all (time advances, poses stay)."""
    before, poses, time = scene.stepper.evaluations, [b.pose.copy() for b in scene.bodies], scene.time
    for _ in range(steps):
        scene.step(dt)
    still = all(np.array_equal(b.pose, p) for b, p in zip(scene.bodies, poses, strict=True))
    assert scene.time == pytest.approx(time + steps * dt)
    return scene.stepper.evaluations == before and still


def test_a_part_at_rest_is_not_integrated_and_every_change_wakes_it() -> None:
    initial = START[None, :].copy()
    program = (ProgramStep(CombinedField(0.2), 30.0), ProgramStep(CombinedField(0.4), math.inf))
    scene = Scene([Body(PLUS, START.copy())], program, "ideal")
    settle(scene)
    assert resting(scene)
    # A program step switch (at 30 s of program time): the new field moves the part.
    while scene.time < 30.0:
        scene.step(2.5e-3)
    assert not resting(scene, 10)

    changes = {
        "set_program": lambda: scene.set_program((ProgramStep(CombinedField(0.3), math.inf),)),
        "faults": lambda: scene.set_faults(ArrayFaults(strength_error=0.5)),
        "placement": lambda: place_parts(scene, ["p"], (["p"], [1e-4], [0.0], [0.3]), 1.0),
        "reset_parts": lambda: reset_parts(scene, initial),
        "damping": lambda: scene.set_damping(2.0),
    }
    for name, change in changes.items():
        settle(scene)
        assert resting(scene), name
        evaluations = scene.stepper.evaluations
        change()
        scene.step(2.5e-3)
        assert scene.stepper.evaluations > evaluations, f"{name} did not wake the part"


def test_stop_rests_at_once_and_reset_wakes() -> None:
    scene = combined_scene(1.0)
    scene.run(0.05, 2.5e-3)
    scene.switched_on = False  # ~/stop: no field, the step is a fixed point bit for bit
    scene.step(2.5e-3)
    assert resting(scene)
    scene.switched_on = True  # ~/reset
    scene.set_program(scene.program)
    assert not resting(scene, 5)


def test_field_strength_change_wakes_even_without_a_new_object() -> None:
    """Conditions are compared by value too: an equal program field keeps the rest, another wakes."""
    scene = combined_scene(1.0)
    settle(scene)
    scene.program = (ProgramStep(CombinedField(0.2), math.inf),)  # equal, not the same object
    assert resting(scene, 5)
    scene.program = (ProgramStep(CombinedField(0.2, strength=2.0), math.inf),)
    assert not resting(scene, 5)


@pytest.mark.parametrize("name", ["bracket", "plus", "square", "washer"])
def test_the_examples_settle_and_rest_at_the_predicted_equilibrium(name: str) -> None:
    """As before (tests/mems/test_settling.py asks 1e-6 rad and 1e-6 m): at the equilibrium Prop. 5 picks,
    in orientation within REST_TRAVEL plus the error control's tolerance, and at rest."""
    part = load_part(EXAMPLES / f"{name}.yaml")
    start = np.array([3e-4, -2e-4, 1.0])
    field = CombinedField(0.3)
    scene = Scene([Body(part, start.copy())], (ProgramStep(field, math.inf),), "ideal")
    settle(scene, dt=1e-3)
    found = match(predict(part, field), scene.bodies[0].pose)
    expected = final_equilibrium(find_equilibria(part, field.delta), start[2])
    assert found.at and found.theta == pytest.approx(expected.theta % TWO_PI)
    assert found.distance < REST_TRAVEL + TRAJECTORY_TOLERANCE
    assert found.position_distance < 1e-6  # m: the planner's own position is 8e-8 m off for the plus
    assert resting(scene, 50, 1e-3)
