"""The squeeze cell over DDS: `feeder launch cell_squeeze.yaml --real-time-factor max`, the gripper orienting.

One launch for the module, in lockstep at ``max`` with a fixed start and a recorded bag: the reference
controller brings up the squeeze gripper, the arm and the fixture, asks the squeeze planner for the
rectangle's plan once, and runs the scene's three cycles with the gripper as the orienting station (a new
part at a random orientation, the plan, then infeed, feed, tilt and return). The scene's copy adds a
fault process to the gripper (``part_dropped`` certain for 0.6 s every 8.7 s of cell time: a drop in the
second and in the third cycle's ORIENT): the fault policy's RESET_RETRY resets the gripper, waits for its
jaws to open, places a new part and runs the plan again. The tests read what the controller logged and
what the bag holds: the gripper's own counters and the controller's last status.
"""

from __future__ import annotations

import math
import os
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
import ros_harness
import yaml

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "feeder_cell" / "scenes" / "cell_squeeze.yaml"
START_S = 1000.0
CYCLES = 3  # the scene's
RECTANGLE_PLAN = (0.0, math.pi / 4)  # Goldberg's two squeezes for the 2 x 1 rectangle (docs/squeeze.md)
ORIENT_TOLERANCE = 1e-7  # rad: the ideal fidelity ends at the plan's final orientation to rounding
# A dropped part while injected (probability 1 a squeeze); fixed times: failures from +8.7 s and +18.0 s,
# 0.6 s each (the controller injects at the first quantum after, 0.1 s later). The first drops the part at
# the first squeeze of cycle 2 (it ends at +9.22 s), its repair over before RECOVER begins: the reset
# comes at once and RECOVER must wait for the jaws to open before ~/place_part (refused while OPENING). The
# second drops cycle 3's, RECOVER waiting out the repair.
FAULTS = {
    "squeeze_gripper": {
        "fault": "part_dropped",
        "value": 1.0,
        "mtbf": 8.7,
        "mttr": 0.6,
        "distribution": "fixed",
    }
}


@dataclass
class Run:
    """One launch of the scene: its exit code, the controller's log, the last message of each topic."""

    returncode: int
    stderr: str
    log: str
    last: dict[str, Any]
    topics: set[str]


