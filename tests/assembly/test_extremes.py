"""Extremes: mu = 0 and 100, 1 to 2000 contact points, bodies from 1e-5 m to 1e3 m, a mass ratio of 1e-9."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import in_cone, random_directions

from feeder_planner.assembly.generate import random_assembly


def _pyramid(mu: float) -> np.ndarray:
    s = mu / math.sqrt(2)
    return np.array([[a * s, b * s, 1.0] for a in (-1, 1) for b in (-1, 1)])


def _corner_stack(small: float, mu: float) -> dict:
    """A 1 m cube in a grounded corner (Fig. 11) with a cube ``small`` m across resting on its top face."""
    return {
        "name": "corner_stack",
        "mu": mu,
        "bodies": [
            {
                "name": "corner",
                "grounded": True,
                "boxes": [
                    {"min": [-1, -1, -1], "max": [2, 2, 0]},
                    {"min": [-1, -1, 0], "max": [0, 2, 2]},
                    {"min": [-1, -1, 0], "max": [2, 0, 2]},
                ],
            },
            {"name": "huge", "boxes": [{"min": [0, 0, 0], "max": [1, 1, 1]}]},
            {"name": "tiny", "boxes": [{"min": [0.5, 0.5, 1], "max": [0.5 + small, 0.5 + small, 1 + small]}]},
        ],
    }


def test_mass_ratio_1e_9_the_tiny_body_still_decides(from_doc) -> None:
    prepared = from_doc(_corner_stack(1e-3, 0.0))
    masses = {b.name: b.mass for b in prepared.assembly.bodies}
    assert masses["tiny"] / masses["huge"] == pytest.approx(1e-9)
    # Frictionless: the huge cube alone is stable on the whole negative octant (Fig. 11), but the tiny cube on
    # its top face only for g = -z; ignoring the tiny body's equations would give the octant.
    region = prepared.region
    assert region.kind == "point"
    assert region.vertices[0] == pytest.approx([0, 0, -1], abs=1e-9)
    # With friction the tiny cube's pyramid (mu = 0.2) cuts the huge cube's region (the force cone of the
    # three corner faces' pyramids): g is stable iff -g is in both cones.
    s = 0.2 / math.sqrt(2)
    corner = np.array(
        [[a * s, b * s, 1] for a in (-1, 1) for b in (-1, 1)]
        + [[1, a * s, b * s] for a in (-1, 1) for b in (-1, 1)]
        + [[a * s, 1, b * s] for a in (-1, 1) for b in (-1, 1)]
    )
    prepared = from_doc(_corner_stack(1e-3, 0.2))
    region = prepared.region
    assert region.kind == "region"
    for g in random_directions(400, 9):
        if abs(region.margin(g)) > 1e-6:
            assert region.contains(g) == (in_cone(_pyramid(0.2), -g) and in_cone(corner, -g))


@pytest.mark.parametrize("scale", [1e-5, 1e3])
def test_tiny_and_huge_assemblies_give_the_same_region(from_doc, scale: float) -> None:
    reference = from_doc(random_assembly(6, 8, mu=0.8)).region
    scaled = from_doc(random_assembly(6, 8, mu=0.8, scale=scale)).region
    assert scaled.kind == reference.kind == "region"
    assert scaled.area_sr == pytest.approx(reference.area_sr, rel=1e-6)
    assert np.allclose(sorted(map(tuple, scaled.vertices)), sorted(map(tuple, reference.vertices)), atol=1e-6)


def test_mu_zero_and_mu_one_hundred(example) -> None:
    assert example("cube_in_corner", mu=0.0).region.area_sr == pytest.approx(math.pi / 2)
    # With mu = 100 (pyramid half-width mu/sqrt(2) > 1) floor and upright friction can wedge the block against
    # any gravity, even straight up: N_f >= N_w / mu' and M + N_f <= mu' N_w are compatible once mu'^2 > 1.
    huge = example("block_in_l_bracket", mu=100.0)
    assert huge.region.kind == "sphere"
    assert huge.check(np.array([0.0, 0.0, 1.0])).stable
    assert example("block_in_l_bracket", mu=1.0).region.kind == "region"


def test_one_contact_point_under_the_centre_of_mass_is_a_single_direction(from_doc) -> None:
    document = {
        "name": "pin",
        "mu": 0.0,
        "bodies": [
            {"name": "ground", "grounded": True, "boxes": [{"min": [-1, -1, -1], "max": [1, 1, 0]}]},
            {"name": "ball", "boxes": [{"min": [-0.5, -0.5, 0.5], "max": [0.5, 0.5, 1.5]}]},
        ],
        "contacts": [{"a": "ball", "b": "ground", "point": [0, 0, 0], "normal": [0, 0, 1]}],
    }
    region = from_doc(document).region
    assert region.kind == "point"
    assert region.vertices[0] == pytest.approx([0, 0, -1])
    # Off-centre, no direction balances the torque.
    document["contacts"][0]["point"] = [0.1, 0, 0]
    assert from_doc(document).region.kind == "empty"


def test_two_thousand_contact_points(from_doc) -> None:
    prepared = from_doc(random_assembly(8, 500, mu=0.9, walls=False))
    assert len(prepared.contacts) >= 1900
    region = prepared.region
    assert region.kind == "region" and region.area_sr > 0
    assert prepared.check(region.center).stable
    for v in region.vertices:  # just outside each corner, away from the centre: unstable
        outside = v + 1e-3 * (v - region.center)
        assert not prepared.checker(outside, explain=False).stable
