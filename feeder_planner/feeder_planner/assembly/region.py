"""The exact set of stable gravity directions (secs. II-D and III): a spherical polygon or a degenerate kind.

Method. V = {g : eq. (9) is feasible} is a polyhedral cone (sec. II-C). As in sec. III we cut it with the unit
cube, P = V n {|g|_inf <= 1}, but instead of traversing six 2-D face projections by parametric programming we
build P itself by support-function (outer/inner) iteration: start from LP-found points of P, take their convex
hull, and for every hull facet (normal n, offset h) solve max n.g over P. If the optimum is <= h + tol the
facet is a facet of P (certified by the LP's optimum); otherwise the optimiser is a new vertex of P and the
hull grows. This stops after (#vertices + #facets of P) LPs with P exact up to the LP tolerance; it is the
same computation as the paper's traversal (each step is one LP with a swept objective), done in 3-D so that
every degenerate kind falls out of the same code: first the linear span of V is found (Property 1's cases),
then facets of P through the origin are exactly the facets of V, i.e. the great arcs bounding the "spherygon".
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, replace
from typing import Any, Literal, Protocol, get_args

import numpy as np
from scipy import sparse
from scipy.optimize import minimize
from scipy.spatial import ConvexHull, QhullError

from feeder_planner.assembly.geometry import tangent_basis
from feeder_planner.assembly.lp import WarmLP
from feeder_planner.assembly.support import SupportOracle
from feeder_planner.assembly.tolerances import (
    CENTER_CHUNK,
    CENTER_SLSQP_FTOL,
    CENTER_SLSQP_MAXITER,
    CONTAINS_TOLERANCE,
    DEGENERATE_NORM,
    DISTINCT_POINT_TOLERANCE,
    ENUMERATED_CENTER_FACETS,
    FAR_PIVOTS,
    GENERIC_FRAME_SEED,
    MAX_HULL_ROUNDS,
    ORIGIN_TOLERANCE,
    PLANE_MATCH_TOLERANCE,
    SAME_VERTEX,
    SPLIT_COLUMNS,
    SUPPORT_TOLERANCE,
    VERTEX_FEASIBILITY,
    VERTICAL_AXIS_NORM,
    ZERO_COMPONENT,
)
from feeder_planner.assembly.wrench import EquilibriumSystem, split_components
from feeder_planner.errors import SolverError

__all__ = [
    "KINDS",
    "ConstraintOracle",
    "Oracle",
    "RegionKind",
    "StableRegion",
    "cone_region",
    "stable_region",
]

RegionKind = Literal[
    "empty", "point", "antipodal_pair", "arc", "great_circle", "region", "hemisphere", "sphere"
]
"""The contract's region kinds: Property 1's cases of V, by the dimension of its span and its facets."""
KINDS: tuple[RegionKind, ...] = get_args(RegionKind)


@dataclass(frozen=True)
class StableRegion:
    """{unit g : n.g <= 0 for n in normals, e.g = 0 for e in equalities}, described as the contract says."""

    kind: RegionKind
    normals: np.ndarray
    equalities: np.ndarray
    vertices: np.ndarray
    area_sr: float
    center: np.ndarray | None
    facets: int
    lp_count: int = 0

    def contains(self, g: np.ndarray, tolerance: float = CONTAINS_TOLERANCE) -> bool:
        """Tell whether g (normalised here) satisfies every inequality and equality within ``tolerance``."""
        g = np.asarray(g, float) / np.linalg.norm(g)
        return bool(
            np.all(self.normals @ g <= tolerance) and np.all(np.abs(self.equalities @ g) <= tolerance)
        )

    def margin(self, g: np.ndarray) -> float:
        """Return the signed angle (rad) from g to the nearest boundary great circle: > 0 inside a 2-D region.

        Inside a region (or hemisphere) it is exactly the angular distance to the boundary (a cap fits in the
        region iff it fits in every bounding hemisphere). Outside, or for kinds without interior, it is <= 0
        and its magnitude is a lower bound on the distance to the set. The whole sphere has margin pi.
        """
        g = np.asarray(g, float) / np.linalg.norm(g)
        if self.kind == "sphere":
            return math.pi
        if self.kind == "empty":
            return -math.pi
        values = [math.asin(float(np.clip(-n @ g, -1.0, 1.0))) for n in self.normals]
        values += [-math.asin(float(np.clip(abs(e @ g), 0.0, 1.0))) for e in self.equalities]
        return min(values)

    def to_json(self) -> dict[str, Any]:
        """Return the contract's region object (unit vectors with rounding noise printed as 0)."""

        def clean(a: np.ndarray) -> object:
            return np.where(np.abs(a) < ZERO_COMPONENT, 0.0, a).tolist()

        return {
            "kind": self.kind,
            "normals": clean(self.normals),
            "equalities": clean(self.equalities),
            "vertices": clean(self.vertices),
            "area_sr": self.area_sr,
            "center": None if self.center is None else clean(self.center),
            "facets": self.facets,
            "lp_count": self.lp_count,
        }


