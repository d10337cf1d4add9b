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
# The ideal model's Heun step evaluates the velocity twice: k1 at the pose, k2 a step dt further. On a
# mode that decays at rate lambda, k2 - k1 = -lambda dt k1, so |k2 - k1| / |k1| measures lambda dt at every
# step for free. Heun is stable for lambda dt < 2, and at 2 exactly k2 = -k1: the part stops where it is,
# off its equilibrium, and reads as settled (the plus at drag 1 and a 5.5e-3 s step ends 1.6 mm and
# 0.75 rad away). A step whose ratio passes 1.5, three quarters of that limit, is counted as stiff and
# a settling it took part in is not certified: the margin covers the change of lambda along the way.
# (Fixed points of the step are the field's equilibria at any stable step, so below the limit the
# final poses are exact; only the transients' timing degrades.)
STIFF_STEP_RATIO: Final = 1.5
