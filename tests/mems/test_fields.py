"""Fields of the array: exact wrench = -grad of the lifted potential, against sampling; program parsing."""

from __future__ import annotations

import math

import numpy as np
import pytest
from shapes import bracket, plus, washer

from feeder_planner.errors import InputError
from feeder_planner.mems.fields import (
    CombinedField,
    ConstantField,
    QuadraticField,
    RadialField,
    SqueezeField,
    field_from_mapping,
    program_from_mapping,
)
from feeder_planner.mems.frame import PartFrame

FIELDS = [
    RadialField((0.1, 0.2), 1.3),
    ConstantField((0.3, -1.0)),
    CombinedField(0.3, (0.1, 0.2)),
    SqueezeField((0.2, 0.1), 0.4, 1.0),
    QuadraticField((0.1, 0.3), (1.0, 3.0), 0.3),
]
POSE = (0.3, -0.4, 0.7)


@pytest.mark.parametrize("field", FIELDS, ids=lambda f: type(f).__name__)
def test_wrench_is_minus_gradient_of_lifted_potential(field) -> None:
    part = washer()
    wrench = field.wrench(part.placed(*POSE), np.array(POSE[:2]))
    step = 1e-6
    for k in range(3):
        q = np.array(POSE, float)
        q[k] += step
        up = field.lifted(part.placed(*q))
        q[k] -= 2 * step
        down = field.lifted(part.placed(*q))
        assert abs(-(up - down) / (2 * step) - wrench[k]) <= 1e-6 * (1 + abs(wrench[k]))


@pytest.mark.parametrize("field", FIELDS, ids=lambda f: type(f).__name__)
@pytest.mark.parametrize("make", [washer, plus, bracket], ids=lambda m: m.__name__)
def test_wrench_at_a_pose_in_the_part_frame_is_the_wrench_on_the_placed_part(field, make) -> None:
    """wrench_at (the part frame, the edges built once) = wrench on the placed loops, to rounding."""
    part = make()
    frame = PartFrame.of(part)
    rng = np.random.default_rng(3)
    # Forces scale with the area, torques with the area times the radius: rounding relative to those.
    scale = np.array([1.0, 1.0, part.radius]) * part.area * 3.0
    for _ in range(50):
        pose = np.array([*rng.uniform(-1.5, 1.5, 2) * part.radius, rng.uniform(0, 2 * math.pi)])
        placed = field.wrench(part.placed(*pose), pose[:2])
        assert np.all(np.abs(field.wrench_at(frame, pose) - placed) <= 1e-13 * scale)


@pytest.mark.parametrize("field", FIELDS, ids=lambda f: type(f).__name__)
def test_wrench_matches_dense_sampling(field) -> None:
    part = washer()
    loops = part.placed(*POSE)
    n = 800
    xs = np.linspace(-4, 4, n, endpoint=False) + 4.0 / n
    gx, gy = np.meshgrid(xs, xs)
    pts = np.column_stack([gx.ravel(), gy.ravel()])
    from matplotlib.path import Path

    inside = Path(loops[0]).contains_points(pts) & ~Path(loops[1]).contains_points(pts)
    cell = (xs[1] - xs[0]) ** 2
    f = field.force_density(pts[inside]) * cell
    r = pts[inside] - np.array(POSE[:2])
    sampled = np.array([f[:, 0].sum(), f[:, 1].sum(), (r[:, 0] * f[:, 1] - r[:, 1] * f[:, 0]).sum()])
    exact = field.wrench(loops, np.array(POSE[:2]))
    assert np.allclose(sampled, exact, atol=3e-3 * part.area * 3, rtol=2e-3)


def test_radial_field_lifted_potential_is_eq_4() -> None:
    """The lifted potential of the unit radial field at (x, y, theta) equals V(X, Y) (eq. 4)."""
    from feeder_planner.mems import lifted

    part = washer()
    x, y, theta = POSE
    big_x = x * math.cos(theta) + y * math.sin(theta)
    big_y = -x * math.sin(theta) + y * math.cos(theta)
    v = lifted.potential(lifted.part_edges(part), np.array([big_x, big_y]))
    assert abs(RadialField().lifted(part.placed(*POSE)) / v - 1) <= 1e-12


def test_program_parsing_names_bad_fields() -> None:
    program = program_from_mapping(
        {
            "steps": [
                {"field": {"type": "combined", "delta": 0.2}, "duration": 1.0},
                {"field": {"type": "squeeze", "angle": 0.5}},
            ]
        }
    )
    assert isinstance(program[0].field, CombinedField) and math.isinf(program[1].duration)
    with pytest.raises(InputError) as info:
        field_from_mapping({"type": "vortex"}, "program.steps[0].field")
    assert info.value.field == "program.steps[0].field.type"
    with pytest.raises(InputError) as info:
        program_from_mapping({"steps": [{"field": {"type": "combined", "delta": 1.5}, "duration": 1}]})
    assert info.value.field == "program.steps[0].field.delta"
    with pytest.raises(InputError) as info:
        program_from_mapping(
            {"steps": [{"field": {"type": "radial", "center": [0, float("nan")]}, "duration": 1}]}
        )
    assert info.value.field == "program.steps[0].field.center[1]"
    with pytest.raises(InputError) as info:
        program_from_mapping({"steps": [{"field": {"type": "radial"}, "duration": -1}]})
    assert info.value.field == "program.steps[0].duration"


def test_example_program_file_loads() -> None:
    from pathlib import Path

    from feeder_planner.fields_io import load_yaml_mapping

    path = Path(__file__).resolve().parents[2] / "examples" / "mems" / "program_squeeze_then_orient.yaml"
    program = program_from_mapping(load_yaml_mapping(path))
    assert [type(s.field).__name__ for s in program] == ["SqueezeField", "QuadraticField", "CombinedField"]
    assert math.isinf(program[-1].duration)
