"""The ROS-free cell loop is the ROS cell: the same cycles as `feeder launch --real-time-factor max`.

Issue 38 item 5. The cell scene (feeder_cell/scenes/cell.yaml) runs through `feeder launch` in lockstep
(the cell host, the cell clock's 0.1 s quantum), and the same scene and replication through
``feeder_cell.experiment.loop``. Every cycle's cell time (the log prints it to 0.01 s; both are whole
quanta), its throws, the cumulative faults seen and handled, every fault-policy line (state, outcome,
code, policy) and the end agree. Two scenes: the default (no random inputs: every cycle 17.10 s, 11
throws), and one with a seed, arrivals and a fault process whose first failure falls in cycle 1's feed.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
import yaml

from feeder_cell.experiment.loop import LoopResult, read_scene, scene_loop
from feeder_cell.launcher import scene_copy

pytestmark = pytest.mark.ros  # it runs the scene through `feeder launch`: real node processes over DDS

ROOT = Path(__file__).resolve().parents[2]
CYCLE = re.compile(
    r"cycle (\d+): ([\d.]+) s \(.*?\), (\d+) throws; \d+ cycles, (\d+) parts, "
    r".*?faults seen (\d+) handled (\d+)"
)
POLICY = re.compile(r"\]: (\w+): (\w+)(?: (\d+))? .*-> (RETRY|RESET_RETRY|STOP)")
ARRIVALS = {
    "mems": {"orientation": "uniform", "feed_area": {"x": [-0.001, 0.001], "y": [-0.001, 0.001]}},
    "arm": {"drop": "quasi_static", "radius": [0.115, 0.125]},
}
# part_lost 11.6 s after the first cycle starts (in cycle 1's feed at seed 21), repaired 0.5 s later.
FAULTS = {"throwing_arm": {"fault": "part_lost", "mtbf": 11.6, "mttr": 0.5, "distribution": "fixed"}}


def _scene(tmp_path: Path, extra: dict[str, Any]) -> Path:
    path = scene_copy(ROOT / "feeder_cell/scenes/cell.yaml", tmp_path, {"cell_controller": {"cycles": 2}})
    document = yaml.safe_load(path.read_text())
    path.write_text(yaml.safe_dump({**document, **extra}))
    return path


def _ros_log(path: Path, logs: Path) -> str:
    """Run the scene through feeder launch in lockstep at max speed; return the controller's log."""
    import ros_harness

    lease = ros_harness.DomainLease()
    try:
        result = subprocess.run(
            [sys.executable, "-m", "feeder_cell.cli.main", "launch", str(path), "--real-time-factor", "max"]
            + ["--log-dir", str(logs)],
            env=dict(os.environ, ROS_DOMAIN_ID=str(lease.domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST"),
            capture_output=True,
            text=True,
            timeout=400,
        )
    finally:
        lease.release()
    (controller_log,) = sorted(logs.glob("cell.cell_controller-*.log"))
    log = controller_log.read_text()
    assert result.returncode == 0, f"{result.stderr[-1500:]}\n{log[-3000:]}"
    return log


def _compare(log: str, loop: LoopResult) -> None:
    """Assert the loop's cycles are the log's, and both finished."""
    ros = [
        (int(c), float(t), int(n), int(parts), int(seen), int(handled))
        for c, t, n, parts, seen, handled in CYCLE.findall(log)
    ]
    seen = handled = parts = 0
    mine = []
    for record in loop.cycles:
        seen, handled = seen + record.faults_seen, handled + record.faults_handled
        parts += record.presented + record.rejected  # the ROS count: every part the sensor presented
        mine.append((record.cycle, round(record.time, 2), record.throws, parts, seen, handled))
    assert mine == ros, f"loop {mine}\nROS {ros}\n{log[-3000:]}"
    assert "cell FINISHED: 2 cycles, 2 parts" in log and loop.end_state == "FINISHED"


def _loop_policies(loop: LoopResult) -> list[tuple[str, str, int, str]]:
    """The loop's fault-policy decisions as the log's lines give them: (state, event, code, policy)."""
    out = []
    for _, source, outcome, target in loop.transitions:
        event, *rest = outcome.split(" ")
        if target == "RECOVER":
            policy = "RESET_RETRY"
        elif target == source:
            policy = "RETRY"
        elif target == "STOPPED":
            policy = "STOP"
        else:
            continue
        code = int(rest[0]) if rest and rest[0].isdigit() else 0
        out.append((source, event, code, policy))
    return out


@pytest.mark.parametrize("case", ["default", "fault"])
def test_a_replication_equals_the_ros_lockstep_run(tmp_path: Path, case: str) -> None:
    """Same cycle times, throws, parts, faults seen and handled, policy decisions; both FINISHED."""
    extra = {} if case == "default" else {"seed": 21, "arrivals": ARRIVALS, "faults": FAULTS}
    path = _scene(tmp_path, extra)
    loop = scene_loop(read_scene(path), replication=0).run()
    log = _ros_log(path, tmp_path / "logs")
    _compare(log, loop)
    ros_policies = [(s, e, int(c or 0), p) for s, e, c, p in POLICY.findall(log)]
    assert _loop_policies(loop) == ros_policies, log[-3000:]
    times = [round(r.time, 2) for r in loop.cycles]
    if case == "default":
        # The figure the issue quotes: every cycle 17.10 s of cell time and 11 throws.
        assert times == [17.1, 17.1] and [r.throws for r in loop.cycles] == [11, 11]
    else:
        # The failure met in cycle 1's feed, reset after its repair, the part fed again.
        assert ros_policies == [("FEED", "FAULT", 102, "RESET_RETRY")]
        assert [(f.start, f.end) for f in loop.failures[:1]] == [(11.6, 12.1)]
        assert times == [15.8, 19.9]


def test_replay_runs_a_replication_as_a_ros_scene_with_a_bag(tmp_path: Path) -> None:
    """`feeder experiment FILE --replay 1 --scenario 1 --record DIR`: the ROS run's cycles are the loop's
    (scenario 1's period 0.4 s, arrivals, a part_lost process), and the bag holds the arm's throw events."""
    import ros_harness

    experiment = {
        "scene": str(ROOT / "feeder_cell/scenes/cell.yaml"),
        "seed": 7,
        "arrivals": ARRIVALS,
        "faults": {"throwing_arm": {"fault": "part_lost", "mtbf": 30.0, "mttr": 2.0}},
        "factors": {"throwing_arm.period": [0.5, 0.4]},
        "replications": 2,
        "horizon": {"cycles": 2},
    }
    path = tmp_path / "exp.yaml"
    path.write_text(yaml.safe_dump(experiment))
    bag = tmp_path / "bag"
    lease = ros_harness.DomainLease()
    try:
        result = subprocess.run(
            [sys.executable, "-m", "feeder_cell.cli.main", "experiment", str(path), "--replay", "1"]
            + ["--scenario", "1", "--record", str(bag)],
            env=dict(os.environ, ROS_DOMAIN_ID=str(lease.domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST"),
            capture_output=True,
            text=True,
            timeout=400,
        )
    finally:
        lease.release()
    assert result.returncode == 0, result.stderr[-3000:]
    expected = re.search(r"the loop's cycles: (.*)", result.stderr)
    scene = re.search(r"as a ROS scene: (\S+)", result.stderr)
    assert expected and scene, result.stderr[-3000:]
    (log_file,) = sorted((Path(scene.group(1)).parent / "logs").glob("cell.cell_controller-*.log"))
    ros = [f"cycle {c}: {t} s, {n} throws" for c, t, n, *_ in CYCLE.findall(log_file.read_text())]
    assert ros == expected.group(1).split("; ") and len(ros) == 2, (ros, expected.group(1))
    assert "/cell/throwing_arm/throw_events" in (bag / "metadata.yaml").read_text()
