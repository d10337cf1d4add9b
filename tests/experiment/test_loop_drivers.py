"""The cell loop's drivers: the DeviceStatus codes they hold, and the stations they share with the nodes.

The loop imports no ROS message, so its drivers hold the fault codes as numbers; these must be the
message's. Each driver ticks the station its device node ticks (docs/devices.md, "The station"): one
definition of a tick, whoever drives it.
"""

from __future__ import annotations

import importlib
from pathlib import Path

import pytest

from feeder_cell.experiment import drivers
from feeder_cell.experiment.loop import read_scene, scene_loop
from feeder_msgs.msg import DeviceStatus
from feeder_sim.fixture.station import FixtureStation
from feeder_sim.mems.station import MemsStation
from feeder_sim.throwing.station import ArmStation

SCENE = Path(__file__).resolve().parents[2] / "feeder_cell" / "scenes" / "cell.yaml"


@pytest.mark.parametrize(
    "name",
    [
        "FAULT_MOTOR",
        "FAULT_PART_LOST",
        "FAULT_POWER_LOSS",
        "FAULT_AXIS_STALL",
        "FAULT_RATE_LIMIT",
        "FAULT_TIME_STEP",
    ],
)
def test_the_drivers_fault_codes_are_the_messages(name: str) -> None:
    assert getattr(drivers, name) == getattr(DeviceStatus, name)


@pytest.mark.parametrize(
    ("node", "station"),
    [("throwing_arm", ArmStation), ("mems_field_array", MemsStation), ("assembly_fixture", FixtureStation)],
)
def test_the_loop_and_the_node_tick_the_same_station(node: str, station: type) -> None:
    module = importlib.import_module(f"feeder_sim.nodes.{node}")
    assert station in vars(module).values(), f"{node} does not build {station.__name__}"
    loop = scene_loop(read_scene(SCENE))
    driver = loop.by_name[node]
    assert type(driver.station) is station  # type: ignore[attr-defined]
