"""Model constants and numerical limits of the MEMS simulator's fidelity models, each with its reason.

The defaults of a scene (array geometry, drag) are here too, so that the scene and the node that
declares them as parameters share one definition. Changing a value changes simulations.
"""

from __future__ import annotations

from typing import Final

from feeder_planner import units

__all__ = [
    "DEFAULT_CELLS",
    "DEFAULT_PITCH",
    "DEFAULT_DAMPING",
    "DEFAULT_FRICTION",
    "GRAVITY",
    "COLLISION_FRICTION",
    "EAR_CLIP_PASSES",
    "SETTLED_SPEED",
    "SETTLED_ANGULAR_SPEED",
    "STIFF_STEP_RATIO",
    "STABLE_STEP_TARGET",
    "STEP_ERROR_TOLERANCE",
    "TRAJECTORY_TOLERANCE",
    "STEP_SAFETY",
    "STEP_GROWTH",
    "STEP_SHRINK",
    "MIN_STEP_FRACTION",
    "REST_TRAVEL",
    "REST_DIFFERENCE",
    "REST_NEUTRAL",
]

# A 100 x 100 array of 100 um cells: 1 cm square, with 20-40 cells across the 2-4 mm parts of the
# examples (the 'array' model converges to 'ideal' as the pitch shrinks, see docs/mems.md).
DEFAULT_CELLS: Final = (100, 100)
DEFAULT_PITCH: Final = 1e-4
# Viscous surface drag per unit area (N s/m^3). In the quasi-static models v = F/(damping A) it only
# scales time, so equilibria do not depend on it; with 1, a 4 mm part in a unit-strength field settles
# within the 1.5 s the tests simulate.
DEFAULT_DAMPING: Final = 1.0
# Coulomb friction coefficient with the surface ('dynamic'): none by default, like the paper's model.
DEFAULT_FRICTION: Final = 0.0
# Standard gravity (m/s^2): the normal force of a part on the array is its weight, for Coulomb friction.
GRAVITY: Final = units.STANDARD_GRAVITY
# Coulomb coefficient between touching parts (pymunk shape friction): a moderate dry-contact value; it
# acts only while parts collide, and no planned equilibrium depends on it.
COLLISION_FRICTION: Final = 0.5
# Ear clipping removes one ear per pass; a simple polygon of n vertices needs n - 3 passes, each
# scanning at most n candidates. 10 n^2 bounds the work of a degenerate (not simple) outline.
EAR_CLIP_PASSES: Final = 10
# A part counts as settled (status counter parts_settled; the device is busy until every part is)
# below 0.1 um/s, a thousandth of the default 100 um pitch per second, and 1e-5 rad/s. Quasi-static
# motion decays exponentially near a stable equilibrium, so the speeds pass these within a fraction of
# a second of the tests' 1e-7 m / 1e-4 rad pose tolerances being met.
SETTLED_SPEED: Final = 1e-7
SETTLED_ANGULAR_SPEED: Final = 1e-5
# The ideal model's Heun step evaluates the velocity twice: k1 at the pose, k2 a step h further. On a
# mode that decays at rate lambda, k2 - k1 = -lambda h k1, so |k2 - k1| / |k1| measures lambda h at every
# step for free. Heun multiplies such a mode by 1 - z + z^2/2 (z = lambda h; the modes of the
# quasi-static gradient flow are real, stepping.py): it decays for z < 2, and at 2 exactly k2 = -k1 and
# the part stops where it is, off its equilibrium (the plus at drag 1 and a fixed 5.5e-3 s step ended
# 1.6 mm and 0.75 rad away), with a small error estimate when it is slow. A step whose ratio passes 1.8
# is taken again shorter: 1.8 still decays (by 0.82 a step), and the tenth left to 2 covers the change of
# lambda within one step, since the ratio is measured at every step. Error control keeps the other steps
# accurate; this limit only keeps them off the frozen point. A dt on which a full step would have passed
# 1.8 counts as a stiff step (FAULT_TIME_STEP: the configured time_step is beyond the margin). The
# scenes' own steps stay inside it: the plus at drag 1 peaks at 0.97 with the cell scene's 2.5e-3 s, the
# demo's quadratic field (k 3000 N/m^3 per unit area, drag 1) at 1.5 with its 5e-4 s, where the former
# limit of 1.5 itself flagged every demo goal by a rounding hair.
STIFF_STEP_RATIO: Final = 1.8
# A cut step aims at this ratio, a quarter below the limit, so that the next step is not cut again.
STABLE_STEP_TARGET: Final = 1.35
# Local error per Heun step, estimated by the embedded Euler step (h/2 |k2 - k1|), in the pose scale:
# x and y in part radii, theta in radians. 1e-6 is 3 nm for the 3 mm plus and 1e-6 rad, a hundredth of
# the tests' 1e-4 rad pose tolerance. Heun's own error is of higher order than the estimate, and the
# quasi-static flow contracts, so a trajectory stays within TRAJECTORY_TOLERANCE of a fine fixed-step
# reference (measured: within 3.4e-7 over drags 0.05 to 50; tests/mems/test_adaptive.py). A tenth of it
# triples the evaluations of a transient for ten times less error, which no tolerance downstream needs.
STEP_ERROR_TOLERANCE: Final = 1e-6
# What the error control promises of a whole trajectory, in the same scale (tested).
TRAJECTORY_TOLERANCE: Final = 1e-6
# Step-size control: the usual safety factor on the optimal step (tolerance / error)^(1/2), a growth of
# at most 5x and a cut of at most 5x per step, so that one odd estimate cannot swing the step far.
STEP_SAFETY: Final = 0.9
STEP_GROWTH: Final = 5.0
STEP_SHRINK: Final = 0.2
# No step shorter than this fraction of time_step is cut further (accepted as it is): a bound on the
# work of one time_step (a million steps at the worst) for a field the error control cannot resolve.
MIN_STEP_FRACTION: Final = 1e-6
# A settled part (SETTLED_SPEED) rests, and is not integrated, when the linearised rest of its motion,
# the Newton step |J^-1 v| to the equilibrium it approaches, is at most 1e-7 in the pose scale (part
# radii, radians): a thousandth of the tests' 1e-4 rad and a tenth of the 1e-6 rad the settling tests
# ask of the ideal model. With every mode of J decaying, the quasi-static motion from there is that
# step (to second order), so a rest leaves the part within 1e-7 of where integration would take it.
REST_TRAVEL: Final = 1e-7
# J by forward differences of 1e-6 part radii and 1e-6 rad: relative error ~1e-6 from the curvature,
# and the rate's rounding (1e-16 of its scale) divided by the offset stays far below the slowest mode.
REST_DIFFERENCE: Final = 1e-6
# A mode of J slower than this fraction of the fastest counts as neutral, not decaying (the radial field
# alone: every orientation is an equilibrium, Prop. 3): no rest is certified, integration goes on.
REST_NEUTRAL: Final = 1e-6
