"""Over DDS: the assembly fixture as a managed device.

Lifecycle (deactivate freezes the table, activate resumes the move; cleanup), status and diagnostics,
stop/reset, runtime and read-only parameters, a namespaced fixture and its planner, node-clock time under a
stepped cell clock (elapsed-time motion and its cap), and one test per injected fault as a subscriber sees
it. What every device does alike (a bad parameter failing configure, hostile requests...) is the conformance
suite's, tests/devices/test_device_conformance_ros.py.

The fixture holds the built-in block in an L bracket; tilting about tilt_y alone to -0.9 rad keeps it stable
(margin > 0.27 rad), so the moves below pass the interlock. Along such a move gravity follows the great circle
of constant tilt_x, so tilt_y changes at exactly max_rate_y: every position is an exact number.
"""

from __future__ import annotations

import math
import threading
import time
from typing import Any, Callable

import numpy as np
import pytest
import ros_harness
from ros_harness import counters, set_parameter, trigger
from ros_harness import inject_fault as inject
from ros_harness import lifecycle_of as lifecycle

from feeder_sim.fixture import FixtureFaults, TableLimits, gravity_of

pytestmark = pytest.mark.ros

NODE = "assembly_fixture"


def _level_margin() -> float:
    from feeder_planner.assembly import DEFAULT_ASSEMBLY_YAML, assembly_from_text, check_result, prepare

    return check_result(
        prepare(assembly_from_text(DEFAULT_ASSEMBLY_YAML)), np.array([0.0, 0.0, -1.0])
    ).margin_rad


LEVEL_MARGIN = _level_margin()  # the built-in assembly's margin with the table level (about 0.209 rad)


# --- helpers --------------------------------------------------------------------------------------
def latched() -> Any:
    from feeder_planner.node_kit import LATCHED

    return LATCHED


def wait_for(
    client: Any,
    msg_type: Any,
    topic: str,
    accept: Callable[[Any], bool],
    timeout: float = 30.0,
    qos: Any = None,
) -> Any:
    """Return the first message on ``topic`` that ``accept`` takes; fail with the last one seen."""
    seen: list[Any] = []
    done = threading.Event()

    def on_message(msg: Any) -> None:
        seen.append(msg)
        if accept(msg):
            done.set()

    sub = client.create_subscription(msg_type, topic, on_message, qos if qos is not None else 10)
    try:
        done.wait(timeout)
    finally:
        client.destroy_subscription(sub)
    assert done.is_set(), (
        f"no accepted message on {topic} within {timeout} s; last: {seen[-1] if seen else None}"
    )
    return next(m for m in seen if accept(m))


def status(
    client: Any, device: str, accept: Callable[[Any], bool] = lambda s: True, timeout: float = 30.0
) -> Any:
    from feeder_msgs.msg import DeviceStatus

    return wait_for(client, DeviceStatus, f"{device}/status", accept, timeout, latched())


def joints(
    client: Any, device: str, accept: Callable[[Any], bool] = lambda m: True, timeout: float = 30.0
) -> Any:
    from sensor_msgs.msg import JointState

    return wait_for(client, JointState, f"{device}/joint_states", accept, timeout)


def at(position: tuple[float, float], tol: float = 1e-9) -> Callable[[Any], bool]:
    """Accept a joint state at ``position`` (rad), standing still."""
    return lambda m: np.allclose(m.position, position, atol=tol) and not any(m.velocity)


def stability(client: Any, device: str, accept: Callable[[Any], bool] = lambda m: True) -> Any:
    from feeder_msgs.msg import StabilityStatus

    return wait_for(client, StabilityStatus, f"{device}/stability", accept)


def move(client: Any, device: str, *targets: tuple[float, float]) -> Any:
    """Command a move through the gravity directions of joint targets (tilt_x, tilt_y)."""
    from geometry_msgs.msg import Vector3

    from feeder_msgs.srv import FixtureMove

    waypoints = [Vector3(x=g[0], y=g[1], z=g[2]) for g in (gravity_of(np.array(t)).tolist() for t in targets)]
    request = FixtureMove.Request(waypoints=waypoints)
    return ros_harness.call_service(client, FixtureMove, f"{device}/move", request)