def _read_bag(bag: Path) -> tuple[dict[str, Any], set[str]]:
    """Return the last message of every status topic (decoded) and the set of topics recorded."""
    from mcap.reader import make_reader
    from rclpy.serialization import deserialize_message

    from feeder_cell.bag.types import message_class

    last: dict[str, Any] = {}
    topics: set[str] = set()
    for path in sorted(bag.glob("*.mcap")):
        with open(path, "rb") as handle:
            for schema, channel, message in make_reader(handle).iter_messages(log_time_order=True):
                topics.add(channel.topic)
                if channel.topic.endswith("/status"):
                    last[channel.topic] = deserialize_message(message.data, message_class(schema.name))
    return last, topics


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> Run:
    from feeder_cell.launcher import scene_copy

    folder = tmp_path_factory.mktemp("squeeze_cell")
    bag, logs = folder / "bag", folder / "logs"
    scene = scene_copy(SCENE, folder, {})
    document = yaml.safe_load(scene.read_text())
    scene.write_text(yaml.safe_dump({**document, "seed": 3, "faults": FAULTS}))
    lease = ros_harness.DomainLease()
    env = dict(os.environ, ROS_DOMAIN_ID=str(lease.domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    command = [sys.executable, "-m", "feeder_cell.cli.main", "launch", str(scene)]
    command += ["--real-time-factor", "max", "--start-time", str(START_S), "--record", str(bag)]
    command += ["--log-dir", str(logs), "--json"]
    try:
        result = subprocess.run(command, env=env, capture_output=True, text=True, timeout=400, cwd=folder)
    finally:
        lease.release()
    controller = sorted(logs.glob("cell.cell_controller-*.log"))
    log = controller[0].read_text() if controller else ""
    last, topics = _read_bag(bag) if bag.is_dir() else ({}, set())
    return Run(result.returncode, result.stderr, log, last, topics)


def drops(log: str) -> int:
    """Return the dropped parts the fault policy reset and retried."""
    return len(re.findall(r"ORIENT: FAULT 402 .* -> RESET_RETRY: reset squeeze, then retry", log))


def test_the_controller_finishes_its_cycles_orienting_on_the_gripper(run: Run) -> None:
    assert run.returncode == 0, f"{run.stderr[-1500:]}\n{run.log[-2000:]}"
    assert f"cell FINISHED: {CYCLES} cycles, {CYCLES} parts" in run.log
    status = run.last["/cell/cell_controller/status"]
    assert (status.state, status.cycles_completed, status.parts_presented) == ("FINISHED", CYCLES, CYCLES)
    # Every fault seen was a dropped part, and each was handled: the cell went on.
    dropped = drops(run.log)
    assert dropped >= 1 and (status.faults_seen, status.faults_handled) == (dropped, dropped)
    assert status.stopped is False and status.retries == dropped
    # Each cycle's line counts the plan's squeezes beside the arm's throws (a dropped part's too).
    per_cycle = re.findall(r"cycle \d+: [\d.]+ s \(orient [\d.]+ .*, \d+ throws, (\d+) squeezes", run.log)
    assert len(per_cycle) == CYCLES and all(int(n) >= 2 for n in per_cycle), per_cycle
    # The MEMS array is not in this cell: the controller never waited on it.
    assert not any("mems_field_array" in topic for topic in run.topics), sorted(run.topics)


def test_the_planners_plan_is_asked_once_and_orients_every_new_part(run: Run) -> None:
    plans = re.findall(r"squeeze plan from \S+: (\d+) squeezes at \[([^\]]*)\] rad", run.log)
    assert len(plans) == 1, plans
    angles = [float(a) for a in plans[0][1].split(",")]
    assert angles == pytest.approx(RECTANGLE_PLAN, abs=1e-6)
    arrivals = [float(a) for a in re.findall(r"a part arrives in the squeeze gripper at (\S+) rad", run.log)]
    # A part each cycle and one after each drop, from the gripper's seeded stream: all different.
    assert len(arrivals) == CYCLES + drops(run.log) and len(set(arrivals)) == len(arrivals)
    errors = re.findall(r"ORIENT on the squeeze gripper: 2 squeezes.*\((\S+) rad from the plan", run.log)
    assert len(errors) == CYCLES and all(abs(float(e)) < ORIENT_TOLERANCE for e in errors), errors


def test_the_grippers_counters_show_the_plans_run_and_the_drops(run: Run) -> None:
    status = run.last["/cell/squeeze_gripper/status"]
    counters = dict(zip(status.counter_names, status.counter_values, strict=True))
    dropped = drops(run.log)
    # One part at configure (place_part: true), one arriving each cycle and one after each drop; one plan
    # a cycle and one more for each drop; the squeezes are the ones the cycle lines count.
    expected = {
        "plan_goals": CYCLES + dropped,
        "plans_done": CYCLES,
        "parts_placed": 1 + CYCLES + dropped,
        "parts_dropped": dropped,
    }
    assert {k: counters[k] for k in expected} == expected, counters
    per_cycle = re.findall(r", \d+ throws, (\d+) squeezes;", run.log)
    assert counters["squeezes"] == sum(int(n) for n in per_cycle) >= 2 * CYCLES, (counters, per_cycle)
    assert counters["jaw_stalls"] == counters["squeeze_goals"] == 0


@pytest.mark.parametrize(
    ("parameters", "named"),
    [
        ({"orienter": "gripper"}, "parameter orienter: must be one of mems, squeeze, got 'gripper'"),
        ({"orienter": "squeeze"}, "parameter squeeze_part_file: is required with orienter squeeze"),
        (
            {"orienter": "squeeze", "squeeze_part_file": "/nonexistent/part.yaml"},
            "parameter squeeze_part_file:",
        ),
        (
            {
                "orienter": "squeeze",
                "squeeze_part_file": str(ROOT / "examples/squeeze/rectangle.yaml"),
                "arrivals_file": str(ROOT / "examples/experiments/arm_period.yaml"),
            },
            "parameter arrivals_file: arrivals.mems places parts on the MEMS array, but the orienter is "
            "squeeze",
        ),
    ],
)
def test_a_bad_squeeze_setting_exits_2_naming_it(
    ros_domain: int, tmp_path: Path, parameters: dict[str, Any], named: str
) -> None:
    node = ros_harness.start_node(
        "feeder_cell", "cell_controller", parameters, tmp_path, namespace="/nowhere"
    )
    try:
        assert node.process.wait(timeout=60) == 2
    finally:
        node.stop()
    assert named in node.output() and "Traceback" not in node.output(), node.output()[-1500:]
