"""Over DDS: the throwing_arm simulator and throw_planner (sensor at a planned radius, faults, bad input)."""

from __future__ import annotations

import math
import threading
import time
from pathlib import Path

import pytest
import ros_harness
import yaml

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "throwing"
TRIANGLE = EXAMPLES / "triangle.yaml"
PAPER = {"offset": -0.005, "release_speed": math.radians(320), "gravity": -9.66, "mu": 0.5}
GOAL = 1
HEIGHT = 0.001


def part_msg(path: Path = TRIANGLE):
    from feeder_planner.node_kit.msg_parts import part_to_msg

    return part_to_msg(yaml.safe_load(path.read_text()))


@pytest.fixture(scope="module")
def planner(launch_module_node):
    return launch_module_node(
        "feeder_planner",
        "throw_planner",
        {},
        wait_services=(
            "/throw_planner/trigger_radii",
            "/throw_planner/throw",
            "/throw_planner/grasp_radii",
            "/throw_planner/limit_set",
            "/throw_planner/design_search",
        ),
    )


def paper_params() -> dict:
    """Return PAPER as ThrowParams keywords."""
    return {
        "offset": PAPER["offset"],
        "speed": PAPER["release_speed"],
        "gravity": PAPER["gravity"],
        "mu": PAPER["mu"],
    }


def _trigger(ros_client):
    from feeder_msgs.srv import SensorTriggerRadii

    request = SensorTriggerRadii.Request(part=part_msg(), goal_edge=GOAL, sensing_height=HEIGHT, **PAPER)
    return ros_harness.call_service(
        ros_client, SensorTriggerRadii, "/throw_planner/trigger_radii", request, 60
    )


def _status(listen, accept, device: str = "/throwing_arm", timeout: float = 30.0):
    """Return the first ~/status of the device from the current one on that ``accept`` takes."""
    from feeder_msgs.msg import DeviceStatus

    return listen(DeviceStatus, f"{device}/status", latched=True).wait(accept, timeout, current=True)


def _wait_for(condition, timeout: float, what: str):
    deadline = time.monotonic() + timeout
    while True:
        value = condition()
        if value is not None:
            return value
        assert time.monotonic() < deadline, f"timed out after {timeout:.0f} s waiting for {what}"
        time.sleep(0.005)