def diagnostic(client: Any, device: str, accept: Callable[[Any], bool] = lambda s: True) -> Any:
    from diagnostic_msgs.msg import DiagnosticArray

    message = wait_for(
        client,
        DiagnosticArray,
        "/diagnostics",
        lambda m: any(s.name == device and accept(s) for s in m.status),
    )
    return next(s for s in message.status if s.name == device and accept(s))


def launch_fixture(launch_node: Any, namespace: str, parameters: dict | None = None, **extra: Any) -> str:
    device = f"{namespace}/{NODE}"
    launch_node(
        "feeder_sim",
        NODE,
        parameters or {},
        namespace=namespace,
        wait_services=(f"{device}/move",),
        **extra,
    )
    return device


# --- lifecycle ------------------------------------------------------------------------------------
def test_deactivate_freezes_the_table_and_activate_resumes_the_move(launch_node, ros_client) -> None:
    from sensor_msgs.msg import JointState

    device = launch_fixture(launch_node, "/life", {"max_rate_y": 0.2})
    response = move(ros_client, device, (0.0, -0.6))
    assert response.ok and response.duration == pytest.approx(3.0, rel=1e-9), response.error
    joints(ros_client, device, lambda m: m.position[1] < -0.1)
    received: list[Any] = []
    sub = ros_client.create_subscription(JointState, f"{device}/joint_states", received.append, 50)
    try:
        deadline = time.monotonic() + 30
        while not received and time.monotonic() < deadline:  # the subscription is matched
            time.sleep(0.05)
        client = lifecycle(ros_client, device)
        assert client.change("deactivate") == "inactive"
        paused = status(ros_client, device, lambda s: s.state_name == "PAUSED")
        assert not paused.ready and not paused.busy
        time.sleep(0.5)
        frozen = received[-1].position[1]
        count = len(received)
        time.sleep(1.5)
        assert len(received) == count  # no stream while paused
        refused = move(ros_client, device, (0.0, 0.0))
        assert not refused.ok and "PAUSED" in refused.error
        assert client.change("activate") == "active"
        resumed = joints(ros_client, device)
    finally:
        ros_client.destroy_subscription(sub)
    # The 2 s paused were not simulated (they would have moved tilt_y by 0.4 rad): it resumes from where
    # it froze, a few ticks of 0.01 rad on, and finishes the move.
    assert 0.0 <= frozen - resumed.position[1] < 0.05, (frozen, resumed.position[1])
    assert -0.55 < frozen < -0.1
    joints(ros_client, device, at((0.0, -0.6)))
    done = status(ros_client, device, lambda s: counters(s)["moves_completed"] == 1)
    assert done.state_name == "IDLE" and counters(done)["moves"] == 1
    # cleanup releases everything: unconfigured, the streams gone, moves refused; configure starts afresh
    assert client.change("deactivate") == "inactive" and client.change("cleanup") == "unconfigured"
    assert status(ros_client, device, lambda s: s.state_name == "UNCONFIGURED").fault_code == 0
    deadline = time.monotonic() + 10
    published = {"x"}
    while time.monotonic() < deadline:
        published = {n for n, _ in ros_client.get_publisher_names_and_types_by_node(NODE, "/life")}
        if f"{device}/joint_states" not in published:
            break
        time.sleep(0.2)
    assert f"{device}/joint_states" not in published and f"{device}/status" in published
    refused = move(ros_client, device, (0.0, 0.0))
    assert not refused.ok and "UNCONFIGURED" in refused.error
    assert client.bring_to("active") == "active"
    joints(ros_client, device, at((0.0, 0.0), tol=0.0))
    assert counters(status(ros_client, device, lambda s: s.state_name == "IDLE"))["moves"] == 0


