"""A running scene as an integrator meets it: frame ids tf2 accepts, and every node stopping cleanly.

Each test launches a scene with ``feeder launch`` on a domain of its own and ends it by pid.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any, Iterator

import pytest
import ros_harness

ROOT = Path(__file__).resolve().parents[2]
FEEDER = [sys.executable, "-m", "feeder_cell.cli.main", "launch"]

pytestmark = pytest.mark.ros


def _env(domain: int) -> dict[str, str]:
    return dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")


_node_pids = ros_harness.launched_node_pids


def _end(process: subprocess.Popen[str]) -> tuple[str, str]:
    """Interrupt a launch and return its output (killed if it does not end)."""
    if process.poll() is None:
        process.send_signal(signal.SIGINT)
    try:
        return process.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        process.kill()
        return process.communicate()


# --- frame ids --------------------------------------------------------------------------------------
def bad_frame_ids(message: Any, path: str = "") -> Iterator[str]:
    """Yield ``path: frame id`` for every frame id in ``message`` that starts with a slash.

    Walks the message by rosidl's introspection (``get_fields_and_field_types``), into nested messages
    and sequences and arrays of them: every ``std_msgs/Header``'s ``frame_id`` and every
    ``child_frame_id`` (a tf transform's, an odometry's).
    """
    fields = getattr(type(message), "get_fields_and_field_types", None)
    if fields is None:
        return
    for name, type_name in fields().items():
        value = getattr(message, name)
        where = f"{path}.{name}" if path else name
        if isinstance(value, str):
            header_field = name == "frame_id" and type(message).__name__ == "Header"
            if (header_field or name == "child_frame_id") and value.startswith("/"):
                yield f"{where}: {value!r}"
        elif "/" in type_name and not type_name.startswith(("sequence<", "string")) and "[" not in type_name:
            yield from bad_frame_ids(value, where)
        elif "/" in type_name and isinstance(value, (list, tuple)):
            for index, item in enumerate(value):
                yield from bad_frame_ids(item, f"{where}[{index}]")


def test_the_frame_id_walk_finds_headers_in_arrays_and_tf_children() -> None:
    from geometry_msgs.msg import TransformStamped
    from std_msgs.msg import Header
    from tf2_msgs.msg import TFMessage
    from visualization_msgs.msg import Marker, MarkerArray

    tf = TFMessage(transforms=[TransformStamped(), TransformStamped()])
    tf.transforms[1].header.frame_id, tf.transforms[1].child_frame_id = "cell", "/arm"
    assert list(bad_frame_ids(tf)) == ["transforms[1].child_frame_id: '/arm'"]
    markers = MarkerArray(markers=[Marker(), Marker()])
    markers.markers[0].header.frame_id = "/cell/assembly"
    assert list(bad_frame_ids(markers)) == ["markers[0].header.frame_id: '/cell/assembly'"]
    assert list(bad_frame_ids(Header(frame_id="/cell/arm"))) == ["frame_id: '/cell/arm'"]
    assert list(bad_frame_ids(Header(frame_id="cell/arm"))) == []


def test_no_published_frame_id_starts_with_a_slash(tmp_path: Path) -> None:
    """Every topic the cell scene's nodes publish (clock, simulation, devices, planners, controller)."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    from feeder_cell.bag.qos import matching_qos, offered_qos
    from feeder_cell.bag.types import message_class
    from feeder_cell.launcher import load_scene

    names = {s.fully_qualified_name for s in load_scene(ROOT / "feeder_cell/scenes/cell.yaml").nodes}
    names |= {"/cell_clock", "/cell_simulation"}
    lease = ros_harness.DomainLease()
    launch = subprocess.Popen(
        # Enough cycles that the launch outlives the walk: the scene's own 3 can end it at `max` before the
        # walk's 8 s without a new topic (a CI run saw it: exit 0 after 14.8 s), and that end is no fault.
        [*FEEDER, str(ROOT / "feeder_cell/scenes/cell.yaml"), "--real-time-factor", "max"]
        + ["--set", "cell_controller.cycles=1000", "--log-dir", str(tmp_path / "logs"), "--json"],
        env=_env(lease.domain),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=lease.domain)
    node = rclpy.create_node("frame_id_probe", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    seen: dict[str, int] = {}
    bad: dict[str, str] = {}

    def on_message(topic: str, message: Any) -> None:
        seen[topic] = seen.get(topic, 0) + 1
        for found in bad_frame_ids(message):
            bad.setdefault(topic, found)

    try:
        subscribed: set[str] = set()
        deadline = time.monotonic() + 60
        last_new = time.monotonic()
        # Until no new topic has appeared for 8 s and the arm has thrown (a whole cycle's topics), or 60 s.
        while time.monotonic() < deadline and (time.monotonic() - last_new < 8 or not subscribed):
            assert launch.poll() is None, f"the launch ended early: {launch.communicate()[1][-1500:]}"
            for name, ns in node.get_node_names_and_namespaces():
                fqn = f"{ns.rstrip('/')}/{name}"
                if fqn not in names:
                    continue
                for topic, types in node.get_publisher_names_and_types_by_node(name, ns):
                    if topic in subscribed or topic in ("/rosout", "/parameter_events") or len(types) != 1:
                        continue
                    publishers = node.get_publishers_info_by_topic(topic)
                    if not publishers:
                        continue
                    subscribed.add(topic)
                    last_new = time.monotonic()
                    node.create_subscription(
                        message_class(types[0]),
                        topic,
                        lambda m, t=topic: on_message(t, m),
                        matching_qos(*offered_qos(publishers), depth=100),
                    )
            for _ in range(20):
                executor.spin_once(timeout_sec=0.02)
        out, err = _end(launch)
    finally:
        if launch.poll() is None:
            _end(launch)
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=context)
        lease.release()
    assert bad == {}, f"frame ids with a leading slash: {bad}"
    # What was walked: the lockstep answers (Header: the controller's; the hosted devices answer the hosted
    # clock by direct calls), tf, markers, device streams and statuses.
    for topic in (
        "/lockstep/reacted",
        "/tf_static",
        "/cell/throwing_arm/status",
        "/cell/throwing_arm/joint_states",
        "/cell/mems_field_array/part_states",
        "/cell/assembly_fixture/joint_states",
    ):
        assert seen.get(topic, 0) > 0, f"nothing heard on {topic}: {sorted(seen)}; launch:\n{err[-3000:]}"
    assert len(seen) >= 25, sorted(seen)
    summary = json.loads(out)
    assert all(n["exit_code"] == 0 for n in summary["nodes"]), [
        (n["name"], n["exit_code"]) for n in summary["nodes"]
    ]


