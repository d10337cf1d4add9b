"""The exact (second-order) Coulomb cone of eq. (2): one direction by a conic program, regions bracketed.

A single direction is decided by a second-order cone program (Clarabel): the contact forces of eq. (8) with
|f_t| <= mu f_n exactly (eq. 2). The region under the exact cone is convex but not a polygon; for any K the
inscribed pyramid is inside the circular cone and the circumscribed one (tangential radius mu / cos(pi/K))
contains it, so the exact region lies between the two LP regions: with a large K the pair bounds its area and
lets the paper's K = 4 linearisation (eq. 9) be measured against it. Refining K until the two verdicts agree
is the conic check's fallback and cross-check.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from scipy import sparse

from feeder_planner.assembly.contacts import Contact
from feeder_planner.assembly.geometry import tangent_basis
from feeder_planner.assembly.model import Assembly
from feeder_planner.assembly.region import RegionKind, StableRegion, stable_region
from feeder_planner.assembly.stability import StabilityChecker, unit_gravity
from feeder_planner.assembly.tolerances import (
    BRACKET_MAX_FACETS,
    BRACKET_START_FACETS,
    COMPARED_FACETS,
    CONE_TOLERANCE,
    HAUSDORFF_SAMPLES_PER_EDGE,
    INSIDE_TOLERANCE,
    NORM_FLOOR,
    REFERENCE_FACETS,
    RESIDUAL_TOLERANCE,
)
from feeder_planner.assembly.wrench import EquilibriumSystem, build_system, wrench_system

try:
    import clarabel as _clarabel
except ImportError:  # pragma: no cover - requirements.lock installs it; the pyramid bracket decides instead
    _clarabel = None

__all__ = [
    "ExactMethod",
    "ExactVerdict",
    "PyramidComparison",
    "PyramidRow",
    "check_exact",
    "check_exact_bracketed",
    "check_exact_socp",
    "compare_pyramids",
    "distances_to_region",
    "exact_bracket",
    "hausdorff_to",
]

ExactMethod = Literal["socp", "pyramids"]
"""How an exact-cone verdict was reached: one conic program, or the bracket of growing pyramids."""


@dataclass(frozen=True)
class ExactVerdict:
    """The exact cone's verdict: True/False when certified, None when undecided (on the boundary).

    ``method`` is 'socp' (one conic program; ``facets`` 0) or 'pyramids' (the bracket reached K = ``facets``).
    """

    stable: bool | None
    facets: int
    method: ExactMethod = "pyramids"

    def to_json(self) -> dict[str, Any]:
        """Return the ``exact_cone`` object of ``check-stability --json``: the verdict and its method."""
        return {"stable": self.stable, "method": self.method}


@dataclass(frozen=True)
class PyramidRow:
    """One K-facet pyramid's region measured against the exact-cone bracket (areas in sr, angles in rad)."""

    facets: int
    kind: RegionKind
    area_sr: float
    area_error_sr: float
    area_error_lower_sr: float
    hausdorff_rad: float
    lp_count: int

    def to_json(self) -> dict[str, Any]:
        """Return the row as in the ``exact_cone.pyramids`` list of ``stable-region --json``."""
        return {
            "facets": self.facets,
            "kind": self.kind,
            "area_sr": self.area_sr,
            "area_error_sr": self.area_error_sr,
            "area_error_lower_sr": self.area_error_lower_sr,
            "hausdorff_rad": self.hausdorff_rad,
            "lp_count": self.lp_count,
        }


@dataclass(frozen=True)
class PyramidComparison:
    """The exact-cone region's area bracket (inner, outer), and each pyramid's region against it."""

    exact_area_sr: tuple[float, float]
    reference_facets: int
    bracket_hausdorff_rad: float
    pyramids: tuple[PyramidRow, ...]

    def to_json(self) -> dict[str, Any]:
        """Return the ``exact_cone`` object of ``stable-region --exact-cone --json``."""
        return {
            "exact_area_sr": list(self.exact_area_sr),
            "reference_facets": self.reference_facets,
            "bracket_hausdorff_rad": self.bracket_hausdorff_rad,
            "pyramids": [row.to_json() for row in self.pyramids],
        }


def check_exact(
    assembly: Assembly, contacts: list[Contact], g: np.ndarray, max_facets: int = BRACKET_MAX_FACETS
) -> ExactVerdict:
    """Decide unit g under the exact friction cone: by the conic program, else by the pyramid bracket."""
    if _clarabel is not None:
        return check_exact_socp(assembly, contacts, g)
    return check_exact_bracketed(assembly, contacts, g, max_facets)


def check_exact_bracketed(
    assembly: Assembly, contacts: list[Contact], g: np.ndarray, max_facets: int = BRACKET_MAX_FACETS
) -> ExactVerdict:
    """Decide g by inscribed (stable is proof) and circumscribed (unstable is proof) pyramids of growing K."""
    facets = BRACKET_START_FACETS
    while facets <= max_facets:
        if StabilityChecker(build_system(assembly, contacts, facets))(g).stable:
            return ExactVerdict(True, facets)
        if not StabilityChecker(build_system(assembly, contacts, facets, circumscribed=True))(g).stable:
            return ExactVerdict(False, facets)
        facets *= 2
    return ExactVerdict(None, max_facets)