def stable_region(system: EquilibriumSystem, far_pivots: int | None = FAR_PIVOTS) -> StableRegion:
    """Return the exact region of potentially stable unit gravity directions for the system of eq. (9).

    Independent sub-assemblies (linked only through grounded bodies) are solved separately and their
    constraints intersected: V is the intersection of their cones, each found with its own, smaller LPs.
    ``far_pivots`` is the SupportOracle's switch to the interior point route (None: simplex only, the
    baseline).
    """
    parts = split_components(system) if system.columns > SPLIT_COLUMNS else [system]
    if len(parts) == 1:
        return cone_region(SupportOracle(system, far_pivots), system.facets)
    regions = [cone_region(SupportOracle(part, far_pivots), part.facets) for part in parts]
    spent = sum(r.lp_count for r in regions)
    empty = next((r for r in regions if r.kind == "empty"), None)
    if empty is not None:
        return replace(empty, lp_count=spent)
    oracle = ConstraintOracle(
        np.vstack([r.normals for r in regions]), np.vstack([r.equalities for r in regions])
    )
    combined = cone_region(oracle, system.facets)
    return replace(combined, lp_count=combined.lp_count + spent)


class Oracle(Protocol):
    """A support function of the cone section P: direction -> (max value, maximiser); counts its LPs."""

    calls: int

    def __call__(self, direction: np.ndarray) -> tuple[float, np.ndarray]:
        """Return max direction.g over P and a maximiser g."""
        ...


class ConstraintOracle:
    """max c.g over {|g|_inf <= 1, n.g <= 0, e.g = 0}: the support LP of an explicitly described cone."""

    def __init__(self, normals: np.ndarray, equalities: np.ndarray) -> None:
        k, e = len(normals), len(equalities)
        top = np.hstack([normals.reshape(k, 3), np.eye(k)])
        bottom = np.hstack([equalities.reshape(e, 3), np.zeros((e, k))])
        self.lp = WarmLP(
            sparse.csc_matrix(np.vstack([top, bottom])),
            np.zeros(k + e),
            np.concatenate([-np.ones(3), np.zeros(k)]),
            np.concatenate([np.ones(3), np.full(k, np.inf)]),
        )
        self.calls = 0

    def __call__(self, direction: np.ndarray) -> tuple[float, np.ndarray]:
        """Return max direction.g over the cone's cube section and a maximiser g."""
        self.calls += 1
        self.lp.set_cost(np.arange(3), -np.asarray(direction, float))
        result = self.lp.solve()
        if result.status != "optimal":
            raise SolverError(
                f"support LP of the intersected cone failed ({result.status}): {result.message}"
            )
        g = np.clip(result.solution[:3], -1.0, 1.0)
        return float(np.asarray(direction, float) @ g), g


