"""The named steps of the simulated arm: carry check, arm schedule, rest classification, faults, commands."""

import math

import numpy as np
import pytest
from throwing_helpers import TRIANGLE_PARAMS, triangle

from feeder_planner.errors import InputError
from feeder_planner.throwing.flight import rest_pose
from feeder_sim.throwing import (
    ARM_COMMANDS,
    FIDELITIES,
    ThrowingArm,
    ThrowOutcome,
    check_fidelity,
    parse_command,
    rest_outcome,
)
from feeder_sim.throwing.dynamic import arm_rate, carry_fault, resting_edge, time_limit
from feeder_sim.throwing.tolerances import CARRY_ANGLE, MAX_TILT


def test_carry_fault_names_the_arm_angle_only_outside_the_grasp():
    part, p = triangle(), TRIANGLE_PARAMS
    assert carry_fault(part, p, 1, 0.12, CARRY_ANGLE) is None
    reason = carry_fault(part, p, 1, 0.12, 1.0)  # slow and long: past the friction angle atan(0.5)
    assert reason is not None and "dynamic grasp" in reason and "arm angle" in reason


def test_arm_rate_accelerates_through_the_carry_then_returns_and_stops():
    w, carry = 5.0, 0.02
    alpha = w * w / (2 * carry)
    carry_time, step = w / alpha, 1e-4
    rates = [arm_rate(t, 0.0, carry_time, alpha, w, step) for t in np.arange(0.0, carry_time, step)]
    assert np.all(np.diff(rates) > 0) and rates[-1] <= w * (1 + 1e-9)
    assert arm_rate(carry_time, 0.5, carry_time, alpha, w, step) == -w  # far up: back down at W
    assert arm_rate(carry_time, 1e-6, carry_time, alpha, w, step) == pytest.approx(
        -1e-6 / step
    )  # lands level
    assert arm_rate(carry_time, 0.0, carry_time, alpha, w, step) == 0.0


def test_time_limit_grows_with_the_throw():
    assert (
        time_limit(0.01, 5.0, 3.0, -9.66)
        < time_limit(0.01, 5.0, 6.0, -9.66)
        < time_limit(0.01, 10.0, 6.0, -9.66)
    )


def test_resting_edge_and_tilt_fault():
    part = triangle()
    for e in range(part.n):
        theta = float(rest_pose(part, e, 0.1, 0.0)[2])
        assert resting_edge(part, theta + 0.01) == (e, pytest.approx(0.01))
        assert resting_edge(part, theta - 4 * math.pi) == (e, pytest.approx(0.0, abs=1e-12))
    theta = float(rest_pose(part, 1, 0.1, 0.0)[2])
    tilted = rest_outcome(part, 1, 0.1, theta + 2 * MAX_TILT, 0.1, ((0.0, 0.1, 0.0, theta),))
    assert tilted.kind == "fault" and "tilted" in tilted.fault and tilted.path and tilted.edge_after == -1
    assert rest_outcome(part, 1, 0.1, theta + 0.5 * MAX_TILT, 0.11).kind == "jog"


def test_fault_outcome_constructor_and_fault_of_a_landing():
    fault = ThrowOutcome.failure(2, 0.1, "why")
    assert (fault.edge_before, fault.radius_before, fault.edge_after, fault.kind, fault.fault) == (
        2,
        0.1,
        -1,
        "fault",
        "why",
    )
    assert math.isnan(fault.radius_after) and fault.turns == 0 and fault.rotation == 0.0 and fault.path == ()
    landed = ThrowOutcome(1, 0.1, 0, 0.2, "flip", 0, 2.0, "", ((0.0, 0.1, 0.0, 0.0),))
    turned = landed.with_fault("left the arm")
    assert (turned.kind, turned.fault, turned.edge_after, turned.radius_after, turned.path) == (
        "fault",
        "left the arm",
        0,
        0.2,
        landed.path,
    )
    assert landed.kind == "flip"  # frozen: the original is unchanged


def test_arm_commands_and_fidelities_are_closed_sets_checked_by_name():
    assert ARM_COMMANDS == ("throw", "start", "stop") and FIDELITIES == ("paper", "contact", "dynamic")
    assert check_fidelity("analytic") == "paper"  # the paper model's earlier name stays accepted
    assert parse_command("  Throw ") == "throw" and parse_command("STOP") == "stop"
    with pytest.raises(InputError) as info:
        parse_command("dance")
    assert info.value.field == "command" and "throw, start or stop" in info.value.problem
    assert check_fidelity("dynamic") == "dynamic"
    with pytest.raises(InputError) as info:
        check_fidelity("magic", "parameter fidelity")
    assert info.value.field == "parameter fidelity"


def test_arm_fault_keeps_a_stable_landing_and_refuses_further_throws():
    part, p = triangle(), TRIANGLE_PARAMS
    arm = ThrowingArm(part, p, 1, 0.17, arm_length=0.2)
    outcomes = [arm.throw() for _ in range(5)]
    first = next(o for o in outcomes if o.kind == "fault")
    assert "left the arm" in first.fault and first.edge_after >= 0
    assert (arm.edge, arm.radius) == (first.edge_after, first.radius_after)
    assert outcomes[-1].fault.startswith("arm faulted earlier")