# --- status, diagnostics, stop/reset, parameters ----------------------------------------------------
def test_status_and_diagnostics_report_state_counters_and_rate(launch_node, ros_client) -> None:
    from diagnostic_msgs.msg import DiagnosticStatus

    device = launch_fixture(launch_node, "/stat")
    first = status(ros_client, device, lambda s: s.state_name == "IDLE")
    assert (
        first.ready
        and not first.busy
        and ros_harness.unfaulted(first.fault_code)
        and list(first.active_faults) == []
    )
    assert counters(first) == {
        "moves": 0,
        "refused_moves": 0,
        "moves_completed": 0,
        "stalls": 0,
        "capped_ticks": 0,
        "path_goals": 0,
        "path_goals_reached": 0,
        "path_goals_refused": 0,
    }
    assert first.configured_rate == 20.0 and first.configured_real_time_factor == 1.0
    assert move(ros_client, device, (0.0, -0.5)).ok
    running = status(ros_client, device, lambda s: s.state_name == "RUNNING")
    assert running.busy and running.ready
    idle = status(ros_client, device, lambda s: counters(s)["moves_completed"] == 1)
    assert idle.state_name == "IDLE" and not idle.busy
    refused = move(ros_client, device, (0.0, 0.6))  # outside the stable region: the interlock refuses
    assert not refused.ok and "refused by the interlock" in refused.error
    report = status(ros_client, device, lambda s: counters(s)["refused_moves"] == 1)
    assert counters(report)["moves"] == 1
    time.sleep(2.0)
    later = status(
        ros_client, device, lambda s: s.achieved_rate > 0 and s.header.stamp.sec > first.header.stamp.sec
    )
    assert abs(later.achieved_rate - 20.0) < 4.0, later
    assert abs(later.achieved_real_time_factor - 1.0) < 0.2, later
    entry = diagnostic(ros_client, device)
    values = {kv.key: kv.value for kv in entry.values}
    assert entry.hardware_id == f"sim:{device}"
    assert entry.level in (DiagnosticStatus.OK, DiagnosticStatus.WARN)
    assert values["state"] == "IDLE" and values["moves"] == "1" and values["refused_moves"] == "1"
    assert {"moves_completed", "stalls", "capped_ticks", "achieved_rate_hz", "configured_rate_hz"} <= set(
        values
    )
    assert values["active_faults"] == ""


def test_stop_halts_the_table_and_reset_makes_it_commandable(launch_node, ros_client) -> None:
    device = launch_fixture(launch_node, "/stop", {"max_rate_y": 0.25})
    assert move(ros_client, device, (0.0, -0.8)).ok
    joints(ros_client, device, lambda m: m.position[1] < -0.1)
    response = trigger(ros_client, device, "stop")
    assert response.success, response.message
    stopped = status(ros_client, device, lambda s: s.state_name == "STOPPED")
    assert not stopped.ready and not stopped.busy
    from sensor_msgs.msg import JointState

    held = ros_harness.collect(ros_client, JointState, f"{device}/joint_states", count=6)
    assert len({m.position[1] for m in held}) == 1 and not any(held[-1].velocity)
    assert -0.7 < held[-1].position[1] < -0.1
    refused = move(ros_client, device, (0.0, 0.0))
    assert not refused.ok and "STOPPED" in refused.error
    response = trigger(ros_client, device, "reset")
    assert response.success and "IDLE" in response.message, response.message
    assert status(ros_client, device, lambda s: s.state_name == "IDLE").ready
    assert move(ros_client, device, (0.0, 0.0)).ok
    joints(ros_client, device, at((0.0, 0.0)))
    assert counters(status(ros_client, device, lambda s: counters(s)["moves_completed"] == 1))["moves"] == 2


def test_runtime_parameters_are_applied_and_read_only_ones_refused(launch_node, ros_client) -> None:
    device = launch_fixture(launch_node, "/param")
    outside = (0.0, 0.6)
    refused = move(ros_client, device, outside)
    assert not refused.ok and "refused by the interlock" in refused.error
    result = set_parameter(ros_client, device, "interlock", False)
    assert result.successful, result.reason
    moved = move(ros_client, device, outside)
    assert (
        moved.ok and "interlock off, moving anyway" in moved.warning and moved.unbalanced_bodies == ["block"]
    )
    fallen = stability(ros_client, device, lambda m: not m.stable and not m.moving)
    assert list(fallen.unbalanced_bodies) == ["block"] and fallen.margin < 0
    # back (from an unstable start the interlock would refuse any path: its first sample fails)
    assert move(ros_client, device, (0.0, 0.0)).ok
    joints(ros_client, device, at((0.0, 0.0)))
    assert set_parameter(ros_client, device, "interlock", True).successful
    again = move(ros_client, device, outside)
    assert not again.ok and "refused by the interlock" in again.error
    # a rate applied to the running model: the same move takes twice as long
    assert move(ros_client, device, (0.0, -0.3)).duration == pytest.approx(0.3, rel=1e-9)
    joints(ros_client, device, at((0.0, -0.3)))
    assert set_parameter(ros_client, device, "max_rate_y", 0.5).successful
    slow = move(ros_client, device, (0.0, 0.0))
    assert slow.ok and slow.duration == pytest.approx(0.6, rel=1e-9)
    moving = joints(ros_client, device, lambda m: any(m.velocity))
    assert moving.velocity[1] == pytest.approx(0.5, rel=1e-9)
    for name, value, why in [
        ("max_rate_y", -1.0, "max_rate_y"),
        ("path_step", 0.0, "path_step"),
        ("facets", 8, "read-only"),
        ("publish_rate", 10.0, "read-only"),
        ("tilt_x_max", 0.3, "read-only"),
        ("real_time_factor", 2.0, "read-only"),
    ]:
        result = set_parameter(ros_client, device, name, value)
        assert not result.successful and why in result.reason, (name, result.reason)
    # A cap of 5 ms per 50 ms tick: the table falls behind the clock, and the device says so.
    joints(ros_client, device, at((0.0, 0.0)))
    assert set_parameter(ros_client, device, "max_advance_per_tick", 0.005).successful
    behind = status(ros_client, device, lambda s: s.behind_real_time, timeout=30)
    assert behind.fault_code == 2 and "behind real time" in behind.fault_text
    # over the 5 s window the achieved factor sinks towards 0.005 s / 0.05 s = 0.1
    lagging = status(ros_client, device, lambda s: s.achieved_real_time_factor < 0.5, timeout=30)
    assert lagging.behind_real_time and counters(lagging)["capped_ticks"] > 20
    assert abs(lagging.achieved_rate - 20.0) < 4.0  # the ticks keep their rate: it is the model that lags


