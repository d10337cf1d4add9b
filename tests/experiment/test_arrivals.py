"""Arrivals (issue 38 item 2): the scene's arrivals: section, validated, and its seeded per-cycle draws."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from feeder_cell.experiment.arrivals import ArrivalStream, arrivals_from_mapping
from feeder_cell.experiment.streams import PURPOSES, device_key, seed_sequence, stream
from feeder_cell.launcher import load_scene
from feeder_planner.errors import InputError
from feeder_planner.parts import load_part
from feeder_planner.throwing.drop import quasi_static_drop
from feeder_planner.throwing.geometry import arm_part

ROOT = Path(__file__).resolve().parents[2]
TRIANGLE = ROOT / "examples/throwing/triangle.yaml"
SECTION: dict[str, Any] = {
    "mems": {"orientation": "uniform", "feed_area": {"x": [-0.002, 0.002], "y": [-0.001, 0.003]}},
    "arm": {"drop": "quasi_static", "radius": [0.115, 0.125]},
}


def with_part(section: dict[str, Any], seed: int = 7, replication: int = 0) -> ArrivalStream:
    arrivals = ArrivalStream(arrivals_from_mapping(section), seed, replication)
    arrivals.set_part(arm_part(load_part(TRIANGLE)))
    return arrivals


# --- the random streams ---------------------------------------------------------------------------------
def test_a_stream_is_numpys_spawned_child_of_the_scene_seed() -> None:
    # replication 3's arm stream, key (cycle) 5: the same state as spawning child by child
    spawned = np.random.SeedSequence(11).spawn(4)[3].spawn(PURPOSES["arm_arrival"] + 1)[-1].spawn(6)[5]
    direct = seed_sequence(11, 3, "arm_arrival", 5)
    assert spawned.generate_state(4).tolist() == direct.generate_state(4).tolist()
    a = stream(11, 3, "arm_arrival", 5).random(3)
    np.testing.assert_array_equal(a, stream(11, 3, "arm_arrival", 5).random(3))
    assert not np.array_equal(a, stream(11, 4, "arm_arrival", 5).random(3))  # another replication
    assert not np.array_equal(a, stream(11, 3, "mems_arrival", 5).random(3))  # another purpose
    assert not np.array_equal(a, stream(12, 3, "arm_arrival", 5).random(3))  # another seed


def test_device_keys_are_stable_across_runs() -> None:
    # CRC-32, not Python's hash() (salted per process): the same key in every process and run
    assert device_key("throwing_arm") == 0x92CEFCF3
    assert device_key("throwing_arm") != device_key("mems_field_array")


# --- draws ------------------------------------------------------------------------------------------------
def test_cycle_k_draws_the_same_part_whatever_was_drawn_before() -> None:
    one, other = with_part(SECTION), with_part(SECTION)
    for cycle in range(1, 6):
        one.arm(cycle)
        one.mems(cycle, 2)
    # ``other`` skips cycles 1-4 and draws cycle 5 twice: the same as ``one``'s cycle 5
    assert other.arm(5) == one.arm(5) == other.arm(5)
    assert other.mems(5, 2) == one.mems(5, 2)
    assert with_part(SECTION, replication=1).arm(5) != one.arm(5)


def test_arm_arrivals_follow_the_drop_distribution_and_the_radius_range() -> None:
    arrivals = with_part(SECTION)
    drawn = [arrivals.arm(cycle) for cycle in range(1, 6001)]
    expected = quasi_static_drop(arm_part(load_part(TRIANGLE))).probabilities
    shares = np.bincount([a.edge for a in drawn], minlength=3) / len(drawn)
    # 4 binomial standard errors of 6,000 draws (under 0.025)
    assert np.all(np.abs(shares - expected) <= 4 * np.sqrt(expected * (1 - expected) / len(drawn)))
    radii = np.array([a.radius for a in drawn])
    assert radii.min() >= 0.115 and radii.max() <= 0.125
    # uniform: mean 0.12, standard deviation 0.01 / sqrt(12); 4 standard errors of the mean
    assert abs(radii.mean() - 0.12) <= 4 * 0.01 / math.sqrt(12 * len(drawn))
    assert radii.min() < 0.1152 and radii.max() > 0.1248  # the whole range is reached


def test_mems_arrivals_fill_the_feed_area_and_the_orientation() -> None:
    arrivals = with_part(SECTION)
    poses = np.array([p for cycle in range(1, 3001) for p in arrivals.mems(cycle, 1)])
    x, y, theta = poses.T
    assert x.min() >= -0.002 and x.max() <= 0.002 and y.min() >= -0.001 and y.max() <= 0.003
    assert theta.min() >= -math.pi and theta.max() < math.pi
    # uniform on [-pi, pi): the share in each quarter is 1/4 within 4 standard errors
    quarters = np.bincount(((theta + math.pi) // (math.pi / 2)).astype(int), minlength=4) / len(theta)
    assert np.all(np.abs(quarters - 0.25) <= 4 * math.sqrt(0.25 * 0.75 / len(theta)))


def test_a_given_orientation_distribution_is_followed() -> None:
    section = {
        "mems": {
            "orientation": {"angles": [0.0, 1.5], "weights": [3, 1]},
            "feed_area": {"x": 0.0, "y": [0.0, 0.0]},
        }
    }
    arrivals = ArrivalStream(arrivals_from_mapping(section), 1)
    poses = [arrivals.mems(cycle, 1)[0] for cycle in range(1, 4001)]
    thetas = [p[2] for p in poses]
    assert set(thetas) == {0.0, 1.5} and {(p[0], p[1]) for p in poses} == {(0.0, 0.0)}
    assert abs(thetas.count(0.0) / 4000 - 0.75) <= 4 * math.sqrt(0.75 * 0.25 / 4000)
    ranged = ArrivalStream(
        arrivals_from_mapping({"mems": {**section["mems"], "orientation": {"range": [1, 2]}}}), 1
    )
    assert all(1.0 <= ranged.mems(cycle, 1)[0][2] <= 2.0 for cycle in range(1, 200))


# --- validation -------------------------------------------------------------------------------------------
def changed(path: str, value: Any) -> dict[str, Any]:
    section = yaml.safe_load(yaml.safe_dump(SECTION))
    *parents, key = path.split(".")
    node = section
    for parent in parents:
        node = node[parent]
    if value is KeyError:
        del node[key]
    else:
        node[key] = value
    return section


@pytest.mark.parametrize(
    ("path", "value", "field", "words"),
    [
        ("arm.radius", [-0.1, 0.1], "arrivals.arm.radius", "must be > 0"),
        ("arm.radius", [0.13, 0.12], "arrivals.arm.radius", "lo <= hi"),
        ("arm.radius", "wide", "arrivals.arm.radius", "expected [lo, hi]"),
        ("arm.radius", [0.1, math.nan], "arrivals.arm.radius[1]", "finite"),
        ("arm.radius", KeyError, "arrivals.arm.radius", "is required"),
        ("arm.drop", "exact", "arrivals.arm.drop", "quasi_static, dynamic"),
        ("arm.drops", 100, "arrivals.arm.drops", "drop: dynamic only"),
        ("arm.speed", 1, "arrivals.arm.speed", "not a field"),
        ("mems.feed_area", KeyError, "arrivals.mems.feed_area", "is required"),
        ("mems.feed_area", {"x": [0, 1]}, "arrivals.mems.feed_area.y", "is required"),
        ("mems.orientation", "random", "arrivals.mems.orientation", "expected uniform"),
        ("mems.orientation", {"range": [0, 7]}, "arrivals.mems.orientation.range", "more than 2 pi"),
        (
            "mems.orientation",
            {"angles": [0, 1], "weights": [1, -1]},
            "arrivals.mems.orientation.weights[1]",
            ">= 0",
        ),
        (
            "mems.orientation",
            {"angles": [0, 1], "weights": [1]},
            "arrivals.mems.orientation.weights",
            "one weight",
        ),
    ],
)
def test_a_bad_arrivals_value_is_one_line_naming_its_field(
    path: str, value: Any, field: str, words: str
) -> None:
    with pytest.raises(InputError) as caught:
        arrivals_from_mapping(changed(path, value))
    assert caught.value.field == field and words in caught.value.problem, str(caught.value)
    assert "\n" not in str(caught.value)


def test_dynamic_settings_are_checked_by_their_field() -> None:
    section = changed("arm", {"drop": "dynamic", "radius": 0.12, "drops": 0})
    with pytest.raises(InputError) as caught:
        arrivals_from_mapping(section)
    assert caught.value.field == "arrivals.arm.drops"
    section = changed("arm", {"drop": "dynamic", "radius": 0.12, "drop_height": -1.0})
    with pytest.raises(InputError, match=r"^arrivals\.arm\.drop_height: "):
        arrivals_from_mapping(section)
    ok = arrivals_from_mapping(
        changed("arm", {"drop": "dynamic", "radius": 0.12, "drops": 50, "friction": 0.3})
    )
    assert ok.arm is not None and (ok.arm.settings.drops, ok.arm.settings.friction) == (50, 0.3)
    assert ok.arm.radius == (0.12, 0.12)


# --- the scene --------------------------------------------------------------------------------------------
def cell_scene(tmp_path: Path, **top: Any) -> Path:
    document = yaml.safe_load((ROOT / "feeder_cell/scenes/cell.yaml").read_text())
    document.update(top)
    path = tmp_path / "cell.yaml"
    (tmp_path / "cell.yaml").write_text(yaml.safe_dump(document))
    # the scene's relative part files, from the copy's folder
    for node in document["nodes"]:
        for key, value in node.get("parameters", {}).items():
            if key.endswith("_file") and isinstance(value, str):
                node["parameters"][key] = str((ROOT / "feeder_cell/scenes" / value).resolve())
            if key.endswith("_files"):
                node["parameters"][key] = [str((ROOT / "feeder_cell/scenes" / v).resolve()) for v in value]
    path.write_text(yaml.safe_dump(document))
    return path


def test_a_scene_with_arrivals_points_the_controller_at_itself(tmp_path: Path) -> None:
    path = cell_scene(tmp_path, seed=9, arrivals=SECTION)
    scene = load_scene(path)
    assert scene.seed == 9 and scene.arrivals is not None and scene.arrivals.arm is not None
    (controller,) = [n for n in scene.nodes if n.executable == "cell_controller"]
    assert controller.parameters["arrivals_file"] == str(path.resolve())
    # without the section, nothing changes: the controller keeps its fixed infeed
    plain = load_scene(cell_scene(tmp_path))
    assert plain.arrivals is None and plain.seed == 0
    (controller,) = [n for n in plain.nodes if n.executable == "cell_controller"]
    assert "arrivals_file" not in controller.parameters


@pytest.mark.parametrize(
    ("top", "field"),
    [
        ({"arrivals": changed("arm.radius", [-1, 1])}, "arrivals.arm.radius"),
        ({"arrivals": {}}, "arrivals"),
        ({"seed": -1}, "seed"),
        ({"seed": "seven"}, "seed"),
    ],
)
def test_a_bad_scene_section_names_the_file_and_field(
    tmp_path: Path, top: dict[str, Any], field: str
) -> None:
    path = cell_scene(tmp_path, **top)
    with pytest.raises(InputError) as caught:
        load_scene(path)
    assert caught.value.source == str(path) and caught.value.field == field, str(caught.value)


def test_feeder_launch_refuses_a_bad_arrivals_section_in_one_line(tmp_path: Path, capsys: Any) -> None:
    from feeder_cell.cli.main import main

    path = cell_scene(tmp_path, arrivals=changed("arm.radius", [0.2, 0.1]))
    assert main(["launch", str(path), "--log-dir", str(tmp_path / "logs")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "arrivals.arm.radius" in err[0] and "lo <= hi" in err[0], err
