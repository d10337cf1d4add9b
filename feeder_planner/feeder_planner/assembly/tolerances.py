"""Numerical tolerances and model constants of the assembly model: the one place they are defined.

Every value says what it guards and what scale it is relative to. Lengths are relative to the assembly's (or
piece's) size, forces to each body's weight (the equations are scaled so, see ``wrench.EquilibriumSystem``),
and directions are unit vectors, so an angle tolerance is absolute. ``docs/assembly.md`` (Tolerances) states
the ones a user sees.
"""

from __future__ import annotations

import math

import numpy as np

from feeder_planner import units

__all__ = [
    "ANGLE_TOLERANCE",
    "ANTIPODAL_ANGLE",
    "ANTIPODAL_COSINE",
    "AREA_TOLERANCE",
    "BRACKET_MAX_FACETS",
    "BRACKET_START_FACETS",
    "CENTER_CHUNK",
    "CENTER_SLSQP_FTOL",
    "CENTER_SLSQP_MAXITER",
    "COMPARED_FACETS",
    "CONE_TOLERANCE",
    "CONTAINS_TOLERANCE",
    "DEFAULT_FACETS",
    "DEFAULT_PATH_STEP",
    "DEGENERATE_NORM",
    "DISTANCE_TOLERANCE",
    "DISTINCT_POINT_TOLERANCE",
    "ENUMERATED_CENTER_FACETS",
    "FACE_TILT",
    "FAR_PIVOTS",
    "FEASIBILITY_TOLERANCE",
    "FLAT_TOLERANCE",
    "GENERIC_FRAME_SEED",
    "HAUSDORFF_SAMPLES_PER_EDGE",
    "INSIDE_TOLERANCE",
    "INTERIOR_POINT_ROWS",
    "INTERIOR_TOLERANCE",
    "MAX_HULL_ROUNDS",
    "MIDPOINT_MIN_NORM",
    "MIN_DIRECTION_NORM",
    "MIN_FACETS",
    "NORMAL_KEY_SCALE",
    "NORM_FLOOR",
    "ON_PLANE_FACTOR",
    "ORIGIN_TOLERANCE",
    "PARALLEL_EDGES",
    "PENETRATION_TOLERANCE",
    "PLANE_MATCH_TOLERANCE",
    "POLYGON_DEDUPE",
    "REFERENCE_FACETS",
    "REGION_TOLERANCE_RAD",
    "RESIDUAL_TOLERANCE",
    "SAME_EDGE_DIRECTION",
    "SAME_POINT_ANGLE",
    "SAME_VERTEX",
    "SPLIT_COLUMNS",
    "STANDARD_GRAVITY",
    "SUPPORT_TOLERANCE",
    "TILT_AXIS",
    "UNIT_NORMAL_TOLERANCE",
    "VERTEX_FEASIBILITY",
    "VERTICAL_AXIS_NORM",
    "ZERO_COMPONENT",
]

# --- Model constants ---

# m/s^2: contact forces are reported in newtons for |g| = 1 standard gravity (the LP itself is scale-free).
STANDARD_GRAVITY = units.STANDARD_GRAVITY
# Facets K of the friction pyramid by default: the paper's square pyramid of eq. (9).
DEFAULT_FACETS = 4
# The fewest facets of a pyramid: with two the "pyramid" is a wedge and no longer a cone around the normal.
MIN_FACETS = 3
# rad: spacing of the samples of a planned great-arc path (Property 2), each one certified by the LP; 1 degree
# keeps a path of a few tens of samples (one LP each, well under a millisecond) yet finer than any margin a
# user would plan with.
DEFAULT_PATH_STEP = math.radians(1.0)

# --- Geometry (geometry.py): relative to the piece's size ---

# Flatness and coplanarity of a convex piece's vertices, as a fraction of its size: far above the rounding of
# coordinates given in a file (1e-16 relative), far below any real feature a file would describe.
FLAT_TOLERANCE = 1e-9
# qhull's triangles of one face are merged, and a vertex lies on a face, within this many FLAT_TOLERANCEs:
# looser than the flatness test so that rounding in qhull's plane equations never splits one face in two.
ON_PLANE_FACTOR = 10
# Two hull plane normals (unit) are the same face when their cosine exceeds 1 - this.
PLANE_MATCH_TOLERANCE = 1e-9
# Edge pairs closer to parallel than this (norm of the unit cross product) give no separating axis: their
# cross product is rounding noise, and the parallel case is covered by the face normals.
PARALLEL_EDGES = 1e-9
# Two unit edge directions are the same axis when |cos| exceeds 1 - this (only de-duplicates the axis list).
SAME_EDGE_DIRECTION = 1e-12

