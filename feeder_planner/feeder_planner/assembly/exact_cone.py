"""The exact (second-order) Coulomb cone of eq. (8), bracketed by inscribed and circumscribed K-facet pyramids.

For any K the inscribed pyramid is inside the circular cone and the circumscribed one (tangential radius
mu / cos(pi/K)) contains it, so the exact stable set lies between the two LP regions. Refining K until the two
verdicts agree decides a single direction exactly (or places it within the gap of the boundary); with a large K
the pair bounds the exact region's area and lets the paper's K = 4 linearisation be measured against it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from feeder_planner.assembly.contacts import Contact
from feeder_planner.assembly.model import Assembly
from feeder_planner.assembly.region import StableRegion, stable_region
from feeder_planner.assembly.stability import StabilityChecker
from feeder_planner.assembly.wrench import build_system

REFERENCE_FACETS = 256


@dataclass(frozen=True)
class ExactVerdict:
    """stable is True/False when certified, None when the direction is within the bracket's gap (on the boundary)."""

    stable: bool | None
    facets: int


def check_exact(assembly: Assembly, contacts: list[Contact], g: np.ndarray, max_facets: int = 1024) -> ExactVerdict:
    """Stability under the exact friction cone, decided by inscribed/circumscribed pyramids of growing K."""
    facets = 8
    while facets <= max_facets:
        if StabilityChecker(build_system(assembly, contacts, facets))(g).stable:
            return ExactVerdict(True, facets)
        if not StabilityChecker(build_system(assembly, contacts, facets, circumscribed=True))(g).stable:
            return ExactVerdict(False, facets)
        facets *= 2
    return ExactVerdict(None, max_facets)


def exact_bracket(assembly: Assembly, contacts: list[Contact], facets: int = REFERENCE_FACETS
                  ) -> tuple[StableRegion, StableRegion]:
    """Inner and outer regions that bracket the exact-cone region."""
    inner = stable_region(build_system(assembly, contacts, facets))
    outer = stable_region(build_system(assembly, contacts, facets, circumscribed=True))
    return inner, outer


def compare_pyramids(assembly: Assembly, contacts: list[Contact], facet_counts: tuple[int, ...] = (4, 8, 16, 32),
                     reference: int = REFERENCE_FACETS) -> dict:
    """Area and Hausdorff angle of each K-facet region against the exact-cone region (bracketed)."""
    inner, outer = exact_bracket(assembly, contacts, reference)
    rows = []
    for k in facet_counts:
        region = stable_region(build_system(assembly, contacts, k))
        rows.append({"facets": k, "kind": region.kind, "area_sr": region.area_sr,
                     "area_error_sr": outer.area_sr - region.area_sr,
                     "area_error_lower_sr": inner.area_sr - region.area_sr,
                     "hausdorff_rad": hausdorff_to(region, outer), "lp_count": region.lp_count})
    return {"exact_area_sr": [inner.area_sr, outer.area_sr], "reference_facets": reference,
            "bracket_hausdorff_rad": hausdorff_to(inner, outer), "pyramids": rows}


def hausdorff_to(region: StableRegion, outer: StableRegion, per_edge: int = 32) -> float:
    """max over the boundary of ``outer`` of the angle to ``region`` (region inside outer; both 'region' kind).

    For nested convex sets this is their Hausdorff distance; the boundary is sampled ``per_edge`` points per edge.
    """
    if region.kind != "region" or outer.kind != "region":
        return float("nan") if region.kind != outer.kind else 0.0
    vertices = list(outer.vertices)
    samples = []
    for a, b in zip(vertices, vertices[1:] + vertices[:1]):
        t = np.linspace(0.0, 1.0, per_edge, endpoint=False)[:, None]
        points = (1 - t) * a + t * b
        samples.append(points / np.linalg.norm(points, axis=1, keepdims=True))
    return float(np.max(distances_to_region(np.vstack(samples), region)))


def distances_to_region(points: np.ndarray, region: StableRegion) -> np.ndarray:
    """Angles from unit points (rows) to a convex spherical polygon (0 inside), vectorised over points and edges."""
    points = np.atleast_2d(points)
    a = region.vertices
    b = np.roll(region.vertices, -1, axis=0)
    m = np.cross(a, b)
    m /= np.linalg.norm(m, axis=1, keepdims=True)
    pm = points @ m.T                                                  # (S, E)
    q = points[:, None, :] - pm[:, :, None] * m[None, :, :]             # projection on each edge's great circle
    q /= np.maximum(np.linalg.norm(q, axis=2, keepdims=True), 1e-300)
    # q is on the arc iff it lies between a and b (both cross products along m).
    on_arc = (np.einsum("sek,ek->se", np.cross(a[None], q), m) >= 0) & \
             (np.einsum("sek,ek->se", np.cross(q, b[None]), m) >= 0)
    to_line = np.arcsin(np.clip(np.abs(pm), 0.0, 1.0))
    to_ends = np.minimum(np.arccos(np.clip(points @ a.T, -1, 1)), np.arccos(np.clip(points @ b.T, -1, 1)))
    distance = np.where(on_arc, to_line, to_ends).min(axis=1)
    inside = np.all(points @ region.normals.T <= 1e-12, axis=1)
    return np.where(inside, 0.0, distance)


def distance_to_region(p: np.ndarray, region: StableRegion) -> float:
    """Angle from unit p to a convex spherical polygon (0 inside)."""
    return float(distances_to_region(np.asarray(p, float)[None, :], region)[0])
