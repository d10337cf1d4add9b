"""The squeeze gripper's station without ROS: the tick's cap, a squeeze goal to its end, a stall that acts.

The station is what the squeeze_gripper node ticks (docs/devices.md, "The station").
"""

from __future__ import annotations

from pathlib import Path

from feeder_device.declarations import ActiveFault
from feeder_sim.squeeze.fault_specs import fault_specs
from feeder_sim.squeeze.parameters import GripperParameters
from feeder_sim.squeeze.plan_goal import check_plan_goal
from feeder_sim.squeeze.station import SqueezeStation
from feeder_sim.squeeze.tolerances import MAX_ADVANCE_PER_TICK

RECTANGLE = Path(__file__).resolve().parents[2] / "examples" / "squeeze" / "rectangle.yaml"
START = 1_000_000_000
TICK = 20_000_000  # ns: 50 Hz
FAULTS = fault_specs({"jaw_stall": 1, "part_dropped": 2, "jaw_worn": 3})


def gripper() -> SqueezeStation:
    return SqueezeStation(GripperParameters(part_file=str(RECTANGLE)))


def test_a_tick_longer_than_the_cap_is_capped_and_said() -> None:
    station = gripper()
    ticked = station.tick(int(10 * MAX_ADVANCE_PER_TICK * 1e9))
    assert ticked.capped and ticked.fault is None
    assert abs(station.gripper.time - MAX_ADVANCE_PER_TICK) < 1e-12


def test_a_squeeze_goal_ends_done_with_one_squeeze() -> None:
    station = gripper()
    goal = station.start(check_plan_goal([0.3], 0.0), START)
    now, squeezes = START, 0
    for _ in range(5000):
        now += TICK
        squeezes += station.tick(TICK).squeezes
        station.advance_goal(goal, now, None)
        if goal.done:
            break
    assert goal.outcome is not None and goal.outcome.name == "DONE", goal.outcome
    assert squeezes == 1 and len(goal.outcome.widths) == 1


def test_a_jaw_stall_acts_during_a_squeeze_and_clearing_it_opens_the_jaws() -> None:
    station = gripper()
    station.apply_fault(ActiveFault(FAULTS["jaw_stall"], 0.0, False, (), 0.0, 0))
    goal = station.start(check_plan_goal([0.3], 0.0), START)
    fault = None
    now = START
    for _ in range(5000):
        now += TICK
        fault = station.tick(TICK).fault
        station.advance_goal(goal, now, None if fault is None else (1, fault[1]))
        if fault is not None:
            break
    assert fault is not None and fault[0] == "jaw_stall" and fault[1].endswith("(~/reset opens the jaws)")
    assert goal.outcome is not None and goal.outcome.name == "FAULT"
    assert station.clear_fault("jaw_stall", stalled=True) is True
    assert station.gripper.phase == "IDLE"
    assert station.clear_fault("jaw_worn", stalled=False) is False
