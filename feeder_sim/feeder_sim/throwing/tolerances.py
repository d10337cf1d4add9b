"""Numerical tolerances and model constants of the simulated throwing arm (pymunk, faults, node display).

The pymunk world is scaled so that the part radius is 1 ("part radii" below): pymunk's contact tolerances
are absolute, and this makes them the same for a 1 cm and a 10 cm part. Times are seconds, angles radians.
Changing a value changes results: the tests and the benchmark were run with exactly these.
"""

from __future__ import annotations

from typing import Final

__all__ = [
    "DEFAULT_STEP",
    "CARRY_ANGLE",
    "CARRY_CHECKS",
    "RESTITUTION",
    "ARM_FRICTION",
    "ARM_ELASTICITY",
    "COLLISION_SLOP",
    "SOLVER_ITERATIONS",
    "ARM_THICKNESS",
    "FREE_ARM_MARGIN",
    "PART_MASS",
    "DROP_GAP",
    "SETTLE_BEFORE",
    "RECORD_EVERY",
    "FALL_HEIGHT",
    "FALL_ALLOWANCE",
    "FLIGHT_ALLOWANCE",
    "EXTRA_TIME",
    "JUDGE_AFTER",
    "ARM_LEVEL",
    "STILL_SPEED",
    "STILL_TIME",
    "LOST_DEPTH",
    "MAX_TILT",
    "PATH_SAMPLES",
    "MAX_SPEED_ERROR_SIGMA",
    "MIN_SPEED_SCALE",
    "MAX_SPEED_ERROR",
    "MAX_TICK_PERIODS",
    "LIFT_GUARD",
    "LEVEL_SLACK",
    "CONTACT_RTOL",
    "CONTACT_ATOL",
    "SLIDE_TIME_LIMIT",
    "MAX_CONTACT_EVENTS",
]

# --- Time stepping -----------------------------------------------------------------------------------
# Default pymunk step (s): agreement with the analytic model on (edge, jog/flip) is 1.0 from 1e-3 s down
# (docs/throwing.md, bench), and 1e-4 s resolves the 0.02 rad carry at W = 5.6 rad/s in ~70 steps.
DEFAULT_STEP: Final = 1e-4

# --- The carry (section III-A.1) ---------------------------------------------------------------------
# The arm turns this far (rad) while accelerating uniformly to W: short enough to approximate the
# paper's impulsive throw, long enough to be a real carry the wrench-cone test can check.
CARRY_ANGLE: Final = 0.02
# Arm angles of the carry (evenly spaced, both ends included) at which the wrench-cone test is applied.
CARRY_CHECKS: Final = 9

# --- Contact materials -------------------------------------------------------------------------------
# Restitution of the part: low, as on the paper's damping foam, but not the ideal sticking impact.
RESTITUTION: Final = 0.05
# pymunk multiplies the two shapes' coefficients, so the arm carries 1.0 and the part's own mu and
# restitution are the contact's.
ARM_FRICTION: Final = 1.0
ARM_ELASTICITY: Final = 1.0
# Allowed overlap of shapes (part radii): small against the part so resting poses are exact to 1e-4 of
# its radius, as pymunk's default (0.1) would not be for a part of radius 1.
COLLISION_SLOP: Final = 1e-4
# Contact solver iterations per step: three times pymunk's default of 10, for stiffer resting contacts;
# the agreement with the analytic model in docs/throwing.md was measured with it.
SOLVER_ITERATIONS: Final = 30

# --- The scene ---------------------------------------------------------------------------------------
# Thickness of the arm slab below its top surface (part radii): thick enough that no vertex tunnels
# through it in one step at the impact speeds of a throw.
ARM_THICKNESS: Final = 0.5
# An arm of infinite length is modelled as FREE_ARM_MARGIN x (R + FREE_ARM_MARGIN) part radii each side
# of the pivot (R in part radii): far beyond where any throw of the map's domain lands.
FREE_ARM_MARGIN: Final = 10
# Mass of the part body; the dynamics do not depend on it (its inertia is mass x rho^2).
PART_MASS: Final = 1.0
# The part starts this far (part radii) above the arm so the shapes do not overlap at t = 0.
DROP_GAP: Final = 1e-6
# Time (s) for the part to settle into contact before the throw.
SETTLE_BEFORE: Final = 0.02
# Interval (s) between recorded poses of the path the node shows.
RECORD_EVERY: Final = 0.005