# --- Assembly files (model.py) ---

# Two pieces overlapping deeper than this fraction of the assembly's size interpenetrate: touching faces
# written with rounded coordinates overlap by far less, a modelling error by far more.
PENETRATION_TOLERANCE = 1e-7
# An explicit contact normal must have unit length within this: a file's rounding, not a wrong vector.
UNIT_NORMAL_TOLERANCE = 1e-6

# --- Contacts (contacts.py) ---

# Faces touch when their planes are within this fraction of the assembly's size (same scale as the
# interpenetration test, so a pair is either touching or separated, never both or neither).
DISTANCE_TOLERANCE = 1e-7
# rad: faces are opposite when their normals are antiparallel within this.
ANGLE_TOLERANCE = 1e-6
# A common polygon with area below this x (smaller face's diameter)^2 is an edge or point touch: no contact
# (the paper assumes a contact surface of non-vanishing area, sec. II-B).
AREA_TOLERANCE = 1e-9
# Contact normals are rounded to 1 / this for the duplicate-contact key: ANGLE_TOLERANCE's resolution.
NORMAL_KEY_SCALE = 1e6
# Polygon vertices closer than this x the polygon's extent are one vertex, and three vertices whose cross
# product is below this x extent^2 are collinear: the clipping's rounding, relative to the polygon's own size.
POLYGON_DEDUPE = 1e-12
# Smallest divisor: turns a zero extent or norm into a harmless scale instead of a division by zero.
NORM_FLOOR = 1e-300

# --- Equilibrium LP (lp.py, stability.py, support.py): on the scaled equations ---

# HiGHS primal and dual feasibility: the equations are scaled to O(1) per body (forces / weight), so this is a
# 1e-9 fraction of each body's weight, two orders below RESIDUAL_TOLERANCE: every certified optimum passes it.
FEASIBILITY_TOLERANCE = 1e-9
# Accepted residual of the returned forces on the scaled equations: a 1e-7 fraction of each body's weight (and
# weight x size for torques). Forces beyond it are never returned as a stable verdict.
RESIDUAL_TOLERANCE = 1e-7
# Clarabel's gap and feasibility tolerances on the dual LP: the crossover only needs the right active set;
# HiGHS then certifies the crossover basis at FEASIBILITY_TOLERANCE (or the simplex continues from it).
INTERIOR_TOLERANCE = 1e-8
# A gravity vector shorter than this has no direction (inputs may have any length; none real is this short).
MIN_DIRECTION_NORM = 1e-12

# --- Support LPs of the region (support.py) ---

# A restarted support LP still unsolved after this many pivots has its optimum in another corner of P: it is
# solved by the interior point method and crossover instead. Measured on brick walls: the restarts that
# succeed take 0-125 pivots, the far ones 2000-6000.
FAR_PIVOTS = 150
# Below this many equations a far LP costs the simplex (pivots are O(rows)) less than the interior point
# route's fixed cost (about 20 ms at 140 rows, 1.1x faster at 264 rows, 2x at 540): they stay on the simplex.
INTERIOR_POINT_ROWS = 200
# Relative tilt of a far LP's objective for the interior point solve (SupportOracle._far_optimum): far above
# INTERIOR_TOLERANCE, so it decides ties over an edge or face of P towards one vertex; small, so that vertex
# is still optimal for the exact direction unless its normal cone is thinner than the tilt (the simplex on the
# exact objective certifies it or moves on).
FACE_TILT = 1e-4
# The tilt's direction: a fixed axis in general position (no assembly is aligned with it).
TILT_AXIS = np.array([0.37, -0.61, 0.70]) / np.linalg.norm([0.37, -0.61, 0.70])

# --- The stable region (region.py): in the cube metric of P = V n {|g|_inf <= 1} ---

