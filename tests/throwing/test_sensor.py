"""The one-bit sensor sees the part itself, not its hull (contract 3)."""

import numpy as np
from throwing_helpers import bracket, rectangle

from feeder_planner.throwing.sensor import intersect, merge, reads, resting_cover, subtract


def test_bracket_on_its_bridging_hull_edge_is_seen_only_at_its_feet():
    part = bracket()
    # Hull edge 2 runs from (1.4, 0.7) to (0.5, 1.05) cm over the notch: only its end vertices touch the arm.
    e = 2
    (ul, _), (ur, _) = part.contact_vertices(e)
    height = 1e-5
    cover = resting_cover(part, e, height)
    assert len(cover) == 2  # two separate feet
    assert not reads(part, e, 0.1, 0.1 + 0.5 * (ul + ur), height)  # nothing above the sensor mid-edge
    assert reads(part, e, 0.1, 0.1 + ul, height) and reads(part, e, 0.1, 0.1 + ur, height)


def test_rectangle_cover_is_its_bottom_edge_and_grows_with_height_only_if_walls_slope():
    part = rectangle(0.04, 0.01)
    cover = resting_cover(part, 0, 0.002)
    assert len(cover) == 1 and np.allclose(cover[0], (-0.02, 0.02))
    assert not reads(part, 0, 0.1, 0.1 + 0.0201, 0.002)


def test_interval_algebra():
    assert merge([(0, 1), (0.5, 2), (3, 4)]) == [(0, 2), (3, 4)]
    assert intersect([(0, 2), (3, 5)], [(1, 4)]) == [(1, 2), (3, 4)]
    assert subtract([(0, 10)], [(2, 3), (5, 6)]) == [(0, 2), (3, 5), (6, 10)]
