"""ROS-free: the goals of the fixture's ~/follow_path action (feeder_sim.fixture.follow).

Waypoints checked naming the field, tilt pairs turned into gravity by the kinematics' one definition, the path
planned on ~/move's code path, progress along it, and where a canceled goal stops (the next certified sample).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from feeder_planner.assembly import DEFAULT_ASSEMBLY_YAML, assembly_from_text, prepare
from feeder_planner.errors import InputError
from feeder_sim.fixture import (
    FixtureFaults,
    Table,
    TableLimits,
    certify,
    goal_waypoints,
    gravity_of,
    plan_goal,
    plan_path,
    sample_waypoints,
)
from feeder_sim.fixture.follow import BOTH_FIELDS, GRAVITY_FIELD, TILT_FIELD

STEP = math.radians(0.5)
LIMITS = TableLimits()


def _prepared():
    return prepare(assembly_from_text(DEFAULT_ASSEMBLY_YAML))


def _inside_region(prepared, fraction: float) -> list[np.ndarray]:
    """Two directions from the region planner: from its centre part way towards two of its vertices."""
    region = prepared.region
    waypoints = []
    for vertex in region.vertices[:2]:
        g = region.center + fraction * (vertex - region.center)
        waypoints.append(g / np.linalg.norm(g))
    return waypoints


# --- the waypoints, checked ----------------------------------------------------------------------
@pytest.mark.parametrize(
    "gravity,tilt,field,problem",
    [
        ([], [], BOTH_FIELDS, "at least one waypoint"),
        ([(0.0, 0.0, -1.0)], [0.1, 0.2], BOTH_FIELDS, "not both"),
        ([(0.0, 0.0, -1.0), (math.nan, 0.0, -1.0)], [], f"{GRAVITY_FIELD}[1]", "finite"),
        ([(0.0, 0.0, 0.0)], [], f"{GRAVITY_FIELD}[0]", "non-zero"),
        ([], [0.1, 0.2, 0.3], TILT_FIELD, "odd number"),
        ([], [0.1, math.inf], f"{TILT_FIELD}[1] (tilt_y of waypoint 0)", "finite"),
        ([], [0.0, 0.0, 2.0, 0.0], f"{TILT_FIELD}[2] (tilt_x of waypoint 1)", "outside the joint range"),
        ([], [0.0, -3.5], f"{TILT_FIELD}[1] (tilt_y of waypoint 0)", "outside the joint range"),
    ],
)
def test_bad_waypoints_are_refused_naming_the_field(gravity, tilt, field, problem) -> None:
    with pytest.raises(InputError) as caught:
        goal_waypoints(gravity, tilt, LIMITS)
    assert caught.value.field == field and problem in caught.value.problem, str(caught.value)


def test_tilt_limits_are_the_configured_ranges_not_the_mechanism() -> None:
    narrow = TableLimits(y_min=-0.5, y_max=0.5)
    assert len(goal_waypoints([], [0.0, -0.6], LIMITS).gravity) == 1
    with pytest.raises(InputError, match=r"tilt_waypoints\[1\].*outside the joint range \[-0.5, 0.5\]"):
        goal_waypoints([], [0.0, -0.6], narrow)


def test_gravity_waypoints_become_unit_directions() -> None:
    waypoints = goal_waypoints([(0.0, 0.0, -2.0), (1.0, 0.0, -1.0)], [], LIMITS)
    assert waypoints.field == GRAVITY_FIELD and waypoints.tilt is None
    assert np.allclose(waypoints.gravity[0], [0.0, 0.0, -1.0])
    assert np.allclose(waypoints.gravity[1], np.array([1.0, 0.0, -1.0]) / math.sqrt(2))


def test_tilt_pairs_become_gravity_by_the_kinematics() -> None:
    pairs = [0.2, -0.3, -0.1, 0.4]
    waypoints = goal_waypoints([], pairs, LIMITS)
    assert waypoints.field == TILT_FIELD and waypoints.tilt is not None
    for g, q in zip(waypoints.gravity, np.reshape(pairs, (-1, 2)), strict=True):
        assert np.array_equal(g, gravity_of(q))


# --- planning -----------------------------------------------------------------------------------
def test_plan_path_is_moves_code_path_and_indexes_the_waypoints() -> None:
    prepared = _prepared()
    table = Table(np.zeros(2), LIMITS)
    waypoints = _inside_region(prepared, 0.5)
    planned = plan_path(table, waypoints, STEP)
    # the same samples and joints ~/move planned before the action existed
    samples = sample_waypoints(table.gravity(), waypoints, STEP)
    assert np.array_equal(planned.samples, samples)
    assert np.array_equal(planned.path.joints, table.plan(samples[1:]).joints)
    assert planned.waypoint_samples[-1] == len(samples) - 1
    for index, w in zip(planned.waypoint_samples, waypoints, strict=True):
        assert np.allclose(planned.samples[index], w, atol=1e-12)
    angles = np.arccos(np.clip(np.sum(samples[1:] * samples[:-1], axis=1), -1, 1))
    assert np.all(angles <= STEP + 1e-12)
    for q, g in zip(planned.path.joints, planned.samples, strict=True):
        assert np.allclose(gravity_of(q), g, atol=1e-12)
    # both waypoints lie in the planner's region, so by Property 2 every sample is certified
    assert certify(prepared, planned.samples).stable


def test_tilt_waypoints_are_reached_as_the_angles_asked() -> None:
    table = Table(np.zeros(2), LIMITS)
    asked = np.array([[0.1, -0.4], [-0.2, -0.7]])
    planned = plan_goal(table, goal_waypoints([], asked.ravel().tolist(), LIMITS), STEP)
    for q, index in zip(asked, planned.waypoint_samples, strict=True):
        assert np.allclose(planned.path.joints[index], q, atol=1e-12)
    assert np.allclose(planned.path.joints[-1], asked[-1], atol=1e-12)


def test_a_tilt_pair_at_gimbal_lock_is_refused_naming_it() -> None:
    table = Table(np.zeros(2), LIMITS)
    with pytest.raises(InputError) as caught:
        plan_goal(table, goal_waypoints([], [0.0, -0.2, math.pi / 2, 0.7], LIMITS), STEP)
    assert caught.value.field == f"{TILT_FIELD}[2:4] (waypoint 1)", str(caught.value)
    assert "tilt_y" in caught.value.problem


def test_a_path_leaving_the_joint_ranges_is_refused_naming_the_goal_field() -> None:
    table = Table(np.zeros(2), TableLimits(y_min=-0.3, y_max=0.3))
    with pytest.raises(InputError) as caught:
        plan_path(table, [gravity_of(np.array([0.0, -0.6]))], STEP, GRAVITY_FIELD)
    assert caught.value.field.startswith(f"{GRAVITY_FIELD} (sample "), str(caught.value)
    assert "tilt_y" in caught.value.problem and "outside" in caught.value.problem


def test_antipodal_consecutive_waypoints_are_refused_naming_the_waypoint() -> None:
    table = Table(np.zeros(2), LIMITS)
    with pytest.raises(InputError) as caught:
        plan_path(table, [np.array([1.0, 0.0, 0.0]), np.array([-1.0, 0.0, 0.0])], STEP, GRAVITY_FIELD)
    assert caught.value.field == f"{GRAVITY_FIELD}[1]"
    assert "antipodal to gravity_waypoints[0]" in caught.value.problem
    with pytest.raises(InputError, match=r"gravity_waypoints\[0\]: is antipodal to the start"):
        plan_path(table, [np.array([0.0, 0.0, 1.0])], STEP, GRAVITY_FIELD)


# --- progress -----------------------------------------------------------------------------------
def _follow(table: Table, planned, dt: float) -> list[tuple[float, float]]:
    """Advance the table along the planned path; return (time, progress) after every step."""
    table.start(planned.path)
    seen = []
    t = 0.0
    while table.moving:
        table.advance(dt)
        t += dt
        seen.append((t, planned.progress(table.joints, table.remaining)))
    return seen


def test_progress_is_the_planned_time_fraction_and_rises_to_one() -> None:
    table = Table(np.zeros(2), LIMITS)
    planned = plan_path(table, _inside_region(_prepared(), 0.6), STEP)
    seen = _follow(table, planned, 0.013)
    progress = [p for _, p in seen]
    assert progress[-1] == 1.0 and all(b >= a for a, b in zip(progress, progress[1:], strict=False))
    duration = planned.path.duration
    for t, p in seen[:-1]:  # no fault: the motion is the planned timing, so progress is time / duration
        assert p == pytest.approx(min(t / duration, 1.0), abs=1e-9)


def test_progress_under_a_rate_limit_follows_the_position_not_the_clock() -> None:
    faults = FixtureFaults()
    table = Table(np.zeros(2), LIMITS, faults)
    planned = plan_path(table, [gravity_of(np.array([0.0, -0.5]))], STEP)
    faults.inject("rate_limit", LIMITS, value=0.5, indices=(1,))  # after planning: it takes twice as long
    seen = _follow(table, planned, 0.01)
    assert seen[-1][1] == 1.0
    t, p = seen[len(seen) // 2]
    assert p == pytest.approx(t / (2 * planned.path.duration), abs=1e-9)


def test_a_clock_stepped_by_exactly_the_duration_finds_the_table_at_the_end() -> None:
    table = Table(np.zeros(2), LIMITS)
    planned = plan_path(table, [gravity_of(np.array([0.0, -0.5]))], STEP)  # 0.5 s at 1 rad/s
    table.start(planned.path)
    for _ in range(10):  # whole node-clock steps of 0.05 s, as a stepped cell clock gives them
        table.advance(50_000_000 / 1e9)
    assert not table.moving and np.array_equal(table.joints, planned.path.joints[-1])


# --- cancel ---------------------------------------------------------------------------------------
def test_cancel_stops_at_the_next_sample_ahead_and_it_is_certified() -> None:
    prepared = _prepared()
    table = Table(np.zeros(2), LIMITS)
    planned = plan_path(table, _inside_region(prepared, 0.6), STEP)
    table.start(planned.path)
    table.advance(0.3037)  # mid-segment
    before = table.joints.copy()
    stop = planned.cancel_stop(table.joints, table.remaining, lambda j: True)
    assert stop.keep == 1 and stop.certified
    assert stop.sample == len(planned.path.joints) - table.remaining  # the one the table was heading for
    table.truncate(stop.keep)
    table.advance(1.0)
    assert not table.moving
    assert np.array_equal(table.joints, planned.path.joints[stop.sample])
    assert np.linalg.norm(table.joints - before) <= STEP  # at most one sample on
    assert prepared.check(table.gravity()).stable


def test_cancel_on_a_sample_halts_there() -> None:
    table = Table(np.zeros(2), LIMITS)
    planned = plan_path(table, [gravity_of(np.array([0.0, -0.5]))], STEP)
    table.start(planned.path)
    t3 = planned.path.times[3]
    table.advance(t3)
    assert np.allclose(table.joints, planned.path.joints[3], atol=1e-15)
    stop = planned.cancel_stop(table.joints, table.remaining, lambda j: True)
    assert (stop.sample, stop.keep, stop.certified) == (3, 0, True)
    table.truncate(stop.keep)
    assert not table.moving


def test_cancel_with_the_interlock_off_runs_on_to_the_next_certified_sample_or_says_none() -> None:
    table = Table(np.zeros(2), LIMITS)
    planned = plan_path(table, [gravity_of(np.array([0.0, -0.5]))], STEP)
    table.start(planned.path)
    table.advance(0.101)
    ahead = len(planned.path.joints) - table.remaining
    stop = planned.cancel_stop(table.joints, table.remaining, lambda j: j >= ahead + 3)
    assert (stop.sample, stop.keep, stop.certified) == (ahead + 3, 4, True)
    none = planned.cancel_stop(table.joints, table.remaining, lambda j: False)
    assert (none.sample, none.keep, none.certified) == (ahead, 1, False)


def test_progress_and_cancel_need_a_move_in_progress() -> None:
    table = Table(np.zeros(2), LIMITS)
    planned = plan_path(table, [gravity_of(np.array([0.0, -0.5]))], STEP)
    assert planned.progress(table.joints, 0) == 1.0
    with pytest.raises(ValueError, match="not in progress"):
        planned.cancel_stop(table.joints, 0, lambda j: True)