@pytest.mark.ros
def test_sensor_at_planned_radius_reads_true_only_on_goal_edge_and_every_cycle(
    planner, ros_client, launch_node
):
    from std_msgs.msg import Bool

    from feeder_msgs.msg import ThrowEvent
    from feeder_msgs.srv import ArmCommand

    plan = _trigger(ros_client)
    assert plan.ok, plan.error
    assert plan.has_trigger and plan.radius_min < plan.radius_max and GOAL in plan.cycle_edges
    sensor_radius = 0.5 * (plan.radius_min + plan.radius_max)
    # std_msgs/Bool carries no stamp, so which rest phase a reading belongs to is made certain by
    # construction: one commanded throw at a time, and readings taken only after that throw's event
    # (published when the motion ends) while no further throw is queued; the part is at rest throughout.
    # Readings on one topic arrive in publish order, but a client that falls behind still delivers the
    # previous rest's readings after the throw's event (rclpy's multi-threaded executor lagged by up to
    # 0.8 s at 100 Hz here). So this test listens on its own single-threaded node, the sensor runs at
    # 50 Hz, and only the newest readings of a run that starts after a settling pause are judged.
    settle_s, run_length, judged_length = 0.1, 6, 3
    events, readings, lock = [], [], threading.Lock()

    def on_event(msg):
        with lock:
            events.append(msg)

    def on_sensor(msg):
        with lock:
            readings.append(msg.data)

    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    context = rclpy.Context()
    rclpy.init(context=context)
    listener = rclpy.create_node("sensor_listener", context=context)
    listener.create_subscription(ThrowEvent, "/throwing_arm/throw_events", on_event, 100)
    listener.create_subscription(Bool, "/throwing_arm/sensor", on_sensor, 200)
    command = listener.create_client(ArmCommand, "/throwing_arm/command")
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(listener)
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    burn_in, wanted = 30, 150  # about 20 throws a goal-edge visit here: at least 5 complete visits
    rest_reads = []  # (edge at rest, readings while at rest)
    try:
        sim = launch_node(
            "feeder_sim",
            "throwing_arm",
            {
                "part_file": str(TRIANGLE),
                **PAPER,
                "sensor_radius": sensor_radius,
                "sensing_height": HEIGHT,
                "period": 0.1,
                "motion_fraction": 0.3,
                "initial_edge": 1,
                "initial_radius": 0.12,
                "arm_length": 0.4,
                "autostart": False,
                "sensor_rate": 50.0,
            },
            wait_topics=("/throwing_arm/sensor", "/throwing_arm/throw_events"),
            wait_services=("/throwing_arm/command",),
        )
        assert command.wait_for_service(timeout_sec=30)
        for _ in range(burn_in + wanted):
            with lock:
                seen = len(events)
            future = command.call_async(ArmCommand.Request(command="throw", count=1))
            response = _wait_for(
                lambda future=future: future.result() if future.done() else None, 30, "the throw command"
            )
            assert response.ok, response.error
            event = _wait_for(
                lambda seen=seen: events[seen] if len(events) > seen else None,
                30,
                f"throw event {seen + 1}; node log:\n{sim.output()[-2000:]}",
            )
            # Readings published during the flight may still be in transit when the event arrives.
            time.sleep(settle_s)
            with lock:
                readings.clear()
            got = _wait_for(
                lambda: list(readings) if len(readings) >= run_length else None, 30, "sensor readings at rest"
            )
            rest_reads.append((event.edge_after, got[-judged_length:]))
    finally:
        executor.shutdown(timeout_sec=2.0)
        listener.destroy_node()
        rclpy.try_shutdown(context=context)
        spinner.join(timeout=5.0)
    with lock:
        events_ = list(events)
    assert len(events_) == burn_in + wanted
    # The event's own record: at rest the sensor is true only on the goal edge.
    assert not any(ev.sensor_at_rest and ev.edge_after != GOAL for ev in events_)
    assert not any(ev.fault for ev in events_), [ev.fault_reason for ev in events_ if ev.fault][:3]
    # Each event carries the paper model's assumption flags of its throw (issue 14 item 2).
    from feeder_planner.parts import load_part
    from feeder_planner.throwing import ThrowParams, arm_part, throw

    arm = arm_part(load_part(TRIANGLE))
    for ev in events_[:20]:
        again = throw(arm, ev.edge_before, ev.radius_before, ThrowParams(**paper_params(), arm_length=0.4))
        assert (ev.lift_off, ev.slip, ev.off_arm, ev.toe_stub) == (
            again.lift_off,
            again.slip,
            again.off_arm,
            again.toe_stub,
        )
    assert any(ev.slip or ev.lift_off for ev in events_)  # the triangle's cycle breaks them (doc'd)
    rest_reads = rest_reads[burn_in:]
    wrong = [(e, r) for e, r in rest_reads if e != GOAL and any(r)]
    assert not wrong, f"sensor read true off the goal edge: {wrong[:5]}"
    # Every visit to the goal edge (once per cycle of the limit set) shows a true reading at rest.
    visits, current = [], []
    for e, r in rest_reads:
        if e == GOAL:
            current.append(r)
        elif current:
            visits.append(current)
            current = []
    complete = visits[1:]  # the first visit may be cut by the burn-in
    assert len(complete) >= 5  # wanted throws at about 20 a visit
    assert all(any(any(r) for r in visit) for visit in complete), [
        v for v in complete if not any(any(r) for r in v)
    ][:3]


