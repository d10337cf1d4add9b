"""Over DDS: the throwing arm as a managed device.

Lifecycle (deactivate freezes a throw in flight and activate resumes it; cleanup), status and diagnostics,
stop/reset, runtime and read-only parameters, a namespaced arm and planner, node-clock time under a stepped
cell clock (and the cap on simulated time per tick), and one test per injected fault as a subscriber sees
it. What every device does alike (a bad parameter failing configure, hostile requests...) is the conformance
suite's, tests/devices/test_device_conformance_ros.py.

Every arm starts at rest on edge 1 of the paper's triangle at R = 12 cm: a sensor at x = 12 cm (under the
centre of mass) reads true there, one at 35 cm reads false. The analytic throw is deterministic, so the
effect of a parameter or a fault on a throw is an exact number the test computes with the same model.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any, Callable

import pytest
import ros_harness
from ros_harness import counters, set_parameter, trigger
from ros_harness import inject_fault as inject
from ros_harness import lifecycle_of as lifecycle

from feeder_planner.parts import load_part
from feeder_planner.throwing import ThrowParams, arm_part
from feeder_sim.throwing import ArmFaults, ThrowingArm

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "throwing"
TRIANGLE = EXAMPLES / "triangle.yaml"
PAPER = {"offset": -0.005, "release_speed": math.radians(320), "gravity": -9.66, "mu": 0.5}
EDGE, RADIUS = 1, 0.12
SEES, BLIND = RADIUS, 0.35  # sensor radii that read true / false for the part at rest at (EDGE, RADIUS)
HEIGHT = 0.001


def arm_parameters(**overrides: Any) -> dict[str, Any]:
    return {
        "part_file": str(TRIANGLE),
        **PAPER,
        "initial_edge": EDGE,
        "initial_radius": RADIUS,
        "sensor_rate": 50.0,
        "period": 0.2,
        "sensing_height": HEIGHT,
        "sensor_radius": BLIND,
        **overrides,
    }


def local_arm(edge: int = EDGE, radius: float = RADIUS, speed: float = PAPER["release_speed"]) -> ThrowingArm:
    """The model the node runs, in this process (the same analytic throw, so the same numbers)."""
    params = ThrowParams(PAPER["offset"], speed, PAPER["gravity"], PAPER["mu"])
    return ThrowingArm(arm_part(load_part(TRIANGLE)), params, edge, radius, arm_length=0.4)


# --- helpers --------------------------------------------------------------------------------------
def wait_for(
    listen: Callable[..., Any],
    msg_type: Any,
    topic: str,
    accept: Callable[[Any], bool] = lambda m: True,
    timeout: float = 30.0,
    latched: bool = False,
) -> Any:
    """Return the first message on ``topic`` from now on (for a latched topic, the current one too)."""
    return listen(msg_type, topic, latched).wait(accept, timeout, current=latched)


def status(
    listen: Callable[..., Any],
    device: str,
    accept: Callable[[Any], bool] = lambda s: True,
    timeout: float = 30.0,
) -> Any:
    """Return the first status from the current one on that ``accept`` takes."""
    from feeder_msgs.msg import DeviceStatus

    return wait_for(listen, DeviceStatus, f"{device}/status", accept, timeout, latched=True)


def no_fault(msg: Any) -> bool:
    """Whether a status has no fault but perhaps the warning that the device is behind real time."""
    from feeder_msgs.msg import DeviceStatus

    return msg.fault_code in (DeviceStatus.FAULT_NONE, DeviceStatus.FAULT_BEHIND_REAL_TIME)


def diagnostics(
    listen: Callable[..., Any], device: str, accept: Callable[[Any], bool] = lambda s: True
) -> Any:
    """Return the first DiagnosticStatus of ``device`` on /diagnostics that ``accept`` takes."""
    from diagnostic_msgs.msg import DiagnosticArray

    def mine(msg: Any) -> Any:
        return next((s for s in msg.status if s.name == device), None)

    array = wait_for(
        listen, DiagnosticArray, "/diagnostics", lambda m: mine(m) is not None and accept(mine(m)), timeout=30
    )
    return mine(array)


def values(diagnostic: Any) -> dict[str, str]:
    return {kv.key: kv.value for kv in diagnostic.values}


class Recorder:
    """The session listeners of some topics, read from a mark: what arrived since the recorder began."""

    def __init__(self, listen: Callable[..., Any], topics: dict[str, Any]) -> None:
        self.listeners = {topic: listen(msg_type, topic) for topic, msg_type in topics.items()}
        self.marks = {topic: listener.count() for topic, listener in self.listeners.items()}

    def get(self, topic: str) -> list[Any]:
        return self.listeners[topic].since(self.marks[topic])

    def clear(self) -> None:
        self.marks = {topic: listener.count() for topic, listener in self.listeners.items()}

    def window(self, seconds: float) -> dict[str, list[Any]]:
        """Forget what came before, then return what arrives over the next ``seconds``."""
        self.clear()
        time.sleep(seconds)
        return {topic: self.get(topic) for topic in self.listeners}

    def wait(self, topic: str, count: int, timeout: float = 30.0) -> list[Any]:
        deadline = time.monotonic() + timeout
        while len(self.get(topic)) < count:
            assert time.monotonic() < deadline, f"{len(self.get(topic))} of {count} messages on {topic}"
            time.sleep(0.02)
        return self.get(topic)


def streams(listen: Callable[..., Any], device: str) -> Recorder:
    from geometry_msgs.msg import PoseStamped
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Bool

    from feeder_msgs.msg import ThrowEvent

    return Recorder(
        listen,
        {
            f"{device}/sensor": Bool,
            f"{device}/joint_states": JointState,
            f"{device}/part_pose": PoseStamped,
            f"{device}/throw_events": ThrowEvent,
        },
    )


def command(client: Any, device: str, word: str, count: int = 0) -> Any:
    from feeder_msgs.srv import ArmCommand

    request = ArmCommand.Request(command=word, count=count)
    return ros_harness.call_service(client, ArmCommand, f"{device}/command", request)


def place(client: Any, device: str, edge: int = EDGE, radius: float = RADIUS) -> Any:
    from feeder_msgs.srv import ArmPlacePart

    request = ArmPlacePart.Request(edge=edge, radius=radius)
    return ros_harness.call_service(client, ArmPlacePart, f"{device}/place_part", request)


def throw_events(
    client: Any, device: str, recorder: Recorder, count: int, timeout: float = 30.0
) -> list[Any]:
    """Command ``count`` throws and return their events (the recorder must listen to the events)."""
    topic = f"{device}/throw_events"
    before = len(recorder.get(topic))
    reply = command(client, device, "throw", count)
    assert reply.ok, reply.error
    return recorder.wait(topic, before + count, timeout)[before:]


def readings(
    recorder: Recorder, device: str, seconds: float = 1.0, settle: float = 0.2, expect: bool | None = None
) -> list[bool]:
    """Return the sensor bits of a ``seconds`` window, after what came before has drained.

    With ``expect``, the window opens once a sample reads ``expect``: on a loaded machine the samples
    published before a change can sit in the queues for longer than any fixed settle time.
    """
    time.sleep(settle)  # samples already in flight belong to what came before
    if expect is not None:
        topic, deadline = f"{device}/sensor", time.monotonic() + 15.0
        recorder.clear()
        while not any(m.data == expect for m in recorder.get(topic)):
            assert time.monotonic() < deadline, f"no sensor sample read {expect} within 15 s"
            time.sleep(0.01)
    seen = [m.data for m in recorder.window(seconds)[f"{device}/sensor"]]
    assert len(seen) >= 5, f"only {len(seen)} sensor samples in {seconds} s"  # never judged on nothing
    return seen


# --- lifecycle ------------------------------------------------------------------------------------
@pytest.mark.ros
def test_deactivate_freezes_a_throw_in_flight_activate_resumes_it_and_cleanup_releases(
    launch_node, ros_client, listen
) -> None:
    from geometry_msgs.msg import PoseStamped

    device = "/life/throwing_arm"
    # A 3.6 s motion window: the throw is shown in flight for seconds, so it can be paused mid-air.
    launch_node(
        "feeder_sim", "throwing_arm", arm_parameters(period=4.0, motion_fraction=0.9), namespace="/life"
    )
    rest = local_arm().rest_pose()
    recorder = streams(listen, device)
    poses, events = f"{device}/part_pose", f"{device}/throw_events"
    recorder.wait(poses, 5)
    assert command(ros_client, device, "throw", 1).ok
    assert status(listen, device, lambda s: s.state_name == "RUNNING").busy
    time.sleep(1.0)
    client = lifecycle(ros_client, device)
    assert client.change("deactivate") == "inactive"
    paused = status(listen, device, lambda s: s.state_name == "PAUSED")
    assert not paused.ready and not paused.busy
    time.sleep(0.5)
    frozen = recorder.get(poses)[-1].pose.position
    assert math.hypot(frozen.x - rest[0], frozen.y - rest[1]) > 5e-3  # mid-air, centimetres up
    assert recorder.window(2.0) == {topic: [] for topic in recorder.listeners}  # nothing while paused
    assert not command(ros_client, device, "throw", 1).ok
    assert client.change("activate") == "active"
    activated = time.monotonic()
    resumed = recorder.wait(poses, 1)[0].pose.position
    assert math.hypot(resumed.x - frozen.x, resumed.y - frozen.y) < 1e-2  # from where it froze
    event = recorder.wait(events, 1, timeout=30)[0]
    # 2.6 s of the window were left when it froze: the 2.5 s paused were not simulated.
    assert time.monotonic() - activated > 1.5
    expected = local_arm().throw()
    assert (event.index, event.edge_after, event.radius_after) == (
        1,
        expected.edge_after,
        expected.radius_after,
    )
    assert counters(status(listen, device, lambda s: s.state_name == "IDLE"))["throws"] == 1
    # cleanup releases the model: unconfigured, commands refused; configure again starts afresh
    client = lifecycle(ros_client, device)
    assert client.change("deactivate") == "inactive" and client.change("cleanup") == "unconfigured"
    unconfigured = status(listen, device, lambda s: s.state_name == "UNCONFIGURED")
    assert unconfigured.fault_code == 0 and list(unconfigured.counter_names) == []
    assert "UNCONFIGURED" in command(ros_client, device, "throw", 1).error
    assert client.bring_to("active") == "active"
    again = status(listen, device, lambda s: s.state_name == "IDLE")
    assert counters(again) == {
        "throws": 0,
        "faults": 0,
        "parts_presented": 0,
        "feed_goals": 0,
        "feeds_presented": 0,
        "parts_loaded": 0,
    }
    pose = wait_for(listen, PoseStamped, poses).pose.position
    assert (pose.x, pose.y) == pytest.approx(rest[:2], abs=1e-12)  # back at the initial state


# --- status, diagnostics, stop/reset, parameters ----------------------------------------------------
@pytest.mark.ros
def test_status_and_diagnostics_report_state_counters_and_the_achieved_rate(
    launch_node, ros_client, listen
) -> None:
    from diagnostic_msgs.msg import DiagnosticStatus

    device = "/stat/throwing_arm"
    launch_node(
        "feeder_sim",
        "throwing_arm",
        arm_parameters(autostart=True, hardware_id="arm-7"),
        namespace="/stat",
    )
    first = status(listen, device, lambda s: s.state_name == "RUNNING" and counters(s)["throws"] >= 1)
    assert first.ready and first.busy and no_fault(first) and list(first.active_faults) == []
    assert list(first.counter_names) == [
        "throws",
        "faults",
        "parts_presented",
        "feed_goals",
        "feeds_presented",
        "parts_loaded",
    ]
    time.sleep(6.0)  # the rate window is 5 s
    last = status(listen, device, lambda s: s.achieved_rate > 0)
    assert last.configured_rate == 50.0 and abs(last.achieved_rate - 50.0) < 5.0, last.achieved_rate
    assert last.configured_real_time_factor == 1.0
    assert abs(last.achieved_real_time_factor - 1.0) < 0.1
    # Behind real time is said, never hidden: a rate 2 % short is flagged, with the warning code.
    assert last.behind_real_time or last.achieved_rate >= 0.98 * 50.0
    assert last.behind_real_time == (last.fault_code == 2)
    # 0.2 s between throws for about 6 s: about 30 throws, none of them a fault
    assert 20 <= counters(last)["throws"] - counters(first)["throws"] <= 40 and counters(last)["faults"] == 0
    diag = diagnostics(listen, device, lambda s: values(s).get("state") == "RUNNING")
    kv = values(diag)
    assert diag.hardware_id == "arm-7"
    if kv["behind_real_time"] == "true":  # a loaded machine: a warning with the achieved figures
        assert diag.level == DiagnosticStatus.WARN and "behind real time" in diag.message
    else:
        assert diag.level == DiagnosticStatus.OK and diag.message == "running"
    assert kv["configured_rate_hz"] == "50" and abs(float(kv["achieved_rate_hz"]) - 50.0) < 5.0
    assert int(kv["throws"]) >= counters(last)["throws"] and kv["faults"] == "0" and kv["active_faults"] == ""


@pytest.mark.ros
def test_commanded_throws_are_counted_stop_halts_and_reset_returns_to_idle(
    launch_node, ros_client, listen
) -> None:
    from diagnostic_msgs.msg import DiagnosticStatus

    device = "/cmd/throwing_arm"
    # A sensor radius where some rests of the six throws read true (the local model says which).
    model = local_arm()
    rests = [model.throw() for _ in range(6)]
    sensor_radius = rests[2].radius_after
    check = local_arm()
    presented = []
    for _ in rests:
        check.throw()
        presented.append(check.sensor(sensor_radius, HEIGHT))
    assert 1 <= sum(presented) < 6
    launch_node("feeder_sim", "throwing_arm", arm_parameters(sensor_radius=sensor_radius), namespace="/cmd")
    recorder = streams(listen, device)
    events = throw_events(ros_client, device, recorder, 6)
    idle = status(listen, device, lambda s: s.state_name == "IDLE" and counters(s)["throws"] == 6)
    assert counters(idle) == {
        "throws": 6,
        "faults": 0,
        "parts_presented": sum(presented),
        "feed_goals": 0,
        "feeds_presented": 0,
        "parts_loaded": 0,
    }
    assert [e.sensor_at_rest for e in events] == presented and [e.index for e in events] == list(range(1, 7))
    assert [e.radius_after for e in events] == [r.radius_after for r in rests]
    assert all(e.header.frame_id == "cmd/arm_pivot" for e in events)
    # start throws every period until ~/stop halts the device
    assert command(ros_client, device, "start").ok
    assert status(listen, device, lambda s: s.state_name == "RUNNING").busy
    stopped = trigger(ros_client, device, "stop")
    assert stopped.success
    halted = status(listen, device, lambda s: s.state_name == "STOPPED")
    assert not halted.ready and not halted.busy
    throws = counters(halted)["throws"]
    time.sleep(1.0)
    assert counters(status(listen, device))["throws"] == throws  # nothing thrown while stopped
    refused = command(ros_client, device, "throw", 1)
    assert not refused.ok and "STOPPED" in refused.error and "~/reset" in refused.error
    diag = diagnostics(listen, device, lambda s: values(s).get("state") == "STOPPED")
    assert diag.level == DiagnosticStatus.WARN
    reset = trigger(ros_client, device, "reset")
    assert reset.success and reset.message == "reset: IDLE"
    assert not status(listen, device, lambda s: s.state_name == "IDLE").busy  # start not resumed
    assert len(throw_events(ros_client, device, recorder, 1)) == 1


@pytest.mark.ros
def test_runtime_parameters_are_applied_and_read_only_ones_refused(launch_node, ros_client, listen) -> None:
    device = "/param/throwing_arm"
    launch_node("feeder_sim", "throwing_arm", arm_parameters(), namespace="/param")
    recorder = streams(listen, device)
    faster = PAPER["release_speed"] * 1.05
    assert set_parameter(ros_client, device, "release_speed", faster).successful
    event = throw_events(ros_client, device, recorder, 1)[0]
    expected, nominal = local_arm(speed=faster).throw(), local_arm().throw()
    assert (event.edge_after, event.radius_after) == (expected.edge_after, expected.radius_after)
    assert event.radius_after != nominal.radius_after  # the new W, not the configured one
    assert place(ros_client, device).ok
    assert not any(readings(recorder, device, expect=False))  # sensor at 35 cm
    assert set_parameter(ros_client, device, "sensor_radius", SEES).successful
    seen = readings(recorder, device, expect=True)
    assert len(seen) >= 10 and all(seen)  # the sensor moved under the part at once
    refused = set_parameter(ros_client, device, "offset", -0.004)
    assert not refused.successful and "read-only" in refused.reason
    for name in ("gravity", "fidelity", "part_file", "sensor_rate", "inject_faults"):
        value = {"gravity": -9.81, "fidelity": "dynamic", "part_file": "x.yaml", "sensor_rate": 10.0}.get(
            name, ["motor_fault"]
        )
        assert not set_parameter(ros_client, device, name, value).successful, name
    bad = set_parameter(ros_client, device, "sensing_height", -1.0)
    assert not bad.successful and "sensing_height" in bad.reason
    assert not set_parameter(ros_client, device, "release_speed", 0.0).successful
    event = throw_events(ros_client, device, recorder, 1)[0]  # still at the applied W
    assert event.radius_after == local_arm(speed=faster).throw().radius_after


@pytest.mark.ros
def test_a_namespaced_arm_and_its_planner_keep_to_their_namespace(launch_node, ros_client, listen) -> None:
    from feeder_msgs.srv import ThrowCompute
    from feeder_planner.node_kit.msg_parts import part_to_msg

    namespace, device = "/cell/feeder_t", "/cell/feeder_t/throwing_arm"
    launch_node("feeder_sim", "throwing_arm", arm_parameters(), namespace=namespace)
    launch_node(
        "feeder_planner",
        "throw_planner",
        {},
        namespace=namespace,
        wait_services=(f"{namespace}/throw_planner/throw",),
    )
    recorder = streams(listen, device)
    event = throw_events(ros_client, device, recorder, 1)[0]
    pose = recorder.wait(f"{device}/part_pose", 1)[-1]
    assert event.header.frame_id == pose.header.frame_id == "cell/feeder_t/arm_pivot"
    import yaml

    request = ThrowCompute.Request(
        part=part_to_msg(yaml.safe_load(TRIANGLE.read_text())), edge=EDGE, radius=RADIUS, **PAPER
    )
    answer = ros_harness.call_service(ros_client, ThrowCompute, f"{namespace}/throw_planner/throw", request)
    assert answer.ok and (answer.edge_after, answer.radius_after) == (event.edge_after, event.radius_after)
    topics = {name for name, _ in ros_client.get_topic_names_and_types()}
    services = {name for name, _ in ros_client.get_service_names_and_types()}
    for name in ("sensor", "joint_states", "part_pose", "throw_events", "status"):
        assert f"{device}/{name}" in topics and f"/throwing_arm/{name}" not in topics
    for name in ("command", "place_part", "stop", "reset", "inject_fault", "change_state"):
        assert f"{device}/{name}" in services
    assert not any(s.startswith("/throw_planner/") for s in services)
    assert ros_client.get_publishers_info_by_topic("/clock") == []  # no device publishes /clock
    assert diagnostics(listen, device).hardware_id == f"sim:{device}"


# --- one clock --------------------------------------------------------------------------------------
@pytest.mark.ros
def test_node_clock_time_under_a_stepped_cell_clock_and_the_cap_per_tick(
    launch_node, ros_client, listen
) -> None:

    from feeder_msgs.msg import DeviceStatus

    def step(seconds: float) -> int:
        return ros_harness.step_clock(ros_client, seconds, "/cell_clock")

    stamp = ros_harness.stamp_ns

    launch_node(
        "feeder_cell",
        "cell_clock",
        {"start_paused": True, "start_time": 1.0e9},
        wait_services=("/cell_clock/step",),
    )
    device = "/clock/throwing_arm"
    # 20 Hz ticks, a throw every 0.2 s shown for 0.06 s: with 0.05 s steps a throw every 4th tick.
    launch_node(
        "feeder_sim",
        "throwing_arm",
        arm_parameters(use_sim_time=True, autostart=True, sensor_rate=20.0, motion_fraction=0.3),
        namespace="/clock",
    )
    recorder = streams(listen, device)
    statuses = listen(DeviceStatus, f"{device}/status", latched=True)
    joints, events = f"{device}/joint_states", f"{device}/throw_events"

    def tick(seconds: float) -> int:
        """Step the clock; return its time once the arm has ticked at it."""
        now = step(seconds)
        deadline = time.monotonic() + 30
        while not any(stamp(m) == now for m in recorder.get(joints)):
            assert time.monotonic() < deadline, f"no joint state stamped {now}"
            time.sleep(0.005)
        return now

    # Steps count once the arm has heard the held clock (its heartbeat stamped with the clock's start):
    # the first time it hears is its origin, and a step sent before that is a step it never saw.
    statuses.wait(lambda s: stamp(s) == 10**18, 30.0, current=True)
    time.sleep(0.5)
    assert recorder.get(joints) == []  # a held clock: no tick, nothing simulated
    ticks = [tick(0.05) for _ in range(20)]
    time.sleep(0.3)
    stamps = [stamp(m) for m in recorder.get(joints)]
    thrown = recorder.get(events)
    # The cap: at most 10 periods (0.5 s here) of simulated time per tick. With a throw every 2 s,
    # shown for 1.8 s, 5 s steps advance the model 0.5 s each: a throw and its landing take 5 ticks.
    kept_up = statuses.since(0)
    mark = statuses.count()
    assert set_parameter(ros_client, device, "period", 2.0).successful
    assert set_parameter(ros_client, device, "motion_fraction", 0.9).successful
    big = [tick(5.0) for _ in range(14)]
    time.sleep(0.3)
    lagging = statuses.since(mark)
    late = recorder.get(events)[len(thrown) :]
    # Stamps are the stepped clock's, one tick per step, from its start (not from 0).
    assert (
        stamps == ticks
        and ticks[0] >= 10**18
        and all(b - a == 50_000_000 for a, b in zip(ticks, ticks[1:], strict=False))
    )
    assert len(thrown) == 5 and [stamp(e) for e in thrown] == [ticks[k] for k in (2, 6, 10, 14, 18)]
    assert [e.index for e in thrown] == [1, 2, 3, 4, 5]
    landed = [stamp(e) for e in late]
    assert len(landed) >= 2 and all(t in big for t in landed)
    assert all(b - a == 25 * 10**9 for a, b in zip(landed, landed[1:], strict=False)), landed
    # ... and it says so: simulated time keeping 0.1 s per clock second is behind (fault code 2), while
    # 0.05 s steps, each simulated in full, never were (a held clock is not behind: nothing is late).
    assert len(kept_up) >= 3 and not any(s.behind_real_time for s in kept_up)
    assert any(s.behind_real_time and s.fault_code == DeviceStatus.FAULT_BEHIND_REAL_TIME for s in lagging)


# --- injected faults, one test each -----------------------------------------------------------------
@pytest.mark.ros
def test_sensor_stuck_reads_its_state_whatever_is_there(launch_node, ros_client, listen) -> None:
    device = "/stuck/throwing_arm"
    launch_node(
        "feeder_sim",
        "throwing_arm",
        arm_parameters(inject_faults=["sensor_stuck=true"]),  # set at configure from the parameter
        namespace="/stuck",
    )
    recorder = streams(listen, device)
    report = status(listen, device, lambda s: s.state_name == "IDLE")
    assert list(report.active_faults) == ["sensor_stuck(state=true)"] and no_fault(report) and report.ready
    assert values(diagnostics(listen, device))["active_faults"] == "sensor_stuck(state=true)"
    seen = readings(recorder, device)
    assert len(seen) >= 10 and all(seen)  # true though the sensor at 35 cm sees nothing
    assert inject(ros_client, device, "sensor_stuck", clear=True).ok
    assert list(status(listen, device, lambda s: not s.active_faults).active_faults) == []
    assert not any(readings(recorder, device, expect=False))
    assert set_parameter(ros_client, device, "sensor_radius", SEES).successful
    assert all(readings(recorder, device, expect=True))  # the part is seen again
    response = inject(ros_client, device, "sensor_stuck", state=False)
    assert response.ok and list(response.active_faults) == ["sensor_stuck(state=false)"]
    assert not any(readings(recorder, device, expect=False))  # stuck at false over the part
    assert trigger(ros_client, device, "reset").success  # ~/reset clears it too
    assert all(readings(recorder, device, expect=True))


@pytest.mark.ros
def test_sensor_dropout_drops_samples_with_its_probability(launch_node, ros_client, listen) -> None:
    device = "/drop/throwing_arm"
    launch_node("feeder_sim", "throwing_arm", arm_parameters(sensor_radius=SEES), namespace="/drop")
    recorder = streams(listen, device)
    sensor, joints = f"{device}/sensor", f"{device}/joint_states"
    for bad, field in (({"value": 1.5}, "value"), ({"indices": [4]}, "indices")):
        response = inject(ros_client, device, "sensor_dropout", **bad)
        assert not response.ok and field in response.error and list(response.active_faults) == []
    unknown = inject(ros_client, device, "wobble")
    assert not unknown.ok and "fault" in unknown.error and "sensor_dropout" in unknown.error
    assert inject(ros_client, device, "sensor_dropout", value=1.0).ok
    time.sleep(0.2)
    got = recorder.window(1.5)
    assert got[sensor] == [] and len(got[joints]) >= 20  # every sample missing, the arm still ticks
    assert inject(ros_client, device, "sensor_dropout", value=0.5, seed=7).ok
    assert list(status(listen, device, lambda s: "sensor_dropout(0.5)" in s.active_faults).active_faults)
    time.sleep(0.2)
    got = recorder.window(3.0)
    share = len(got[sensor]) / len(got[joints])
    assert 0.3 < share < 0.7 and all(m.data for m in got[sensor]), share  # missing, never wrong
    assert inject(ros_client, device, "sensor_dropout", clear=True).ok
    time.sleep(0.2)
    got = recorder.window(1.5)
    assert len(got[sensor]) >= 0.9 * len(got[joints]) > 0


@pytest.mark.ros
def test_sensor_bit_flip_inverts_the_published_bit(launch_node, ros_client, listen) -> None:
    device = "/flip/throwing_arm"
    launch_node("feeder_sim", "throwing_arm", arm_parameters(), namespace="/flip")
    recorder = streams(listen, device)
    assert inject(ros_client, device, "sensor_bit_flip", value=1.0).ok
    assert all(readings(recorder, device, expect=True))  # nothing there: every bit reads true
    assert set_parameter(ros_client, device, "sensor_radius", SEES).successful
    assert not any(
        readings(recorder, device, expect=False)
    )  # the part there: every bit reads false (not stuck)
    assert inject(ros_client, device, "sensor_bit_flip", value=0.3, seed=11).ok
    seen = readings(recorder, device, 3.0, expect=True)  # past the all-false samples of value 1.0
    share = seen.count(False) / len(seen)
    assert 0.1 < share < 0.5, share
    assert inject(ros_client, device, "sensor_bit_flip", clear=True).ok
    # A loaded machine can hold flipped samples in the queues for a while: let them drain first.
    assert all(readings(recorder, device, settle=1.0, expect=True))


@pytest.mark.ros
def test_release_speed_error_scales_w_per_throw_fixed_or_drawn_with_its_seed(
    launch_node, ros_client, listen
) -> None:
    device = "/speed/throwing_arm"
    launch_node("feeder_sim", "throwing_arm", arm_parameters(), namespace="/speed")
    recorder = streams(listen, device)
    bad = inject(ros_client, device, "release_speed_error", value=-1.0, state=True)
    assert not bad.ok and "value" in bad.error
    response = inject(ros_client, device, "release_speed_error", value=0.1, state=True)
    assert response.ok and list(response.active_faults) == ["release_speed_error(0.1, state=true)"]
    fixed = throw_events(ros_client, device, recorder, 1)[0]
    model = local_arm()
    expected = model.throw(1.1)
    assert (fixed.edge_after, fixed.radius_after) == (expected.edge_after, expected.radius_after)
    assert fixed.radius_after != local_arm().throw().radius_after
    # drawn: e ~ Normal(0, 0.05) per throw from the fault's seed, the same draws as the model's
    assert inject(ros_client, device, "release_speed_error", value=0.05, seed=3).ok
    drawn = throw_events(ros_client, device, recorder, 3)
    faults = ArmFaults(model)
    faults.inject("release_speed_error", 0.05, False, (), 3)
    expected_drawn = [faults.throw() for _ in range(3)]
    assert [e.radius_after for e in drawn] == [o.radius_after for o in expected_drawn]
    assert inject(ros_client, device, "release_speed_error", clear=True).ok
    after = throw_events(ros_client, device, recorder, 1)[0]
    assert after.radius_after == model.throw().radius_after  # nominal W again


@pytest.mark.ros
def test_motor_fault_stops_the_arm_and_refuses_throws_until_cleared(launch_node, ros_client, listen) -> None:
    from diagnostic_msgs.msg import DiagnosticStatus

    from feeder_msgs.msg import DeviceStatus

    device = "/motor/throwing_arm"
    launch_node("feeder_sim", "throwing_arm", arm_parameters(autostart=True), namespace="/motor")
    recorder = streams(listen, device)
    status(listen, device, lambda s: s.state_name == "RUNNING" and counters(s)["throws"] >= 2)
    assert inject(ros_client, device, "motor_fault").ok
    fault = status(listen, device, lambda s: s.state_name == "FAULT" and not s.busy)  # queue cancelled
    assert fault.fault_code == DeviceStatus.FAULT_MOTOR and not fault.ready
    assert "motor_fault" in fault.fault_text and list(fault.active_faults) == ["motor_fault"]
    diag = diagnostics(listen, device, lambda s: values(s).get("state") == "FAULT")
    assert diag.level == DiagnosticStatus.ERROR and "motor_fault" in diag.message
    time.sleep(0.5)  # a throw already in the air lands
    throws = counters(status(listen, device))["throws"]
    got = recorder.window(1.5)
    assert got[f"{device}/throw_events"] == [] and len(got[f"{device}/joint_states"]) >= 20
    assert all(j.velocity[0] == 0.0 for j in got[f"{device}/joint_states"])  # the arm does not move
    refused = command(ros_client, device, "throw", 1)
    assert not refused.ok and "FAULT" in refused.error and "motor_fault" in refused.error
    assert counters(status(listen, device))["throws"] == throws
    assert inject(ros_client, device, "motor_fault", clear=True).ok
    idle = status(listen, device, lambda s: s.state_name == "IDLE")
    assert no_fault(idle) and counters(idle)["faults"] == 1 and not idle.busy  # start cancelled
    assert len(throw_events(ros_client, device, recorder, 1)) == 1


@pytest.mark.ros
def test_part_lost_takes_the_part_off_until_place_part_puts_it_back(launch_node, ros_client, listen) -> None:
    from feeder_msgs.msg import DeviceStatus

    device = "/lost/throwing_arm"
    launch_node("feeder_sim", "throwing_arm", arm_parameters(sensor_radius=SEES), namespace="/lost")
    recorder = streams(listen, device)
    sensor, poses, joints = f"{device}/sensor", f"{device}/part_pose", f"{device}/joint_states"
    assert all(readings(recorder, device))
    assert inject(ros_client, device, "part_lost").ok
    lost = status(listen, device, lambda s: s.state_name == "FAULT")
    assert lost.fault_code == DeviceStatus.FAULT_PART_LOST and "part_lost" in lost.fault_text
    assert not any(readings(recorder, device, expect=False))  # what came before has drained
    got = recorder.window(1.5)
    assert got[sensor] and not any(m.data for m in got[sensor])  # nothing on the arm to sense
    assert got[poses] == [] and len(got[joints]) >= 20  # no part to locate; the arm still reports
    assert "FAULT" in command(ros_client, device, "throw", 1).error
    # Clearing the injection or ~/reset does not put the part back: still FAULT_PART_LOST.
    assert inject(ros_client, device, "part_lost", clear=True).ok
    held = status(listen, device, lambda s: not s.active_faults)
    assert held.state_name == "FAULT" and held.fault_code == DeviceStatus.FAULT_PART_LOST
    assert "place_part" in held.fault_text
    assert trigger(ros_client, device, "reset").success
    held = status(listen, device)
    assert held.state_name == "FAULT" and held.fault_code == DeviceStatus.FAULT_PART_LOST
    assert not command(ros_client, device, "throw", 1).ok
    bad = place(ros_client, device, EDGE, 0.001)
    assert not bad.ok and "radius" in bad.error
    assert place(ros_client, device).ok
    idle = status(listen, device, lambda s: s.state_name == "IDLE")
    assert no_fault(idle) and counters(idle)["faults"] == 1
    assert all(readings(recorder, device, expect=True)) and recorder.wait(poses, 1)
    event = throw_events(ros_client, device, recorder, 1)[0]
    assert not event.fault and event.radius_after == local_arm().throw().radius_after


# --- the part the arm holds -----------------------------------------------------------------------
@pytest.mark.ros
def test_load_part_replaces_the_part_the_arm_holds_and_puts_a_lost_part_back(
    launch_node, ros_client, listen
) -> None:
    from feeder_msgs.msg import DeviceStatus, Part
    from feeder_msgs.srv import ArmLoadPart

    device = "/load/throwing_arm"
    launch_node("feeder_sim", "throwing_arm", arm_parameters(), namespace="/load")
    held = wait_for(listen, Part, f"{device}/part", latched=True)
    assert held.name == "triangle" and list(held.outer.x) == [0.0, 6.0, 1.5] and held.length_unit == "cm"
    bracket = EXAMPLES / "bracket.yaml"

    def load(**fields: Any) -> Any:
        request = ArmLoadPart.Request(part_yaml=bracket.read_text(), source=str(bracket), **fields)
        return ros_harness.call_service(ros_client, ArmLoadPart, f"{device}/load_part", request)

    # A bad request is refused in one line naming the field, and the arm keeps its part.
    for fields, named in [
        ({"edge": 3, "radius": 0.1}, "edge: must be a stable hull edge"),
        ({"edge": 0, "radius": 0.001}, "radius"),
        ({"name": "bad\nname"}, "name: expected a part name"),
    ]:
        refused = load(**fields)
        assert not refused.ok and named in refused.error and "\n" not in refused.error, refused.error
    refused = ros_harness.call_service(
        ros_client, ArmLoadPart, f"{device}/load_part", ArmLoadPart.Request(part_yaml="vertices: [[0, 0]]")
    )
    assert not refused.ok and "part_yaml.vertices" in refused.error
    # Loaded while the part is lost: the new part is on the arm, the fault is over (as ~/place_part).
    assert inject(ros_client, device, "part_lost").ok
    status(listen, device, lambda s: s.fault_code == DeviceStatus.FAULT_PART_LOST)
    response = load(name="left bracket", edge=0, radius=0.1)
    assert response.ok and response.name == "left bracket", response.error
    idle = status(listen, device, lambda s: s.state_name == "IDLE" and counters(s)["parts_loaded"] == 1)
    assert no_fault(idle)
    held = wait_for(listen, Part, f"{device}/part", lambda m: m.name == "left bracket", latched=True)
    assert list(held.outer.x) == [0.0, 1.4, 1.4, 0.5, 0.5, 0.0] and held.length_unit == "cm"
    # It throws as an arm configured with the bracket from the start.
    params = ThrowParams(PAPER["offset"], PAPER["release_speed"], PAPER["gravity"], PAPER["mu"])
    local = ThrowingArm(arm_part(load_part(bracket)), params, 0, 0.1, arm_length=0.4)
    events = throw_events(ros_client, device, streams(listen, device), 2)
    expected = [local.throw() for _ in range(2)]
    assert [(e.edge_after, e.radius_after) for e in events] == [
        (o.edge_after, o.radius_after) for o in expected
    ]
    assert response.ok and load(edge=-1, radius=0.0).ok  # and serves on
