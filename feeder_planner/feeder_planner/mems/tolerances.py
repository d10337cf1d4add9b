"""Numerical tolerances and model constants of the MEMS mechanics, each with the reason for its value.

Lengths are relative to the part radius (``Edges.scale``) unless a comment says otherwise, so that the
same tolerances hold for a 1 um part and a 1 m part. Changing a value changes results: the tests and
the benchmark were run with exactly these.
"""

from __future__ import annotations

import math
from typing import Final

import numpy as np

__all__ = [
    "ROUNDING_BOUND",
    "ON_BOUNDARY",
    "GRADING_EXTRA_LEVELS",
    "GRADING_MAX_LEVELS",
    "GAUSS_NODES",
    "NEWTON_STEP_TOL",
    "NEWTON_MAX_ITER",
    "NEWTON_LONG_STEP",
    "NEWTON_MAX_BACKTRACKS",
    "NEWTON_DECREASE_SLACK",
    "NEWTON_DECREASE_FLOOR",
    "NEWTON_NOISE_FACTOR",
    "CURVE_ERROR_FACTOR",
    "NUMERIC_SAMPLES",
    "NUMERIC_PHASE",
    "NUMERIC_MAX_DEPTH",
    "NUMERIC_MIN_WIDTH",
    "HERMITE_POINTS",
    "HERMITE_SAFETY",
    "THETA_TOL",
    "RESOLUTION",
    "RESOLVABLE",
    "ROOT_MAX_ITER",
    "SLOPE_FLOOR",
    "SEAM_TOL",
    "MAX_ORDER",
    "EXTRA",
    "FIRST_ORDER",
    "PIVOT_TOL",
    "ZERO_TOL",
    "ASYMPTOTIC_SAMPLES",
    "ROOT_GRID_PER_PERIOD",
    "ROOT_BISECTIONS",
    "ROOT_NEWTON_ITER",
    "ROOT_STEP_TOL",
    "MULTIPLE_ROOT",
    "SERIES_NEWTON_ITER",
    "BRANCH_WINDOW",
    "FOURIER_REPORTED",
    "CERT_THETA",
    "CERT_POSITION",
    "CERT_DELTAS",
]

# --- rounding ---------------------------------------------------------------------------------------
# Bound on the relative rounding error of a sum of closed-form edge terms: each term carries a few
# roundings (sqrt, log, products), 8 eps per term covers them with margin. Used for the rounding floor
# of grad V (lifted.value_gradient_hessian_noise) and of the tilt delta |S| (sin, cos) added to it (curve.py).
ROUNDING_BOUND: Final = 8.0 * float(np.finfo(float).eps)

# --- lifted.py: derivatives of order >= 3 by graded Gauss-Legendre quadrature ------------------------
# The field centre counts as on the boundary (V only C^2 there, Prop. 2) when it is closer than this
# to an edge line segment, relative to the part radius: 1e-15 is a few ulps of the coordinates.
ON_BOUNDARY: Final = 1e-15
# Pieces are graded geometrically (ratio 2) from the foot of the origin; two levels beyond the edge's
# reach guarantee the last piece covers the whole edge.
GRADING_EXTRA_LEVELS: Final = 2
# At most 80 doublings: 2^80 spans the ratio of the part radius to the boundary distance ON_BOUNDARY
# allows (1e15 < 2^50) with room, and bounds the work when a distance is denormal.
GRADING_MAX_LEVELS: Final = 80
# Gauss-Legendre nodes per piece: with every piece one piece length away from the integrand's complex
# singularities, 24 nodes leave only rounding (relative error < 1e-12, tested to order 8).
GAUSS_NODES: Final = 24

# --- curve.py: damped Newton on the strictly convex V (Prop. 3) --------------------------------------
# Newton stops when its step is below this fraction of the part radius (a few ulps of a coordinate).
NEWTON_STEP_TOL: Final = 1e-14
# Damped Newton on a strictly convex function converges from anywhere, quadratically near the minimum;
# 200 iterations are far more than any tested part needs, so hitting the limit means a defect.
NEWTON_MAX_ITER: Final = 200
# Steps longer than this fraction of the part radius are checked for decrease (backtracking); shorter
# ones are inside Newton's quadratic basin, where the check would only cost evaluations.
NEWTON_LONG_STEP: Final = 1e-3
# Halvings of a long step at most: 2^-40 of a step is below NEWTON_STEP_TOL of any step that matters.
NEWTON_MAX_BACKTRACKS: Final = 40
# A trial point is accepted unless it raises U by more than this relative amount (the rounding of U)...
NEWTON_DECREASE_SLACK: Final = 1e-13
# ...plus this absolute floor, so that U = 0 exactly does not reject every trial.
NEWTON_DECREASE_FLOOR: Final = 1e-300
# Newton also stops when its step is within 4x the rounding floor of the gradient mapped through
# Hess^-1: below that, steps are noise and convergence cannot be improved.
NEWTON_NOISE_FACTOR: Final = 4.0
# The reported error of (X*, Y*) is 2x that rounding floor (the floor is a bound for one evaluation;
# the solution is the last of several), plus NEWTON_STEP_TOL.
CURVE_ERROR_FACTOR: Final = 2.0

