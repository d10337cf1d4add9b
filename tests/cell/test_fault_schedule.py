"""The controller's fault schedule: what is injected and cleared when, from the fault processes. No ROS."""

from __future__ import annotations

import math

from feeder_cell.controller.fault_schedule import FaultSchedule
from feeder_cell.experiment.faults_process import FaultProcess, FaultSpec

FIXED = FaultSpec("throwing_arm", "part_lost", mtbf=8.0, mttr=1.0, up="fixed", repair="fixed")


def test_nothing_is_due_without_fault_processes() -> None:
    schedule = FaultSchedule(())
    assert schedule.due(5.0) == [] and math.isnan(schedule.origin)


def test_times_count_from_the_first_look_and_each_failure_is_injected_then_cleared_once() -> None:
    schedule = FaultSchedule((FIXED,), seed=3)
    assert schedule.due(100.0) == [] and schedule.origin == 100.0
    assert schedule.due(107.9) == []
    injected = schedule.due(108.0)
    assert [(a.event.start, a.clear) for a in injected] == [(8.0, False)]
    assert schedule.under_repair_until("throwing_arm") == 109.0
    assert schedule.due(108.5) == []  # once
    cleared = schedule.due(109.0)
    assert [(a.event.start, a.clear) for a in cleared] == [(8.0, True)]
    assert schedule.under_repair_until("assembly_fixture") == -math.inf


def test_a_long_gap_between_looks_injects_every_failure_in_it_in_order_and_clears_the_ended() -> None:
    spec = FaultSpec("throwing_arm", "part_lost", mtbf=2.0, mttr=0.5)
    schedule = FaultSchedule((spec,), seed=11, replication=4)
    schedule.due(0.0)
    actions = schedule.due(30.0)
    expected = []
    for event in FaultProcess(spec, 11, 4).events():
        if event.start > 30.0:
            break
        expected.append(event)
    injected = [a.event for a in actions if not a.clear]
    cleared = [a.event for a in actions if a.clear]
    assert injected == expected and len(expected) > 3
    assert cleared == [e for e in expected if e.end <= 30.0]
    assert actions.index(next(a for a in actions if a.clear)) >= len(injected)  # injections first
    assert schedule.under_repair_until("throwing_arm") == expected[-1].end
