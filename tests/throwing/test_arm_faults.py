"""The arm's injected faults without ROS: magnitudes checked, each effect on the model, seeded draws."""

from __future__ import annotations

import math

import numpy as np
import pytest
from throwing_helpers import TRIANGLE_PARAMS, triangle

from feeder_planner.errors import InputError
from feeder_sim.throwing import ARM_FAULTS, FAULT_INFO, ArmFaults, MotorFaultError, ThrowingArm
from feeder_sim.throwing.tolerances import MAX_SPEED_ERROR_SIGMA, MIN_SPEED_SCALE

EDGE, RADIUS = 1, 0.12


def arm() -> ThrowingArm:
    return ThrowingArm(triangle(), TRIANGLE_PARAMS, EDGE, RADIUS, arm_length=0.4)


def samples(faults: ArmFaults, reading: bool, n: int = 400) -> list[bool | None]:
    return [faults.sensor(reading) for _ in range(n)]


def test_the_six_faults_and_which_stop_the_arm():
    assert ARM_FAULTS == (
        "sensor_stuck",
        "sensor_dropout",
        "sensor_bit_flip",
        "release_speed_error",
        "motor_fault",
        "part_lost",
    )
    assert [name for name in ARM_FAULTS if FAULT_INFO[name].stops] == ["motor_fault", "part_lost"]
    assert all(FAULT_INFO[name].value_meaning for name in ("sensor_dropout", "sensor_bit_flip"))


@pytest.mark.parametrize(
    "name,fields,field",
    [
        ("sensor_dropout", {"value": 1.5}, "value"),
        ("sensor_dropout", {"value": -0.1}, "value"),
        ("sensor_bit_flip", {"value": math.nan}, "value"),
        ("release_speed_error", {"value": MAX_SPEED_ERROR_SIGMA * 1.01}, "value"),
        ("release_speed_error", {"value": -0.1}, "value"),  # a negative sigma
        ("release_speed_error", {"value": -1.0, "state": True}, "value"),  # W (1 + e) = 0
        ("release_speed_error", {"value": 1.5, "state": True}, "value"),
        ("sensor_stuck", {"indices": (3,)}, "indices"),
        ("wobble", {}, "fault"),
    ],
)
def test_bad_magnitudes_name_the_field_and_change_nothing(name, fields, field):
    faults = ArmFaults(arm())
    with pytest.raises(InputError) as info:
        faults.inject(name, **fields)
    assert info.value.field == field
    assert faults.names == () and samples(faults, True, 20) == [True] * 20 and faults.speed_scale() == 1.0


def test_sensor_stuck_reads_its_state_whatever_is_there_until_cleared():
    faults = ArmFaults(arm())
    faults.inject("sensor_stuck", state=True)
    assert samples(faults, False) == [True] * 400
    faults.inject("sensor_stuck", state=False)  # injected again: replaced
    assert samples(faults, True) == [False] * 400 and faults.names == ("sensor_stuck",)
    faults.clear("sensor_stuck")
    assert samples(faults, True) == [True] * 400 and faults.names == ()


def test_sensor_dropout_misses_samples_with_its_probability_deterministically_for_a_seed():
    faults = ArmFaults(arm())
    faults.inject("sensor_dropout", value=0.3, seed=5)
    first = samples(faults, True, 2000)
    assert set(first) == {True, None}
    assert abs(first.count(None) / 2000 - 0.3) < 0.05
    again = ArmFaults(arm())
    again.inject("sensor_dropout", value=0.3, seed=5)
    assert samples(again, True, 2000) == first
    other = ArmFaults(arm())
    other.inject("sensor_dropout", value=0.3, seed=6)
    assert samples(other, True, 2000) != first
    for p, expected in ((0.0, [True] * 50), (1.0, [None] * 50)):
        faults.inject("sensor_dropout", value=p)
        assert samples(faults, True, 50) == expected