# --- several instances ------------------------------------------------------------------------------
def test_namespaced_fixture_and_planner_keep_everything_under_the_namespace(launch_node, ros_client) -> None:
    from geometry_msgs.msg import Vector3

    from feeder_msgs.srv import StabilityCheck

    namespace = "/cell/fixture_a"
    device = launch_fixture(
        launch_node,
        namespace,
        wait_topics=(f"{namespace}/{NODE}/joint_states", f"{namespace}/{NODE}/stability"),
    )
    launch_node(
        "feeder_planner",
        "stable_region_planner",
        {},
        namespace=namespace,
        wait_services=(f"{namespace}/stable_region_planner/check_stability",),
    )
    state = joints(ros_client, device)
    assert state.header.frame_id == "cell/fixture_a/assembly"
    assert stability(ros_client, device).header.frame_id == "cell/fixture_a/assembly"
    request = StabilityCheck.Request(gravity=Vector3(x=0.0, y=0.0, z=-1.0))
    response = ros_harness.call_service(
        ros_client, StabilityCheck, f"{namespace}/stable_region_planner/check_stability", request
    )
    assert response.ok and response.stable, response.error
    assert diagnostic(ros_client, device).hardware_id == f"sim:{device}"
    for node in (NODE, "stable_region_planner"):
        published = {n for n, _ in ros_client.get_publisher_names_and_types_by_node(node, namespace)}
        stray = published - {"/diagnostics", "/rosout", "/parameter_events", "/tf", "/tf_static"}
        assert stray and all(t.startswith(f"{namespace}/{node}/") for t in stray), stray
        assert "/clock" not in published
        served = {n for n, _ in ros_client.get_service_names_and_types_by_node(node, namespace)}
        assert served and all(s.startswith(f"{namespace}/{node}/") for s in served), served


