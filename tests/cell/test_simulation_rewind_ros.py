"""A ResetSimulation of time over DDS: the clock back at its start, and the same run as a fresh launch.

Only the standard's types drive the cell (``simulation_interfaces``, ``rosgraph_msgs``); the device's own
samples (``feeder_msgs/MemsPartStates`` on ``~/part_states``) are what the runs are compared on, and the
fresh launch's come from its recording. The devices scene, launched at ``max`` from ``--start-time``:

- in each layout (the cell host, one process per node): ResetSimulation (scope 0) sets ``/clock`` back to
  the start, every part's state reads its configured initial value at once, and N steps from there publish
  the samples a fresh launch published in its first N quanta after its devices were brought up (relative
  stamps and values, bit for bit); a second reset gives the same run again;
- recording (``feeder launch --record``): the recorder is a lockstep participant that does not follow a
  rewind, so the reset is done without time, the answer says so naming it, and the bag holds one timeline;
  likewise the cell scene's controller, hosted (``--host-controller``), while it cycles.
"""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any, Iterator

import pytest
import ros_harness

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "feeder_cell" / "scenes" / "devices.yaml"
NS = "/cell_simulation"
NANOSECONDS = 1_000_000_000
START_NS = 1_000 * NANOSECONDS  # --start-time 1000
QUANTUM_NS = NANOSECONDS // 10  # --quantum 0.1, the default
STEPS = 15
ARRAY_STATES = "/cell/mems_field_array/part_states"