def test_sensor_bit_flip_inverts_bits_with_its_probability_and_never_a_missing_sample():
    faults = ArmFaults(arm())
    faults.inject("sensor_bit_flip", value=0.25, seed=3)
    got = samples(faults, False, 2000)
    assert None not in got and abs(got.count(True) / 2000 - 0.25) < 0.05
    faults.inject("sensor_bit_flip", value=1.0)
    assert samples(faults, False, 20) == [True] * 20 and samples(faults, True, 20) == [False] * 20
    faults.inject("sensor_dropout", value=1.0)  # a missing sample has no bit to flip
    assert samples(faults, True, 20) == [None] * 20


def test_release_speed_error_fixed_scales_w_and_the_throw_is_the_throw_at_w_times_1_plus_e():
    model = arm()
    faults = ArmFaults(model)
    faults.inject("release_speed_error", value=0.1, state=True)
    assert faults.speed_scale() == pytest.approx(1.1)
    got = faults.throw()
    assert faults.last_speed_scale == pytest.approx(1.1)
    expected = arm().throw(1.1)
    nominal = arm().throw()
    assert (got.edge_after, got.radius_after) == (expected.edge_after, expected.radius_after)
    assert got.radius_after != nominal.radius_after
    faults.clear("release_speed_error")
    assert faults.speed_scale() == 1.0


def test_release_speed_error_drawn_per_throw_from_its_seed_and_clipped():
    faults = ArmFaults(arm())
    faults.inject("release_speed_error", value=0.05, seed=9)
    draws = np.array([faults.speed_scale() for _ in range(4000)])
    assert abs(draws.mean() - 1.0) < 0.005 and abs(draws.std() - 0.05) < 0.005
    again = ArmFaults(arm())
    again.inject("release_speed_error", value=0.05, seed=9)
    assert np.array_equal(draws, [again.speed_scale() for _ in range(4000)])
    wide = ArmFaults(arm())
    wide.inject("release_speed_error", value=MAX_SPEED_ERROR_SIGMA, seed=1)
    assert min(wide.speed_scale() for _ in range(4000)) == MIN_SPEED_SCALE


def test_motor_fault_refuses_throws_and_leaves_the_part_where_it_is():
    model = arm()
    faults = ArmFaults(model)
    faults.inject("motor_fault")
    assert faults.motor_failed
    with pytest.raises(MotorFaultError):
        faults.throw()
    assert (model.edge, model.radius) == (EDGE, RADIUS) and not model.faulted
    faults.clear("motor_fault")
    assert faults.throw().kind in ("jog", "flip")


def test_part_lost_takes_the_part_off_the_arm_until_it_is_placed_again():
    model = arm()
    assert model.sensor(RADIUS, 0.001)  # the sensor under the centre of mass sees the part
    faults = ArmFaults(model)
    faults.inject("part_lost")
    assert not model.on_arm and "part_lost" in model.faulted
    assert not model.sensor(RADIUS, 0.001) and samples(faults, False, 5) == [False] * 5
    out = faults.throw()
    assert out.kind == "fault" and out.lost and "arm faulted earlier" in out.fault
    faults.clear("part_lost")
    assert not model.on_arm  # clearing the injection does not put the part back
    model.place(EDGE, RADIUS)
    assert model.on_arm and not model.faulted and model.sensor(RADIUS, 0.001)
    assert faults.throw().kind in ("jog", "flip")


def test_a_throw_that_leaves_the_arm_marks_the_part_lost_other_faults_do_not():
    model = ThrowingArm(triangle(), TRIANGLE_PARAMS, 1, 0.17, arm_length=0.2)
    outcomes = [model.throw() for _ in range(5)]
    first = next(o for o in outcomes if o.kind == "fault")
    assert "left the arm" in first.fault and first.lost and not model.on_arm
    assert not model.sensor(0.17, 0.001)
    speed = arm()
    with pytest.raises(InputError) as info:
        speed.throw(0.0)
    assert info.value.field == "speed_scale"
