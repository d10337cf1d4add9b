"""Safe paths (Property 2) and the K-facet pyramid against the exact circular cone."""

from __future__ import annotations

import math

import numpy as np
import pytest

from feeder_planner.assembly.exact_cone import check_exact, compare_pyramids, exact_bracket
from feeder_planner.assembly.path import great_arc
from feeder_planner.assembly.planner import path_result
from feeder_planner.errors import InputError


def test_safe_path_between_two_stable_directions_is_certified_and_inside_the_region(example) -> None:
    prepared = example("block_in_l_bracket", mu=0.4)
    region = prepared.region
    g1, g2 = region.vertices[0] * 0.9 + region.center * 0.1, region.vertices[2] * 0.9 + region.center * 0.1
    result = path_result(prepared, g1, g2, step=math.radians(0.5))
    path = result.path
    assert path[0] == pytest.approx(g1 / np.linalg.norm(g1)) and path[-1] == pytest.approx(
        g2 / np.linalg.norm(g2)
    )
    steps = np.arccos(np.clip(np.einsum("ij,ij->i", path[1:], path[:-1]), -1, 1))
    assert steps.max() <= math.radians(0.5) + 1e-12
    # Every sample lies on the one great circle through g1 and g2 (eq. 11) and inside the region.
    plane = np.cross(path[0], path[-1])
    assert np.abs(path @ plane).max() < 1e-12
    assert all(prepared.check(g).stable and region.contains(g, 1e-9) for g in path)
    assert result.min_margin_rad >= -1e-9


def test_path_refuses_an_unstable_end(example) -> None:
    prepared = example("cube_in_corner")
    with pytest.raises(InputError, match="to"):
        path_result(prepared, np.array([-1.0, -1.0, -1.0]), np.array([1.0, 0.0, 0.0]))


def test_antipodal_ends_of_a_pointed_region_have_no_arc() -> None:
    with pytest.raises(InputError, match="antipodal"):
        great_arc(np.array([0, 0, 1.0]), np.array([0, 0, -1.0]), 0.1)


def test_antipodal_ends_on_the_sphere_go_through_a_stable_midpoint(example) -> None:
    prepared = example("block_between_parallel_faces", mu=0.3)
    path = path_result(prepared, np.array([0, 0, -1.0]), np.array([0, 0, 1.0])).path
    assert path[0] @ path[-1] == pytest.approx(-1.0)
    assert (
        np.arccos(np.clip(np.einsum("ij,ij->i", path[1:], path[:-1]), -1, 1)).max() <= math.radians(1) + 1e-12
    )


def test_exact_cone_is_bracketed_and_the_pyramids_converge(example) -> None:
    prepared = example("block_in_l_bracket", mu=0.3)
    comparison = compare_pyramids(prepared.assembly, prepared.contacts, (4, 32), reference=64)
    lower, upper = comparison.exact_area_sr
    assert lower <= upper
    errors = {row.facets: row for row in comparison.pyramids}
    # Inscribed pyramids are inside the exact cone: never more area than the exact region's upper bound.
    assert all(row.area_sr <= upper + 1e-9 for row in errors.values())
    assert errors[32].area_error_sr < errors[4].area_error_sr
    assert errors[32].hausdorff_rad < errors[4].hausdorff_rad


def test_exact_cone_verdict_on_an_incline_matches_tan_alpha_le_mu(from_doc) -> None:
    # One flat contact, normal +z: g at angle alpha from -z slides iff tan(alpha) > mu (circular cone).
    document = {
        "name": "flat",
        "mu": 0.5,
        "bodies": [
            {"name": "ground", "grounded": True, "boxes": [{"min": [-2, -2, -1], "max": [2, 2, 0]}]},
            {"name": "slab", "boxes": [{"min": [-1, -1, 0], "max": [1, 1, 0.2]}]},
        ],
    }
    prepared = from_doc(document)
    for azimuth in (0.0, 0.3, math.pi / 4):
        for alpha, stable in ((math.atan(0.5) - 0.01, True), (math.atan(0.5) + 0.01, False)):
            g = np.array(
                [math.sin(alpha) * math.cos(azimuth), math.sin(alpha) * math.sin(azimuth), -math.cos(alpha)]
            )
            assert check_exact(prepared.assembly, prepared.contacts, g).stable is stable
    inner, outer = exact_bracket(prepared.assembly, prepared.contacts, 64)
    # The exact region is the cap of half-angle atan(mu): area 2 pi (1 - cos atan mu) lies in the bracket.
    cap = 2 * math.pi * (1 - math.cos(math.atan(0.5)))
    assert inner.area_sr <= cap <= outer.area_sr


def test_exact_cone_conic_check_agrees_with_the_pyramid_bracket(example) -> None:
    """The conic program and the bracket of growing pyramids are independent methods: wherever the bracket
    decides, the verdicts must be equal, and the conic program must decide (no None) away from the boundary.
    """
    from feeder_planner.assembly.exact_cone import check_exact_bracketed, check_exact_socp

    prepared = example("block_in_l_bracket", mu=0.3)
    rng = np.random.default_rng(3)
    directions = rng.normal(size=(60, 3))
    directions = np.vstack([directions, prepared.region.center + 0.3 * rng.normal(size=(60, 3))])
    decided = 0
    for g in directions / np.linalg.norm(directions, axis=1, keepdims=True):
        conic = check_exact_socp(prepared.assembly, prepared.contacts, g)
        bracket = check_exact_bracketed(prepared.assembly, prepared.contacts, g, 256)
        assert conic.method == "socp"
        if bracket.stable is not None:
            assert conic.stable is bracket.stable
            decided += 1
    assert decided >= 100


def test_exact_cone_conic_check_handles_frictionless_contacts(example) -> None:
    from feeder_planner.assembly.exact_cone import check_exact_socp

    prepared = example("cube_in_corner")  # mu = 0: the region is the octant of negative directions (Fig. 11)
    assert check_exact_socp(prepared.assembly, prepared.contacts, np.array([-1.0, -2.0, -3.0])).stable is True
    assert check_exact_socp(prepared.assembly, prepared.contacts, np.array([0.2, -1.0, -1.0])).stable is False
