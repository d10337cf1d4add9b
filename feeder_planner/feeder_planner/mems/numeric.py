"""Method (c): equilibria for any 0 <= delta < 1 from the zero crossings of x*(theta, delta) (Prop. 6)."""

from __future__ import annotations

import math

import numpy as np

from feeder_planner.errors import SolverError
from feeder_planner.mems.curve import curve, hessian_xyt, pivot_translation
from feeder_planner.mems.lifted import Edges, part_edges
from feeder_planner.mems.result import EquilibriaResult, Equilibrium
from feeder_planner.parts import Part

SAMPLES = 64  # initial theta grid; intervals that might hide two crossings are subdivided
MAX_DEPTH = 12
THETA_TOL = 1e-12  # root refinement tolerance on theta (rad)
RESOLUTION = 10.0  # x* within RESOLUTION times its rounding-error bound is indistinguishable from 0


def _suspicious(x0: float, x1: float, d0: float, d1: float, width: float, floor: float) -> bool:
    """Could x* have two crossings (or touch zero) between two samples of equal sign?

    Cubic Hermite model of x*: flag the interval when it dips to within floor of zero, or when the
    derivative changes sign and the extrapolated extremum could reach zero (safety factor 2).
    """
    if x0 * x1 <= 0 or min(abs(x0), abs(x1)) <= floor:
        return False
    t = np.linspace(0.0, 1.0, 17)
    h00, h10 = 2 * t**3 - 3 * t**2 + 1, t**3 - 2 * t**2 + t
    h01, h11 = -2 * t**3 + 3 * t**2, t**3 - t**2
    model = h00 * x0 + h10 * width * d0 + h01 * x1 + h11 * width * d1
    if np.any(model * np.sign(x0) <= floor):
        return True
    return d0 * d1 < 0 and min(abs(x0), abs(x1)) <= 2.0 * width * max(abs(d0), abs(d1))


