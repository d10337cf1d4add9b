"""Over DDS: the planners under bursts and floods, hostile requests, the devices' bounds, one node per name.

Issue 16 items 5, 6 and 7. One set of nodes for the module, started in parallel: the three planners, the
arm, the MEMS array and the fixture.

- A burst of 200 concurrent calls to each planner service gets 200 answers (the request queue is 1000
  deep, rclpy's default 10). Cheap requests: the queue is what is measured, not the work.
- A flood of each planner (200 concurrent calls) leaves another client's small request answered within
  ``SMALL_BOUND`` and a simulator's publish rate above half its nominal rate.
- Hostile contents are answered ``ok: false`` naming the field, and the planner's memory stays flat.
- The devices' own bounds (off-arm placements, a wrapping throw queue, poses at 1e308, a fixture path or
  goal of more than ``MAX_MOVE_SAMPLES`` samples) are hostile requests of the conformance suite
  (tests/devices/test_device_conformance_ros.py); here the devices' services take part in the hostile
  round beside the planners'.
- A second throw_planner under the running one's name logs why and exits 1; the first serves on.
"""

from __future__ import annotations

import math
import subprocess
import threading
import time
from pathlib import Path
from typing import Any, Iterator

import numpy as np
import pytest
import ros_harness
import yaml
from geometry_msgs.msg import Vector3
from load_tools import burst, burst_client, cpu_seconds, rss_mb, timed_call
from rcl_interfaces.srv import GetParameters
from sensor_msgs.msg import JointState

from feeder_msgs.srv import (
    ArmCommand,
    DesignSearch,
    EquilibriaCompute,
    FixtureMove,
    GraspRadii,
    LimitSetCompute,
    MemsPlaceParts,
    SensorTriggerRadii,
    StabilityCheck,
    StablePath,
    StableRegion,
    ThrowCompute,
)
from feeder_planner.node_kit.msg_parts import part_to_msg

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[2]
TRIANGLE = ROOT / "examples" / "throwing" / "triangle.yaml"
SQUARE = ROOT / "examples" / "mems" / "square.yaml"
DESIGN = {"offset": -0.005, "release_speed": math.radians(320), "gravity": -9.66, "mu": 0.5}
BURST = 200
SMALL_BOUND = 3.0  # s: another client's small request during a flood (each alone takes ~10 ms)
ARM_RATE = 50.0
STARTUP = 90.0  # s: six nodes importing at once on two shared cores
THROW, REGION, EQUILIBRIA = "/throw_planner", "/stable_region_planner", "/field_equilibria_planner"
ARM, SIM, FIXTURE = "/throwing_arm", "/mems_field_array", "/assembly_fixture"
DOWN = Vector3(x=0.0, y=0.0, z=-1.0)


@pytest.fixture(scope="module")
def nodes(
    ros_client: Any, started_processes: list, tmp_path_factory: pytest.TempPathFactory
) -> Iterator[dict[str, ros_harness.NodeProcess]]:
    """Start every node of the module at once, then wait for each (managed ones brought to active)."""
    specs: dict[str, tuple[str, str, dict[str, Any], tuple[str, ...], tuple[str, ...]]] = {
        THROW: ("feeder_planner", "throw_planner", {}, (), (f"{THROW}/throw",)),
        REGION: ("feeder_planner", "stable_region_planner", {}, (), (f"{REGION}/check_stability",)),
        EQUILIBRIA: ("feeder_planner", "field_equilibria_planner", {}, (), (f"{EQUILIBRIA}/equilibria",)),
        ARM: (
            "feeder_sim",
            "throwing_arm",
            {
                "part_file": str(TRIANGLE),
                **DESIGN,
                "sensor_rate": ARM_RATE,
                "initial_edge": 1,
                "initial_radius": 0.12,
                "arm_length": 0.4,
            },
            (f"{ARM}/joint_states",),
            (f"{ARM}/place_part", f"{ARM}/command"),
        ),
        SIM: (
            "feeder_sim",
            "mems_field_array",
            {"part_files": [str(SQUARE)], "seed": 7, "placement_radius": 1e-3},
            (f"{SIM}/part_states",),
            (f"{SIM}/place_parts",),
        ),
        FIXTURE: ("feeder_sim", "assembly_fixture", {}, (), (f"{FIXTURE}/move",)),
    }
    log_dir = tmp_path_factory.mktemp("load_nodes")
    processes: dict[str, ros_harness.NodeProcess] = {}
    try:
        for key, (package, executable, parameters, _, _) in specs.items():
            processes[key] = ros_harness.start_node(package, executable, parameters, log_dir)
            started_processes.append(processes[key])
        for key, (_, _, _, topics, services) in specs.items():
            node = processes[key]
            ros_harness.wait_for_graph_node(ros_client, node, node.spec.node_name, STARTUP)
            ros_harness.bring_to(ros_client, node, "active")
            ros_harness.wait_for_graph(ros_client, node, topics, services, STARTUP)
        yield processes
    finally:
        # Stopped at once, not one grace period after another.
        stoppers = [threading.Thread(target=node.stop) for node in processes.values()]
        for stopper in stoppers:
            stopper.start()
        for stopper in stoppers:
            stopper.join()


