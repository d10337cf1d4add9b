"""The two-axis tilting table: joints <-> gravity, joint limits, rate-limited timing, the interlock."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import random_directions

from feeder_planner.errors import InputError
from feeder_sim.fixture.interlock import certify, sample_waypoints
from feeder_sim.fixture.kinematics import TableLimits, gravity_of, joints_of, plan_joint_path


def _rotation(alpha: float, beta: float) -> np.ndarray:
    ca, sa, cb, sb = math.cos(alpha), math.sin(alpha), math.cos(beta), math.sin(beta)
    rx = np.array([[1, 0, 0], [0, ca, -sa], [0, sa, ca]])
    ry = np.array([[cb, 0, sb], [0, 1, 0], [-sb, 0, cb]])
    return rx @ ry


def test_gravity_is_world_down_seen_from_the_tilted_table() -> None:
    for alpha, beta in [(0.3, -1.2), (-1.0, 2.5), (0.0, 0.0)]:
        expected = _rotation(alpha, beta).T @ np.array([0, 0, -1.0])
        assert gravity_of(np.array([alpha, beta])) == pytest.approx(expected, abs=1e-15)


def test_every_direction_is_reached_and_inverse_kinematics_round_trips() -> None:
    for g in random_directions(500, 3):
        assert gravity_of(joints_of(g)) == pytest.approx(g, abs=1e-12)


def test_joint_limits_refuse_naming_the_sample() -> None:
    limits = TableLimits(x_min=-0.5, x_max=0.5).validate()
    with pytest.raises(InputError, match=r"sample 0.*tilt_x"):
        plan_joint_path(np.array([[0.0, -1.0, 0.0]]), np.zeros(2), limits)


def test_timing_respects_the_rate_limits() -> None:
    limits = TableLimits(rate_x=0.5, rate_y=2.0).validate()
    samples = sample_waypoints(np.array([0, 0, -1.0]), [np.array([0.5, -0.5, -1.0])], math.radians(1))
    path = plan_joint_path(samples[1:], np.zeros(2), limits)
    rates = np.abs(np.diff(path.joints, axis=0)) / np.diff(path.times)[:, None]
    assert rates[:, 0].max() <= 0.5 + 1e-9 and rates[:, 1].max() <= 2.0 + 1e-9
    assert path.at(path.duration + 1)[0] == pytest.approx(joints_of(samples[-1]))
    assert gravity_of(path.at(path.duration)[0]) == pytest.approx(samples[-1] / np.linalg.norm(samples[-1]))


@pytest.mark.parametrize(
    "limits, field",
    [
        (TableLimits(x_min=0.2, x_max=0.1), "tilt_x_min/tilt_x_max"),
        (TableLimits(rate_y=0.0), "max_rate_y"),
        (TableLimits(y_max=math.nan), "tilt_y_max"),
    ],
)
def test_bad_limits_name_the_parameter(limits: TableLimits, field: str) -> None:
    with pytest.raises(InputError) as caught:
        limits.validate()
    assert caught.value.field == field


def test_interlock_finds_the_first_unstable_sample_and_the_body(example) -> None:
    prepared = example("block_in_l_bracket", mu=0.3)
    samples = sample_waypoints(np.array([0, 0, -1.0]), [np.array([1.0, 0.0, -0.3])], math.radians(1))
    verdict = certify(prepared, samples)
    assert not verdict.stable and verdict.unbalanced_bodies == ("block",)
    first = verdict.first_unstable
    assert all(prepared.check(g).stable for g in samples[:first])
    assert prepared.region.margin(samples[first]) <= 1e-9