# --- When the throw is over --------------------------------------------------------------------------
# Time limit = carry + FLIGHT_ALLOWANCE x (flight bound) + EXTRA_TIME, where the flight bound is the
# ballistic time up and down at the release speed scale W max(R, 1) plus FALL_ALLOWANCE times the fall
# from FALL_HEIGHT part radii: generous, so that only a part that never comes to rest hits it.
FALL_HEIGHT: Final = 4.0
FALL_ALLOWANCE: Final = 4.0
FLIGHT_ALLOWANCE: Final = 4.0
EXTRA_TIME: Final = 2.0
# Stillness is judged only this long (s) after the carry, once the part has surely left the arm.
JUDGE_AFTER: Final = 0.05
# The arm is back at horizontal when its angle is at most this (rad).
ARM_LEVEL: Final = 1e-12
# The part is still when |v| + |omega| is below this fraction of its release speed scale W max(R, 1).
STILL_SPEED: Final = 1e-3
# ... for this long (s) in a row: it has settled.
STILL_TIME: Final = 0.05
# A part this far (part radii) below the arm surface has fallen off the arm.
LOST_DEPTH: Final = 5.0
# A resting part tilted more than this (rad) from every hull edge is not lying on an edge: a fault.
MAX_TILT: Final = 0.05

# --- Display -----------------------------------------------------------------------------------------
# Poses of the analytic flight path the node shows (the analytic model has no path of its own).
PATH_SAMPLES: Final = 20

# --- Injected faults (faults.py) ---------------------------------------------------------------------
# Largest sigma of release_speed_error: a calibration error of the motor's speed, not a different
# machine; at 0.5 a throw's W still lies within [0, 2 W] for 95 % of the draws.
MAX_SPEED_ERROR_SIGMA: Final = 0.5
# Smallest factor 1 + e a throw is released at (fixed or drawn): a release speed error never stops or
# reverses the arm (that is a motor fault); draws below it are clipped to it.
MIN_SPEED_SCALE: Final = 0.05
# Largest fixed release speed error e (release at up to twice W).
MAX_SPEED_ERROR: Final = 1.0

# --- The node's clock --------------------------------------------------------------------------------
# At most this many sensor periods of simulated time per tick: a node that falls further behind its
# clock (a slow machine, a long dynamic throw, a big clock step) loses the rest, and its recorded
# simulated time lags the clock visibly (status behind_real_time) instead of jumping ahead unseen.
MAX_TICK_PERIODS: Final = 10

# --- The contact fidelity (contact.py) ---------------------------------------------------------------
# A vertex that has just lifted off starts with height, velocity (and at the instant N = 0, acceleration)
# zero, so its own next crossing is searched from this much rotation (rad) later (or this fraction of
# the free-fall time sqrt(r / |g|) without spin): its height there is ~1e-12 of the part radius, above
# rounding (1e-16), and no vertex can come back to the arm within 1e-4 rad of rising.
LIFT_GUARD: Final = 1e-4
# A vertex within this fraction of the part radius of the arm when a slide starts counts as on the arm
# (the other end of an edge that has just come down, level up to rounding ~1e-16 of the radius).
LEVEL_SLACK: Final = 1e-9
# Relative and absolute (part radii per free-fall time) tolerances of the sliding-contact ODE (DOP853);
# its events (lift-off, stick, strike) are located by the solver's root finding to about these.
CONTACT_RTOL: Final = 1e-10
CONTACT_ATOL: Final = 1e-12
# A slide lasts at most this many free-fall times sqrt(r / |g|): friction stops a slide within a few.
SLIDE_TIME_LIMIT: Final = 1000.0
# Events (impacts, lift-offs, slides) of one contact throw before it is a SolverError: the paper's own
# settling takes tens of impacts; this only catches a model that does not settle.
MAX_CONTACT_EVENTS: Final = 5000