def part(path: Path = TRIANGLE) -> Any:
    return part_to_msg(yaml.safe_load(path.read_text()))


def grasp() -> GraspRadii.Request:
    return GraspRadii.Request(part=part(), offset=DESIGN["offset"], mu=DESIGN["mu"])


def throw(radius: float = 0.12) -> ThrowCompute.Request:
    return ThrowCompute.Request(part=part(), edge=1, radius=radius, **DESIGN)


def equilibria() -> EquilibriaCompute.Request:
    return EquilibriaCompute.Request(part=part(SQUARE), delta=0.5, method="")


def call(client: Any, srv_type: Any, name: str, request: Any) -> Any:
    return ros_harness.call_service(client, srv_type, name, request)


def assert_all_answered(name: str, answers: list[Any], field: str = "") -> None:
    """Every call answered; all ok, or (``field``) all refused naming it."""
    lost = sum(a is None for a in answers)
    assert lost == 0, f"{name}: {lost} of {len(answers)} calls got no answer"
    if field:
        assert all(not a.ok and field in a.error for a in answers), answers[0].error
    else:
        assert all(a.ok for a in answers), next(a.error for a in answers if not a.ok)


def flood_while_measuring(
    ros_client: Any,
    listener: ros_harness.Listener,
    rate: float,
    flood: tuple[Any, str, list[Any]],
    small: tuple[Any, str, Any],
    timeout: float = 60.0,
) -> list[Any]:
    """Send a flood; meanwhile time one small call of another client and a simulator's stream.

    Returns the flood's answers (None: lost). Asserts the small call is answered ok within
    ``SMALL_BOUND`` and the stream kept more than half its rate before the flood (or its nominal
    ``rate``, if lower).
    """
    flood_service = burst_client(ros_client, flood[0], flood[1])
    small_service = burst_client(ros_client, small[0], small[1])
    # The stream's rate before the flood, on this machine now (other work shares its two cores).
    listener.next(1)
    begin = time.monotonic()
    listener.next(10)
    before = 10 / (time.monotonic() - begin)
    mark, start = listener.count(), time.monotonic()
    futures = [flood_service.call_async(r) for r in flood[2]]
    answer, waited = timed_call(small_service, small[2], timeout=30.0)
    assert answer is not None, f"{small[1]} got no answer during the flood of {flood[1]}"
    assert waited < SMALL_BOUND, f"{small[1]} waited {waited:.2f} s during the flood of {flood[1]}"
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and not all(f.done() for f in futures):
        time.sleep(0.05)
    elapsed = time.monotonic() - start
    during = (listener.count() - mark) / elapsed
    # The simulator is another process: a flood of its neighbour must not silence it (2 cores, shared).
    assert during > 0.5 * min(rate, before), (
        f"{listener.topic} at {during:.1f} Hz during the flood, {before:.1f} Hz before (nominal {rate:g})"
    )
    return [f.result() if f.done() else None for f in futures]


# --- bursts and floods ----------------------------------------------------------------------------------


