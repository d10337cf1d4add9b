"""Method (c): equilibria for any 0 <= delta < 1 from the zero crossings of x*(theta, delta) (Prop. 6).

By Prop. 5, dU*/dtheta = delta |S| x*(theta, delta) along the equilibrium curve, so the equilibria are
the roots of x*, and by Prop. 6 the stable ones are those where x* crosses zero upwards. The steps:
sample x* (``sample_curve``), subdivide intervals that might hide two crossings (``subdivide``),
bracket the sign changes (``bracket_roots``), refine them (``refine_roots``), classify each root by the
Hessian of U(x, y, theta), cross-checked with Prop. 6 (``classify``), and drop the duplicate the
0 / 2 pi seam may produce (``drop_seam_duplicates``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from feeder_planner.errors import SolverError
from feeder_planner.mems.curve import CurvePoints, curve, hessian_xyt, pivot_point, pivot_translation
from feeder_planner.mems.lifted import Edges, part_edges
from feeder_planner.mems.result import EquilibriaResult, Equilibrium, NumericDetails
from feeder_planner.mems.tolerances import (
    HERMITE_POINTS,
    HERMITE_SAFETY,
    NUMERIC_MAX_DEPTH,
    NUMERIC_MIN_WIDTH,
    NUMERIC_PHASE,
    NUMERIC_SAMPLES,
    RESOLUTION,
    RESOLVABLE,
    ROOT_MAX_ITER,
    SEAM_TOL,
    SLOPE_FLOOR,
    THETA_TOL,
)
from feeder_planner.parts import Part

__all__ = [
    "CurveSamples",
    "Brackets",
    "numeric_equilibria",
    "sample_curve",
    "resolution_floor",
    "subdivide",
    "bracket_roots",
    "refine_roots",
    "classify",
    "drop_seam_duplicates",
]

TWO_PI = 2 * math.pi


@dataclass(frozen=True)
class CurveSamples:
    """x*(theta, delta), its theta-derivative and (X*, Y*) at increasing angles theta."""

    theta: np.ndarray  # (N,)
    x: np.ndarray  # (N,)
    dx: np.ndarray  # (N,)
    z: np.ndarray  # (N, 2)


@dataclass(frozen=True)
class Brackets:
    """Intervals [lo, hi] of theta that each hold one sign change of x*."""

    lo: np.ndarray
    hi: np.ndarray
    x_lo: np.ndarray  # x* at lo (its sign tells the sides apart)
    z_start: np.ndarray  # (X*, Y*) at lo: where Newton on the curve starts


def _suspicious(x0: float, x1: float, d0: float, d1: float, width: float, floor: float) -> bool:
    """Return whether x* could have two crossings (or touch zero) between two samples of equal sign.

    Cubic Hermite model of x*: flag the interval when it dips to within floor of zero, or when the
    derivative changes sign and the extrapolated extremum could reach zero (safety HERMITE_SAFETY).
    """
    if x0 * x1 <= 0 or min(abs(x0), abs(x1)) <= floor:
        return False
    t = np.linspace(0.0, 1.0, HERMITE_POINTS)
    h00, h10 = 2 * t**3 - 3 * t**2 + 1, t**3 - 2 * t**2 + t
    h01, h11 = -2 * t**3 + 3 * t**2, t**3 - t**2
    model = h00 * x0 + h10 * width * d0 + h01 * x1 + h11 * width * d1
    if np.any(model * np.sign(x0) <= floor):
        return True
    return d0 * d1 < 0 and min(abs(x0), abs(x1)) <= HERMITE_SAFETY * width * max(abs(d0), abs(d1))


def sample_curve(edges: Edges, area: float, delta: float, z0: np.ndarray) -> CurvePoints:
    """Return the equilibrium curve at NUMERIC_SAMPLES + 1 angles covering one turn (ends included).

    An irrational phase keeps symmetric parts' equilibria (often at multiples of pi/4) off the grid.
    """
    theta = TWO_PI * (np.arange(NUMERIC_SAMPLES + 1) + NUMERIC_PHASE) / NUMERIC_SAMPLES
    return curve(edges, area, delta, theta, z0)


def resolution_floor(points: CurvePoints, delta: float) -> float:
    """Return the level (m) below which |x*| counts as zero; refuse when x* never clears it by far.

    The floor is RESOLUTION times the rounding bound of x*. When |x*| stays below RESOLVABLE floors
    for every theta (tiny delta on a symmetric part), crossings cannot be located: SolverError.
    """
    floor = RESOLUTION * float(points.error.max())
    if np.abs(points.x).max() <= RESOLVABLE * floor:
        raise SolverError(
            f"x*(theta, delta={delta}) stays below {RESOLVABLE * floor:.3g} m for every theta: "
            "too small to resolve numerically (use the asymptotic method)"
        )
    return floor


def subdivide(edges: Edges, area: float, delta: float, points: CurvePoints, floor: float) -> CurveSamples:
    """Return the samples, sorted by theta, with every interval that might hide two crossings halved.

    Halving repeats until no interval is suspicious (cubic Hermite test) or NUMERIC_MAX_DEPTH rounds
    have passed, which is refused as a tangential crossing.
    """
    theta, x, dx, z = points.theta, points.x, points.dx, points.z
    for _ in range(NUMERIC_MAX_DEPTH):
        order = np.argsort(theta)
        theta, x, dx, z = theta[order], x[order], dx[order], z[order]
        split = [
            i
            for i in range(len(theta) - 1)
            if _suspicious(x[i], x[i + 1], dx[i], dx[i + 1], theta[i + 1] - theta[i], floor)
            and theta[i + 1] - theta[i] > NUMERIC_MIN_WIDTH
        ]
        if not split:
            return CurveSamples(theta, x, dx, z)
        index = np.array(split)
        more = curve(edges, area, delta, 0.5 * (theta[index] + theta[index + 1]), z[index])
        theta = np.concatenate([theta, more.theta])
        x = np.concatenate([x, more.x])
        dx = np.concatenate([dx, more.dx])
        z = np.concatenate([z, more.z])
    raise SolverError("could not separate the zero crossings of x*(theta) (tangential crossing?)")


def bracket_roots(samples: CurveSamples, floor: float) -> Brackets:
    """Return one bracket per sign change of x* over the turn the samples cover.

    Samples within ``floor`` of zero count as zero; a crossing there is bracketed by its neighbours
    (across the 0 / 2 pi seam if need be). A zero sample whose neighbours have the same sign is a
    touching, not a crossing: SolverError, as is a curve without any sign change (Prop. 5 forbids it).
    """
    theta, x, z = samples.theta, samples.x, samples.z
    sign = np.where(np.abs(x) <= floor, 0.0, np.sign(x))
    found = [(theta[i], theta[i + 1], x[i], z[i]) for i in range(len(theta) - 1) if sign[i] * sign[i + 1] < 0]
    period = len(theta) - 1  # the first and last samples are the same angle one turn apart
    for i in np.flatnonzero(sign == 0):
        j, k = (i - 1) % period, (i + 1) % period
        if sign[j] * sign[k] >= 0:
            raise SolverError(
                f"x*(theta) touches zero without crossing near theta = {theta[i]:.6f} (degenerate)"
            )
        lo = theta[j] if j < i else theta[j] - TWO_PI
        found.append((lo, theta[i] + (theta[k] - theta[i]) % TWO_PI, x[j], z[j]))
    if not found:
        raise SolverError("x*(theta) never changes sign: no equilibrium found (contradicts Prop. 5)")
    return Brackets(
        np.array([b[0] for b in found]),
        np.array([b[1] for b in found]),
        np.array([b[2] for b in found]),
        np.array([b[3] for b in found]),
    )


def refine_roots(edges: Edges, area: float, delta: float, brackets: Brackets) -> CurvePoints:
    """Return the equilibrium curve at the root of x* in every bracket, to THETA_TOL.

    Safeguarded Newton on theta with the exact dx*/dtheta, all roots at once: a Newton step leaving
    its bracket is replaced by bisection.
    """
    lo, hi, flo, zstart = brackets.lo, brackets.hi, brackets.x_lo, brackets.z_start
    guess = 0.5 * (lo + hi)
    for _ in range(ROOT_MAX_ITER):
        p = curve(edges, area, delta, guess, zstart)
        left = p.x * flo > 0
        lo, hi = np.where(left, guess, lo), np.where(left, hi, guess)
        flo = np.where(left, p.x, flo)
        newton = guess - p.x / np.where(p.dx == 0, np.inf, p.dx)
        inside = (newton > lo) & (newton < hi)
        new = np.where(inside, newton, 0.5 * (lo + hi))
        zstart = p.z
        converged = np.all(np.abs(new - guess) <= THETA_TOL) or np.all(hi - lo <= THETA_TOL)
        guess = new
        if converged:
            return curve(edges, area, delta, guess, zstart)
    raise SolverError("root refinement of x*(theta) did not converge")


def classify(roots: CurvePoints, floor: float, scale: float) -> tuple[list[Equilibrium], list[float]]:
    """Return the equilibria at the roots sorted by theta, and the smallest eigenvalue of Hess U at each.

    Stable iff Hess U(x, y, theta) is positive definite; its Schur complement on theta equals
    delta |S| dx*/dtheta (Prop. 5), so Prop. 6 (dx*/dtheta > 0) must agree. A disagreement, or a slope
    too small to tell, is a degenerate equilibrium: SolverError.
    """
    equilibria, eig_min = [], []
    for k, theta in enumerate(roots.theta):
        eig = np.linalg.eigvalsh(hessian_xyt(roots.grad[k], roots.hess[k], roots.z[k], float(theta)))
        stable_hess = bool(eig.min() > 0)
        stable_prop6 = bool(roots.dx[k] > 0)
        if stable_hess != stable_prop6 or abs(roots.dx[k]) * scale <= floor:
            raise SolverError(
                f"degenerate equilibrium near theta = {theta:.6f}: Hessian and Prop. 6 disagree"
            )
        eig_min.append(float(eig.min()))
        equilibria.append(
            Equilibrium(float(roots.x[k]), float(roots.y[k]), float(theta % TWO_PI), stable_hess)
        )
    order = np.argsort([e.theta for e in equilibria])
    return [equilibria[i] for i in order], [eig_min[i] for i in order]


def drop_seam_duplicates(equilibria: list[Equilibrium]) -> list[Equilibrium]:
    """Return equilibria sorted by theta without repeats: one found twice across 0 / 2 pi counts once."""
    unique: list[Equilibrium] = []
    for e in equilibria:
        if not unique or abs(e.theta - unique[-1].theta) > SEAM_TOL:
            unique.append(e)
    if len(unique) > 1 and abs(unique[-1].theta - unique[0].theta - TWO_PI) <= SEAM_TOL:
        unique.pop()
    return unique


def numeric_equilibria(part: Part, delta: float, edges: Edges | None = None) -> EquilibriaResult:
    """Return all equilibria for one delta: sample x*, bracket its sign changes, refine and classify."""
    edges = edges or part_edges(part)
    z0 = pivot_translation(edges)
    points = sample_curve(edges, part.area, delta, z0)
    floor = resolution_floor(points, delta)
    samples = subdivide(edges, part.area, delta, points, floor)
    roots = refine_roots(edges, part.area, delta, bracket_roots(samples, floor))
    equilibria, eig_min = classify(roots, floor, edges.scale)
    # theta is only as good as x* near its root: rounding floor over the slope (Prop. 6 crossing)
    uncertainty = floor / np.maximum(np.abs(roots.dx), SLOPE_FLOOR) + THETA_TOL
    details = NumericDetails(len(samples.theta), floor, tuple(eig_min), float(uncertainty.max()))
    return EquilibriaResult(
        pivot_point(z0),
        part.area,
        delta,
        "numeric",
        tuple(drop_seam_duplicates(equilibria)),
        certified=True,
        numeric=details,
    )
