"""Over DDS: the reference controller places each cycle's parts where the scene's arrivals draw them.

A cell like tests/cell/test_cell_controller_ros.py's (clock, the plus on the ideal array, the triangle on
the arm, the fixture, the region planner); the controller reads an arrivals file (a scene's arrivals:
section and seed) and runs two cycles. What it placed, read from its log, is what ArrivalStream draws
for replication 1 of that seed, and the cycles finish: the devices accepted every drawn placement.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any, Callable

import pytest
import yaml

from feeder_cell.cli.launch import clock_rate
from feeder_cell.experiment.arrivals import ArrivalStream, arrivals_from_mapping
from feeder_planner.parts import load_part
from feeder_planner.throwing.geometry import arm_part

ROOT = Path(__file__).resolve().parents[2]
FACTOR = 5.0
NS = "/cell"
SIM = {"use_sim_time": True, "real_time_factor": FACTOR}
SECTION = {
    "mems": {"orientation": "uniform", "feed_area": {"x": [-0.001, 0.001], "y": [-0.001, 0.001]}},
    "arm": {"drop": "quasi_static", "radius": [0.115, 0.125]},
}
SEED, REPLICATION = 21, 1


@pytest.mark.ros
def test_each_cycle_places_the_drawn_parts_and_finishes(
    launch_node: Callable[..., Any], listen: Callable[..., Any], tmp_path: Path
) -> None:
    from feeder_msgs.msg import CellStatus

    launch_node("feeder_cell", "cell_clock", {"real_time_factor": FACTOR, "publish_rate": clock_rate(FACTOR)})
    mems = {**SIM, "fidelity": "ideal", "part_files": [str(ROOT / "examples/mems/plus.yaml")], "seed": 7}
    launch_node("feeder_sim", "mems_field_array", {**mems, "time_step": 2.5e-3}, namespace=NS)
    arm = {**SIM, "part_file": str(ROOT / "examples/throwing/triangle.yaml"), "period": 0.25}
    launch_node("feeder_sim", "throwing_arm", arm, namespace=NS)
    launch_node("feeder_sim", "assembly_fixture", SIM, namespace=NS)
    launch_node(
        "feeder_planner",
        "stable_region_planner",
        {"use_sim_time": True},
        namespace=NS,
        wait_services=(f"{NS}/stable_region_planner/safe_path",),
    )
    arrivals_file = tmp_path / "arrivals.yaml"
    arrivals_file.write_text(yaml.safe_dump({"seed": SEED, "arrivals": SECTION}))
    parameters = {
        "use_sim_time": True,
        "cycles": 2,
        "arrivals_file": str(arrivals_file),
        "arrivals_replication": REPLICATION,
        "feed_max_throws": 40,
        "orient_tolerance": 1e-4,
        "orient_timeout": 45.0,
        "answer_timeout": 20.0,
        "wall_timeout": 120.0,
    }
    controller = launch_node("feeder_cell", "cell_controller", parameters, namespace=NS, name="ctl_arrivals")
    status = listen(CellStatus, f"{NS}/ctl_arrivals/status", latched=True).wait(
        lambda m: m.finished, timeout=180.0, current=True
    )
    log = controller.output()
    assert status.state == "FINISHED", f"{status}\n{log[-3000:]}"
    assert (status.cycles_completed, status.parts_presented) == (2, 2)

    expected = ArrivalStream(arrivals_from_mapping(SECTION), SEED, REPLICATION)
    expected.set_part(arm_part(load_part(ROOT / "examples/throwing/triangle.yaml")))
    for cycle in (1, 2):
        drawn = expected.arm(cycle)
        line = f"cycle {cycle}: part arrives on edge {drawn.edge} at R {drawn.radius:.6g} m"
        assert line in log, f"{line!r} not in\n{log[-3000:]}"
        ((x, y, theta),) = expected.mems(cycle, 1)
        line = f"cycle {cycle}: parts placed on the array at plus ({x:.6g}, {y:.6g}, {theta:.6g})"
        assert line in log, f"{line!r} not in\n{log[-3000:]}"
    assert len(re.findall(r"part arrives on edge", log)) == 2