# --- one clock ------------------------------------------------------------------------------------
def test_stepped_cell_clock_moves_the_table_by_elapsed_time_up_to_the_cap(launch_node, ros_client) -> None:
    from sensor_msgs.msg import JointState

    start_ns = 1_000_000_000 * 10**9  # the clock starts at 1e9 s: stamps are the clock's, not from 0
    launch_node(
        "feeder_cell",
        "cell_clock",
        {"start_paused": True, "start_time": 1.0e9},
        namespace="/simclock",
        wait_services=("/simclock/cell_clock/step",),
    )
    device = launch_fixture(launch_node, "/simclock", {"use_sim_time": True})  # cap: 4 periods = 0.2 s
    received: list[Any] = []
    arrived = threading.Condition()

    def on_joints(msg: Any) -> None:
        with arrived:
            received.append(msg)
            arrived.notify_all()

    stamp = ros_harness.stamp_ns

    def step(seconds: float) -> tuple[int, float]:
        now = ros_harness.step_clock(ros_client, seconds, "/simclock/cell_clock")
        with arrived:
            assert arrived.wait_for(lambda: any(stamp(m) == now for m in received), timeout=30), (
                f"no joint state stamped {now}; last {[stamp(m) for m in received[-3:]]}"
            )
            msg = next(m for m in received if stamp(m) == now)
        return now, msg.position[1]

    sub = ros_client.create_subscription(JointState, f"{device}/joint_states", on_joints, 100)
    try:
        ros_harness.wait_heard_clock(ros_client, device, start_ns)
        first, y0 = step(0.05)  # the clock's time reached the device
        assert first >= start_ns + 50_000_000 and y0 == 0.0
        response = move(ros_client, device, (0.0, -0.5))  # 0.5 s at 1 rad/s of the clock
        assert response.ok and response.duration == pytest.approx(0.5, rel=1e-9), response.error
        time.sleep(1.0)  # wall time passes, the clock does not: the table does not move
        with arrived:
            assert all(m.position[1] == 0.0 for m in received)
        _, y1 = step(0.1)
        _, y2 = step(1.0)  # 1 s elapsed, 0.2 s simulated: the rest is dropped, the tick counted
        now, y3 = step(0.05)
        report = status(ros_client, device, lambda s: counters(s)["capped_ticks"] >= 1)
    finally:
        ros_client.destroy_subscription(sub)
    assert y1 == pytest.approx(-0.1, abs=1e-9)
    assert y2 == pytest.approx(-0.3, abs=1e-9)  # capped at max_advance_per_tick
    assert y3 == pytest.approx(-0.35, abs=1e-9)
    assert counters(report)["capped_ticks"] == 1 and report.busy
    assert now == first + 1_150_000_000


# --- injected faults, one test each ---------------------------------------------------------------
FAULTY = "/faulty/assembly_fixture"


@pytest.fixture(scope="module")
def faulty(launch_module_node):
    return launch_module_node(
        "feeder_sim",
        NODE,
        {"fault_seed": 5},
        namespace="/faulty",
        wait_services=(f"{FAULTY}/move",),
        wait_topics=(f"{FAULTY}/joint_states",),
    )


@pytest.fixture
def healthy(faulty, ros_client):
    """Every fault test starts with a healthy, idle fixture at (0, 0), and leaves no fault behind."""

    def home() -> None:
        assert inject(ros_client, FAULTY, "", clear=True).ok
        assert trigger(ros_client, FAULTY, "reset").success
        response = move(ros_client, FAULTY, (0.0, 0.0))
        assert response.ok, response.error
        joints(ros_client, FAULTY, at((0.0, 0.0)))
        status(ros_client, FAULTY, lambda s: s.state_name == "IDLE" and not s.active_faults)

    home()
    yield
    home()


def test_fault_axis_stall_stops_the_joint_there_and_faults_the_device(faulty, healthy, ros_client) -> None:
    from diagnostic_msgs.msg import DiagnosticStatus
    from sensor_msgs.msg import JointState

    from feeder_msgs.msg import DeviceStatus

    before = counters(status(ros_client, FAULTY))
    response = inject(ros_client, FAULTY, "axis_stall", indices=[1], angle=-0.3)
    assert response.ok and list(response.active_faults) == ["axis_stall"], response.error
    armed = status(ros_client, FAULTY, lambda s: list(s.active_faults) == ["axis_stall"])
    assert armed.ready and ros_harness.unfaulted(armed.fault_code)  # armed: it acts when the joint gets there
    assert move(ros_client, FAULTY, (0.0, -0.6)).ok
    report = status(ros_client, FAULTY, lambda s: s.state_name == "FAULT")
    assert report.fault_code == DeviceStatus.FAULT_AXIS_STALL and not report.ready and not report.busy
    assert "tilt_y stalled at -0.3 rad" in report.fault_text and "unfinished" in report.fault_text
    assert counters(report)["stalls"] == before["stalls"] + 1
    assert counters(report)["moves_completed"] == before["moves_completed"]
    held = ros_harness.collect(ros_client, JointState, f"{FAULTY}/joint_states", count=5)
    assert all(m.position[1] == pytest.approx(-0.3, abs=1e-12) and not any(m.velocity) for m in held)
    assert abs(held[-1].position[0]) < 1e-9
    assert not stability(ros_client, FAULTY).moving
    refused = move(ros_client, FAULTY, (0.0, 0.0))
    assert not refused.ok and "FAULT" in refused.error and "stalled" in refused.error
    entry = diagnostic(ros_client, FAULTY, lambda s: s.level == DiagnosticStatus.ERROR)
    assert {kv.key: kv.value for kv in entry.values}["active_faults"] == "axis_stall"
    bad = inject(ros_client, FAULTY, "axis_stall", indices=[0], angle=2.0)  # tilt_x reaches only pi/2
    assert not bad.ok and "angle" in bad.error
    # cleared: the device is commandable again and the joint moves on through -0.3
    assert inject(ros_client, FAULTY, "axis_stall", clear=True).ok
    cleared = status(ros_client, FAULTY, lambda s: s.ready)
    assert (
        cleared.state_name == "IDLE"
        and ros_harness.unfaulted(cleared.fault_code)
        and list(cleared.active_faults) == []
    )
    assert move(ros_client, FAULTY, (0.0, -0.6)).ok
    joints(ros_client, FAULTY, at((0.0, -0.6)))


