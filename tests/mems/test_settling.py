"""Settling detection and the match of final poses to the planner's equilibria (feeder_sim.mems.settling)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from shapes import regular

from feeder_planner.errors import InputError
from feeder_planner.mems import (
    CombinedField,
    ConstantField,
    ProgramStep,
    QuadraticField,
    RadialField,
    SqueezeField,
    final_equilibrium,
    find_equilibria,
)
from feeder_planner.parts import load_part
from feeder_sim.mems import Body, Scene
from feeder_sim.mems.settling import (
    DEFAULT_DWELL,
    DEFAULT_TOLERANCE,
    EQUILIBRIUM_ANGLE_TOLERANCE,
    SettlingCriterion,
    SettlingDetector,
    check_timeout,
    holding_start,
    holding_step,
    match,
    predict,
    settling_criterion,
    wrapped_distance,
)

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "mems"
BRACKET = load_part(EXAMPLES / "bracket.yaml")
SQUARE = load_part(EXAMPLES / "square.yaml")


# --- goal fields ----------------------------------------------------------------------------------
def test_zero_tolerance_and_dwell_pick_the_defaults_and_others_are_kept() -> None:
    assert settling_criterion(0.0, 0.0) == SettlingCriterion(DEFAULT_TOLERANCE, DEFAULT_DWELL)
    assert settling_criterion(1e-5, 2.0) == SettlingCriterion(1e-5, 2.0)


@pytest.mark.parametrize("field", ["tolerance", "dwell"])
@pytest.mark.parametrize("bad", [-1e-6, math.nan, math.inf, -math.inf])
def test_a_bad_tolerance_or_dwell_is_refused_naming_it(field: str, bad: float) -> None:
    values = {"tolerance": 0.0, "dwell": 0.0, field: bad}
    with pytest.raises(InputError, match=rf"^{field}: must be a finite number >= 0"):
        settling_criterion(values["tolerance"], values["dwell"])


@pytest.mark.parametrize("bad", [0.0, -1.0, math.nan, math.inf])
def test_a_timeout_must_be_finite_and_positive(bad: float) -> None:
    with pytest.raises(InputError, match=r"^timeout: must be a finite number > 0"):
        check_timeout(bad)
    assert check_timeout(2.5) == 2.5


def test_a_timeout_beyond_a_year_is_refused_before_its_deadline_could_overflow() -> None:
    from feeder_planner.limits import MAX_GOAL_TIMEOUT

    assert check_timeout(MAX_GOAL_TIMEOUT) == MAX_GOAL_TIMEOUT
    with pytest.raises(InputError, match=r"^timeout: must be at most"):
        check_timeout(1e308)


# --- the detector ---------------------------------------------------------------------------------
def test_a_part_at_rest_settles_once_the_dwell_has_passed_not_before() -> None:
    detector = SettlingDetector(1, SettlingCriterion(1e-6, 0.5))
    pose = np.array([[1e-3, -2e-3, 1.0]])
    times = np.arange(0.0, 1.0001, 0.05)
    flags = [detector.update(t, pose)[0] for t in times]
    first = times[flags.index(True)]
    assert first == pytest.approx(0.5)
    assert all(flags[flags.index(True) :])


def test_a_part_moving_faster_than_tolerance_over_dwell_never_settles() -> None:
    detector = SettlingDetector(1, SettlingCriterion(1e-6, 0.5))
    # 4 um/s: 2 um per dwell, twice the tolerance
    assert not any(detector.update(t, np.array([[4e-6 * t, 0.0, 0.0]]))[0] for t in np.arange(0, 5, 0.05))
    turning = SettlingDetector(1, SettlingCriterion(1e-6, 0.5))
    assert not any(turning.update(t, np.array([[0.0, 0.0, 4e-6 * t]]))[0] for t in np.arange(0, 5, 0.05))


def test_a_part_creeping_below_tolerance_over_dwell_settles() -> None:
    detector = SettlingDetector(1, SettlingCriterion(1e-6, 0.5))
    # 1 um/s: 0.5 um per dwell
    flags = [detector.update(t, np.array([[1e-6 * t, 0.0, 0.0]]))[0] for t in np.arange(0, 2, 0.05)]
    assert flags[-1] and not flags[0]


def test_the_orientation_is_compared_wrapped_across_two_pi() -> None:
    detector = SettlingDetector(1, SettlingCriterion(1e-6, 0.2))
    for k, t in enumerate(np.arange(0, 0.5, 0.05)):
        theta = 2 * math.pi - 1e-8 if k % 2 else 1e-8  # 2e-8 rad apart across the seam
        settled = detector.update(t, np.array([[0.0, 0.0, theta]]))
    assert settled == (True,)
    assert wrapped_distance(2 * math.pi - 0.1, 0.1) == pytest.approx(0.2)


def test_a_settled_part_that_moves_again_is_not_settled_until_a_new_dwell() -> None:
    detector = SettlingDetector(2, SettlingCriterion(1e-6, 0.5))
    rest = np.array([[0.0, 0.0, 0.0], [1e-3, 0.0, 2.0]])
    for t in np.arange(0, 0.6, 0.05):
        detector.update(t, rest)
    assert detector.all_settled
    pushed = rest.copy()
    pushed[1, 0] += 1e-5
    assert detector.update(0.65, pushed) == (True, False) and not detector.all_settled
    assert detector.update(1.1, pushed) == (True, False)
    assert detector.update(1.15, pushed) == (True, True)


def test_no_part_counts_as_settled_before_the_program_holds_its_last_field() -> None:
    detector = SettlingDetector(1, SettlingCriterion(1e-6, 0.5))
    pose = np.array([[0.0, 0.0, 0.0]])
    assert not any(detector.update(t, pose, judging=False)[0] for t in np.arange(0, 2, 0.05))
    # the dwell counts from the first judged sample
    assert detector.update(2.0, pose) == (False,)
    assert detector.update(2.45, pose) == (False,)
    assert detector.update(2.5, pose) == (True,)


# --- programs -------------------------------------------------------------------------------------
def test_the_holding_step_is_the_first_endless_step_or_else_the_last() -> None:
    squeeze, combined = SqueezeField(), CombinedField(0.3)
    finite = (ProgramStep(squeeze, 0.2), ProgramStep(QuadraticField(), 0.3), ProgramStep(combined, 1.0))
    assert holding_step(finite) == 2 and holding_start(finite) == pytest.approx(0.5)
    endless_first = (ProgramStep(squeeze, 0.2), ProgramStep(combined, math.inf), ProgramStep(squeeze, 1.0))
    assert holding_step(endless_first) == 1 and holding_start(endless_first) == pytest.approx(0.2)
    assert holding_step((ProgramStep(combined, math.inf),)) == 0
    assert holding_start((ProgramStep(combined, math.inf),)) == 0.0


# --- predictions ----------------------------------------------------------------------------------
def test_the_prediction_is_the_planners_stable_equilibria_moved_to_the_field_centre() -> None:
    result = find_equilibria(BRACKET, 0.3)
    prediction = predict(BRACKET, CombinedField(0.3, center=(1e-3, -2e-3), strength=2.0))
    stable = [(i, e) for i, e in enumerate(result.equilibria) if e.stable]
    assert prediction.predicted and prediction.reason == ""
    assert [p.index for p in prediction.stable] == [i for i, _ in stable]
    for p, (_, e) in zip(prediction.stable, stable, strict=True):
        assert p.theta == pytest.approx(e.theta % (2 * math.pi), abs=1e-12)
        assert (p.x, p.y) == pytest.approx((e.x + 1e-3, e.y - 2e-3), abs=1e-15)
    # a symmetric part: four stable equilibria a quarter turn apart (the square at delta 0.3)
    square = predict(SQUARE, CombinedField(0.3))
    thetas = sorted(p.theta for p in square.stable)
    assert len(thetas) == 4 and np.diff(thetas) == pytest.approx([math.pi / 2] * 3, abs=1e-6)


@pytest.mark.parametrize(
    "field,named",
    [
        (CombinedField(0.0), "radial field alone"),
        (RadialField(), "radial field"),
        (ConstantField(), "constant field"),
        (SqueezeField(), "squeeze field"),
        (QuadraticField(k=(1.0, 2.0)), "quadratic field"),
    ],
)
def test_fields_the_planner_does_not_predict_give_no_prediction_saying_so(field, named) -> None:
    prediction = predict(BRACKET, field)
    assert not prediction.predicted and prediction.stable == ()
    assert named in prediction.reason and "combined field with delta > 0" in prediction.reason
    found = match(prediction, (0.0, 0.0, 1.0))
    assert found.index == -1 and not found.at
    assert math.isnan(found.theta) and math.isnan(found.distance) and math.isnan(found.position_distance)


def test_a_refusal_of_the_planner_is_an_absent_prediction_with_its_reason() -> None:
    # a disc-like 13-gon: x* too small to resolve, no asymptotic order up to 9 (refused, not guessed)
    prediction = predict(regular(13), CombinedField(1e-3))
    assert not prediction.predicted and "the planner refused" in prediction.reason
    assert "too small to resolve" in prediction.reason


# --- matching -------------------------------------------------------------------------------------
def test_a_pose_at_a_stable_equilibrium_matches_it_and_one_off_it_does_not() -> None:
    prediction = predict(SQUARE, CombinedField(0.3))
    target = prediction.stable[2]
    at = match(prediction, (target.x, target.y + 1e-7, target.theta + 1e-4))
    assert at.at and at.index == target.index and at.theta == target.theta
    assert at.distance == pytest.approx(1e-4) and at.position_distance == pytest.approx(1e-7)
    off = match(prediction, (target.x, target.y, target.theta + 2 * EQUILIBRIUM_ANGLE_TOLERANCE))
    assert not off.at and off.index == -1
    assert off.theta == target.theta and off.distance == pytest.approx(2 * EQUILIBRIUM_ANGLE_TOLERANCE)
    far = match(prediction, (target.x + 1e-4, target.y, target.theta))  # right angle, 100 um away
    assert not far.at and far.index == -1 and far.position_distance == pytest.approx(1e-4)


def test_the_nearest_equilibrium_is_found_across_the_seam() -> None:
    prediction = predict(SQUARE, CombinedField(0.3))
    lowest = min(prediction.stable, key=lambda e: e.theta)  # pi/4
    found = match(prediction, (lowest.x, lowest.y, lowest.theta - 1e-3 + 2 * math.pi))
    assert found.index == lowest.index and found.distance == pytest.approx(1e-3)


def test_a_simulated_part_settles_at_the_equilibrium_the_planner_predicts() -> None:
    """The ideal model, the detector fed every 50 ms, and Prop. 5's prediction from the start pose."""
    field = CombinedField(0.3)
    start = np.array([3e-4, -2e-4, 1.0])
    scene = Scene([Body(BRACKET, start.copy())], (ProgramStep(field, math.inf),), "ideal")
    detector = SettlingDetector(1, settling_criterion(0.0, 0.0))
    t = 0.0
    while not detector.all_settled:
        scene.run(0.05, 1e-3)
        t += 0.05
        detector.update(t, np.array([scene.bodies[0].pose]))
        assert t < 10.0, "never settled"
    expected = final_equilibrium(find_equilibria(BRACKET, field.delta), start[2])
    found = match(predict(BRACKET, field), scene.bodies[0].pose)
    assert found.at and found.index == find_equilibria(BRACKET, field.delta).equilibria.index(expected)
    assert found.distance < 1e-6 and found.position_distance < 1e-6
