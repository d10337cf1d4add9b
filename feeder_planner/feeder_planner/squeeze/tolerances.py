"""Numerical tolerances and model limits of the squeeze-grasp mechanics (one place, stated)."""

from __future__ import annotations

from typing import Final

# Two breakpoints of the diameter function closer than this (rad) are one: parallel hull edges give the
# same breakpoint twice (a rectangle's four normals are two breakpoints mod pi), and atan2 of the two
# edges differs by a few ulps. Far below any angle a gripper can set (about 1e-4 rad).
ANGLE_TOLERANCE: Final = 1e-9
# A hull whose area is below this fraction of its span squared is degenerate (a segment or a point):
# its diameter function has no isolated minima, so no squeeze plan exists.
DEGENERATE_AREA_FRACTION: Final = 1e-9
# Two stable orientations whose images under a plan differ by less than this (rad, mod the symmetry
# period) are the same final orientation.
FINAL_TOLERANCE: Final = 1e-7
# Largest number of squeezes a plan may have: Goldberg's plans have length O(n) in the hull's vertices
# (Chen and Ierardi 1995), and a part has at most MAX_PART_VERTICES vertices.
MAX_PLAN_SQUEEZES: Final = 10_000
# Friction coefficient between jaws and part: above 2 no squeeze of a polygon slides (the friction cone's
# half-angle exceeds 63 degrees); the dynamic fidelity refuses values outside [0, MAX_FRICTION].
MAX_FRICTION: Final = 2.0
# The exhaustive shortest-plan search visits at most this many distinct states before giving up (it
# raises SolverError rather than report an uncertified bound).
MAX_SEARCH_STATES: Final = 200_000
# Stable orientations a period the planner takes: its O(n^2) runs are arrays of n^2 entries (2,000: 4
# million, about 200 MB and a few seconds); a part beyond it is refused naming its vertices.
MAX_STEPS_PER_PERIOD: Final = 2_000