def cone_region(oracle: Oracle, facets: int) -> StableRegion:
    """Classify and describe V from its support oracle (Property 1's cases, then the spherical polygon)."""
    points, span = _span(oracle)
    if len(span) < 2:
        return _linear_region(oracle, span, facets)
    basis = np.array(span)
    planes, section = _facets(oracle, basis, points)
    origin_normals = _unique([basis.T @ n for n, offset in planes if offset < ORIGIN_TOLERANCE])
    if len(span) == 2:
        e = np.cross(span[0], span[1])
        e /= np.linalg.norm(e)
        return _planar(origin_normals, e, facets, oracle)
    return _solid(origin_normals, section, facets, oracle)


def _linear_region(oracle: Oracle, span: list[np.ndarray], facets: int) -> StableRegion:
    """Describe a V spanning at most a line (Property 1's cases 1, 3): empty, a point, an antipodal pair."""
    if not span:
        return _region("empty", [], list(np.eye(3)), [], 0.0, None, facets, oracle)
    d = span[0]
    other = _complement(span)
    value, _ = oracle(-d)
    if value > SUPPORT_TOLERANCE:
        return _region("antipodal_pair", [], other, [d, -d], 0.0, d if d[2] <= 0 else -d, facets, oracle)
    return _region("point", [-d], other, [d], 0.0, d, facets, oracle)


def _region(
    kind: RegionKind,
    normals: Sequence[np.ndarray],
    equalities: Sequence[np.ndarray],
    vertices: Sequence[np.ndarray],
    area: float,
    center: np.ndarray | None,
    facets: int,
    oracle: Oracle,
) -> StableRegion:
    """Build the StableRegion of one kind: rows as (k, 3) arrays, centre normalised, the oracle's LP count."""

    def as_array(rows: Sequence[np.ndarray]) -> np.ndarray:
        return np.asarray(rows, dtype=float).reshape(-1, 3)

    return StableRegion(
        kind,
        as_array(normals),
        as_array(equalities),
        as_array(vertices),
        float(area),
        None if center is None else np.asarray(center, float) / np.linalg.norm(center),
        facets,
        oracle.calls,
    )