def test_burst_of_200_to_every_throw_planner_service_gets_200_answers(ros_client: Any, nodes: dict) -> None:
    # Valid requests where an answer is quick; for the long services requests refused at their limits.
    cases: list[tuple[Any, str, Any, str]] = [
        (GraspRadii, "grasp_radii", grasp(), ""),
        (ThrowCompute, "throw", throw(), ""),
        (LimitSetCompute, "limit_set", LimitSetCompute.Request(part=part(), throws=1, **DESIGN), "throws"),
        (
            SensorTriggerRadii,
            "trigger_radii",
            SensorTriggerRadii.Request(part=part(), goal_edge=-1, **DESIGN),
            "goal_edge",
        ),
        (
            DesignSearch,
            "design_search",
            DesignSearch.Request(part=part(), goal_edge=1, offsets=[0.0] * 100, release_speeds=[1.0]),
            "offsets",
        ),
    ]
    for srv_type, name, request, field in cases:
        service = burst_client(ros_client, srv_type, f"{THROW}/{name}")
        assert_all_answered(name, burst(service, [request] * BURST, timeout=60.0), field)


def test_burst_of_200_to_every_stable_region_planner_service_gets_200_answers(
    ros_client: Any, nodes: dict
) -> None:
    # The node's own assembly: its region is prepared at start-up; a path from down to down is one LP.
    cases: list[tuple[Any, str, Any]] = [
        (StableRegion, "stable_region", StableRegion.Request()),
        (StablePath, "safe_path", StablePath.Request(start=DOWN, goal=DOWN)),
    ]
    for srv_type, name, request in cases:
        service = burst_client(ros_client, srv_type, f"{REGION}/{name}")
        assert_all_answered(name, burst(service, [request] * BURST, timeout=60.0))
    # ~/check_stability is flooded below with 200 calls, each checked the same way.


def test_flood_of_throw_planner_leaves_other_clients_and_the_arm_served(
    ros_client: Any, nodes: dict, listen: Any
) -> None:
    joints = listen(JointState, f"{ARM}/joint_states")
    # Limit sets (each ~0.1-0.5 s of work) on one service, sent first...
    heavy = LimitSetCompute.Request(part=part(), goal_edge=1, starts_per_edge=3, throws=100, **DESIGN)
    heavy_service = burst_client(ros_client, LimitSetCompute, f"{THROW}/limit_set")
    heavy_futures = [heavy_service.call_async(heavy) for _ in range(10)]
    # ...then 200 throws on another, while a grasp request and the arm's stream are measured.
    throws = [throw(0.10 + 0.0001 * i) for i in range(BURST)]
    answers = flood_while_measuring(
        ros_client,
        joints,
        ARM_RATE,
        (ThrowCompute, f"{THROW}/throw", throws),
        (GraspRadii, f"{THROW}/grasp_radii", grasp()),
    )
    assert_all_answered("throw", answers)
    deadline = time.monotonic() + 60.0
    while time.monotonic() < deadline and not all(f.done() for f in heavy_futures):
        time.sleep(0.05)
    assert_all_answered("limit_set", [f.result() if f.done() else None for f in heavy_futures])


