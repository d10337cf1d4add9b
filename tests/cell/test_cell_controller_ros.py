"""Over DDS: the reference cell controller runs production cycles against the real device processes.

One cell for the module, under /cell on one cell clock faster than real time: the MEMS array (the plus,
ideal), the throwing arm (the paper's triangle), the assembly fixture (the built-in block in an L
bracket) and the stable region planner, started unconfigured: the first controller brings them up (its
bring-up leaves a device that is already active as it is). Each test starts its own controller (its own
name, so its latched ~/status is its own) and reads what the controller says and what the devices count.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Callable

import pytest
import ros_harness
from ros_harness import counters, trigger
from ros_harness import inject_fault as inject

from feeder_cell.cli.launch import clock_rate

ROOT = Path(__file__).resolve().parents[2]
FACTOR = 5.0  # the cell clock's real-time factor: a 10 s cycle takes about 2 s of wall time
NS = "/cell"
MEMS, ARM, FIXTURE = f"{NS}/mems_field_array", f"{NS}/throwing_arm", f"{NS}/assembly_fixture"
SIM = {"use_sim_time": True, "real_time_factor": FACTOR}
# From the infeed pose (edge 2, R = 12 cm) the analytic arm presents on edge 1 after exactly 11 throws.
CONTROLLER = {
    "use_sim_time": True,
    "infeed_edge": 2,
    "infeed_radius": 0.12,
    "feed_max_throws": 20,
    "feed_timeout": 60.0,
    "orient_tolerance": 1e-4,
    "orient_timeout": 45.0,
    "answer_timeout": 20.0,
    "wall_timeout": 120.0,
}
CYCLE_WALL_S = 60.0  # generous wall bound per cycle on a loaded 2-core machine
# The whole scene is nine nodes on the cell clock, each handling every /clock message (at factor F the
# clock updates 200 F times a wall second): at 5 they saturate two cores and the array falls behind;
# at 2 every device keeps up on a loaded 2-core machine.


@pytest.fixture(scope="module")
def cell(launch_module_node: Callable[..., Any]) -> dict[str, Any]:
    """Start the cell's clock, devices (unconfigured) and region planner once for the module."""
    launch_module_node(
        "feeder_cell", "cell_clock", {"real_time_factor": FACTOR, "publish_rate": clock_rate(FACTOR)}
    )
    nodes = {
        "mems": launch_module_node(
            "feeder_sim",
            "mems_field_array",
            {
                **SIM,
                "fidelity": "ideal",
                "part_files": [str(ROOT / "examples/mems/plus.yaml")],
                "seed": 7,
                "time_step": 2.5e-3,  # as the cell scene: half the ideal model's stable step at drag 1.0
            },
            namespace=NS,
            lifecycle="unconfigured",
        ),
        "arm": launch_module_node(
            "feeder_sim",
            "throwing_arm",
            {**SIM, "part_file": str(ROOT / "examples/throwing/triangle.yaml"), "period": 0.25},
            namespace=NS,
            lifecycle="unconfigured",
        ),
        "fixture": launch_module_node(
            "feeder_sim", "assembly_fixture", SIM, namespace=NS, lifecycle="unconfigured"
        ),
        "planner": launch_module_node(
            "feeder_planner",
            "stable_region_planner",
            {"use_sim_time": True},
            namespace=NS,
            wait_services=(f"{NS}/stable_region_planner/safe_path",),
        ),
    }
    return nodes


def cell_status(listen: Callable[..., Any], name: str) -> Any:
    from feeder_msgs.msg import CellStatus

    return listen(CellStatus, f"{NS}/{name}/status", latched=True)


def device_status(listen: Callable[..., Any], device: str) -> Any:
    from feeder_msgs.msg import DeviceStatus

    return listen(DeviceStatus, f"{device}/status", latched=True).wait(current=True)