# --- stopping ---------------------------------------------------------------------------------------
DEVICES = ("/mems_field_array", "/throwing_arm", "/assembly_fixture")
PLANNERS = ("/field_equilibria_planner", "/throw_planner", "/stable_region_planner")


def _wait_until_running(node: Any, executor: Any, launch: subprocess.Popen[str], timeout: float) -> None:
    """Wait until the demo scene runs: each device ready (its latched status) and each planner serving."""
    from feeder_msgs.msg import DeviceStatus
    from feeder_planner.node_kit import LATCHED

    ready: dict[str, bool] = {}
    subscriptions = [
        node.create_subscription(
            DeviceStatus, f"{d}/status", lambda m, d=d: ready.__setitem__(d, bool(m.ready)), LATCHED
        )
        for d in DEVICES
    ]

    def serving(planner: str) -> bool:
        names = {n for n, _ in node.get_service_names_and_types()}
        return any(n.startswith(f"{planner}/") and "parameter" not in n for n in names)

    deadline = time.monotonic() + timeout
    try:
        while not (all(ready.get(d) for d in DEVICES) and all(serving(p) for p in PLANNERS)):
            assert launch.poll() is None, launch.communicate()[1][-1500:]
            assert time.monotonic() < deadline, f"scene not running after {timeout} s: {ready}"
            executor.spin_once(timeout_sec=0.1)
    finally:
        for subscription in subscriptions:
            node.destroy_subscription(subscription)