def numeric_equilibria(part: Part, delta: float, edges: Edges | None = None) -> EquilibriaResult:
    """All equilibria for one delta: sample x*, bracket its sign changes, refine, classify by Hess U(x, y, theta)."""
    edges = edges or part_edges(part)
    z0 = pivot_translation(edges)
    scale = edges.scale
    # An irrational phase keeps symmetric parts' equilibria (often at multiples of pi/4) off the grid.
    theta = 2 * math.pi * (np.arange(SAMPLES + 1) + 1 / math.pi) / SAMPLES
    pts = curve(edges, part.area, delta, theta, z0)
    floor = RESOLUTION * float(pts.error.max())
    if np.abs(pts.x).max() <= 100 * floor:
        raise SolverError(
            f"x*(theta, delta={delta}) stays below {100 * floor:.3g} m for every theta: "
            "too small to resolve numerically (use the asymptotic method)"
        )
    # Subdivide intervals that might hide a pair of crossings, until none is left.
    th, xs, ds, zs = list(pts.theta), list(pts.x), list(pts.dx), list(pts.z)
    for _ in range(MAX_DEPTH):
        order = np.argsort(th)
        th, xs, ds, zs = (
            [th[i] for i in order],
            [xs[i] for i in order],
            [ds[i] for i in order],
            [zs[i] for i in order],
        )
        mids, starts = [], []
        for i in range(len(th) - 1):
            if (
                _suspicious(xs[i], xs[i + 1], ds[i], ds[i + 1], th[i + 1] - th[i], floor)
                and th[i + 1] - th[i] > 1e-9
            ):
                mids.append(0.5 * (th[i] + th[i + 1]))
                starts.append(zs[i])
        if not mids:
            break
        more = curve(edges, part.area, delta, np.array(mids), np.array(starts))
        th += list(more.theta)
        xs += list(more.x)
        ds += list(more.dx)
        zs += list(more.z)
    else:
        raise SolverError("could not separate the zero crossings of x*(theta) (tangential crossing?)")
    th_a, x_a = np.array(th), np.array(xs)
    z_a = np.array(zs)
    # Samples within the rounding floor count as zero; a crossing there is bracketed by its neighbours.
    sign = np.where(np.abs(x_a) <= floor, 0.0, np.sign(x_a))
    brackets = [
        (th_a[i], th_a[i + 1], x_a[i], z_a[i]) for i in range(len(th_a) - 1) if sign[i] * sign[i + 1] < 0
    ]
    for i in np.flatnonzero(sign == 0):
        j, k = (i - 1) % (len(th_a) - 1), (i + 1) % (len(th_a) - 1)
        if sign[j] * sign[k] >= 0:
            raise SolverError(
                f"x*(theta) touches zero without crossing near theta = {th_a[i]:.6f} (degenerate)"
            )
        lo_t = th_a[j] if j < i else th_a[j] - 2 * math.pi
        brackets.append((lo_t, th_a[i] + (th_a[k] - th_a[i]) % (2 * math.pi), x_a[j], z_a[j]))
    if not brackets:
        raise SolverError("x*(theta) never changes sign: no equilibrium found (contradicts Prop. 5)")
    lo = np.array([b[0] for b in brackets])
    hi = np.array([b[1] for b in brackets])
    flo = np.array([b[2] for b in brackets])
    zstart = np.array([b[3] for b in brackets])
    guess = 0.5 * (lo + hi)
    # Safeguarded Newton on theta with the exact dx*/dtheta, all roots at once.
    for _ in range(100):
        p = curve(edges, part.area, delta, guess, zstart)
        left = p.x * flo > 0
        lo, hi = np.where(left, guess, lo), np.where(left, hi, guess)
        flo = np.where(left, p.x, flo)
        newton = guess - p.x / np.where(p.dx == 0, np.inf, p.dx)
        inside = (newton > lo) & (newton < hi)
        new = np.where(inside, newton, 0.5 * (lo + hi))
        zstart = p.z
        if np.all(np.abs(new - guess) <= THETA_TOL) or np.all(hi - lo <= THETA_TOL):
            guess = new
            break
        guess = new
    else:
        raise SolverError("root refinement of x*(theta) did not converge")
    final = curve(edges, part.area, delta, guess, zstart)
    equilibria = []
    eig_min = []
    # theta is only as good as x* near its root: rounding floor over the slope (Prop. 6 crossing)
    uncertainty = floor / np.maximum(np.abs(final.dx), 1e-300) + THETA_TOL
    for k in range(len(guess)):
        hxy = hessian_xyt(final.grad[k], final.hess[k], final.z[k], float(guess[k]))
        eig = np.linalg.eigvalsh(hxy)
        # Schur complement of Hess U on theta equals delta |S| dx*/dtheta (Prop. 5): both must agree.
        stable_hess = bool(eig.min() > 0)
        stable_prop6 = bool(final.dx[k] > 0)
        if stable_hess != stable_prop6 or abs(final.dx[k]) * scale <= floor:
            raise SolverError(
                f"degenerate equilibrium near theta = {guess[k]:.6f}: Hessian and Prop. 6 disagree"
            )
        eig_min.append(float(eig.min()))
        equilibria.append(
            Equilibrium(float(final.x[k]), float(final.y[k]), float(guess[k] % (2 * math.pi)), stable_hess)
        )
    order = np.argsort([e.theta for e in equilibria])
    equilibria = [equilibria[i] for i in order]
    # drop a duplicate produced by the 0 / 2 pi seam
    unique: list[Equilibrium] = []
    for e in equilibria:
        if not unique or abs(e.theta - unique[-1].theta) > 1e-9:
            unique.append(e)
    if len(unique) > 1 and abs(unique[-1].theta - unique[0].theta - 2 * math.pi) <= 1e-9:
        unique.pop()
    details = {
        "certified": True,
        "samples": len(th_a),
        "x_resolution": floor,
        "hessian_min_eigenvalues": [eig_min[i] for i in order],
        "theta_uncertainty": float(uncertainty.max()),
    }
    return EquilibriaResult(
        (float(-z0[0]), float(-z0[1])), part.area, delta, "numeric", tuple(unique), details
    )