# --- numeric.py: zero crossings of x*(theta, delta) (Props. 5-6) -------------------------------------
# Initial theta grid; intervals that might hide two crossings are subdivided afterwards.
NUMERIC_SAMPLES: Final = 64
# Grid phase in units of one grid step: irrational, so the equilibria of symmetric parts (often at
# multiples of pi/4) never fall on a sample.
NUMERIC_PHASE: Final = 1 / math.pi
# Subdivision rounds at most: 12 halvings take an interval to 2 pi / 64 / 2^12 = 2.4e-5 rad; crossings
# not separated by then are taken as tangential, which is refused.
NUMERIC_MAX_DEPTH: Final = 12
# Intervals narrower than this (rad) are not subdivided further (far below any physical resolution).
NUMERIC_MIN_WIDTH: Final = 1e-9
# Points at which the cubic Hermite model of x* between two samples is checked for a dip to zero.
HERMITE_POINTS: Final = 17
# Safety factor on the extrapolated extremum of x* when its derivative changes sign in an interval.
HERMITE_SAFETY: Final = 2.0
# Root refinement tolerance on theta (rad): a few ulps of 2 pi.
THETA_TOL: Final = 1e-12
# x* within RESOLUTION times its rounding-error bound is indistinguishable from 0.
RESOLUTION: Final = 10.0
# x* must exceed RESOLVABLE times that floor somewhere, or the curve is too flat to locate crossings
# (tiny delta on a symmetric part): the method refuses instead of reporting noise.
RESOLVABLE: Final = 100.0
# Safeguarded Newton iterations on theta at most (it converges in well under 10).
ROOT_MAX_ITER: Final = 100
# Floor of |dx*/dtheta| when dividing by it (avoids 0 division; any real slope is far larger).
SLOPE_FLOOR: Final = 1e-300
# Two equilibria closer than this (rad) are one, found twice across the 0 / 2 pi seam.
SEAM_TOL: Final = 1e-9

# --- asymptotic.py: Table 1 and Theorem 7 ------------------------------------------------------------
# Highest order n of d^n x*/d delta^n tried (Table 1's loop). An m-fold symmetric part needs n = m - 1
# (tested: the plus, n = 3; the octagon, n = 7), so 9 covers up to 10-fold symmetry; a part needing
# more is treated as rotation-invariant and refused.
MAX_ORDER: Final = 9
# Orders of the expansion beyond n used to refine theta(delta) (truncation error ~ delta^3).
EXTRA: Final = 2
# The first expansion is computed to this n (plus EXTRA): enough for every 4-fold symmetric part
# (n = 3); the order is raised to MAX_ORDER only when needed.
FIRST_ORDER: Final = 3
# |(X0, Y0)| below PIVOT_TOL times its rounding-error bound: pivot = centroid (Table 1's test).
PIVOT_TOL: Final = 100.0
# d^k x*/d delta^k is 'identically zero' below this fraction of max_{j<=k} |d^j (X*, Y*)|; Fourier
# coefficients below this fraction of the largest are rounding noise of an exactly symmetric part.
ZERO_TOL: Final = 1e-9
# theta samples of the Taylor coefficients: they are trig polynomials of degree <= k + 1 <= 12 < 16,
# so the FFT of 32 samples is exact.
ASYMPTOTIC_SAMPLES: Final = 32
# Samples per period of the highest frequency when bracketing the roots of d^n x*: a simple root pair
# of a trig polynomial of that degree cannot hide between them.
ROOT_GRID_PER_PERIOD: Final = 16
# Bisections of every bracket before Newton: shrink it by 2^12 so Newton starts in its basin.
ROOT_BISECTIONS: Final = 12
# Newton polishing iterations on a trig root (quadratic convergence from a 2^-12 bracket: 8 is ample).
ROOT_NEWTON_ITER: Final = 8
# A Newton step below this (rad) has converged: an ulp of 2 pi is 8.9e-16.
ROOT_STEP_TOL: Final = 1e-15
# A root whose slope is below this fraction of the largest Fourier amplitude is multiple (Theorem 7
# (iii) fails): the expansion is refused rather than classified by the sign of noise.
MULTIPLE_ROOT: Final = 1e-7
# Newton iterations following each Theorem-7 root to the root of the truncated series at delta.
SERIES_NEWTON_ITER: Final = 30
# A followed root may move at most this fraction of half the root spacing (pi / number of roots);
# further means delta is outside the range of the small-delta expansion.
BRANCH_WINDOW: Final = 0.5
# Fourier coefficients of d^n x* reported in the details: those above this fraction of the largest.
FOURIER_REPORTED: Final = 1e-9

# --- equilibria.py: certification of 'auto' -----------------------------------------------------------
# 'auto' accepts the asymptotic prediction when it matches the numeric one in count and stability,
# every angle within CERT_THETA + delta^3 rad and every position within (CERT_POSITION + delta^3) part
# radii (delta^3: the truncation order of the expansion after its EXTRA = 2 refining orders).
CERT_THETA: Final = 1e-6
CERT_POSITION: Final = 1e-6
# Where to certify the expansion when delta is below the numeric method's resolution: the smallest of
# these above delta at which both methods work (one decade apart, then up to the expansion's range).
CERT_DELTAS: Final = (1e-4, 1e-3, 1e-2, 3e-2, 0.1)