@pytest.mark.ros
def test_sim_faults_when_part_leaves_arm_and_runtime_parameters(ros_client, launch_node, listen):
    from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
    from rcl_interfaces.srv import SetParameters
    from std_srvs.srv import Trigger

    from feeder_msgs.msg import DeviceStatus, ThrowEvent
    from feeder_msgs.srv import ArmCommand, ArmPlacePart

    sim = launch_node(
        "feeder_sim",
        "throwing_arm",
        {
            "part_file": str(TRIANGLE),
            **PAPER,
            "period": 0.05,
            "arm_length": 0.2,
            "initial_edge": 1,
            "initial_radius": 0.17,
        },
        wait_services=("/throwing_arm/command", "/throwing_arm/place_part"),
        wait_topics=("/throwing_arm/throw_events",),
    )
    bad = ros_harness.call_service(
        ros_client, ArmPlacePart, "/throwing_arm/place_part", ArmPlacePart.Request(edge=1, radius=0.001)
    )
    assert not bad.ok and "radius" in bad.error
    bad = ros_harness.call_service(
        ros_client,
        ArmPlacePart,
        "/throwing_arm/place_part",
        ArmPlacePart.Request(edge=1, radius=float("nan")),
    )
    assert not bad.ok and "radius" in bad.error
    bad = ros_harness.call_service(
        ros_client, ArmCommand, "/throwing_arm/command", ArmCommand.Request(command="dance")
    )
    assert not bad.ok and "command" in bad.error
    ok = ros_harness.call_service(
        ros_client, ArmPlacePart, "/throwing_arm/place_part", ArmPlacePart.Request(edge=1, radius=0.17)
    )
    assert ok.ok, ok.error
    events = listen(ThrowEvent, "/throwing_arm/throw_events")
    mark = events.count()
    reply = ros_harness.call_service(
        ros_client, ArmCommand, "/throwing_arm/command", ArmCommand.Request(command="throw", count=20)
    )
    assert reply.ok, reply.error
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline and not any(ev.fault for ev in events.since(mark)):
        time.sleep(0.1)
    time.sleep(0.5)  # a throw after the fault would show by now
    got = events.since(mark)
    faults = [ev for ev in got if ev.fault]
    assert faults and "left the arm" in faults[0].fault_reason and faults[0].kind == "fault"
    assert len(faults) == 1 and got[-1].fault  # the fault stopped the arm: no throw after it
    # The model's fault is the device's: FAULT_PART_LOST, throws refused until the part is placed again.
    report = _status(listen, lambda s: s.state_name == "FAULT")
    assert report.fault_code == DeviceStatus.FAULT_PART_LOST and "left the arm" in report.fault_text
    counts = dict(zip(report.counter_names, report.counter_values, strict=True))
    assert counts["faults"] == 1 and counts["throws"] == len(got)
    refused = ros_harness.call_service(
        ros_client, ArmCommand, "/throwing_arm/command", ArmCommand.Request(command="throw", count=1)
    )
    assert not refused.ok and "FAULT" in refused.error and "place_part" in refused.error
    reset = ros_harness.call_service(ros_client, Trigger, "/throwing_arm/reset", Trigger.Request())
    assert reset.success and reset.message == "reset: FAULT"  # ~/reset alone does not put the part back
    ok = ros_harness.call_service(
        ros_client, ArmPlacePart, "/throwing_arm/place_part", ArmPlacePart.Request(edge=1, radius=0.12)
    )
    assert ok.ok, ok.error
    idle = _status(listen, lambda s: s.state_name == "IDLE")
    assert idle.ready and idle.fault_code != DeviceStatus.FAULT_PART_LOST

    # Runtime parameters: a bad sensor radius is refused, a good one accepted; the node lives on.
    def set_param(name, value):
        request = SetParameters.Request(
            parameters=[
                Parameter(
                    name=name, value=ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=value)
                )
            ]
        )
        return ros_harness.call_service(
            ros_client, SetParameters, "/throwing_arm/set_parameters", request
        ).results[0]

    assert not set_param("sensor_radius", float("nan")).successful
    assert not set_param("sensing_height", -1.0).successful
    assert set_param("sensor_radius", 0.15).successful
    assert sim.alive()


