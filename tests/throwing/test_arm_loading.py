"""ROS-free: replacing the part the throwing arm holds (``~/load_part``'s model, feeder_sim.throwing.loading).

An arm that loads a part throws it exactly as an arm configured with that part from the start (same
throws, same sensor), at every fidelity; -1 and 0 start it where the parameters would; a refused load
names the field and changes nothing.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from throwing_helpers import EXAMPLES, TRIANGLE_PARAMS

from feeder_planner.errors import InputError
from feeder_planner.parts import load_part
from feeder_planner.throwing import arm_part
from feeder_sim.throwing import ArmFaults, ThrowingArm
from feeder_sim.throwing.cycle import ThrowCycle
from feeder_sim.throwing.loading import arm_part_from_yaml, configured_part, load_arm_part
from feeder_sim.throwing.parameters import ArmParameters, configure_arm

TRIANGLE, BRACKET = EXAMPLES / "triangle.yaml", EXAMPLES / "bracket.yaml"
ARM_LENGTH = 0.4


def cycle_on(path: Path, edge: int, radius: float, fidelity: str = "paper") -> ThrowCycle:
    arm = ThrowingArm(
        arm_part(load_part(path)), TRIANGLE_PARAMS, edge, radius, fidelity, ARM_LENGTH, dynamic_step=5e-4
    )
    return ThrowCycle(arm, ArmFaults(arm))


def throws(cycle: ThrowCycle, count: int) -> list[tuple[str, int, float, str]]:
    out = []
    for _ in range(count):
        o = cycle.arm.throw()
        out.append((o.kind, o.edge_after, o.radius_after, o.fault))
    return out


@pytest.mark.parametrize("fidelity,count", [("paper", 6), ("contact", 6), ("dynamic", 2)])
def test_a_loaded_part_throws_as_an_arm_configured_with_it(fidelity: str, count: int) -> None:
    loaded = cycle_on(TRIANGLE, 1, 0.12, fidelity)
    throws(loaded, 2)  # the former part has been thrown: nothing of it may remain
    held = load_arm_part(loaded, BRACKET.read_text(), "", str(BRACKET), (0, 0.1), ARM_LENGTH)
    fresh = cycle_on(BRACKET, 0, 0.1, fidelity)
    assert held.name == "bracket" and held.source == str(BRACKET)
    assert (loaded.arm.edge, loaded.arm.radius) == (fresh.arm.edge, fresh.arm.radius) == (0, 0.1)
    assert loaded.arm.rest_pose() == fresh.arm.rest_pose()
    for radius in (0.05, 0.1, 0.2):
        assert loaded.arm.sensor(radius, 0.001) == fresh.arm.sensor(radius, 0.001)
    assert throws(loaded, count) == throws(fresh, count)


def test_minus_one_and_zero_start_the_part_where_the_parameters_would() -> None:
    p = ArmParameters(part_file=str(BRACKET), initial_edge=-1, initial_radius=0.0)
    configured = configure_arm(p)
    cycle = cycle_on(TRIANGLE, 1, 0.12)
    load_arm_part(cycle, BRACKET.read_text(), "", "", (-1, 0.0), ARM_LENGTH)
    assert (cycle.arm.edge, cycle.arm.radius) == (configured.edge, configured.radius)
    assert configured_part(p, configured.part).name == "bracket"


def test_names_the_given_one_else_the_documents_else_part() -> None:
    _, held = arm_part_from_yaml(BRACKET.read_text(), "left bracket", "bin 3")
    assert (held.name, held.source, held.description()["name"]) == ("left bracket", "bin 3", "left bracket")
    part, held = arm_part_from_yaml("vertices: [[0, 0], [0.06, 0], [0.015, 0.05]]")
    assert held.name == "part" == part.part.name and held.description()["vertices"][1] == [0.06, 0]


@pytest.mark.parametrize(
    "change,named",
    [
        ({"text": "vertices: ["}, "part_yaml: not valid YAML"),
        ({"text": "- 1\n- 2"}, "part_yaml: expected a mapping"),
        ({"text": "vertices: [[0, 0], [1, 0]]"}, "part_yaml.vertices"),
        ({"text": "vertices: [[0, 0], [1, 0], [0, 1]]\ndensity: -1"}, "part_yaml.density"),
        ({"name": " padded"}, "name"),
        ({"name": "two\nlines"}, "name"),
        ({"source": "a\nb"}, "source"),
        ({"start": (7, 0.1)}, "edge"),
        ({"start": (0, math.nan)}, "radius"),
        ({"start": (0, 1.0)}, "radius"),  # beyond the arm
        ({"start": (0, 0.001)}, "radius"),  # below the grasp radius
    ],
)
def test_a_refused_load_names_the_field_and_changes_nothing(change: dict, named: str) -> None:
    cycle = cycle_on(TRIANGLE, 1, 0.12)
    before = (cycle.arm.part, cycle.arm.edge, cycle.arm.radius)
    request = {"text": BRACKET.read_text(), "name": "", "source": "", "start": (0, 0.1), **change}
    with pytest.raises(InputError) as raised:
        load_arm_part(
            cycle, request["text"], request["name"], request["source"], request["start"], ARM_LENGTH
        )
    assert str(raised.value).startswith(named) or f": {named}" in str(raised.value), str(raised.value)
    assert "\n" not in str(raised.value)
    assert (cycle.arm.part, cycle.arm.edge, cycle.arm.radius) == before


def test_a_bad_part_is_attributed_to_its_source() -> None:
    cycle = cycle_on(TRIANGLE, 1, 0.12)
    with pytest.raises(InputError, match=r"^bin/7\.yaml: part_yaml\.vertices"):
        load_arm_part(cycle, "vertices: [[0, 0], [1, 0]]", "", "bin/7.yaml", (0, 0.1), ARM_LENGTH)


def test_loading_puts_a_lost_part_back_and_ends_the_throw_shown() -> None:
    cycle = cycle_on(TRIANGLE, 1, 0.12)
    cycle.throw(0)
    assert cycle.motion is not None
    cycle.faults.inject("part_lost")
    assert not cycle.arm.on_arm and cycle.arm.faulted
    load_arm_part(cycle, BRACKET.read_text(), "", "", (-1, 0.0), ARM_LENGTH)
    assert cycle.arm.on_arm and not cycle.arm.faulted and cycle.motion is None
    assert "part_lost" not in cycle.faults.names
    assert "arm faulted earlier" not in cycle.arm.throw().fault