def run_controller(launch_node: Callable[..., Any], name: str, **parameters: Any) -> ros_harness.NodeProcess:
    return launch_node(
        "feeder_cell", "cell_controller", {**CONTROLLER, **parameters}, namespace=NS, name=name
    )


def finished(listen: Callable[..., Any], name: str, cycles: int) -> Any:
    return cell_status(listen, name).wait(
        lambda m: m.finished, timeout=CYCLE_WALL_S * max(cycles, 1) + 30, current=True
    )


@pytest.mark.ros
def test_controller_brings_the_cell_up_and_completes_n_cycles(
    cell: dict[str, Any], launch_node: Callable[..., Any], listen: Callable[..., Any], ros_client: Any
) -> None:
    before_arm = counters(device_status(listen, ARM))
    controller = run_controller(launch_node, "ctl_cycles", cycles=2)
    status = finished(listen, "ctl_cycles", 2)
    assert status.state == "FINISHED", f"{status}\n{controller.output()[-3000:]}"
    assert (status.cycles_completed, status.parts_presented, status.cycle) == (2, 2, 2)
    assert not status.stopped and status.faults_seen == 0
    assert math.isfinite(status.mean_cycle_time) and status.mean_cycle_time > 0
    assert status.parts_per_minute > 0
    # The devices were brought up through their lifecycles and did the work the metrics claim.
    for device in (MEMS, ARM, FIXTURE):
        client = ros_harness.lifecycle_of(ros_client, device)
        try:
            assert client.get_state() == "active"
        finally:
            client.close()
    arm = counters(device_status(listen, ARM))
    assert arm["parts_presented"] - before_arm.get("parts_presented", 0) >= 2
    fixture = counters(device_status(listen, FIXTURE))
    assert fixture["path_goals_reached"] >= 4  # to the target and back, twice
    # One line per cycle in the log, with the cycle's time and parts per minute.
    log = controller.output()
    assert log.count("parts/min") == 2 and "cell FINISHED: 2 cycles, 2 parts" in log


@pytest.mark.ros
def test_sensor_stuck_false_ends_the_feed_by_max_throws_then_reset_recovers(
    cell: dict[str, Any], launch_node: Callable[..., Any], listen: Callable[..., Any], ros_client: Any
) -> None:
    # Two cycles: the fault comes in the second, after a whole cycle ran clean.
    run_controller(launch_node, "ctl_stuck", cycles=2, max_retries=2, feed_max_throws=15)
    cell_status(listen, "ctl_stuck").wait(lambda m: m.cycle >= 2, timeout=CYCLE_WALL_S + 30, current=True)
    response = inject(ros_client, ARM, "sensor_stuck", state=False)
    assert response.ok, response.error
    status = finished(listen, "ctl_stuck", 2)
    assert status.state == "FINISHED", status
    assert (status.cycles_completed, status.parts_presented) == (2, 2)
    # The feed after the injection ended by max throws; ~/reset cleared the stuck sensor; it recovered.
    assert status.faults_seen >= 1 and status.faults_handled == status.faults_seen
    assert "FEED: MAX_THROWS" in status.last_fault or "FEED: TIMEOUT" in status.last_fault
    assert status.retries == status.faults_seen
    assert device_status(listen, ARM).active_faults == []


@pytest.mark.ros
def test_motor_fault_stops_the_cell_with_the_fault_named(
    cell: dict[str, Any], launch_node: Callable[..., Any], listen: Callable[..., Any], ros_client: Any
) -> None:
    from feeder_msgs.msg import DeviceStatus

    run_controller(launch_node, "ctl_motor", cycles=0)  # until stopped
    cell_status(listen, "ctl_motor").wait(lambda m: m.cycle >= 1, timeout=CYCLE_WALL_S, current=True)
    try:
        assert inject(ros_client, ARM, "motor_fault").ok
        status = finished(listen, "ctl_motor", 1)
        assert status.state == "STOPPED" and status.stopped, status
        assert status.fault_code == DeviceStatus.FAULT_MOTOR
        assert "motor_fault" in status.stop_reason and "101" in status.stop_reason
        assert status.faults_seen >= 1 and status.faults_handled == 0
    finally:
        assert trigger(ros_client, ARM, "reset").success