@pytest.mark.ros
@pytest.mark.parametrize(
    "change,field",
    [
        ({"gravity": 9.66}, "gravity"),
        ({"gravity": 0.0}, "gravity"),
        ({"release_speed": 0.0}, "release_speed"),
        ({"release_speed": -1.0}, "release_speed"),
        ({"mu": 0.0}, "mu"),
        ({"radius": 0.01}, "radius"),
        ({"radius": float("nan")}, "radius"),
        ({"edge": 9}, "edge"),
    ],
)
def test_planner_bad_requests_name_the_field_and_keep_serving(planner, ros_client, change, field):
    from feeder_msgs.srv import ThrowCompute

    fields = {**PAPER, "edge": 1, "radius": 0.12, **change}
    response = ros_harness.call_service(
        ros_client, ThrowCompute, "/throw_planner/throw", ThrowCompute.Request(part=part_msg(), **fields)
    )
    assert not response.ok and field in response.error
    good = ros_harness.call_service(
        ros_client,
        ThrowCompute,
        "/throw_planner/throw",
        ThrowCompute.Request(part=part_msg(), edge=1, radius=0.12, **PAPER),
    )
    assert good.ok and good.kind in ("jog", "flip") and good.edge_after in (0, 1, 2)
    assert planner.alive()


@pytest.mark.ros
def test_planner_non_simple_part_and_grasp_radii(planner, ros_client):
    from feeder_msgs.srv import GraspRadii, LimitSetCompute
    from feeder_planner.parts import load_part
    from feeder_planner.throwing.geometry import arm_part
    from feeder_planner.throwing.grasp import grasp_radii

    msg = part_msg()
    msg.outer.x, msg.outer.y = [0.0, 1.0, 1.0, 0.0], [0.0, 1.0, 0.0, 1.0]
    response = ros_harness.call_service(
        ros_client,
        LimitSetCompute,
        "/throw_planner/limit_set",
        LimitSetCompute.Request(part=msg, goal_edge=-1, sensing_height=-1.0, **PAPER),
    )
    assert not response.ok and "part.outer" in response.error
    response = ros_harness.call_service(
        ros_client,
        GraspRadii,
        "/throw_planner/grasp_radii",
        GraspRadii.Request(part=part_msg(), offset=-0.005, mu=0.5),
    )
    assert response.ok, response.error
    expected = grasp_radii(arm_part(load_part(TRIANGLE)), -0.005, 0.5)
    assert list(response.stable_edges) == sorted(expected)
    assert list(response.grasp_radius) == pytest.approx([expected[i] for i in sorted(expected)], rel=1e-12)
    response = ros_harness.call_service(
        ros_client,
        GraspRadii,
        "/throw_planner/grasp_radii",
        GraspRadii.Request(part=part_msg(), offset=-0.005, mu=-1.0),
    )
    assert not response.ok and "mu" in response.error