def test_flood_of_stable_region_planner_leaves_other_clients_and_the_fixture_served(
    ros_client: Any, nodes: dict, listen: Any
) -> None:
    # 200 stability checks (one LP each) of directions around down; meanwhile another client asks for
    # the region, served on its own service's thread.
    from feeder_msgs.msg import StabilityStatus

    stability = listen(StabilityStatus, f"{FIXTURE}/stability")
    checks = [
        StabilityCheck.Request(gravity=Vector3(x=0.001 * (i % 20), y=0.001 * (i // 20), z=-1.0))
        for i in range(BURST)
    ]
    answers = flood_while_measuring(
        ros_client,
        stability,
        20.0,  # the fixture's publish_rate
        (StabilityCheck, f"{REGION}/check_stability", checks),
        (StableRegion, f"{REGION}/stable_region", StableRegion.Request()),
    )
    assert_all_answered("check_stability", answers)
    assert all(a.stable for a in answers), "a direction near down was judged unstable"


def test_flood_of_field_equilibria_planner_leaves_other_clients_and_the_arm_served(
    ros_client: Any, nodes: dict, listen: Any
) -> None:
    # The planner has one service; another client's small request is one to its parameter service,
    # served on the node's main group beside the flooded service's thread. The stream measured is the
    # arm's: the MEMS array's own ticks are heavy, it runs at a few Hz of its 20 on a loaded machine.
    joints = listen(JointState, f"{ARM}/joint_states")
    answers = flood_while_measuring(
        ros_client,
        joints,
        ARM_RATE,
        (EquilibriaCompute, f"{EQUILIBRIA}/equilibria", [equilibria()] * BURST),
        (GetParameters, f"{EQUILIBRIA}/get_parameters", GetParameters.Request(names=["default_method"])),
    )
    assert_all_answered("equilibria", answers)
    assert len({len(a.equilibria) for a in answers}) == 1 and answers[0].equilibria


# --- hostile requests and memory -----------------------------------------------------------------------


def hostile_cases() -> list[tuple[Any, str, Any, str]]:
    huge = [0.1] * 100_000
    cases: list[tuple[Any, str, Any, str]] = [
        (ThrowCompute, "throw", throw(math.nan), "radius"),
        (ThrowCompute, "throw", throw(1e308), "radius"),
        (
            ThrowCompute,
            "throw",
            ThrowCompute.Request(part=part(), edge=1, radius=0.12, **{**DESIGN, "release_speed": 1e308}),
            "release_speed",
        ),
        (
            ThrowCompute,
            "throw",
            ThrowCompute.Request(part=part(), edge=1, radius=0.12, **{**DESIGN, "gravity": -1e308}),
            "gravity",
        ),
        (GraspRadii, "grasp_radii", GraspRadii.Request(part=part(), offset=math.inf, mu=0.5), "offset"),
        (
            LimitSetCompute,
            "limit_set",
            LimitSetCompute.Request(part=part(), throws=4294967295, **DESIGN),
            "throws",
        ),
        (
            LimitSetCompute,
            "limit_set",
            LimitSetCompute.Request(part=part(), starts_per_edge=4294967295, **DESIGN),
            "starts_per_edge",
        ),
        (LimitSetCompute, "limit_set", LimitSetCompute.Request(part=part(), throws=1, **DESIGN), "throws"),
        (
            LimitSetCompute,
            "limit_set",
            LimitSetCompute.Request(part=part(), offset=1e308, release_speed=1.0, gravity=-9.8, mu=0.5),
            "offset",
        ),
        (
            SensorTriggerRadii,
            "trigger_radii",
            SensorTriggerRadii.Request(part=part(), goal_edge=1, sensing_height=1e308, **DESIGN),
            "sensing_height",
        ),
        (
            DesignSearch,
            "design_search",
            DesignSearch.Request(part=part(), goal_edge=1, offsets=huge, release_speeds=huge),
            "offsets",
        ),
        (
            DesignSearch,
            "design_search",
            DesignSearch.Request(
                part=part(), goal_edge=1, offsets=[1e308], release_speeds=[1.0], gravity=-9.8, mu=0.5
            ),
            "offsets[0]",
        ),
    ]
    big_part = part()
    big_part.outer.x, big_part.outer.y = huge, huge
    cases.append(
        (GraspRadii, "grasp_radii", GraspRadii.Request(part=big_part, offset=-0.005, mu=0.5), "part.outer")
    )
    named = part()
    named.name = "n" * 10_000_000
    cases.append(
        (ThrowCompute, "throw", ThrowCompute.Request(part=named, edge=1, radius=0.12, **DESIGN), "part.name")
    )
    return cases


ROUND_MB = 10 * (10.0 + 2 * 1.6)  # a round's payload: 10 x (a 10 MB name and two 1.6 MB array pairs)
FLAT_MB = 20.0  # the trend of RSS over repeated rounds, MB a round, at most
ROUNDS = 8  # after the warm-up round: about 0.6 s each
REFUSALS_CPU_S = 5.0  # the planner's CPU s for 10 refusals at most (the 10 MB names: about 0.3 s)


def test_hostile_requests_are_refused_by_name_with_flat_memory(ros_client: Any, nodes: dict) -> None:
    planner = nodes[THROW]
    cases = hostile_cases()

    def hostile_round() -> None:
        for srv_type, name, request, field in cases:
            service = burst_client(ros_client, srv_type, f"{THROW}/{name}")
            cpu = cpu_seconds(planner.pid)
            answers = burst(service, [request] * 10, 30.0)
            assert all(a is not None for a in answers), f"{name}/{field}: a hostile request got no answer"
            # Refused before any work: the planner's own CPU time, which a loaded machine does not stretch
            # as it stretches the wall time (CI saw 15 s of wall for the 10 MB names, beside a launch).
            spent = cpu_seconds(planner.pid) - cpu
            assert spent < REFUSALS_CPU_S, f"{name}/{field}: 10 refusals took {spent:.1f} CPU s"
            for answer in answers:
                assert not answer.ok and field in answer.error, f"{name}/{field}: {answer.error[:200]}"
                assert "internal error" not in answer.error and len(answer.error) <= 1000

    # Two rounds warm up: every client discovered, every path run, and DDS's payload pools grown to a
    # burst of the largest request (kept for reuse). After it, the planner's RSS moves by tens of MB from
    # one round to the next, both ways, with no trend (measured: +39, -41, +31, +3, -20, 0, 0 MB over seven
    # rounds: the allocator and the pools), so two rounds cannot tell a leak from that noise (a bound of
    # 20 MB on the smaller of two growths failed once in CI). A leak of the requests adds its share to
    # every round: the trend over ROUNDS rounds (a least-squares slope, its noise about 4 MB a round) is
    # what is bounded.
    hostile_round()
    hostile_round()  # the pools still grow in the second (measured: 270 MB after one, 315 after two)
    sizes = [rss_mb(planner.pid)]
    for _ in range(ROUNDS):
        hostile_round()
        sizes.append(rss_mb(planner.pid))
    slope = float(np.polyfit(np.arange(len(sizes)), sizes, 1)[0])
    print(f"planner RSS {sizes[0]:.0f} MB after the warm-up rounds; then {[round(s) for s in sizes[1:]]} MB")
    assert slope < FLAT_MB, (
        f"planner RSS grows {slope:.0f} MB a round over {ROUNDS} repeated hostile rounds "
        f"(each ~{ROUND_MB:.0f} MB of requests): {[round(s) for s in sizes]} MB"
    )
    # and it still answers a good request
    answer = burst(burst_client(ros_client, ThrowCompute, f"{THROW}/throw"), [throw()], 30.0)[0]
    assert answer is not None and answer.ok


def other_hostile_cases() -> list[tuple[Any, str, Any, str]]:
    """Hostile contents for every other node's services: (type, service, request, the field named)."""
    bomb = "a: &a [x, x, x, x, x, x, x, x, x, x]\n" + "".join(
        f"{chr(98 + i)}: &{chr(98 + i)} [{', '.join([f'*{chr(97 + i)}'] * 10)}]\n" for i in range(7)
    )
    named = part()
    named.name = "n" * 10_000_000
    wide = part()
    wide.outer.x, wide.outer.y = [0.1] * 100_000, [0.1] * 100_000
    nan = Vector3(x=math.nan, y=0.0, z=-1.0)
    down = Vector3(x=0.0, y=0.0, z=-1.0)
    return [
        (StableRegion, f"{REGION}/stable_region", StableRegion.Request(override_mu=True, mu=math.nan), "mu"),
        (StableRegion, f"{REGION}/stable_region", StableRegion.Request(facets=100_000), "facets"),
        (
            StableRegion,
            f"{REGION}/stable_region",
            StableRegion.Request(assembly_yaml="x: " + "y" * 10_000_000),
            "assembly_yaml",
        ),
        (StableRegion, f"{REGION}/stable_region", StableRegion.Request(assembly_yaml=bomb), "assembly_yaml"),
        (
            StableRegion,
            f"{REGION}/stable_region",
            StableRegion.Request(assembly_yaml="a: ["),
            "assembly_yaml",
        ),
        (StabilityCheck, f"{REGION}/check_stability", StabilityCheck.Request(gravity=Vector3()), "gravity"),
        (StabilityCheck, f"{REGION}/check_stability", StabilityCheck.Request(gravity=nan), "gravity"),
        (
            StablePath,
            f"{REGION}/safe_path",
            StablePath.Request(start=down, goal=Vector3(x=1.0), step=1e-9),
            "step",
        ),
        (
            EquilibriaCompute,
            f"{EQUILIBRIA}/equilibria",
            EquilibriaCompute.Request(part=part(), delta=math.nan),
            "delta",
        ),
        (
            EquilibriaCompute,
            f"{EQUILIBRIA}/equilibria",
            EquilibriaCompute.Request(part=part(), delta=0.3, method="spiral"),
            "method",
        ),
        (
            EquilibriaCompute,
            f"{EQUILIBRIA}/equilibria",
            EquilibriaCompute.Request(part=wide, delta=0.3),
            "part.outer",
        ),
        (
            EquilibriaCompute,
            f"{EQUILIBRIA}/equilibria",
            EquilibriaCompute.Request(part=named, delta=0.3),
            "part.name",
        ),
        (MemsPlaceParts, f"{SIM}/place_parts", MemsPlaceParts.Request(names=["p"] * 20_000), "names"),
        (
            MemsPlaceParts,
            f"{SIM}/place_parts",
            MemsPlaceParts.Request(names=[""], x=[math.nan], y=[0.0], theta=[0.0]),
            "x",
        ),
        (ArmCommand, f"{ARM}/command", ArmCommand.Request(command=""), "command"),
        (ArmCommand, f"{ARM}/command", ArmCommand.Request(command="n" * 10_000_000), "command"),
        (FixtureMove, f"{FIXTURE}/move", FixtureMove.Request(waypoints=[nan]), "waypoints"),
        (FixtureMove, f"{FIXTURE}/move", FixtureMove.Request(waypoints=[Vector3()]), "waypoints"),
    ]


def test_hostile_requests_to_every_other_node_are_refused_by_name_and_each_keeps_serving(
    ros_client: Any, nodes: dict
) -> None:
    for srv_type, name, request, field in other_hostile_cases():
        answers = burst(burst_client(ros_client, srv_type, name), [request] * 5, 30.0)
        assert all(a is not None for a in answers), f"{name}/{field}: a hostile request got no answer"
        for answer in answers:
            assert not answer.ok and field in answer.error, f"{name}/{field}: {answer.error[:200]}"
            assert "internal error" not in answer.error and len(answer.error) <= 1000, answer.error[:200]
    # every node still answers a good request
    good = StabilityCheck.Request(gravity=Vector3(x=0.0, y=0.0, z=-1.0))
    assert burst(burst_client(ros_client, StabilityCheck, f"{REGION}/check_stability"), [good], 30.0)[0].ok
    assert burst(
        burst_client(ros_client, EquilibriaCompute, f"{EQUILIBRIA}/equilibria"), [equilibria()], 30.0
    )[0].ok
    assert nodes[ARM].alive() and nodes[SIM].alive() and nodes[FIXTURE].alive()


# --- one node per name (last: a namesake serves the module's planner's services while it lives) --------


def test_a_namesake_exits_1_and_the_first_serves_on(
    ros_client: Any, nodes: dict, started_processes: list, tmp_path: Path
) -> None:
    first = nodes[THROW]
    second = ros_harness.start_node("feeder_planner", "throw_planner", {}, tmp_path)
    started_processes.append(second)
    try:
        # Its exit is what is waited for: start-up (imports) plus discovery of the first, a few seconds.
        second.process.wait(timeout=60.0)
    except subprocess.TimeoutExpired:
        log = second.output()[-2000:]
        raise AssertionError(f"the namesake still runs after 60 s; its log:\n{log}") from None
    finally:
        second.stop()
    assert second.process.returncode == 1, second.output()[-2000:]
    assert f"another node named {THROW} is already running" in second.output()
    assert first.alive()
    assert call(ros_client, GraspRadii, f"{THROW}/grasp_radii", grasp()).ok
    assert first.alive()