@dataclass(frozen=True)
class _ConeColumns:
    """The exact cone's force columns: per contact its normal (then u, v when frictional), and owners."""

    system: EquilibriumSystem
    owners: np.ndarray
    first: np.ndarray  # each contact's first column: its normal force
    mus: np.ndarray

    @property
    def cone_first(self) -> np.ndarray:
        """First columns of the frictional contacts: (f_n, f_u, f_v) there is one second-order cone."""
        return self.first[self.mus > 0]

    @property
    def nonneg(self) -> np.ndarray:
        """Columns of the frictionless contacts: only f_n >= 0."""
        return self.first[self.mus == 0]


def _cone_columns(assembly: Assembly, contacts: list[Contact]) -> _ConeColumns:
    """Build eq. (8)'s system on eq. (1)'s force columns f_n n + f_u u + f_v v (f_n n alone for mu = 0)."""
    generators: list[np.ndarray] = []
    owners: list[int] = []
    for index, contact in enumerate(contacts):
        n = np.asarray(contact.normal, float)
        if contact.mu > 0:
            u, v = tangent_basis(n)
            generators += [n, u, v]
            owners += [index] * 3
        else:
            generators.append(n)
            owners.append(index)
    owner_array = np.asarray(owners, dtype=int)
    system = wrench_system(
        assembly, contacts, np.asarray(generators, float).reshape(-1, 3), owner_array, facets=0
    )
    first = np.searchsorted(owner_array, np.arange(len(contacts)))
    return _ConeColumns(system, owner_array, first, np.array([c.mu for c in contacts], float))


def _socp_problem(
    columns: _ConeColumns, rhs: np.ndarray
) -> tuple[sparse.csc_matrix, np.ndarray, list[object], np.ndarray]:
    """Return Clarabel's G x + s = h, s in K, and the cost: least total normal force under eqs. (2), (8).

    Rows: the equilibrium equations (zero cone), f_n >= 0 of frictionless contacts, then per frictional
    contact the rows of s = (mu f_n, f_u, f_v) in a 3-D second-order cone.
    """
    system = columns.system
    rows, count = system.A.shape
    cone_first, nonneg = columns.cone_first, columns.nonneg
    frictional = columns.mus[columns.mus > 0]
    selected = np.concatenate([nonneg, (cone_first[:, None] + np.arange(3)[None, :]).ravel()]).astype(int)
    weights = np.concatenate(
        [np.ones(len(nonneg)), np.column_stack([frictional, np.ones((len(cone_first), 2))]).ravel()]
    )
    cone_block = sparse.csr_matrix(
        (-weights, (np.arange(len(selected)), selected)), shape=(len(selected), count)
    )
    G = sparse.vstack([system.A, cone_block], format="csc")
    h = np.concatenate([rhs, np.zeros(len(selected))])
    cones: list[object] = [_clarabel.ZeroConeT(rows)]  # Clarabel's cone objects, handed to its solver
    if len(nonneg):
        cones.append(_clarabel.NonnegativeConeT(len(nonneg)))
    cones += [_clarabel.SecondOrderConeT(3) for _ in cone_first]
    cost = np.zeros(count)
    cost[columns.first] = 1.0  # least total normal force: a bounded objective with well-scaled forces
    return G, h, cones, cost


def _cone_violation(columns: _ConeColumns, x: np.ndarray) -> float:
    """Return the largest violation by x of eq. (2), |(f_u, f_v)| <= mu f_n, and of f_n >= 0 (mu = 0)."""
    cone_first = columns.cone_first
    tangential = np.hypot(x[cone_first + 1], x[cone_first + 2]) - columns.mus[columns.mus > 0] * x[cone_first]
    return max(
        float(np.max(tangential, initial=0.0)),
        float(np.max(-x[columns.nonneg], initial=0.0)),
    )


def _certified_stable(columns: _ConeColumns, x: np.ndarray, rhs: np.ndarray) -> bool:
    """Check forces x ourselves: equilibrium residual and cone violation within tolerance."""
    residual = float(np.abs(columns.system.A @ x - rhs).max())
    scale = max(1.0, float(np.abs(x).max()))
    return residual <= RESIDUAL_TOLERANCE and _cone_violation(columns, x) <= CONE_TOLERANCE * scale