@pytest.mark.ros
def test_planner_limit_set_and_design_services_match_the_cli_library(planner, ros_client):
    import json

    from feeder_msgs.srv import DesignSearch, LimitSetCompute, ThrowCompute
    from feeder_planner.parts import load_part
    from feeder_planner.throwing import ThrowParams, arm_part, limit_set, throw

    response = ros_harness.call_service(
        ros_client,
        LimitSetCompute,
        "/throw_planner/limit_set",
        LimitSetCompute.Request(
            part=part_msg(), goal_edge=GOAL, sensing_height=HEIGHT, starts_per_edge=8, throws=200, **PAPER
        ),
        60,
    )
    assert response.ok, response.error
    expected = limit_set(
        arm_part(load_part(TRIANGLE)),
        ThrowParams(PAPER["offset"], PAPER["release_speed"], PAPER["gravity"], PAPER["mu"]),
        GOAL,
        8,
        200,
        sensing_height=HEIGHT,
    ).to_json()
    assert json.loads(response.json) == expected
    assert list(response.cycle_edges) == expected["cycle"]["edges"] and response.unique
    assert (response.trigger_min, response.trigger_max) == tuple(expected["trigger"]["radius_range"])
    # The attractors as messages (issue 14): the one periodic attractor of the triangle, [1, 0, 2].
    (only,) = response.attractors
    (want,) = expected["attractors"]
    assert (
        list(only.edges) == want["edges"] and only.periodic and list(only.cycle) == want["cycle"] == [1, 0, 2]
    )
    assert only.basin == 1.0 and response.converged and response.trigger_note == ""
    assert only.throws_per_round_mean == want["throws_per_round"][1]
    assert [r.edge for r in only.ranges] == want["edges"]
    assert only.slip == want["assumption_violations"]["slip"] and only.off_arm == 0.0
    thrown = ros_harness.call_service(
        ros_client,
        ThrowCompute,
        "/throw_planner/throw",
        ThrowCompute.Request(part=part_msg(), edge=1, radius=0.12, **PAPER),
        60,
    )
    assert thrown.ok, thrown.error
    flags = throw(arm_part(load_part(TRIANGLE)), 1, 0.12, ThrowParams(**paper_params()))
    assert (thrown.lift_off, thrown.slip, thrown.off_arm, thrown.toe_stub) == (
        flags.lift_off,
        flags.slip,
        flags.off_arm,
        flags.toe_stub,
    )
    design = ros_harness.call_service(
        ros_client,
        DesignSearch,
        "/throw_planner/design_search",
        DesignSearch.Request(
            part=part_msg(),
            goal_edge=GOAL,
            offsets=[-0.005, -0.003],
            release_speeds=[PAPER["release_speed"]],
            gravity=PAPER["gravity"],
            mu=PAPER["mu"],
            sensing_height=HEIGHT,
        ),
        120,
    )
    assert design.ok, design.error
    assert len(design.designs) == 2 and design.found and design.best.unique and design.best.has_trigger
    bad = ros_harness.call_service(
        ros_client,
        DesignSearch,
        "/throw_planner/design_search",
        DesignSearch.Request(
            part=part_msg(),
            goal_edge=GOAL,
            offsets=[-0.005],
            release_speeds=[-1.0],
            gravity=PAPER["gravity"],
            mu=PAPER["mu"],
            sensing_height=HEIGHT,
        ),
        60,
    )
    assert not bad.ok and "release_speed" in bad.error
    low = ros_harness.call_service(
        ros_client,
        DesignSearch,
        "/throw_planner/design_search",
        DesignSearch.Request(
            part=part_msg(),
            goal_edge=GOAL,
            offsets=[-0.005, -0.05],  # the triangle's d_min is 1.7 cm: -5 cm is below -d_min
            release_speeds=[PAPER["release_speed"]],
            gravity=PAPER["gravity"],
            mu=PAPER["mu"],
            sensing_height=HEIGHT,
        ),
        60,
    )
    assert not low.ok and "offsets" in low.error and "d_min" in low.error


@pytest.mark.ros
def test_dynamic_fidelity_node_throws_on_command(ros_client, launch_node, listen):
    from feeder_msgs.msg import ThrowEvent
    from feeder_msgs.srv import ArmCommand

    launch_node(
        "feeder_sim",
        "throwing_arm",
        {
            "part_file": str(TRIANGLE),
            **PAPER,
            "fidelity": "dynamic",
            "dynamic_step": 5e-4,
            "period": 0.2,
            "initial_edge": 1,
            "initial_radius": 0.12,
        },
        wait_services=("/throwing_arm/command",),
        wait_topics=("/throwing_arm/throw_events",),
    )
    events = listen(ThrowEvent, "/throwing_arm/throw_events")
    mark = events.count()
    reply = ros_harness.call_service(
        ros_client, ArmCommand, "/throwing_arm/command", ArmCommand.Request(command="throw", count=3)
    )
    assert reply.ok and reply.pending == 3
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline and len(events.since(mark)) < 3:
        time.sleep(0.1)
    got = events.since(mark)
    assert len(got) == 3
    assert all(ev.fidelity == "dynamic" and ev.kind in ("jog", "flip") and not ev.fault for ev in got)
    assert got[0].edge_before == 1 and abs(got[0].radius_before - 0.12) < 1e-12
    assert all(
        a.edge_after == b.edge_before and a.radius_after == b.radius_before
        for a, b in zip(got, got[1:], strict=False)
    )