def _span(oracle: Oracle) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Find points of P spanning the linear hull of V, and an orthonormal basis of it (Property 1's cases)."""
    points = [np.zeros(3)]
    span: list[np.ndarray] = []
    while len(span) < 3:
        found = _point_off_span(oracle, span)
        if found is None:
            break
        points.append(found)
        residual = found - sum((found @ b) * b for b in span)
        span.append(residual / np.linalg.norm(residual))
    return points, span


def _point_off_span(oracle: Oracle, span: list[np.ndarray]) -> np.ndarray | None:
    """Find a point of P with a component off ``span`` (one or two LPs per complement direction), or None."""
    for d in _complement(span):
        for sign in (1.0, -1.0):
            value, g = oracle(sign * d)
            if value > SUPPORT_TOLERANCE:
                return g
    return None


def _generic_frame() -> np.ndarray:
    """Return a fixed orthonormal frame in general position (rows) for the first support LPs.

    Assemblies are often axis-aligned, and an axis direction then maximises over a whole edge or face of P. A
    generic one hits a vertex of P, which the hull needs anyway (measured on the 960-point wall: about 15 %
    less time).
    """
    q, _ = np.linalg.qr(np.array(GENERIC_FRAME_SEED))
    return q.T


def _complement(span: list[np.ndarray]) -> list[np.ndarray]:
    """Return an orthonormal basis of the complement of ``span`` (the generic frame for an empty span)."""
    if not span:
        return list(_generic_frame())
    if len(span) == 1:
        u, v = tangent_basis(span[0])
        return [u, v]
    if len(span) == 2:
        e = np.cross(span[0], span[1])
        return [e / np.linalg.norm(e)]
    return []


def _facets(
    oracle: Oracle, basis: np.ndarray, points: list[np.ndarray]
) -> tuple[list[tuple[np.ndarray, float]], np.ndarray]:
    """Find the certified facets (normal, offset) of P in ``basis`` coordinates (outer/inner iteration).

    Each round solves one LP per unconfirmed hull facet: the facet is confirmed when its support value does
    not exceed its offset, else the optimiser joins the point set; the hull is rebuilt after each round.
    """
    coords = np.asarray([basis @ p for p in points])
    confirmed_n = np.zeros((0, basis.shape[0]))
    confirmed_h = np.zeros(0)
    for _ in range(MAX_HULL_ROUNDS):
        normals, offsets = _hull_planes(coords)
        pending = _unconfirmed(normals, offsets, confirmed_n, confirmed_h)
        if len(pending) == 0:
            return list(zip(normals, offsets, strict=True)), coords @ basis
        new_points = []
        for i in pending:
            value, g = oracle(basis.T @ normals[i])
            if value <= offsets[i] + SUPPORT_TOLERANCE:
                confirmed_n = np.vstack([confirmed_n, normals[i]])
                confirmed_h = np.append(confirmed_h, offsets[i])
            else:
                new_points.append(basis @ g)
        if new_points:
            coords = np.vstack([coords, _distinct_rows(np.asarray(new_points))])
    raise SolverError("stable region iteration did not converge")


def _hull_planes(coords: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return outward unit normals and offsets (n.x <= h) of the hull of ``coords``, one per plane."""
    try:
        hull = ConvexHull(coords)
    except QhullError as exc:
        raise SolverError(f"hull of the stable cone section failed: {str(exc).splitlines()[0]}") from None
    return _distinct_planes(hull.equations[:, :-1], -hull.equations[:, -1])


def _same_plane(
    normals: np.ndarray, offsets: np.ndarray, other_normals: np.ndarray, other_offsets: np.ndarray
) -> np.ndarray:
    """Return the matrix [i, j]: plane i (unit normal, offset) is plane j of the others, to tolerance."""
    return (normals @ other_normals.T > 1 - PLANE_MATCH_TOLERANCE) & (
        np.abs(offsets[:, None] - other_offsets[None, :]) < PLANE_MATCH_TOLERANCE
    )


def _unconfirmed(
    normals: np.ndarray, offsets: np.ndarray, confirmed_n: np.ndarray, confirmed_h: np.ndarray
) -> np.ndarray:
    """Return the indices of the hull planes not yet certified by an LP (not among the confirmed ones)."""
    if not len(confirmed_h):
        return np.arange(len(offsets))
    return np.nonzero(~_same_plane(normals, offsets, confirmed_n, confirmed_h).any(axis=1))[0]


def _distinct_planes(normals: np.ndarray, offsets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Merge the coplanar triangles qhull reports for one facet."""
    keep: list[int] = []
    for i in range(len(offsets)):
        if keep and _same_plane(normals[i : i + 1], offsets[i : i + 1], normals[keep], offsets[keep]).any():
            continue
        keep.append(i)
    return normals[keep], offsets[keep]


def _distinct_rows(rows: np.ndarray) -> np.ndarray:
    """Drop near-duplicate rows (within DISTINCT_POINT_TOLERANCE), first occurrence kept."""
    keep: list[int] = []
    for i in range(len(rows)):
        if not keep or np.min(np.linalg.norm(rows[keep] - rows[i], axis=1)) > DISTINCT_POINT_TOLERANCE:
            keep.append(i)
    return rows[keep]


def _unique(vectors: list[np.ndarray]) -> list[np.ndarray]:
    """Normalise the vectors and drop repeated directions (within PLANE_MATCH_TOLERANCE), first kept."""
    unique: list[np.ndarray] = []
    for v in vectors:
        v = v / np.linalg.norm(v)
        if not any(v @ u > 1 - PLANE_MATCH_TOLERANCE for u in unique):
            unique.append(v)
    return unique


def _planar(normals: list[np.ndarray], e: np.ndarray, facets: int, oracle: Oracle) -> StableRegion:
    """Describe a V spanning a plane: great circle (no bounding line), half circle (one), arc (two)."""
    if not normals:
        down = np.array([0.0, 0.0, -1.0]) - (e[2] * -1.0) * e
        center = down if np.linalg.norm(down) > VERTICAL_AXIS_NORM else tangent_basis(e)[0]
        return _region("great_circle", [], [e], [], 0.0, center, facets, oracle)
    if len(normals) == 1:
        n = normals[0]
        end = np.cross(e, n)
        return _region("arc", [n], [e], [end, -end], 0.0, -n, facets, oracle)
    if len(normals) > 2:
        raise SolverError(f"planar stable cone with {len(normals)} bounding lines (expected at most 2)")
    ends = []
    for n, other in ((normals[0], normals[1]), (normals[1], normals[0])):
        end = np.cross(e, n)
        ends.append(end if other @ end <= 0 else -end)
    return _region("arc", normals, [e], ends, 0.0, ends[0] + ends[1], facets, oracle)


def _solid(normals: list[np.ndarray], section: np.ndarray, facets: int, oracle: Oracle) -> StableRegion:
    """Describe a 3-D V: the sphere, a hemisphere, a lune, or a convex spherical polygon."""
    if not normals:
        return _region("sphere", [], [], [], 4 * math.pi, np.array([0.0, 0.0, -1.0]), facets, oracle)
    if len(normals) == 1:
        return _region("hemisphere", normals, [], [], 2 * math.pi, -normals[0], facets, oracle)
    if len(normals) == 2:
        n1, n2 = normals
        axis = np.cross(n1, n2)
        axis /= np.linalg.norm(axis)
        angle = math.pi - math.acos(float(np.clip(n1 @ n2, -1.0, 1.0)))
        return _region(
            "region", normals, [], _ccw([axis, -axis], -(n1 + n2)), 2 * angle, -(n1 + n2), facets, oracle
        )
    # The sum of P's points is inside the pointed cone V: a direction to order the vertices around.
    inside = section.sum(axis=0)
    vertices = _vertices(normals, inside)
    center = _center(normals, vertices)
    area = _polygon_area(vertices, center)
    return _region("region", normals, [], vertices, area, center, facets, oracle)


def _vertices(normals: list[np.ndarray], inside: np.ndarray) -> list[np.ndarray]:
    """Return the corners of the spherical polygon: n_i x n_j (either sign) satisfying every n.g <= 0."""
    n = np.asarray(normals)
    i, j = np.triu_indices(len(n), 1)
    axes = np.cross(n[i], n[j])
    norms = np.linalg.norm(axes, axis=1)
    axes = axes[norms > DEGENERATE_NORM] / norms[norms > DEGENERATE_NORM, None]
    candidates = np.vstack([axes, -axes])
    feasible = candidates[np.all(candidates @ n.T <= VERTEX_FEASIBILITY, axis=1)]
    found: list[np.ndarray] = []
    for v in feasible:
        if not found or np.max(np.asarray(found) @ v) < 1 - SAME_VERTEX:
            found.append(v)
    if len(found) < 3:
        raise SolverError(f"stable region with {len(normals)} facets has only {len(found)} vertices")
    return _ccw(found, inside)


def _ccw(vertices: list[np.ndarray], around: np.ndarray) -> list[np.ndarray]:
    """Order vertices counter-clockwise as seen from outside the sphere, looking at ``around``."""
    c = around / np.linalg.norm(around)
    u, v = tangent_basis(c)
    return sorted(vertices, key=lambda p: math.atan2(float(p @ v), float(p @ u)))


def _center(normals: list[np.ndarray], vertices: list[np.ndarray]) -> np.ndarray:
    """Return argmax over unit g of min_i (-n_i . g): the point farthest in angle from every boundary circle.

    The optimum is equidistant from an active set of at most three great circles, so enumerating the
    candidate points of every set of one, two or three normals and keeping the best feasible one is exact.
    Beyond ENUMERATED_CENTER_FACETS facets (fine pyramids only) the max-min is solved by SLSQP from the vertex
    mean instead.
    """
    n = np.asarray(normals)
    if len(n) > ENUMERATED_CENTER_FACETS:
        return _center_slsqp(n, np.sum(vertices, axis=0))
    cand = np.vstack(list(_center_candidates(n)))
    norms = np.linalg.norm(cand, axis=1)
    cand = cand[norms > DEGENERATE_NORM] / norms[norms > DEGENERATE_NORM, None]
    scores = np.min(-(cand @ n.T), axis=1)
    return cand[int(np.argmax(scores))]


def _center_candidates(n: np.ndarray) -> Iterator[np.ndarray]:
    """Yield unnormalised candidate centres: equidistant from one, two or three great circles of normals n.

    One circle: -n_i. Two: the bisector -(n_i + n_j). Three: the direction g with n_i.g = n_j.g = n_k.g, i.e.
    g along (n_i - n_j) x (n_i - n_k), signed to lie on the inner side of n_i. Triples come in batches of
    CENTER_CHUNK.
    """
    yield -n
    pairs = np.array(list(itertools.combinations(range(len(n)), 2)))
    yield -(n[pairs[:, 0]] + n[pairs[:, 1]])
    if len(n) < 3:
        return
    for chunk in _chunks(list(itertools.combinations(range(len(n)), 3)), CENTER_CHUNK):
        t = np.asarray(chunk)
        g = np.cross(n[t[:, 0]] - n[t[:, 1]], n[t[:, 0]] - n[t[:, 2]])
        sign = np.where(np.einsum("ij,ij->i", -n[t[:, 0]], g) >= 0, 1.0, -1.0)
        yield g * sign[:, None]


def _center_slsqp(n: np.ndarray, start: np.ndarray) -> np.ndarray:
    """Find the max-min centre by SLSQP on (g, t): max t s.t. -n_i.g >= t, |g| <= 1, from ``start``."""
    x0 = np.concatenate([start / np.linalg.norm(start), [0.0]])
    result = minimize(
        lambda x: -x[3],
        x0,
        jac=lambda x: np.array([0.0, 0.0, 0.0, -1.0]),
        method="SLSQP",
        constraints=[
            {
                "type": "ineq",
                "fun": lambda x: -(n @ x[:3]) - x[3],
                "jac": lambda x: np.hstack([-n, -np.ones((len(n), 1))]),
            },
            {
                "type": "ineq",
                "fun": lambda x: 1.0 - x[:3] @ x[:3],
                "jac": lambda x: np.concatenate([-2 * x[:3], [0.0]])[None, :],
            },
        ],
        options={"ftol": CENTER_SLSQP_FTOL, "maxiter": CENTER_SLSQP_MAXITER},
    )
    g = result.x[:3]
    return g / np.linalg.norm(g)


def _chunks(items: list[tuple[int, ...]], size: int) -> Iterator[list[tuple[int, ...]]]:
    """Yield consecutive slices of ``items`` of at most ``size`` elements."""
    for start in range(0, len(items), size):
        yield items[start : start + size]


def _polygon_area(vertices: list[np.ndarray], center: np.ndarray) -> float:
    """Return the solid angle of a convex spherical polygon (Van Oosterom-Strackee triangle fan)."""
    total = 0.0
    for a, b in zip(vertices, vertices[1:] + vertices[:1], strict=True):
        numerator = abs(float(center @ np.cross(a, b)))
        denominator = 1.0 + float(center @ a + a @ b + b @ center)
        total += 2.0 * math.atan2(numerator, denominator)
    return total
