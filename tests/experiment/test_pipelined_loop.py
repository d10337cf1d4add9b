"""The pipelined policy in the ROS-free cell loop: parts conserved, one goal per device, throughput.

Under ``policy: pipelined`` the array orients the next cycle's part while the arm feeds the current one
(the machine's ``AHEAD`` rows); everything else (the tables, what counts as good or rejected) is the
sequential policy's.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable

import pytest

from feeder_cell.experiment.design import load_experiment, scene_of
from feeder_cell.experiment.loop import CellLoop, LoopResult, read_scene, scene_loop
from feeder_planner.errors import InputError

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "feeder_cell" / "scenes" / "cell.yaml"
POLICY = ROOT / "examples" / "experiments" / "policy.yaml"


def _guarded(loop: CellLoop) -> list[tuple[float, str]]:
    """Make every goal send check that its device holds no goal; return the overlaps seen per quantum."""
    for driver, name in ((loop.mems, "send_program"), (loop.arm, "send_feed"), (loop.fixture, "send_path")):
        send = getattr(driver, name)

        def checked(*args: Any, _driver: Any = driver, _send: Callable[..., None] = send) -> None:
            assert _driver.goal is None and _driver.pending_goal is None, (
                f"{_driver.name} sent a goal at {loop.t():.1f} s while it held one"
            )
            _send(*args)

        setattr(driver, name, checked)
    overlaps: list[tuple[float, str]] = []
    quantum = loop._quantum

    def watched() -> None:
        quantum()
        if loop.mems.goal is not None and (loop.arm.goal is not None or loop.fixture.goal is not None):
            overlaps.append((loop.t(), loop.machine.state.value))

    loop._quantum = watched  # type: ignore[method-assign]
    return overlaps


def _random_scene() -> Any:
    experiment = load_experiment(POLICY)
    return scene_of(experiment.document, experiment.scene)


@pytest.mark.parametrize("replication", [0, 1])
def test_a_pipelined_replication_conserves_parts_and_runs_one_goal_per_device(replication: int) -> None:
    loop = scene_loop(_random_scene(), replication, {"cell_controller": {"policy": "pipelined"}})
    overlaps = _guarded(loop)
    result = loop.run(until=lambda cycles: len(cycles) >= 5)
    assert result.end_state == "HORIZON", result.stop_reason
    complete = [c for c in result.cycles if c.complete]
    assert len(complete) == 5
    # Every complete cycle's part is good or rejected, exactly one of them.
    assert all(c.presented + c.rejected == 1 for c in complete)
    # Every arrival is accounted for: the five cycles' batches and the sixth's, in process at the horizon
    # (its ORIENT started ahead); none placed twice, none skipped.
    assert loop.batches == [1, 2, 3, 4, 5, 6]
    assert loop.ahead_started
    # The array did orient while the arm fed (and only then: the arm's states overlap it).
    assert overlaps and {state for _, state in overlaps} <= {"FEED", "TILT", "RETURN", "RECOVER", "TILT_SAFE"}


@pytest.mark.parametrize(
    ("device", "fault", "mtbf"),
    [("mems_field_array", "power_loss", 40.0), ("throwing_arm", "part_lost", 15.0)],
)
def test_a_pipelined_cell_that_stops_leaves_every_batch_accounted_for(
    device: str, fault: str, mtbf: float
) -> None:
    experiment = load_experiment(POLICY)
    document = {**experiment.document}
    document["faults"] = {device: {"fault": fault, "mtbf": mtbf, "mttr": 2.0, "distribution": "exponential"}}
    loop = scene_loop(scene_of(document, experiment.scene), 0, {"cell_controller": {"policy": "pipelined"}})
    result = loop.run(until=lambda cycles: len(cycles) >= 6)
    assert result.end_state == "STOPPED", "the measured run stops on the fault (seed 11, replication 0)"
    *complete, stopped = result.cycles
    assert all(c.complete and c.presented + c.rejected == 1 for c in complete) and not stopped.complete
    # Batches: one per recorded cycle, and the next one's when its ORIENT had started ahead.
    in_process = len(loop.batches) - len(complete)
    assert loop.batches == list(range(1, len(loop.batches) + 1))
    assert in_process == 1 + int(loop.ahead_started)


def test_sequential_never_overlaps_goals() -> None:
    loop = scene_loop(_random_scene(), 0)
    overlaps = _guarded(loop)
    result = loop.run(until=lambda cycles: len(cycles) >= 3)
    assert result.end_state == "HORIZON"
    assert overlaps == [] and loop.batches == [1, 2, 3] and not loop.ahead_started


def _run(policy: str, cycles: int) -> LoopResult:
    return scene_loop(read_scene(SCENE), 0, {"cell_controller": {"policy": policy, "cycles": cycles}}).run()


def test_pipelined_throughput_is_at_least_sequentials_on_the_default_scene() -> None:
    sequential, pipelined = _run("sequential", 4), _run("pipelined", 4)
    for result in (sequential, pipelined):
        assert result.end_state == "FINISHED" and sum(c.presented for c in result.cycles) == 4
    # Measured: sequential 17.1 s every cycle; pipelined 17.1 s, then 10.4 s (the array's orient alone:
    # the arm's 6.7 s of infeed, feed, tilt and return hide behind it).
    assert [round(c.time, 1) for c in sequential.cycles] == [17.1] * 4
    assert round(pipelined.cycles[0].time, 1) == 17.1
    assert all(c.time < 11.0 for c in pipelined.cycles[1:])
    assert pipelined.cell_time < sequential.cell_time
    # The same work per part: throws and the arm's RUNNING time do not depend on the policy.
    assert [c.throws for c in pipelined.cycles] == [c.throws for c in sequential.cycles]
    arm = "throwing_arm"
    assert pipelined.device_time[arm]["RUNNING"] == pytest.approx(sequential.device_time[arm]["RUNNING"])


def test_a_bad_policy_names_the_field(tmp_path: Path) -> None:
    with pytest.raises(InputError) as caught:
        scene_loop(read_scene(SCENE), 0, {"cell_controller": {"policy": "parallel"}})
    assert caught.value.field == "cell_controller.parameters.policy"
    bad = tmp_path / "exp.yaml"
    bad.write_text(
        POLICY.read_text()
        .replace("../../feeder_cell/scenes/cell.yaml", str(SCENE))
        .replace("[sequential, pipelined]", "[sequential, parallel]")
    )
    with pytest.raises(InputError) as caught:
        load_experiment(bad)
    assert "factors.cell_controller.policy[1]" in str(caught.value)
    assert "must be one of sequential, pipelined" in str(caught.value)


def test_the_ros_replay_refuses_a_pipelined_scenario_before_launching(tmp_path: Path) -> None:
    from feeder_cell.experiment.experiment import replay_scene

    experiment = load_experiment(POLICY)
    levels = [s.levels["cell_controller.policy"] for s in experiment.scenarios]
    pipelined = levels.index("pipelined")
    with pytest.raises(InputError) as caught:
        replay_scene(experiment, pipelined, 0, tmp_path)
    assert caught.value.field == "--scenario"
    assert "pipelined runs in the ROS-free loop only, so far" in str(caught.value)
    assert not any(tmp_path.iterdir())  # no scene written
