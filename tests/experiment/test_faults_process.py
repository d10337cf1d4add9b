"""Fault processes (issue 38 item 3): per device, failures after MTBF, repairs after MTTR, seeded."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from feeder_cell.experiment.faults_process import FaultProcess, FaultSpec, faults_from_mapping
from feeder_cell.launcher import load_scene
from feeder_planner.errors import InputError

ROOT = Path(__file__).resolve().parents[2]
ARM = {"fault": "part_lost", "mtbf": 100.0, "mttr": 10.0}


def test_fixed_times_fail_and_repair_on_the_dot() -> None:
    (spec,) = faults_from_mapping({"throwing_arm": {**ARM, "distribution": "fixed"}})
    events = FaultProcess(spec, seed=1).until(400.0)
    assert [(e.start, e.end) for e in events] == [(100.0, 110.0), (210.0, 220.0), (320.0, 330.0)]
    assert {(e.device, e.fault) for e in events} == {("throwing_arm", "part_lost")}


def test_exponential_times_have_the_given_means_and_availability() -> None:
    (spec,) = faults_from_mapping({"throwing_arm": ARM})
    events = FaultProcess(spec, seed=3).until(2_000_000.0)  # about 18,000 failures
    starts = np.array([e.start for e in events])
    ends = np.array([e.end for e in events])
    up = starts - np.concatenate(([0.0], ends[:-1]))
    repair = ends - starts
    n = len(events)
    assert n > 15_000
    # exponential: standard deviation = mean, so the mean of n is within 4 mean / sqrt(n)
    assert abs(up.mean() - 100.0) <= 4 * 100.0 / math.sqrt(n)
    assert abs(repair.mean() - 10.0) <= 4 * 10.0 / math.sqrt(n)
    assert up.std() == pytest.approx(100.0, rel=0.05)  # and the spread is the exponential's
    assert repair.min() > 0 and up.min() > 0
    availability = 1.0 - repair.sum() / ends[-1]
    assert availability == pytest.approx(spec.availability, abs=0.005)  # 100 / 110 = 0.909


def test_up_and_repair_may_differ_in_distribution() -> None:
    (spec,) = faults_from_mapping({"arm": {**ARM, "up": "fixed", "repair": "exponential"}})
    events = FaultProcess(spec, seed=5).until(5000.0)
    gaps = [b.start - a.end for a, b in zip(events[:-1], events[1:], strict=True)]
    assert gaps and all(g == pytest.approx(100.0, abs=1e-9) for g in gaps)
    assert len({round(e.end - e.start, 9) for e in events}) == len(events)  # repairs drawn, all different


def test_seeded_per_replication_and_per_device_whatever_the_other_devices() -> None:
    both = faults_from_mapping({"mems_field_array": ARM, "throwing_arm": ARM})
    alone = faults_from_mapping({"throwing_arm": ARM})
    arm_in_both = FaultProcess(both[1], seed=7, replication=2).until(5000.0)
    assert arm_in_both == FaultProcess(alone[0], seed=7, replication=2).until(5000.0)
    assert arm_in_both != FaultProcess(alone[0], seed=7, replication=3).until(5000.0)
    assert arm_in_both != FaultProcess(both[0], seed=7, replication=2).until(5000.0)[: len(arm_in_both)]
    # switching one time's distribution leaves the other draws where they were: the repairs stay
    fixed_up = FaultSpec("throwing_arm", "part_lost", 100.0, 10.0, up="fixed")
    repairs = [e.end - e.start for e in FaultProcess(fixed_up, seed=7, replication=2).until(5000.0)]
    assert repairs[:5] == pytest.approx([e.end - e.start for e in arm_in_both[:5]])


@pytest.mark.parametrize(
    ("entry", "field", "words"),
    [
        ({**ARM, "mtbf": -5.0}, "faults.throwing_arm.mtbf", "must be a time > 0"),
        ({**ARM, "mttr": 0}, "faults.throwing_arm.mttr", "must be a time > 0"),
        ({**ARM, "mtbf": 1e-300}, "faults.throwing_arm.mtbf", "at least 0.001 s"),
        ({**ARM, "mtbf": math.inf}, "faults.throwing_arm.mtbf", "finite"),
        ({**ARM, "mtbf": "often"}, "faults.throwing_arm.mtbf", "expected a number"),
        ({**ARM, "distribution": "weibull"}, "faults.throwing_arm.distribution", "exponential, fixed"),
        ({**ARM, "repair": "normal"}, "faults.throwing_arm.repair", "exponential, fixed"),
        ({"mtbf": 1.0, "mttr": 1.0}, "faults.throwing_arm.fault", "is required"),
        ({**ARM, "mean": 1.0}, "faults.throwing_arm.mean", "not a field"),
        ({**ARM, "state": "yes"}, "faults.throwing_arm.state", "true or false"),
        ({**ARM, "value": "high"}, "faults.throwing_arm.value", "expected a number"),
        ("often", "faults.throwing_arm", "expected a mapping"),
    ],
)
def test_a_bad_fault_process_is_one_line_naming_its_field(entry: Any, field: str, words: str) -> None:
    with pytest.raises(InputError) as caught:
        faults_from_mapping({"throwing_arm": entry})
    assert caught.value.field == field and words in caught.value.problem, str(caught.value)
    assert "\n" not in str(caught.value)


def test_the_scene_section_names_devices_of_the_scene(tmp_path: Path) -> None:
    document = yaml.safe_load((ROOT / "feeder_cell/scenes/cell.yaml").read_text())
    for node in document["nodes"]:
        for key, value in node.get("parameters", {}).items():
            if key.endswith("_file"):
                node["parameters"][key] = str((ROOT / "feeder_cell/scenes" / value).resolve())
            if key.endswith("_files"):
                node["parameters"][key] = [str((ROOT / "feeder_cell/scenes" / v).resolve()) for v in value]
    path = tmp_path / "cell.yaml"
    path.write_text(yaml.safe_dump({**document, "faults": {"throwing_arm": ARM}}))
    scene = load_scene(path)
    assert scene.faults is not None and scene.faults[0].device == "throwing_arm"
    (controller,) = [n for n in scene.nodes if n.executable == "cell_controller"]
    assert controller.parameters["faults_file"] == str(path.resolve())
    assert "arrivals_file" not in controller.parameters  # the scene has no arrivals: section
    path.write_text(yaml.safe_dump({**document, "faults": {"welder": ARM}}))
    with pytest.raises(InputError) as caught:
        load_scene(path)
    assert caught.value.field == "faults.welder" and "names no node of the scene" in caught.value.problem
    path.write_text(yaml.safe_dump({**document, "faults": {"throwing_arm": {**ARM, "fault": "rust"}}}))
    with pytest.raises(InputError) as caught:
        load_scene(path)
    assert (
        caught.value.field == "faults.throwing_arm.fault" and "unknown fault 'rust'" in caught.value.problem
    )
    assert "part_lost" in caught.value.problem  # the device's own faults are listed
    path.write_text(yaml.safe_dump({**document, "faults": {"throw_planner": ARM}}))
    with pytest.raises(InputError, match=r"faults\.throw_planner: .* is not a device"):
        load_scene(path)
    path.write_text(yaml.safe_dump({**document, "faults": {"throwing_arm": {**ARM, "mtbf": -1.0}}}))
    with pytest.raises(InputError, match=r"faults\.throwing_arm\.mtbf: must be a time > 0"):
        load_scene(path)
