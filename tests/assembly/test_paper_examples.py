"""The paper's example assemblies (Figs. 11, 12, 14, 16) give the regions the paper reports."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import in_cone, random_directions


def _as_set(rows: np.ndarray) -> list[tuple]:
    return sorted(tuple(np.round(r, 9) + 0.0) for r in np.asarray(rows))


def test_fig11_cube_in_corner_is_the_negative_octant(example) -> None:
    prepared = example("cube_in_corner")
    region = prepared.region
    assert region.kind == "region"
    assert _as_set(region.normals) == _as_set(np.eye(3))
    assert _as_set(region.vertices) == _as_set(-np.eye(3))
    assert region.area_sr == pytest.approx(4 * math.pi / 8, rel=1e-9)  # one octant of the sphere
    assert region.center == pytest.approx(-np.ones(3) / math.sqrt(3), abs=1e-9)
    for g in random_directions(300, 11):
        assert region.contains(g) == bool(np.all(g <= 0))


def test_fig11_vertices_are_counter_clockwise_seen_from_outside(example) -> None:
    region = example("cube_in_corner").region
    v = region.vertices
    # Counter-clockwise seen from outside: each consecutive triple turns about the outward centre direction.
    for i in range(len(v)):
        a, b, c = v[i], v[(i + 1) % len(v)], v[(i + 2) % len(v)]
        assert np.cross(b - a, c - b) @ region.center > 0


def test_fig12_block_in_l_bracket_frictionless_is_an_arc(example) -> None:
    region = example("block_in_l_bracket").region
    assert region.kind == "arc"
    assert len(region.equalities) == 1 and abs(region.equalities[0] @ [0, 1, 0]) == pytest.approx(1.0)
    assert _as_set(region.vertices) == _as_set([[-1, 0, 0], [0, 0, -1]])
    assert region.area_sr == 0.0
    # Independently: with mu = 0 the contact forces span cone{+x (upright), +z (floor)}; g must be minus it.
    for t in np.linspace(0, math.pi / 2, 7):
        g = -np.array([math.cos(t), 0.0, math.sin(t)])
        assert region.contains(g) and in_cone(np.eye(3)[[0, 2]], -g)
    assert not region.contains(np.array([-1.0, 0.01, -1.0]))


def _bracket_generators(mu: float) -> np.ndarray:
    # The paper's square pyramid |f_u|, |f_v| <= mu f_n / sqrt(2), axes aligned with the bracket's faces.
    s = mu / math.sqrt(2)
    floor = [[a * s, b * s, 1.0] for a in (-1, 1) for b in (-1, 1)]
    upright = [[1.0, a * s, b * s] for a in (-1, 1) for b in (-1, 1)]
    return np.array(floor + upright)


@pytest.mark.parametrize("mu", [0.2, 0.4])
def test_fig14_bracket_with_friction_is_a_patch_matching_the_force_cone(example, mu: float) -> None:
    region = example("block_in_l_bracket", mu=mu).region
    assert region.kind == "region"
    generators = _bracket_generators(mu)
    checked = 0
    for g in random_directions(600, 14):
        if abs(region.margin(g)) < 1e-6:
            continue
        # Torques never bind for this cube: g is stable iff -g is a non-negative combination of pyramid edges.
        assert region.contains(g) == in_cone(generators, -g), g
        checked += 1
    assert checked > 550


def test_fig14_patch_grows_with_mu_and_contains_the_frictionless_arc(example) -> None:
    arc = example("block_in_l_bracket").region
    small = example("block_in_l_bracket", mu=0.2).region
    large = example("block_in_l_bracket", mu=0.4).region
    assert 0.0 < small.area_sr < large.area_sr
    for v in small.vertices:
        assert large.margin(v) > 0.0  # strictly inside the larger patch
    for v in arc.vertices:
        assert (
            small.contains(v) and small.margin(v) > 0.0
        )  # the arc's ends are interior once there is friction


def test_fig16_block_between_parallel_faces(example) -> None:
    frictionless = example("block_between_parallel_faces", mu=0.0).region
    assert frictionless.kind == "arc"
    ends = frictionless.vertices
    assert ends[0] @ ends[1] == pytest.approx(-1.0)  # half a great circle
    assert _as_set(ends) == _as_set([[1, 0, 0], [-1, 0, 0]])
    assert frictionless.contains(np.array([0.3, 0.0, -1.0]))
    # Friction 0.3: squeezing forces on the parallel faces hold the block against any gravity (Fig. 16c:
    # potential stability).
    whole = example("block_between_parallel_faces", mu=0.3).region
    assert whole.kind == "sphere"
    assert whole.area_sr == pytest.approx(4 * math.pi)
    assert whole.contains(np.array([0.0, 0.0, 1.0]))


def test_fig16_without_the_floor_frictionless_gives_an_antipodal_pair(from_doc) -> None:
    document = {
        "name": "walls_only",
        "mu": 0.0,
        "bodies": [
            {"name": "left", "grounded": True, "boxes": [{"min": [0, 0, 0], "max": [1, 2, 3]}]},
            {"name": "right", "grounded": True, "boxes": [{"min": [2, 0, 0], "max": [3, 2, 3]}]},
            {"name": "block", "boxes": [{"min": [1, 0.5, 1], "max": [2, 1.5, 2]}]},
        ],
    }
    region = from_doc(document).region
    assert region.kind == "antipodal_pair"
    assert _as_set(region.vertices) == _as_set([[1, 0, 0], [-1, 0, 0]])
    assert from_doc(document, mu=0.3).region.kind == "sphere"


def test_returned_contact_forces_balance_every_free_body(example) -> None:
    prepared = example("block_in_l_bracket", mu=0.4)
    g = np.array([-0.7, 0.1, -0.7])
    g /= np.linalg.norm(g)
    verdict = prepared.check(g)
    assert verdict.stable
    for index in prepared.assembly.free_bodies:
        body = prepared.assembly.bodies[index]
        force = body.mass * 9.80665 * g
        torque = np.zeros(3)
        for contact, f in zip(prepared.contacts, verdict.forces, strict=True):
            sign = 1.0 if contact.a == index else -1.0 if contact.b == index else 0.0
            force = force + sign * f
            torque += sign * np.cross(contact.point - body.center, f)
            # Each force is inside the Coulomb cone (the pyramid is inscribed) and pushes (never pulls).
            normal_part = f @ contact.normal
            assert normal_part >= -1e-12
            assert np.linalg.norm(f - normal_part * contact.normal) <= 0.4 * normal_part + 1e-12
        weight = body.mass * 9.80665
        assert np.linalg.norm(force) <= 1e-6 * weight
        assert np.linalg.norm(torque) <= 1e-6 * weight * body.size