def check_exact_socp(assembly: Assembly, contacts: list[Contact], g: np.ndarray) -> ExactVerdict:
    """Decide unit g under eq. (8) with the exact Coulomb cone (2), by one second-order cone program.

    Forces f = f_n n + f_u u + f_v v per contact with (mu f_n, f_u, f_v) in the second-order cone (f_n >= 0
    only, for mu = 0) balancing every free body. Stable only when the returned forces pass our own residual
    and cone checks; unstable only on the solver's certificate of primal infeasibility; anything else (a
    direction on the boundary, to tolerance) is None.
    """
    g = unit_gravity(g)
    columns = _cone_columns(assembly, contacts)
    rows, count = columns.system.A.shape
    rhs = -columns.system.B @ g
    if rows == 0:
        return ExactVerdict(True, 0, "socp")
    if count == 0:
        return ExactVerdict(bool(np.abs(rhs).max() <= RESIDUAL_TOLERANCE), 0, "socp")
    G, h, cones, cost = _socp_problem(columns, rhs)
    settings = _clarabel.DefaultSettings()
    settings.verbose = False
    solution = _clarabel.DefaultSolver(sparse.csc_matrix((count, count)), cost, G, h, cones, settings).solve()
    status = str(solution.status)
    if status == "PrimalInfeasible":
        return ExactVerdict(False, 0, "socp")
    if status not in ("Solved", "AlmostSolved"):
        return ExactVerdict(None, 0, "socp")
    stable = _certified_stable(columns, np.asarray(solution.x, float), rhs)
    return ExactVerdict(True if stable else None, 0, "socp")


def exact_bracket(
    assembly: Assembly, contacts: list[Contact], facets: int = REFERENCE_FACETS
) -> tuple[StableRegion, StableRegion]:
    """Return the inner and outer pyramid regions that bracket the exact-cone region."""
    inner = stable_region(build_system(assembly, contacts, facets))
    outer = stable_region(build_system(assembly, contacts, facets, circumscribed=True))
    return inner, outer


def compare_pyramids(
    assembly: Assembly,
    contacts: list[Contact],
    facet_counts: tuple[int, ...] = COMPARED_FACETS,
    reference: int = REFERENCE_FACETS,
) -> PyramidComparison:
    """Measure each K-facet region's area and Hausdorff angle against the exact-cone region (bracketed)."""
    inner, outer = exact_bracket(assembly, contacts, reference)
    rows = []
    for k in facet_counts:
        region = stable_region(build_system(assembly, contacts, k))
        rows.append(
            PyramidRow(
                facets=k,
                kind=region.kind,
                area_sr=region.area_sr,
                area_error_sr=outer.area_sr - region.area_sr,
                area_error_lower_sr=inner.area_sr - region.area_sr,
                hausdorff_rad=hausdorff_to(region, outer),
                lp_count=region.lp_count,
            )
        )
    return PyramidComparison(
        exact_area_sr=(inner.area_sr, outer.area_sr),
        reference_facets=reference,
        bracket_hausdorff_rad=hausdorff_to(inner, outer),
        pyramids=tuple(rows),
    )


def hausdorff_to(
    region: StableRegion, outer: StableRegion, per_edge: int = HAUSDORFF_SAMPLES_PER_EDGE
) -> float:
    """Return the largest angle from the boundary of ``outer`` to ``region`` (nested, both of kind 'region').

    For nested convex sets this is their Hausdorff distance; the boundary is sampled ``per_edge`` points per
    edge.
    """
    if region.kind != "region" or outer.kind != "region":
        return float("nan") if region.kind != outer.kind else 0.0
    vertices = list(outer.vertices)
    samples = []
    for a, b in zip(vertices, vertices[1:] + vertices[:1], strict=True):
        t = np.linspace(0.0, 1.0, per_edge, endpoint=False)[:, None]
        points = (1 - t) * a + t * b
        samples.append(points / np.linalg.norm(points, axis=1, keepdims=True))
    return float(np.max(distances_to_region(np.vstack(samples), region)))


def distances_to_region(points: np.ndarray, region: StableRegion) -> np.ndarray:
    """Return the angles from unit points (rows) to a convex spherical polygon (0 inside), vectorised."""
    points = np.atleast_2d(points)
    a = region.vertices
    b = np.roll(region.vertices, -1, axis=0)
    m = np.cross(a, b)
    m /= np.linalg.norm(m, axis=1, keepdims=True)
    pm = points @ m.T  # (S, E)
    q = points[:, None, :] - pm[:, :, None] * m[None, :, :]  # projection on each edge's great circle
    q /= np.maximum(np.linalg.norm(q, axis=2, keepdims=True), NORM_FLOOR)
    # q is on the arc iff it lies between a and b (both cross products along m).
    on_arc = (np.einsum("sek,ek->se", np.cross(a[None], q), m) >= 0) & (
        np.einsum("sek,ek->se", np.cross(q, b[None]), m) >= 0
    )
    to_line = np.arcsin(np.clip(np.abs(pm), 0.0, 1.0))
    to_ends = np.minimum(np.arccos(np.clip(points @ a.T, -1, 1)), np.arccos(np.clip(points @ b.T, -1, 1)))
    distance = np.where(on_arc, to_line, to_ends).min(axis=1)
    inside = np.all(points @ region.normals.T <= INSIDE_TOLERANCE, axis=1)
    return np.where(inside, 0.0, distance)