def test_fault_encoder_offset_shifts_the_reading_not_the_table(faulty, healthy, ros_client) -> None:
    from geometry_msgs.msg import Vector3Stamped

    response = inject(ros_client, FAULTY, "encoder_offset", indices=[0], value=0.05)
    assert response.ok and list(response.active_faults) == ["encoder_offset"], response.error
    reading = joints(ros_client, FAULTY, at((0.05, 0.0), tol=1e-12))
    assert reading.name == ["tilt_x", "tilt_y"]
    reported = wait_for(
        ros_client,
        Vector3Stamped,
        f"{FAULTY}/gravity",
        lambda m: np.allclose(
            [m.vector.x, m.vector.y, m.vector.z], gravity_of(np.array([0.05, 0.0])), atol=1e-12
        ),
    )
    assert reported.vector.y == pytest.approx(-math.sin(0.05), abs=1e-12)
    truth = stability(ros_client, FAULTY)  # the model's truth: still level, the verdict on the true pose
    assert [truth.gravity.x, truth.gravity.y, truth.gravity.z] == pytest.approx([0.0, 0.0, -1.0], abs=1e-12)
    assert truth.stable and truth.margin == pytest.approx(LEVEL_MARGIN, abs=1e-9)
    report = status(ros_client, FAULTY, lambda s: list(s.active_faults) == ["encoder_offset"])
    assert report.ready and ros_harness.unfaulted(report.fault_code)
    # a move goes where it is commanded; the reading stays 0.05 rad off on tilt_x
    assert move(ros_client, FAULTY, (0.0, -0.4)).ok
    joints(ros_client, FAULTY, at((0.05, -0.4), tol=1e-9))
    bad = inject(ros_client, FAULTY, "encoder_offset", indices=[0], value=0.0)
    assert not bad.ok and "value" in bad.error
    assert inject(ros_client, FAULTY, "encoder_offset", clear=True).ok
    joints(ros_client, FAULTY, at((0.0, -0.4), tol=1e-9))
    status(ros_client, FAULTY, lambda s: list(s.active_faults) == [])


def test_fault_encoder_noise_is_drawn_from_the_seed(faulty, healthy, ros_client) -> None:
    from sensor_msgs.msg import JointState

    received: list[Any] = []
    sub = ros_client.create_subscription(JointState, f"{FAULTY}/joint_states", received.append, 100)
    try:
        joints(ros_client, FAULTY, at((0.0, 0.0), tol=0.0))
        response = inject(ros_client, FAULTY, "encoder_noise", indices=[1], value=0.01, seed=11)
        assert response.ok and list(response.active_faults) == ["encoder_noise"], response.error
        deadline = time.monotonic() + 30
        while sum(1 for m in received if m.position[1] != 0.0) < 40 and time.monotonic() < deadline:
            time.sleep(0.1)
    finally:
        ros_client.destroy_subscription(sub)
    noisy = [m for m in received if m.position[1] != 0.0]
    assert len(noisy) >= 40
    # Every reading after the injection, in order, is the seed's sequence of draws (tilt_x untouched).
    expected = FixtureFaults()
    expected.inject("encoder_noise", TableLimits(), value=0.01, indices=[1], seed=11)
    draws = [expected.read(np.zeros(2)) for _ in noisy]
    assert [m.position[1] for m in noisy] == pytest.approx([d[1] for d in draws], abs=1e-15)
    assert all(m.position[0] == 0.0 for m in noisy)
    assert 0.004 < float(np.std([m.position[1] for m in noisy])) < 0.02
    truth = stability(ros_client, FAULTY)
    assert [truth.gravity.x, truth.gravity.y, truth.gravity.z] == pytest.approx([0.0, 0.0, -1.0], abs=1e-15)
    assert inject(ros_client, FAULTY, "encoder_noise", clear=True).ok
    quiet = ros_harness.collect(ros_client, JointState, f"{FAULTY}/joint_states", count=5)
    assert all(list(m.position) == [0.0, 0.0] for m in quiet[1:])


