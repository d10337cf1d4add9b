"""Over DDS: the MEMS array simulator settles where the equilibria planner says; bad requests are answered.

The array is a managed device (brought to active by the harness); its names are private
(``/mems_field_array/...``), the planner's too (``/field_equilibria_planner/...``), and the planner finds
the array as ``mems_field_array/<topic>`` relative to its namespace.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import pytest
import ros_harness
import yaml

from feeder_planner.mems.equilibria import find_equilibria
from feeder_planner.parts import load_part

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "mems"
PART = EXAMPLES / "bracket.yaml"
DELTA = 0.3
SIM = "/mems_field_array"
PLANNER = "/field_equilibria_planner"


def part_msg():
    from feeder_planner.node_kit.msg_parts import part_to_msg

    return part_to_msg(yaml.safe_load(PART.read_text()))


@pytest.fixture(scope="module")
def nodes(launch_module_node):
    sim = launch_module_node(
        "feeder_sim",
        "mems_field_array",
        {
            "part_files": [str(PART)],
            "seed": 7,
            "publish_rate": 20.0,
            "time_step": 5e-4,
            "default_delta": DELTA,
            "placement_radius": 1e-3,
        },
        wait_topics=(f"{SIM}/part_states", f"{SIM}/field_program"),
        wait_services=(f"{SIM}/set_program", f"{SIM}/place_parts"),
    )
    planner = launch_module_node(
        "feeder_planner",
        "field_equilibria_planner",
        {},
        wait_services=(f"{PLANNER}/equilibria",),
        wait_topics=(f"{PLANNER}/predicted_poses",),
    )
    return sim, planner


def compute(ros_client, **fields):
    from feeder_msgs.srv import EquilibriaCompute

    request = EquilibriaCompute.Request(part=fields.pop("part", part_msg()), delta=DELTA, method="")
    for key, value in fields.items():
        setattr(request, key, value)
    return ros_harness.call_service(ros_client, EquilibriaCompute, f"{PLANNER}/equilibria", request)


@pytest.mark.ros
def test_service_matches_mechanics(nodes, ros_client) -> None:
    response = compute(ros_client)
    assert response.ok, response.error
    assert response.certified and response.method in ("asymptotic", "numeric")
    expected = find_equilibria(load_part(PART), DELTA)
    assert len(response.equilibria) == len(expected.equilibria)
    for got, want in zip(response.equilibria, expected.equilibria, strict=True):
        assert got.stable == want.stable and abs(got.theta - want.theta % (2 * math.pi)) <= 1e-9
    assert (response.pivot_x, response.pivot_y) == pytest.approx(expected.pivot, abs=1e-15)


@pytest.mark.ros
def test_simulator_settles_at_a_planned_stable_equilibrium(nodes, ros_client, listen) -> None:
    from feeder_msgs.msg import EquilibriaPrediction, MemsPartStates

    stable = [e for e in compute(ros_client).equilibria if e.stable]
    deadline = time.monotonic() + 90
    previous = None
    stream = listen(MemsPartStates, f"{SIM}/part_states")
    while time.monotonic() < deadline:
        state = stream.next(1)[-1].parts[0]
        pose = (state.pose.position.x, state.pose.position.y, state.theta)
        if (
            previous is not None
            and math.hypot(pose[0] - previous[0], pose[1] - previous[1]) < 1e-9
            and abs(math.remainder(pose[2] - previous[2], 2 * math.pi)) < 1e-6
        ):
            break
        previous = pose
        time.sleep(0.5)
    else:
        pytest.fail(f"the part did not come to rest; last pose {pose}")
    gaps = [
        (abs(math.remainder(pose[2] - e.theta, 2 * math.pi)), math.hypot(pose[0] - e.x, pose[1] - e.y))
        for e in stable
    ]
    angle_gap, distance = min(gaps)
    assert angle_gap <= 1e-4 and distance <= 1e-7  # stated tolerance: 1e-4 rad, 0.1 um
    predictions = listen(EquilibriaPrediction, f"{PLANNER}/predicted_poses", latched=True)
    prediction = predictions.wait(
        lambda m: abs(math.remainder(m.theta[0] - pose[2], 2 * math.pi)) <= 1e-4, current=True
    )
    assert list(prediction.names) == ["bracket"]


@pytest.mark.ros
@pytest.mark.parametrize(
    "change,field",
    [({"delta": 1.5}, "delta"), ({"delta": float("nan")}, "delta"), ({"method": "guess"}, "method")],
)
def test_bad_requests_name_the_field_and_node_keeps_serving(nodes, ros_client, change, field) -> None:
    response = compute(ros_client, **change)
    assert not response.ok and field in response.error
    assert compute(ros_client).ok


@pytest.mark.ros
def test_bad_part_in_request(nodes, ros_client) -> None:
    msg = part_msg()
    msg.outer.x, msg.outer.y = [0.0, 1.0, 1.0, 0.0], [0.0, 1.0, 0.0, 1.0]  # self-intersecting
    response = compute(ros_client, part=msg)
    assert not response.ok and "part.outer" in response.error
    msg.outer.x, msg.outer.y = [0.0, 1.0], [0.0, 1.0]
    response = compute(ros_client, part=msg)
    assert not response.ok and "part.outer" in response.error


@pytest.mark.ros
def test_stamps_are_node_clock_time_and_cell_forces_are_latched(nodes, ros_client, listen) -> None:
    from feeder_msgs.msg import MemsCellForces, MemsPartStates

    # The array publishes no /clock any more (the cell clock does): without use_sim_time its stamps
    # are the system clock's.
    assert not [i for i in ros_client.get_publishers_info_by_topic("/clock") if i.node_name == SIM[1:]]
    states = listen(MemsPartStates, f"{SIM}/part_states").next(3)
    times = [s.header.stamp.sec + 1e-9 * s.header.stamp.nanosec for s in states]
    assert times == sorted(times) and times[-1] > times[0]
    assert abs(times[-1] - time.time()) < 5.0
    assert states[-1].header.frame_id == "mems_array"
    cells = listen(MemsCellForces, f"{SIM}/cell_forces", latched=True).wait(current=True)
    assert cells.nx == 100 and len(cells.fx) == 100 * 100
    # the default combined field: every cell force has magnitude |(-r/|r|) - delta (0, 1)|,
    # in [1 - delta, 1 + delta]
    magnitude = [math.hypot(x, y) for x, y in zip(cells.fx, cells.fy, strict=True)]
    assert 1 - DELTA - 1e-12 <= min(magnitude) and max(magnitude) <= 1 + DELTA + 1e-12


@pytest.mark.ros
def test_parts_spawned_and_removed_at_runtime_and_the_planner_follows(nodes, ros_client, listen) -> None:
    """~/spawn_part and ~/remove_part: the streams, ~/parts and the planner follow; bad requests are refused.

    Last in the module: it leaves the array as it found it (the spawned part removed again).
    """
    from feeder_msgs.msg import DeviceStatus, EquilibriaPrediction, MemsParts, MemsPartStates
    from feeder_msgs.srv import MemsRemovePart, MemsSpawnPart

    def spawn(**fields):
        request = MemsSpawnPart.Request(**fields)
        return ros_harness.call_service(ros_client, MemsSpawnPart, f"{SIM}/spawn_part", request)

    def remove(name: str):
        request = MemsRemovePart.Request(name=name)
        return ros_harness.call_service(ros_client, MemsRemovePart, f"{SIM}/remove_part", request)

    def names(msg) -> list[str]:
        return [p.name for p in msg.parts]

    parts = listen(MemsParts, f"{SIM}/parts", latched=True)
    states = listen(MemsPartStates, f"{SIM}/part_states")
    status = listen(DeviceStatus, f"{SIM}/status", latched=True)
    square = (EXAMPLES / "square.yaml").read_text()
    response = spawn(part_yaml=square, source="examples/mems/square.yaml", x=2e-3, y=-1e-3, theta=0.5)
    assert response.ok and response.name == "square", response.error
    assert names(parts.wait(lambda m: len(m.parts) == 2, current=True)) == ["bracket", "square"]
    first = states.wait(lambda m: names(m) == ["bracket", "square"])
    later = states.wait(
        lambda m: names(m) == ["bracket", "square"] and ros_harness.stamp_ns(m) > ros_harness.stamp_ns(first)
    )
    assert later.parts[1].pose.position.x != first.parts[1].pose.position.x  # it moves with the field
    predictions = listen(EquilibriaPrediction, f"{PLANNER}/predicted_poses", latched=True)
    assert list(predictions.wait(lambda m: len(m.names) == 2, current=True).names) == ["bracket", "square"]
    # Bad requests: refused in one line naming the field; the array serves on, its parts unchanged.
    for bad, field in [
        ({"name": "bracket", "part_yaml": square}, "name: a part named 'bracket' is on the array already"),
        ({"name": "tri", "part_yaml": "vertices: [[0, 0], [1, 0]]\nlength_unit: mm"}, "part_yaml.vertices"),
        ({"name": "far", "part_yaml": square, "x": 1.0}, "x: must be within"),
    ]:
        refused = spawn(**bad)
        assert not refused.ok and field in refused.error and "\n" not in refused.error, refused.error
        assert refused.name == ""
    refused = remove("nope")
    assert not refused.ok and "name: no part named 'nope'" in refused.error
    assert "'bracket', 'square'" in refused.error
    assert remove("square").ok
    assert names(parts.wait(lambda m: len(m.parts) == 1, current=True)) == ["bracket"]
    assert names(states.wait(lambda m: len(m.parts) == 1)) == ["bracket"]
    done = status.wait(lambda s: ros_harness.counters(s)["removed"] == 1, current=True)
    assert ros_harness.counters(done)["spawned"] == 1 and done.ready
