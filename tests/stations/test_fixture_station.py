"""The assembly fixture's station without ROS: the tick's cap, the interlock at a goal's start, a stall.

The station is what the assembly_fixture node and the ROS-free cell loop both tick (docs/devices.md,
"The station").
"""

from __future__ import annotations

import numpy as np

from feeder_device.declarations import ActiveFault
from feeder_sim.fixture import plan_goal
from feeder_sim.fixture.fault_specs import fault_specs
from feeder_sim.fixture.follow import goal_waypoints
from feeder_sim.fixture.parameters import FixtureParameters, max_advance_per_tick
from feeder_sim.fixture.station import FixtureStation

STALL = 301
TICK = 50_000_000  # ns: 20 Hz
FAULTS = fault_specs({"axis_stall": STALL, "rate_limit": 302})
# The cell scene's route: 30 degrees about y (towards the bracket's wall), which the block in its L
# bracket survives; 30 degrees the other way it slides out.
ROUTE = [(-0.5, 0.0, -0.8660254037844386)]
AWAY = [(0.5, 0.0, -0.8660254037844386)]


def follow(fixture: FixtureStation, gravity: list[tuple[float, float, float]]):  # type: ignore[no-untyped-def]
    waypoints = goal_waypoints(gravity, [], fixture.limits)
    return fixture.follow(waypoints, plan_goal(fixture.table, waypoints, fixture.p.path_step))


def test_an_advance_longer_than_the_cap_is_capped_and_said() -> None:
    fixture = FixtureStation(FixtureParameters(), STALL)
    cap = max_advance_per_tick(fixture.p)
    advanced = fixture.advance(int(10 * cap * 1e9))
    assert advanced.capped and advanced.stall is None and not advanced.move_ended
    assert np.isclose(fixture.table.time, cap)


def test_a_certified_path_is_followed_to_the_end() -> None:
    fixture = FixtureStation(FixtureParameters(), STALL)
    started = follow(fixture, ROUTE)
    assert started.early is None and started.goal is not None and started.verdict is not None
    assert started.verdict.stable and started.warning == ""
    assert fixture.table.moving
    ended = False
    for _ in range(2000):
        advanced = fixture.advance(TICK)
        ended = ended or advanced.move_ended
        fixture.advance_goal(started.goal, None, False)
        if started.goal.done:
            break
    assert started.goal.outcome is not None and started.goal.outcome.name == "REACHED"
    assert ended
    assert np.allclose(fixture.table.gravity(), ROUTE[0], atol=1e-6)


def test_the_interlock_refuses_an_unstable_path_and_nothing_moves() -> None:
    fixture = FixtureStation(FixtureParameters(), STALL)
    before = fixture.table.joints.copy()
    started = follow(fixture, AWAY)
    assert started.goal is None and started.early is not None
    assert started.early.name == "REFUSED" and "nothing moved" in started.early.message
    assert started.verdict is not None and not started.verdict.stable
    assert not fixture.table.moving and np.array_equal(fixture.table.joints, before)
    # The interlock off: the same path moves anyway, with the verdict's warning.
    loose = FixtureStation(FixtureParameters(interlock=False), STALL)
    started = follow(loose, AWAY)
    assert started.goal is not None and started.warning.startswith("interlock off, moving anyway")


def test_an_axis_stall_ends_the_goal_stalled_and_clearing_it_ends_the_fault() -> None:
    fixture = FixtureStation(FixtureParameters(), STALL)
    started = follow(fixture, ROUTE)
    assert started.goal is not None
    fixture.apply_fault(ActiveFault(FAULTS["axis_stall"], 0.0, False, (), 0.0, 0))
    stall = None
    for _ in range(200):
        stall = fixture.advance(TICK).stall
        if stall is not None:
            break
    assert stall is not None and fixture.stalls == 1
    model_fault = (STALL, stall.describe())
    fixture.advance_goal(started.goal, model_fault, False)
    assert started.goal.outcome is not None and started.goal.outcome.name == "STALLED"
    assert fixture.clear_fault("axis_stall", model_fault) is True
    assert fixture.clear_fault("rate_limit", None) is False