def test_fault_rate_limit_slows_the_axis_and_is_reported_without_stopping(
    faulty, healthy, ros_client
) -> None:
    from diagnostic_msgs.msg import DiagnosticStatus

    from feeder_msgs.msg import DeviceStatus

    response = inject(ros_client, FAULTY, "rate_limit", indices=[1], value=0.25)
    assert response.ok and list(response.active_faults) == ["rate_limit"], response.error
    report = status(ros_client, FAULTY, lambda s: s.fault_code == DeviceStatus.FAULT_RATE_LIMIT)
    assert report.state_name == "IDLE" and report.ready  # not a stopping fault
    assert "tilt_y limited to 0.25 of its maximum rate" in report.fault_text
    entry = diagnostic(ros_client, FAULTY, lambda s: s.level == DiagnosticStatus.WARN)
    assert "rate_limit" in entry.message
    slow = move(ros_client, FAULTY, (0.0, -0.3))
    assert slow.ok and slow.duration == pytest.approx(0.3 / 0.25, rel=1e-9), slow.error
    moving = joints(ros_client, FAULTY, lambda m: any(m.velocity))
    assert moving.velocity[1] == pytest.approx(-0.25, rel=1e-9)
    running = status(ros_client, FAULTY, lambda s: s.state_name == "RUNNING")
    assert running.fault_code == DeviceStatus.FAULT_RATE_LIMIT
    joints(ros_client, FAULTY, at((0.0, -0.3)))
    bad = inject(ros_client, FAULTY, "rate_limit", indices=[1], value=1.5)
    assert not bad.ok and "value" in bad.error
    assert inject(ros_client, FAULTY, "rate_limit", clear=True).ok
    cleared = status(ros_client, FAULTY, lambda s: not s.active_faults)
    assert ros_harness.unfaulted(cleared.fault_code)
    fast = move(ros_client, FAULTY, (0.0, 0.0))
    assert fast.ok and fast.duration == pytest.approx(0.3, rel=1e-9)


def test_faults_from_the_inject_faults_parameter_act_from_configure(launch_node, ros_client) -> None:
    from feeder_msgs.msg import DeviceStatus

    entries = ["rate_limit=0.5,indices=0", "encoder_offset=0.02", "axis_stall,indices=1,angle=-0.25"]
    device = launch_fixture(launch_node, "/preset", {"inject_faults": entries})
    report = status(ros_client, device, lambda s: s.state_name == "IDLE")
    assert list(report.active_faults) == ["rate_limit", "encoder_offset", "axis_stall"]
    assert report.fault_code == DeviceStatus.FAULT_RATE_LIMIT and "tilt_x limited to 0.5" in report.fault_text
    joints(ros_client, device, at((0.02, 0.02), tol=1e-12))  # no indices: both axes read 0.02 rad off
    # tilt_x at half its rate; tilt_y at its full rate until it stalls at -0.25
    assert move(ros_client, device, (0.1, 0.0)).duration == pytest.approx(0.1 / 0.5, rel=1e-9)
    joints(ros_client, device, at((0.12, 0.02), tol=1e-9))
    assert move(ros_client, device, (0.1, -0.4)).duration == pytest.approx(0.4, rel=1e-6)
    stalled = status(ros_client, device, lambda s: s.state_name == "FAULT")
    assert (
        stalled.fault_code == DeviceStatus.FAULT_AXIS_STALL
        and "tilt_y stalled at -0.25" in stalled.fault_text
    )
    joints(ros_client, device, lambda m: m.position[1] == pytest.approx(-0.25 + 0.02, abs=1e-12))
    assert trigger(ros_client, device, "reset").success  # reset clears every fault
    cleared = status(ros_client, device, lambda s: not s.active_faults)
    assert ros_harness.unfaulted(cleared.fault_code) and cleared.state_name == "IDLE"