@pytest.mark.ros
def test_interlock_refusing_the_commanded_route_takes_the_planners_safe_path(
    cell: dict[str, Any], launch_node: Callable[..., Any], listen: Callable[..., Any]
) -> None:
    refused_before = counters(device_status(listen, FIXTURE)).get("path_goals_refused", 0)
    # Commanded: first tilt_x to 0.5 rad (outside the stable region: the block falls off the bracket),
    # then to the target 30 degrees about y. The interlock refuses the whole route before moving.
    unstable = [0.0, -math.sin(0.5), -math.cos(0.5)]
    target = [-0.5, 0.0, -math.sqrt(3) / 2]
    controller = run_controller(launch_node, "ctl_route", cycles=1, fixture_route=[*unstable, *target])
    status = finished(listen, "ctl_route", 1)
    assert status.state == "FINISHED", f"{status}\n{controller.output()[-3000:]}"
    assert status.reroutes == 1 and status.faults_seen == 0 and status.cycles_completed == 1
    assert counters(device_status(listen, FIXTURE))["path_goals_refused"] == refused_before + 1
    assert "interlock refused the route" in controller.output()


@pytest.mark.ros
def test_a_failed_configure_stops_the_cell_naming_the_bad_parameter(
    cell: dict[str, Any], launch_node: Callable[..., Any], listen: Callable[..., Any]
) -> None:
    from feeder_msgs.msg import DeviceStatus

    launch_node(
        "feeder_sim",
        "throwing_arm",
        {"use_sim_time": True, "part_file": str(ROOT / "examples/throwing/no_such_part.yaml")},
        namespace="/bad",
        lifecycle="unconfigured",
    )
    # This controller's arm is the bad one; the array and fixture are the cell's (absolute names).
    launch_node(
        "feeder_cell",
        "cell_controller",
        {**CONTROLLER, "mems_device": MEMS, "fixture_device": FIXTURE, "cycles": 1},
        namespace="/bad",
        name="ctl_bad",
    )
    from feeder_msgs.msg import CellStatus

    status = listen(CellStatus, "/bad/ctl_bad/status", latched=True).wait(
        lambda m: m.finished, 60, current=True
    )
    assert status.state == "STOPPED" and status.previous_state == "BRING_UP"
    assert status.fault_code == DeviceStatus.FAULT_CONFIGURATION
    assert "configure refused" in status.stop_reason and "part_file" in status.stop_reason
    assert status.cycle == 0


def test_a_bad_parameter_exits_2_naming_it(ros_domain: int, tmp_path: Path) -> None:
    node = ros_harness.start_node(
        "feeder_cell", "cell_controller", {"fixture_route": [0.0, 0.0]}, tmp_path, namespace="/nowhere"
    )
    try:
        assert node.process.wait(timeout=60) == 2
    finally:
        node.stop()
    assert "parameter fixture_route" in node.output() and "multiple of 3" in node.output()


def test_scene_on_exit_must_be_shutdown(tmp_path: Path) -> None:
    from feeder_cell.launcher import load_scene
    from feeder_planner.errors import InputError

    scene = tmp_path / "scene.yaml"
    scene.write_text("nodes:\n  - {package: feeder_cell, executable: cell_controller, on_exit: restart}\n")
    with pytest.raises(InputError, match=r"nodes\[0\]\.on_exit: must be one of shutdown"):
        load_scene(scene)
    scene.write_text("nodes:\n  - {package: feeder_cell, executable: cell_controller, on_exit: shutdown}\n")
    assert load_scene(scene).nodes[0].on_exit == "shutdown"
