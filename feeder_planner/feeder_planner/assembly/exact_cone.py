"""The exact (second-order) Coulomb cone of eq. (8): one direction by a conic program, the region by a bracket.

A single direction is decided by a second-order cone program (Clarabel): the contact forces of eq. (6) with
|f_t| <= mu f_n exactly. The region under the exact cone is convex but not a polygon; for any K the inscribed
pyramid is inside the circular cone and the circumscribed one (tangential radius mu / cos(pi/K)) contains it, so
the exact region lies between the two LP regions: with a large K the pair bounds its area and lets the paper's
K = 4 linearisation be measured against it. Refining K until the two verdicts agree is the conic check's
fallback and cross-check.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import sparse

from feeder_planner.assembly.contacts import Contact
from feeder_planner.assembly.geometry import tangent_basis
from feeder_planner.assembly.model import Assembly
from feeder_planner.assembly.region import StableRegion, stable_region
from feeder_planner.assembly.stability import RESIDUAL_TOLERANCE, StabilityChecker, unit_gravity
from feeder_planner.assembly.wrench import build_system, wrench_system

try:
    import clarabel as _clarabel
except ImportError:  # pragma: no cover - requirements.lock installs it; the pyramid bracket decides instead
    _clarabel = None

REFERENCE_FACETS = 256
# Accepted violation of |f_t| <= mu f_n by the conic solver's forces, relative to the largest scaled force.
CONE_TOLERANCE = 1e-7


@dataclass(frozen=True)
class ExactVerdict:
    """stable is True/False when certified, None when undecided (the direction is on the boundary to tolerance).

    ``method`` is 'socp' (one conic program; ``facets`` 0) or 'pyramids' (the bracket reached K = ``facets``).
    """

    stable: bool | None
    facets: int
    method: str = "pyramids"


def check_exact(
    assembly: Assembly, contacts: list[Contact], g: np.ndarray, max_facets: int = 1024
) -> ExactVerdict:
    """Stability of unit g under the exact friction cone: the conic program, else the pyramid bracket."""
    if _clarabel is not None:
        return check_exact_socp(assembly, contacts, g)
    return check_exact_bracketed(assembly, contacts, g, max_facets)


def check_exact_bracketed(
    assembly: Assembly, contacts: list[Contact], g: np.ndarray, max_facets: int = 1024
) -> ExactVerdict:
    """Decided by inscribed (stable is proof) and circumscribed (unstable is proof) pyramids of growing K."""
    facets = 8
    while facets <= max_facets:
        if StabilityChecker(build_system(assembly, contacts, facets))(g).stable:
            return ExactVerdict(True, facets)
        if not StabilityChecker(build_system(assembly, contacts, facets, circumscribed=True))(g).stable:
            return ExactVerdict(False, facets)
        facets *= 2
    return ExactVerdict(None, max_facets)


def check_exact_socp(assembly: Assembly, contacts: list[Contact], g: np.ndarray) -> ExactVerdict:
    """Eq. (6) with the exact Coulomb cone (8): find forces f = f_n n + f_u u + f_v v per contact with
    (mu f_n, f_u, f_v) in the second-order cone (f_n >= 0 only, for mu = 0) balancing every free body.

    Stable only when the returned forces pass our own residual and cone checks; unstable only on the solver's
    certificate of primal infeasibility; anything else (a direction on the boundary, to tolerance) is None.
    """
    g = unit_gravity(g)
    generators, owners = [], []
    for index, contact in enumerate(contacts):
        n = np.asarray(contact.normal, float)
        if contact.mu > 0:
            u, v = tangent_basis(n)
            generators += [n, u, v]
            owners += [index] * 3
        else:
            generators.append(n)
            owners.append(index)
    system = wrench_system(
        assembly,
        contacts,
        np.asarray(generators, float).reshape(-1, 3),
        np.asarray(owners, dtype=int),
        facets=0,
    )
    rows, columns = system.A.shape
    rhs = -system.B @ g
    if rows == 0:
        return ExactVerdict(True, 0, "socp")
    if columns == 0:
        return ExactVerdict(bool(np.abs(rhs).max() <= RESIDUAL_TOLERANCE), 0, "socp")
    first = np.searchsorted(owners, np.arange(len(contacts)))  # each contact's first column: its normal force
    mus = np.array([c.mu for c in contacts], float)
    cone_first = first[mus > 0]
    nonneg_rows = first[mus == 0]
    # Clarabel's form G x + s = h, s in K: equilibrium rows (zero cone), f_n >= 0 rows, then per frictional contact
    # the rows of s = (mu f_n, f_u, f_v) in a 3-D second-order cone.
    selected = np.concatenate([nonneg_rows, (cone_first[:, None] + np.arange(3)[None, :]).ravel()]).astype(
        int
    )
    weights = np.concatenate(
        [np.ones(len(nonneg_rows)), (np.column_stack([mus[mus > 0], np.ones((len(cone_first), 2))])).ravel()]
    )
    cone_block = sparse.csr_matrix(
        (-weights, (np.arange(len(selected)), selected)), shape=(len(selected), columns)
    )
    G = sparse.vstack([system.A, cone_block], format="csc")
    h = np.concatenate([rhs, np.zeros(len(selected))])
    cones = [_clarabel.ZeroConeT(rows)]
    if len(nonneg_rows):
        cones.append(_clarabel.NonnegativeConeT(len(nonneg_rows)))
    cones += [_clarabel.SecondOrderConeT(3) for _ in cone_first]
    cost = np.zeros(columns)
    cost[first] = 1.0  # least total normal force: a bounded objective with well-scaled forces
    settings = _clarabel.DefaultSettings()
    settings.verbose = False
    solution = _clarabel.DefaultSolver(
        sparse.csc_matrix((columns, columns)), cost, G, h, cones, settings
    ).solve()
    status = str(solution.status)
    if status == "PrimalInfeasible":
        return ExactVerdict(False, 0, "socp")
    if status not in ("Solved", "AlmostSolved"):
        return ExactVerdict(None, 0, "socp")
    x = np.asarray(solution.x, float)
    residual = float(np.abs(system.A @ x - rhs).max())
    scale = max(1.0, float(np.abs(x).max()))
    violation = max(
        float(
            np.max(np.hypot(x[cone_first + 1], x[cone_first + 2]) - mus[mus > 0] * x[cone_first], initial=0.0)
        ),
        float(np.max(-x[nonneg_rows], initial=0.0)),
    )
    if residual <= RESIDUAL_TOLERANCE and violation <= CONE_TOLERANCE * scale:
        return ExactVerdict(True, 0, "socp")
    return ExactVerdict(None, 0, "socp")


def exact_bracket(
    assembly: Assembly, contacts: list[Contact], facets: int = REFERENCE_FACETS
) -> tuple[StableRegion, StableRegion]:
    """Inner and outer regions that bracket the exact-cone region."""
    inner = stable_region(build_system(assembly, contacts, facets))
    outer = stable_region(build_system(assembly, contacts, facets, circumscribed=True))
    return inner, outer


def compare_pyramids(
    assembly: Assembly,
    contacts: list[Contact],
    facet_counts: tuple[int, ...] = (4, 8, 16, 32),
    reference: int = REFERENCE_FACETS,
) -> dict:
    """Area and Hausdorff angle of each K-facet region against the exact-cone region (bracketed)."""
    inner, outer = exact_bracket(assembly, contacts, reference)
    rows = []
    for k in facet_counts:
        region = stable_region(build_system(assembly, contacts, k))
        rows.append(
            {
                "facets": k,
                "kind": region.kind,
                "area_sr": region.area_sr,
                "area_error_sr": outer.area_sr - region.area_sr,
                "area_error_lower_sr": inner.area_sr - region.area_sr,
                "hausdorff_rad": hausdorff_to(region, outer),
                "lp_count": region.lp_count,
            }
        )
    return {
        "exact_area_sr": [inner.area_sr, outer.area_sr],
        "reference_facets": reference,
        "bracket_hausdorff_rad": hausdorff_to(inner, outer),
        "pyramids": rows,
    }


def hausdorff_to(region: StableRegion, outer: StableRegion, per_edge: int = 32) -> float:
    """Max over the boundary of ``outer`` of the angle to ``region`` (region inside outer; both 'region' kind).

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
    pm = points @ m.T  # (S, E)
    q = points[:, None, :] - pm[:, :, None] * m[None, :, :]  # projection on each edge's great circle
    q /= np.maximum(np.linalg.norm(q, axis=2, keepdims=True), 1e-300)
    # q is on the arc iff it lies between a and b (both cross products along m).
    on_arc = (np.einsum("sek,ek->se", np.cross(a[None], q), m) >= 0) & (
        np.einsum("sek,ek->se", np.cross(q, b[None]), m) >= 0
    )
    to_line = np.arcsin(np.clip(np.abs(pm), 0.0, 1.0))
    to_ends = np.minimum(np.arccos(np.clip(points @ a.T, -1, 1)), np.arccos(np.clip(points @ b.T, -1, 1)))
    distance = np.where(on_arc, to_line, to_ends).min(axis=1)
    inside = np.all(points @ region.normals.T <= 1e-12, axis=1)
    return np.where(inside, 0.0, distance)


def distance_to_region(p: np.ndarray, region: StableRegion) -> float:
    """Angle from unit p to a convex spherical polygon (0 inside)."""
    return float(distances_to_region(np.asarray(p, float)[None, :], region)[0])