@contextlib.contextmanager
def launched(tmp_path: Path, *extra: str, scene: Path = SCENE) -> Iterator[subprocess.Popen[str]]:
    """A scene (the devices scene) at max from START_NS, ended by SIGINT to its pid."""
    process = subprocess.Popen(
        [sys.executable, "-m", "feeder_cell.cli.main", "launch", str(scene), "--real-time-factor", "max"]
        + ["--start-time", str(START_NS // NANOSECONDS), "--log-dir", str(tmp_path / "logs"), *extra],
        env=dict(os.environ),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        yield process
    finally:
        ros_harness.end_launch(process, timeout=60)


class Harness:
    """The standard's services, /clock and the array's samples, from the test's client node."""

    def __init__(self, node: Any) -> None:
        from rclpy.qos import QoSProfile, ReliabilityPolicy
        from rosgraph_msgs.msg import Clock

        from feeder_msgs.msg import MemsPartStates

        self.node = node
        self.clock_ns = 0
        self.samples: list[Any] = []
        self._subscriptions = [
            node.create_subscription(Clock, "/clock", self._on_clock, 10),
            node.create_subscription(
                MemsPartStates,
                ARRAY_STATES,
                self.samples.append,
                QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE),
            ),
        ]

    def close(self) -> None:
        for subscription in self._subscriptions:
            self.node.destroy_subscription(subscription)

    def _on_clock(self, msg: Any) -> None:
        self.clock_ns = int(msg.clock.sec) * NANOSECONDS + int(msg.clock.nanosec)

    def call(self, srv: Any, service: str, **fields: Any) -> Any:
        return ros_harness.call_service(
            self.node, srv, f"{NS}/{service}", srv.Request(**fields), timeout=60.0
        )

    def ok(self, srv: Any, service: str, **fields: Any) -> Any:
        response = self.call(srv, service, **fields)
        assert response.result.result == 1, (
            f"{service}: {response.result.result} {response.result.error_message}"
        )
        return response

    def wait_loaded(self, process: subprocess.Popen[str]) -> None:
        """Until the world has loaded and the array's parts are listed (its configuration is done)."""
        from simulation_interfaces.msg import SimulationState
        from simulation_interfaces.srv import GetEntities, GetSimulationState

        deadline = time.monotonic() + 120
        while True:
            assert process.poll() is None, f"launch ended: {process.communicate()[1][-2000:]}"
            try:
                state = self.call(GetSimulationState, "get_simulation_state").state.state
                names = self.call(GetEntities, "get_entities").entities
            except AssertionError:
                state, names = SimulationState.STATE_LOADING_WORLD, []
            if state != SimulationState.STATE_LOADING_WORLD and any(
                n.startswith("cell/mems_field_array/") for n in names
            ):
                return
            assert time.monotonic() < deadline, f"not loaded after 120 s: {names}"
            time.sleep(0.3)

    def wait_clock_past(self, ns: int) -> None:
        """Until /clock reads past ``ns`` (the cell has run): under load a hosted controller's bring-up can
        hold the clock at its start for seconds after the world has loaded."""
        deadline = time.monotonic() + 60
        while self.clock_ns <= ns:
            assert time.monotonic() < deadline, f"/clock still at {self.clock_ns} ns after 60 s"
            time.sleep(0.05)

    def settled_clock(self) -> int:
        """Cell time once /clock stops moving (the clock publishes where it holds)."""
        last = -1
        for _ in range(100):
            time.sleep(0.3)
            if self.clock_ns == last:
                return last
            last = self.clock_ns
        raise AssertionError("/clock kept moving")

    def part_states(self) -> dict[str, tuple[float, ...]]:
        from simulation_interfaces.msg import EntityFilters
        from simulation_interfaces.srv import GetEntitiesStates

        response = self.ok(
            GetEntitiesStates, "get_entities_states", filters=EntityFilters(filter="^cell/mems_field_array/")
        )
        return {
            name: (s.pose.position.x, s.pose.position.y, s.pose.orientation.z, s.pose.orientation.w)
            for name, s in zip(response.entities, response.states, strict=True)
        }

    def run_after_reset(self) -> tuple[dict[str, tuple[float, ...]], list[tuple[int, Any]]]:
        """ResetSimulation (scope 0); the states then, and the array's samples of STEPS single steps."""
        from simulation_interfaces.srv import ResetSimulation, StepSimulation

        response = self.ok(ResetSimulation, "reset_simulation")
        assert not response.result.error_message, response.result.error_message
        assert self.settled_clock() == START_NS, f"/clock after the reset: {self.clock_ns} ns"
        initial = self.part_states()
        self.samples.clear()
        for k in range(1, STEPS + 1):
            self.ok(StepSimulation, "step_simulation", steps=1)
            until = START_NS + k * QUANTUM_NS
            deadline = time.monotonic() + 30
            while not any(ros_harness.stamp_ns(s) == until for s in self.samples):
                assert time.monotonic() < deadline, f"no {ARRAY_STATES} sample at {until} ns"
                time.sleep(0.01)
        assert self.settled_clock() == START_NS + STEPS * QUANTUM_NS
        return initial, [(ros_harness.stamp_ns(s), _parts(s)) for s in self.samples]


def _parts(msg: Any) -> Any:
    """A sample's parts as plain numbers (the same whether taken from DDS or from a bag)."""
    return [
        (p.name, p.pose.position.x, p.pose.position.y, p.pose.orientation.z, p.pose.orientation.w)
        for p in msg.parts
    ]


def _bag_parts(data: dict[str, Any]) -> Any:
    return [
        (
            p["name"],
            p["pose"]["position"]["x"],
            p["pose"]["position"]["y"],
            p["pose"]["orientation"]["z"],
            p["pose"]["orientation"]["w"],
        )
        for p in data["parts"]
    ]


def _relative(samples: list[tuple[int, Any]]) -> list[tuple[int, Any]]:
    """Samples by their time after the device's activation (its first sample is one period after it)."""
    period = samples[1][0] - samples[0][0]
    origin = samples[0][0] - period
    return [(stamp - origin, parts) for stamp, parts in samples]


@pytest.fixture(scope="module")
def fresh(ros_client: Any, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """A recorded fresh launch: its array's first samples, and what a reset answered while it recorded."""
    from simulation_interfaces.srv import ResetSimulation

    from feeder_cell.bag.compare import read_bag

    tmp_path = tmp_path_factory.mktemp("fresh")
    bag = tmp_path / "bag"
    harness = Harness(ros_client)
    try:
        with launched(tmp_path, "--record", str(bag)) as process:
            harness.wait_loaded(process)
            deadline = time.monotonic() + 60
            while len(harness.samples) < 4 * STEPS:  # the first quanta to compare with are recorded
                assert time.monotonic() < deadline, f"{len(harness.samples)} samples of {ARRAY_STATES}"
                time.sleep(0.1)
            before = harness.clock_ns
            answer = harness.call(ResetSimulation, "reset_simulation").result
            after = harness.clock_ns
    finally:
        harness.close()
    recorded = read_bag(bag, excluded=())[ARRAY_STATES]
    samples = [
        (
            int(r.data["header"]["stamp"]["sec"]) * NANOSECONDS + int(r.data["header"]["stamp"]["nanosec"]),
            _bag_parts(r.data),
        )
        for r in recorded
    ]
    return {"samples": samples, "answer": answer, "clock": (before, after)}


@pytest.mark.parametrize("layout", [(), ("--one-process-per-node",)], ids=["hosted", "one_process_per_node"])
def test_a_reset_sets_the_clock_back_and_the_cell_runs_as_a_fresh_launch(
    ros_client: Any, fresh: dict[str, Any], tmp_path: Path, layout: tuple[str, ...]
) -> None:
    from simulation_interfaces.msg import SimulationState
    from simulation_interfaces.srv import SetSimulationState

    harness = Harness(ros_client)
    try:
        with launched(tmp_path, *layout) as process:
            harness.wait_loaded(process)
            harness.wait_clock_past(START_NS)  # the cell runs before it is paused and reset
            paused = SimulationState(state=SimulationState.STATE_PAUSED)
            harness.ok(SetSimulationState, "set_simulation_state", state=paused)
            assert harness.settled_clock() > START_NS  # the cell ran before the reset
            initial, run = harness.run_after_reset()
            again_initial, again = harness.run_after_reset()
    finally:
        harness.close()
    assert initial and again_initial == initial, "the states right after two resets differ"
    # The initial states are the configured ones: the array's first sample is one tick from them.
    assert [name for name, *_ in run[0][1]] == [name.rsplit("/", 1)[1] for name in initial]
    assert run[0][0] == START_NS + (run[1][0] - run[0][0]), "the first tick is not one period after the start"
    assert again == run, "a second reset and the same steps gave another run"
    count = len(run)
    first = _relative(fresh["samples"])[:count]
    assert len(first) == count, f"the fresh launch recorded {len(first)} samples, fewer than {count}"
    assert _relative(run) == first, "the run after the reset is not the fresh launch's first quanta"


def test_a_recording_launch_resets_without_time_and_says_why(fresh: dict[str, Any]) -> None:
    answer = fresh["answer"]
    assert answer.result == 1, answer.error_message
    assert "cell time was not reset" in answer.error_message and "/feeder_launch" in answer.error_message
    before, after = fresh["clock"]
    assert after >= before > START_NS, f"/clock went from {before} to {after} ns"
    stamps = [stamp for stamp, _ in fresh["samples"]]
    assert stamps == sorted(stamps), "the bag's array samples go back in time"


def test_a_reset_beside_a_hosted_controller_keeps_time_and_names_it(ros_client: Any, tmp_path: Path) -> None:
    """The cell scene, its controller in the cell host (--host-controller) and cycling: it does not follow."""
    from simulation_interfaces.msg import SimulationState
    from simulation_interfaces.srv import ResetSimulation, SetSimulationState

    cell = ROOT / "feeder_cell" / "scenes" / "cell.yaml"
    harness = Harness(ros_client)
    try:
        with launched(
            tmp_path, "--host-controller", "--set", "cell_controller.cycles=1000", scene=cell
        ) as process:
            harness.wait_loaded(process)
            harness.wait_clock_past(START_NS)  # the cell runs before it is paused and reset
            paused = SimulationState(state=SimulationState.STATE_PAUSED)
            harness.ok(SetSimulationState, "set_simulation_state", state=paused)
            held = harness.settled_clock()
            answer = harness.ok(ResetSimulation, "reset_simulation").result.error_message
            after = harness.settled_clock()
    finally:
        harness.close()
    assert "cell time was not reset" in answer and "/cell/cell_controller (react)" in answer, answer
    assert after == held > START_NS, f"/clock {held} then {after} ns"