# A support value above a hull facet's offset by more than this is a new vertex of P, else the facet is
# certified (cube metric, about 1e-7 rad on the sphere): two orders above the LP's feasibility tolerance.
SUPPORT_TOLERANCE = 1e-7
# The region's stated accuracy (rad, `tolerance_rad` in the JSON): the support tolerance read as an angle.
REGION_TOLERANCE_RAD = SUPPORT_TOLERANCE
# Facets of P with an offset below this pass through the origin: they are the facets of V (the region's
# boundary). Facets of P cut by the cube have offsets of order 1.
ORIGIN_TOLERANCE = 1e-6
# LP columns above which independent sub-assemblies are solved separately: each part then costs its own dozen
# small LPs plus a final combination, which pays off only for big LPs.
SPLIT_COLUMNS = 1000
# Points of P (cube coordinates) closer than this are one point: the hull would get a zero-volume sliver.
DISTINCT_POINT_TOLERANCE = 1e-12
# Upper bound on the rounds of the hull iteration; each round certifies or adds at least one point, and P has
# far fewer vertices and facets than this: reaching it means the LP answers are inconsistent.
MAX_HULL_ROUNDS = 10000
# Norm below which a cross product of two unit normals (or a candidate centre) is treated as zero: the normals
# are parallel and give no vertex.
DEGENERATE_NORM = 1e-12
# A candidate vertex n_i x n_j satisfies n.g <= 0 when every n.g is at most this: the normals carry the LP's
# rounding (about 1e-9), a real violation is of the order of the angles between facets.
VERTEX_FEASIBILITY = 1e-8
# A great circle whose axis is within this of vertical (the projection of -z on its plane is shorter) has no
# lowest point: its centre is then any point of it.
VERTICAL_AXIS_NORM = 1e-9
# Two unit vertices are the same corner when their cosine exceeds 1 - this (three facets through one corner).
SAME_VERTEX = 1e-12
# Above this many facets (fine pyramids only) the centre's exact enumeration of triples, O(facets^3) (34,220
# at 60 facets), gives way to SLSQP on the max-min problem.
ENUMERATED_CENTER_FACETS = 60
# Triples of normals per vectorised batch in the centre's enumeration: bounds its temporary arrays.
CENTER_CHUNK = 20000
# SLSQP's function tolerance and iteration cap for the centre beyond ENUMERATED_CENTER_FACETS: the objective
# is the margin, an angle, so 1e-12 rad is exact for every use; the cap only bounds a failing solve.
CENTER_SLSQP_FTOL = 1e-12
CENTER_SLSQP_MAXITER = 500
# Default membership tolerance of StableRegion.contains (n.g of unit vectors): the LP's feasibility tolerance.
CONTAINS_TOLERANCE = 1e-9
# Components of unit vectors below this are rounding noise (the LP tolerance is 1e-9): printed as 0 in JSON.
ZERO_COMPONENT = 1e-15
# Rows of a fixed frame in general position for the first support LPs (orthonormalised by QR): assemblies are
# often axis-aligned, and an axis direction then maximises over a whole edge or face of P.
GENERIC_FRAME_SEED = ((0.8, 0.3, -0.5), (-0.2, 0.9, 0.4), (0.55, -0.35, 0.75))

# --- Paths (path.py): angles between unit vectors ---

# rad: end points closer than this are the same direction (the path is one sample).
SAME_POINT_ANGLE = 1e-15
# rad: end points within this of antipodal have no unique great arc between them.
ANTIPODAL_ANGLE = 1e-9
# Ends whose cosine is below -1 + this are routed through a stable midpoint (safe_path): a wider band than
# ANTIPODAL_ANGLE (about 4.5e-5 rad), so an arc is never planned between nearly antipodal ends.
ANTIPODAL_COSINE = 1e-9
# A midpoint candidate shorter than this after removing its component along g is parallel to g: not usable.
MIDPOINT_MIN_NORM = 1e-6

# --- Exact friction cone (exact_cone.py) ---

# Facets of the inscribed and circumscribed pyramids that bracket the exact-cone region: their tangential
# radii differ by the factor 1 / cos(pi / K), 7.5e-5 relative at K = 256.
REFERENCE_FACETS = 256
# Pyramids measured against the exact cone by default (the paper's K = 4 and three refinements).
COMPARED_FACETS = (4, 8, 16, 32)
# Accepted violation of |f_t| <= mu f_n by the conic solver's forces, relative to the largest scaled force: a
# fraction of its own tolerance's scale, so only a truly feasible force distribution certifies stability.
CONE_TOLERANCE = 1e-7
# The pyramid bracket (check_exact_bracketed) starts at K = 8, the first refinement of the paper's K = 4, and
# doubles K up to the maximum before calling the direction undecided: at 1024 facets the two pyramids' radii
# differ by 4.7e-6 relative.
BRACKET_START_FACETS = 8
BRACKET_MAX_FACETS = 1024
# Samples per boundary edge for the Hausdorff angle between nested regions: the distance is 1-Lipschitz, so
# the sampled maximum is low by at most half the spacing, edge / 64.
HAUSDORFF_SAMPLES_PER_EDGE = 32
# A unit point is inside a spherical polygon when every n.p is at most this (rounding of unit vectors).
INSIDE_TOLERANCE = 1e-12
