"""The fixture's table model and its injected faults, without ROS: motion by elapsed time, stall, encoders."""

from __future__ import annotations

import math

import numpy as np
import pytest

from feeder_planner.errors import InputError
from feeder_sim.fixture import FixtureFaults, Table, TableLimits, gravity_of, sample_waypoints


def _path(table: Table, joints: tuple[float, float]):
    samples = sample_waypoints(table.gravity(), [gravity_of(np.array(joints))], math.radians(0.5))
    return table.plan(samples[1:])


def test_advancing_by_elapsed_time_follows_the_planned_timing_exactly() -> None:
    table = Table(np.zeros(2), TableLimits(rate_x=0.5, rate_y=2.0))
    path = _path(table, (0.15, -0.6))
    table.start(path)
    t = 0.0
    for dt in (0.013, 0.05, 0.2, 0.0, 0.031, 0.1):  # irregular ticks: the motion depends only on the time
        t += dt
        assert table.advance(dt) is None
        expected, velocity = path.at(t)
        assert table.joints == pytest.approx(expected, abs=1e-12)
        assert table.velocity == pytest.approx(velocity, abs=1e-12)
        assert table.moving == (t < path.duration)
    assert table.time == pytest.approx(t)
    table.advance(path.duration)  # more than what is left: it ends on the goal and stops
    assert table.joints == pytest.approx(path.joints[-1], abs=1e-12)
    assert not table.moving and not table.velocity.any()


def test_halt_stops_where_the_table_is() -> None:
    table = Table(np.zeros(2), TableLimits())
    table.start(_path(table, (0.0, -0.5)))
    table.advance(0.2)
    where = table.joints.copy()
    table.halt()
    table.advance(1.0)
    assert table.joints == pytest.approx(where) and not table.moving and where[1] == pytest.approx(-0.2)


def test_axis_stall_stops_the_move_where_the_joint_reaches_the_angle() -> None:
    table = Table(np.zeros(2), TableLimits())
    table.faults.inject("axis_stall", table.limits, indices=[1], angle=-0.3)
    path = _path(table, (0.1, -0.6))
    table.start(path)
    stall = None
    while stall is None and table.moving:
        stall = table.advance(0.05)
    assert stall is not None and stall.axis == 1 and stall.angle == -0.3
    assert table.joints[1] == -0.3 and stall.joints[1] == -0.3
    # the other axis stopped with it, on the planned path (tilt_y falls monotonically along it)
    on_path = np.interp(-0.3, path.joints[::-1, 1], path.joints[::-1, 0])
    assert table.joints[0] == pytest.approx(on_path, abs=1e-12) and 0 < on_path < 0.1
    assert stall.goal == pytest.approx([0.1, -0.6], abs=1e-12)
    assert not table.moving and "tilt_y stalled at -0.3 rad" in stall.describe()
    assert "unfinished" in stall.describe()
    # An axis that is not driven does not stall; cleared, the joint moves on.
    table.start(_path(table, (0.1, -0.3)))
    assert table.advance(1.0) is None
    table.faults.clear("axis_stall")
    table.start(_path(table, (0.1, -0.6)))
    assert table.advance(2.0) is None and table.joints == pytest.approx([0.1, -0.6], abs=1e-12)


def test_a_stall_at_the_present_angle_stops_the_next_move_at_once() -> None:
    table = Table(np.array([0.0, -0.2]), TableLimits())
    table.faults.inject("axis_stall", table.limits, indices=[], angle=-0.2)  # empty: both axes
    table.start(_path(table, (0.0, 0.2)))
    stall = table.advance(0.05)
    assert stall is not None and table.joints == pytest.approx([0.0, -0.2], abs=1e-15)


def test_encoder_offset_and_noise_change_only_the_reading() -> None:
    table = Table(np.array([0.1, -0.2]), TableLimits())
    table.faults.inject("encoder_offset", table.limits, value=0.05, indices=[0])
    assert table.reading() == pytest.approx([0.15, -0.2], abs=1e-15)
    assert table.joints == pytest.approx([0.1, -0.2])
    table.faults.inject("encoder_noise", table.limits, value=0.01, indices=[1], seed=7)
    readings = np.array([table.reading() for _ in range(2000)])
    assert np.all(readings[:, 0] == pytest.approx(0.15, abs=1e-15))
    assert np.std(readings[:, 1]) == pytest.approx(0.01, rel=0.1)
    assert np.mean(readings[:, 1]) == pytest.approx(-0.2, abs=1e-3)
    # The same seed gives the same readings in the same order; another seed others.
    again = FixtureFaults()
    again.inject("encoder_noise", table.limits, value=0.01, indices=[1], seed=7)
    other = FixtureFaults()
    other.inject("encoder_noise", table.limits, value=0.01, indices=[1], seed=8)
    first = [again.read(np.array([0.1, -0.2]))[1] for _ in range(5)]
    assert first == pytest.approx(readings[:5, 1] - 0.0, abs=1e-15)
    assert [other.read(np.array([0.1, -0.2]))[1] for _ in range(5)] != pytest.approx(first)
    table.faults.clear("encoder_noise")
    table.faults.clear("encoder_offset")
    assert table.reading() == pytest.approx([0.1, -0.2], abs=0.0)


def test_rate_limit_slows_the_axis_even_in_the_middle_of_a_move() -> None:
    table = Table(np.zeros(2), TableLimits())
    table.faults.inject("rate_limit", table.limits, value=0.25, indices=[1])
    path = _path(table, (0.0, -0.5))
    assert path.duration == pytest.approx(0.5 / 0.25, rel=1e-9)
    table.faults.clear("rate_limit")
    table.start(_path(table, (0.0, -0.5)))
    table.advance(0.2)
    assert table.joints[1] == pytest.approx(-0.2)
    table.faults.inject("rate_limit", table.limits, value=0.5, indices=[1])
    table.advance(0.2)
    assert table.joints[1] == pytest.approx(-0.3) and table.velocity[1] == pytest.approx(-0.5)
    table.advance(0.4)
    assert table.joints[1] == pytest.approx(-0.5) and not table.moving


@pytest.mark.parametrize(
    "name, fields, named",
    [
        ("axis_stall", {"angle": math.nan}, "angle"),
        ("axis_stall", {"angle": 2.0, "indices": [0]}, "angle"),  # tilt_x only reaches pi/2
        ("axis_stall", {"angle": 0.1, "indices": [2]}, "indices[0]"),
        ("axis_stall", {"angle": 0.1, "indices": [1, 1]}, "indices"),
        ("encoder_offset", {"value": 0.0}, "value"),
        ("encoder_offset", {"value": 1.0}, "value"),  # more than 45 degrees
        ("encoder_noise", {"value": -0.01}, "value"),
        ("rate_limit", {"value": 0.0}, "value"),
        ("rate_limit", {"value": 1.5}, "value"),
        ("motor_fault", {}, "fault"),
    ],
)
def test_bad_fault_magnitudes_name_the_field(name: str, fields: dict, named: str) -> None:
    faults = FixtureFaults()
    with pytest.raises(InputError) as caught:
        faults.inject(name, TableLimits(), **fields)
    assert caught.value.field == named
    assert faults.names == ()