def test_every_node_of_a_running_scene_stops_with_exit_code_0_three_times(tmp_path: Path) -> None:
    """Ctrl-C on a running demo scene: SIGINT to the launch and every node at once, then the launch's own.

    The demo scene has every kind of node (the devices, and the planners on multi-threaded executors). A
    node still cleaning up when the second SIGINT came ended by that signal (-2; node_kit.runner).
    """
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    lease = ros_harness.DomainLease()
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=lease.domain)
    node = rclpy.create_node("stop_probe", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    try:
        for run in range(3):
            launch = subprocess.Popen(
                [
                    *FEEDER,
                    str(ROOT / "feeder_cell/scenes/demo.yaml"),
                    "--log-dir",
                    str(tmp_path / f"logs{run}"),
                ]
                + ["--json"],
                env=_env(lease.domain),
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                text=True,
                start_new_session=True,  # its own process group, as a terminal's Ctrl-C reaches it
            )
            try:
                _wait_until_running(node, executor, launch, 90)
                time.sleep(1.0)  # running: the arm throws, the field planner predicts
                pids = _node_pids(launch.pid)
                os.killpg(launch.pid, signal.SIGINT)
                # ... and the launch's own SIGINT reaching a node while it cleans up, sooner than the
                # launch sends it (it stops one node after another): at 0.05, 0.1, 0.15 s.
                time.sleep(0.05 * (run + 1))
                for pid in pids:
                    try:
                        os.kill(pid, signal.SIGINT)
                    except ProcessLookupError:
                        pass
                out, err = launch.communicate(timeout=60)
            finally:
                if launch.poll() is None:
                    _end(launch)
            codes = {n["name"]: n["exit_code"] for n in json.loads(out)["nodes"]}
            assert len(codes) == 6 and all(code == 0 for code in codes.values()), f"run {run}: {codes}"
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=context)
        lease.release()


@pytest.mark.parametrize(
    "module", ["feeder_sim.nodes.throwing_arm", "feeder_planner.nodes.stable_region_planner"]
)
def test_a_node_stops_with_exit_code_0_under_stop_signals_from_its_start(module: str, tmp_path: Path) -> None:
    """SIGINT and SIGTERM every 5 ms from the node's construction until it is gone: exit 0, no traceback.

    The signals reach the node while it builds itself, spins, cleans up and exits (node_kit.runner
    StopRequest). With rclpy's own handlers a signal raised KeyboardInterrupt in the construction (exit -2
    and a traceback) or in the clean-up; a Python handler left installed ended the interpreter's exit by
    the signal (exit -2). A single-threaded device and a multi-threaded planner. (rcl's debug log says
    when rclpy is up, the construction's start; before it a signal is Python's, as in any program.)
    """
    lease = ros_harness.DomainLease()
    log = tmp_path / "node.log"
    with log.open("w") as sink:
        process = subprocess.Popen(
            [sys.executable, "-m", module, "--ros-args", "-r", "__ns:=/storm", "--log-level", "rcl:=debug"],
            env=_env(lease.domain),
            stdout=sink,
            stderr=subprocess.STDOUT,
        )
    try:
        deadline = time.monotonic() + 60
        while "Initializing node" not in log.read_text() and process.poll() is None:
            assert time.monotonic() < deadline, "the node never started its construction"
            time.sleep(0.005)
        signals = 0
        while process.poll() is None and time.monotonic() < deadline:
            try:
                process.send_signal(signal.SIGTERM if signals % 3 == 2 else signal.SIGINT)
            except ProcessLookupError:
                break
            signals += 1
            time.sleep(0.005)
        process.wait(timeout=30)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
        lease.release()
    out = log.read_text()
    assert "Traceback" not in out, out[-3000:]
    assert process.returncode == 0, f"exit {process.returncode} after {signals} signals:\n{out[-3000:]}"
