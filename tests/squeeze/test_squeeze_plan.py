"""Squeeze-grasp mechanics (Goldberg 1993): known answers, dense sampling, the length bound, bad input.

Tolerances: extrema and plan ends are compared within 1e-9 rad (the model is closed form; float error
is about 1e-15 rad); a final orientation is one orientation modulo the symmetry period within 1e-7 rad.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from feeder_planner.errors import InputError
from feeder_planner.parts import load_part
from feeder_planner.squeeze import (
    apply_plan,
    check_certificate,
    check_friction,
    check_plan_angles,
    diameter_function,
    distinguishable_groups,
    frictional_squeeze,
    hull_symmetry_order,
    jams,
    plan_squeezes,
    read_width,
    shortest_plan_length,
    squeeze_function,
)
from feeder_sim.squeeze.ideal import ideal_squeeze

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"


def regular(n: int, radius: float = 0.01) -> list[list[float]]:
    return [
        [radius * math.cos(2 * math.pi * k / n), radius * math.sin(2 * math.pi * k / n)] for k in range(n)
    ]


def outline(path: str) -> np.ndarray:
    return load_part(EXAMPLES / path).outer


def same_mod(a: float, b: float, period: float, tol: float = 1e-7) -> bool:
    return abs(math.remainder(a - b, period)) <= tol


def test_rectangle_needs_two_squeezes_and_one_leaves_it_either_way_round() -> None:
    sf = squeeze_function(outline("squeeze/rectangle.yaml"))
    assert sf.symmetry == 1 and sf.steps_per_period() == 2
    widths = sorted(e.width for e in sf.diameter.minima)
    assert widths == pytest.approx([0.01, 0.02], abs=1e-12)
    # One squeeze from anywhere leaves two orientations a quarter-turn apart: widths 1 and 2 cm.
    after_one = {round(read_width(sf, t, 1e-4).width, 6) for t in np.linspace(0, 2 * math.pi, 400)}
    assert after_one == {0.01, 0.02}
    plan = plan_squeezes(sf)
    assert len(plan.angles) == 2 == shortest_plan_length(sf)
    check_certificate(sf, plan)
    assert plan.certificate.period == pytest.approx(math.pi)


def test_square_is_oriented_up_to_its_four_fold_symmetry_by_one_squeeze() -> None:
    sf = squeeze_function(outline("mems/square.yaml"))
    assert hull_symmetry_order(sf.diameter.hull) == 4
    assert sf.period == pytest.approx(math.pi / 2)
    plan = plan_squeezes(sf)
    assert len(plan.angles) == 1
    ends = [apply_plan(sf, plan.angles, t) for t in np.linspace(0, 2 * math.pi, 1001)]
    assert all(same_mod(e, ends[0], math.pi / 2) for e in ends)
    # Not oriented to a half turn: four distinct ends modulo 2 pi.
    assert len({(round(math.cos(e), 6) + 0.0, round(math.sin(e), 6) + 0.0) for e in ends}) == 4


@pytest.mark.parametrize("n", [3, 4, 5, 6, 7, 8])
def test_regular_polygon_is_oriented_by_one_squeeze_up_to_its_symmetry(n: int) -> None:
    sf = squeeze_function(regular(n))
    assert hull_symmetry_order(sf.diameter.hull) == n
    # The width has period pi and 2 pi / n: the squeeze function's period is pi / n (n odd), 2 pi / n (even).
    assert sf.period == pytest.approx(math.pi / n if n % 2 else 2 * math.pi / n)
    assert len(plan_squeezes(sf).angles) == 1 == shortest_plan_length(sf)


def test_triangles_equilateral_one_squeeze_scalene_three() -> None:
    assert len(plan_squeezes(squeeze_function(regular(3))).angles) == 1
    sf = squeeze_function(outline("throwing/triangle.yaml"))
    assert sf.symmetry == 1 and sf.steps_per_period() == 3
    assert len(plan_squeezes(sf).angles) == 3 == shortest_plan_length(sf)


def test_brackets_plans_have_their_shortest_lengths() -> None:
    for path, length in (("mems/bracket.yaml", 3), ("throwing/bracket.yaml", 2)):
        sf = squeeze_function(outline(path))
        plan = plan_squeezes(sf)
        check_certificate(sf, plan)
        assert len(plan.angles) == length == shortest_plan_length(sf), path


def test_right_angle_corner_opposite_an_edge_is_a_shoulder_not_a_minimum() -> None:
    # A 3 x 1 right triangle: with a leg flush, the opposite vertex is right above its end, so the width
    # keeps falling past it: the only stable orientation is the hypotenuse on a jaw.
    d = diameter_function([[0, 0], [0.03, 0], [0, 0.01]])
    assert len(d.minima) == 1
    assert d.minima[0].width == pytest.approx(0.03 / math.sqrt(10), rel=1e-12)


def test_minima_are_exact_edge_normals_and_pieces_match_the_definition() -> None:
    for path in ("squeeze/hexagon6.yaml", "mems/bracket.yaml", "squeeze/shallow.yaml"):
        d = diameter_function(outline(path))
        thetas = np.random.default_rng(3).uniform(0, 2 * math.pi, 2000)
        assert max(abs(d(t) - d.direct(t)) for t in thetas) < 1e-15 * 1e3
        for m in d.minima:
            # Local minimum of the definition on both sides, down to 1e-7 rad.
            for h in (1e-7, 1e-4):
                assert d.direct(m.angle - h) > m.width and d.direct(m.angle + h) > m.width
            assert d.direct(m.angle) == pytest.approx(m.width, abs=1e-15)
        for m in d.maxima:
            for h in (1e-6, 1e-3):
                assert d.direct(m.angle - h) < m.width and d.direct(m.angle + h) < m.width


def test_shallow_minimum_a_grid_misses_is_found_and_planned_for() -> None:
    d = diameter_function(outline("squeeze/shallow.yaml"))
    sf = squeeze_function(outline("squeeze/shallow.yaml"))
    bounds, _ = sf.period_steps()
    basins = np.diff(bounds)
    assert basins.min() < 6e-3  # the chamfer's basin: about 5e-3 rad
    grid = (np.arange(1000) + 0.5) * math.pi / 1000
    values = np.array([d.direct(t) for t in grid])
    grid_minima = [i for i in range(1000) if values[i] < values[i - 1] and values[i] < values[(i + 1) % 1000]]
    assert len(grid_minima) == len(d.minima) - 1  # the grid misses one
    plan = plan_squeezes(sf)
    assert len(plan.angles) == 3 == shortest_plan_length(sf)


@pytest.mark.parametrize(
    "path",
    [
        "squeeze/rectangle.yaml",
        "squeeze/hexagon6.yaml",
        "squeeze/shallow.yaml",
        "mems/bracket.yaml",
        "throwing/bracket.yaml",
        "throwing/triangle.yaml",
        "mems/square.yaml",
        "mems/plus.yaml",
    ],
)
def test_plan_orients_from_dense_initial_orientations_in_the_ideal_model(path: str) -> None:
    part = outline(path)
    sf = squeeze_function(part)
    plan = plan_squeezes(sf)
    check_certificate(sf, plan)
    rng = np.random.default_rng(7)
    starts = list(rng.uniform(0, 2 * math.pi, 1500))
    # And right beside every unstable orientation, where a grid or a sloppy basin edge goes wrong.
    for m in sf.maxima:
        for half in (0.0, math.pi):
            starts += [plan.angles[0] + m + half + h for h in (-1e-7, 1e-7, -1e-4, 1e-4)]
    for theta in starts:
        # The independent model: the contact walk from the hull vertices, squeeze by squeeze.
        for alpha in plan.angles:
            theta = alpha + ideal_squeeze(part, theta - alpha).orientation
        assert same_mod(theta, plan.certificate.final, sf.period), (path, theta)
    # And the planner's squeeze function on a denser sample.
    for theta in rng.uniform(0, 2 * math.pi, 20_000):
        assert same_mod(apply_plan(sf, plan.angles, theta), plan.certificate.final, sf.period)


def test_part_whose_plan_meets_its_bound() -> None:
    # Plan length <= steps per period n (each backchained interval gains a step); hexagon6 has n = 6 and
    # the exhaustive search over every distinct squeeze finds no plan of 5.
    sf = squeeze_function(outline("squeeze/hexagon6.yaml"))
    assert sf.symmetry == 1 and sf.steps_per_period() == 6
    assert len(plan_squeezes(sf).angles) == 6 == shortest_plan_length(sf)


def test_goldberg_plan_is_shortest_on_random_polygons_and_within_its_bound() -> None:
    rng = np.random.default_rng(11)
    for _ in range(150):
        sf = squeeze_function(rng.normal(size=(int(rng.integers(3, 12)), 2)) * 0.01)
        plan = plan_squeezes(sf)
        check_certificate(sf, plan)
        assert len(plan.angles) == shortest_plan_length(sf)
        assert len(plan.angles) <= sf.steps_per_period()


def test_jaw_width_sensor_tells_apart_what_the_plan_cannot() -> None:
    sf = squeeze_function(outline("squeeze/rectangle.yaml"))
    groups = distinguishable_groups(sf, 1e-4)
    assert len(groups) == 2  # 1 cm and 2 cm apart: one reading identifies the orientation mod pi
    assert len(distinguishable_groups(sf, 0.02)) == 1  # a sensor coarser than the difference cannot
    reading = read_width(sf, 0.3, 1e-4)
    assert reading.width == pytest.approx(0.02) and len(reading.orientations) == 1


def test_bad_input_is_refused_naming_the_field() -> None:
    with pytest.raises(InputError, match=r"^vertices: the convex hull is degenerate"):
        squeeze_function([[0, 0], [1, 1], [2, 2]])
    with pytest.raises(InputError, match=r"^plan: a plan needs at least one squeeze"):
        check_plan_angles([])
    with pytest.raises(InputError, match=r"^plan\[1\]: must be finite"):
        check_plan_angles([0.0, math.nan])
    with pytest.raises(InputError, match=r"^plan\[0\]: must be finite"):
        check_plan_angles([math.inf])
    with pytest.raises(InputError, match=r"^first_angle: must be finite"):
        plan_squeezes(squeeze_function(regular(4)), first_angle=math.inf)
    with pytest.raises(InputError, match=r"^friction: must be in \[0, 2\]"):
        check_friction(-0.1)
    with pytest.raises(InputError, match=r"^friction: must be in \[0, 2\]"):
        check_friction(2.5)
    with pytest.raises(InputError, match=r"^friction: must be finite"):
        check_friction(math.nan)
    with pytest.raises(InputError, match=r"^friction: must be in \[0, 2\]"):
        frictional_squeeze(squeeze_function(regular(4)), 0.1, -1.0)
    assert check_friction(0.0) == 0.0 and check_friction(2.0) == 2.0
    with pytest.raises(
        InputError, match=r"^vertices: the squeeze function has 6 stable orientations a period"
    ):
        plan_squeezes(squeeze_function(outline("squeeze/hexagon6.yaml")), max_steps=5)


def test_friction_tolerance_is_where_the_later_squeezes_start_to_jam() -> None:
    # The rectangle's second squeeze meets the part 45 deg from the jaws, 18.43 deg from the diagonal's
    # crest at 26.57 deg: it jams for mu >= tan(18.43 deg) = 1/3 in the quasi-static frictional model.
    sf = squeeze_function(outline("squeeze/rectangle.yaml"))
    plan = plan_squeezes(sf)
    assert plan.certificate.friction_tolerance == pytest.approx(1.0 / 3.0, rel=1e-12)
    starts = np.random.default_rng(9).uniform(0, 2 * math.pi, 400)
    first = plan.angles[0]
    clean = [float(t) for t in starts if not jams(sf, float(t) - first, 0.34)]

    def ends(theta: float, mu: float) -> float:
        for alpha in plan.angles:
            theta = alpha + frictional_squeeze(sf, theta - alpha, mu)
        return theta

    # Below it, every start the first squeeze does not hold is oriented; above it, none is.
    assert all(same_mod(ends(t, 0.33), plan.certificate.final, sf.period) for t in clean)
    assert not any(same_mod(ends(t, 0.34), plan.certificate.final, sf.period) for t in clean)
    assert math.isinf(plan_squeezes(squeeze_function(regular(4))).certificate.friction_tolerance)
