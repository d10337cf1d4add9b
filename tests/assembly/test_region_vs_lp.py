"""The exact region agrees with the stability LP of eq. (9) at thousands of random directions."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import random_directions

from feeder_planner.assembly.generate import random_assembly

BOUNDARY_BAND = 1e-6  # rad: directions this close to the boundary are not compared


def _directions(region, count: int, seed: int) -> np.ndarray:
    """Half uniform on the sphere, half scattered around the region's centre (both verdicts frequent)."""
    uniform = random_directions(count - count // 2, seed)
    if region.center is None:
        return uniform
    radius = max([np.arccos(np.clip(region.center @ v, -1, 1)) for v in region.vertices] + [0.05])
    near = region.center + radius * np.random.default_rng(seed + 1).normal(size=(count // 2, 3))
    return np.vstack([uniform, near / np.linalg.norm(near, axis=1, keepdims=True)])


def _agreement(prepared, count: int, seed: int) -> tuple[int, int, int]:
    region = prepared.region
    compared = stable = 0
    for g in _directions(region, count, seed):
        if abs(region.margin(g)) < BOUNDARY_BAND:
            continue
        verdict = prepared.checker(g, explain=False).stable
        assert region.contains(g) == verdict, (g.tolist(), region.margin(g))
        compared += 1
        stable += verdict
    return compared, count, stable


@pytest.mark.parametrize(
    "seed, faces, mu, facets", [(1, 6, 0.8, 4), (2, 12, 1.0, 4), (3, 8, 0.0, 4), (4, 10, 0.7, 7)]
)
def test_random_assembly_membership_equals_the_lp(
    from_doc, seed: int, faces: int, mu: float, facets: int
) -> None:
    prepared = from_doc(random_assembly(seed, faces, mu=mu), facets=facets)
    compared, count, stable = _agreement(prepared, 2000, seed)
    assert compared >= 0.98 * count
    if prepared.region.kind == "region":  # both verdicts well represented: the comparison is not vacuous
        assert 100 < stable < compared - 100


def test_tilted_convex_block_on_an_incline(from_doc) -> None:
    """A hull-shaped ramp and a hull-shaped block on its slope: contacts on a tilted face, region vs LP."""
    slope = np.radians(20.0)
    c, s = np.cos(slope), np.sin(slope)
    ramp = [[0, 0, 0], [4, 0, 0], [0, 2, 0], [4, 2, 0], [4, 0, 4 * np.tan(slope)], [4, 2, 4 * np.tan(slope)]]
    # A 1 x 1 x 0.4 block lying on the slope (x along the slope, z along its normal).
    origin = np.array([1.5, 0.5, 1.5 * np.tan(slope)])
    along, normal = np.array([c, 0, s]), np.array([-s, 0, c])
    block = [
        list(origin + a * along + b * np.array([0, 1, 0]) + h * normal)
        for a in (0, 1)
        for b in (0, 1)
        for h in (0, 0.4)
    ]
    document = {
        "name": "incline",
        "mu": 0.5,
        "bodies": [
            {"name": "ramp", "grounded": True, "convex": [ramp]},
            {"name": "block", "convex": [block]},
        ],
    }
    prepared = from_doc(document)
    assert len(prepared.contacts) == 4
    assert all(np.allclose(contact.normal, normal) for contact in prepared.contacts)
    compared, _, _ = _agreement(prepared, 2000, 5)
    assert compared > 1900
    # Straight down is stable iff tan(20 deg) <= mu along the pyramid's weakest direction (mu / sqrt(2) here).
    assert prepared.check(np.array([0.0, 0.0, -1.0])).stable == (np.tan(slope) <= 0.5 / np.sqrt(2))


def test_independent_sub_assemblies_solved_apart_give_the_same_region(from_doc, monkeypatch) -> None:
    from feeder_planner.assembly import region as region_module
    from feeder_planner.assembly.wrench import split_components

    prepared = from_doc(random_assembly(2, 27, mu=0.9))
    assert len(split_components(prepared.system)) > 2  # towers linked only through grounded bodies
    whole = region_module.stable_region(prepared.system)
    monkeypatch.setattr(region_module, "SPLIT_COLUMNS", 0)
    split = region_module.stable_region(prepared.system)
    assert split.kind == whole.kind == "region"
    assert split.area_sr == pytest.approx(whole.area_sr, rel=1e-7)
    assert np.allclose(sorted(map(tuple, split.vertices)), sorted(map(tuple, whole.vertices)), atol=1e-7)
