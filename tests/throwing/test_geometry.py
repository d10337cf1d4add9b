"""Hull numbering, stable edges, d^i, contact vertices, rho (section II, contract 3)."""

import math

import numpy as np
from throwing_helpers import bracket, rectangle, triangle

from feeder_planner.parts import make_part
from feeder_planner.throwing.geometry import arm_part


def test_hull_numbering_starts_at_first_file_vertex_on_hull_and_runs_ccw():
    # File vertex 0 is a reflex (inner) vertex; vertex 1 is the first on the hull; clockwise file order.
    verts = [[1, 1], [0, 3], [3, 3], [3, 0], [0, 0]]
    part = arm_part(make_part(verts))
    assert part.file_index[0] == 1
    assert sorted(part.file_index) == [1, 2, 3, 4]
    hull = part.hull
    area = 0.5 * sum(hull[i, 0] * hull[(i + 1) % 4, 1] - hull[(i + 1) % 4, 0] * hull[i, 1] for i in range(4))
    assert area > 0  # counter-clockwise


def test_d_and_contact_vertices_match_independent_line_distances():
    part = triangle()
    for i in range(part.n):
        a, b = part.hull[i], part.hull[(i + 1) % part.n]
        t = (b - a) / np.linalg.norm(b - a)
        dist = abs(a[0] * t[1] - a[1] * t[0])  # distance from the centroid (origin) to the edge's line
        assert math.isclose(part.d[i], dist, rel_tol=1e-12)
        (ul, vl), (ur, vr) = part.contact_vertices(i)
        assert vl == vr == -part.d[i] and ul < ur
        assert math.isclose(ur - ul, float(np.linalg.norm(b - a)), rel_tol=1e-12)
        assert math.isclose(ul, float(a @ t), abs_tol=1e-15)


def test_rectangle_radius_of_gyration_and_stability():
    part = rectangle(0.3, 0.1)
    assert math.isclose(part.rho**2, (0.3**2 + 0.1**2) / 12, rel_tol=1e-12)
    assert part.stable.all()
    assert math.isclose(part.d_min, 0.05, rel_tol=1e-12)
    assert math.isclose(part.radius, math.hypot(0.15, 0.05), rel_tol=1e-12)


def test_bracket_has_exactly_one_unstable_edge():
    part = bracket()
    assert part.n == 5 and part.stable.sum() == 4
    i = int(np.flatnonzero(~part.stable)[0])
    assert (part.u_left[i] > 0) == (part.u_right[i] > 0)  # the centre of mass projects outside that edge
