"""Design search over offset h and release speed (unique limit set, widest trigger range)."""

import math

import numpy as np
import pytest
from throwing_helpers import triangle

from feeder_planner.errors import InputError
from feeder_planner.throwing.design import search
from feeder_planner.throwing.limit_set import limit_set
from feeder_planner.throwing.throw_map import ThrowParams


def test_design_search_reports_every_design_and_picks_the_widest_unique_one():
    part = triangle()
    offsets = np.array([-0.008, -0.005, -0.002])
    speeds = np.array([math.radians(280), math.radians(320), math.radians(360)])
    found = search(part, 1, offsets, speeds, -9.66, 0.5, sensing_height=0.001, starts_per_edge=6, throws=300)
    best, rows = found.best, found.designs
    assert len(rows) == 9 and {(r.offset, r.speed) for r in rows} == {(h, w) for h in offsets for w in speeds}
    assert best is not None and best.unique and best.trigger is not None
    assert best.width == max(r.width for r in rows if r.unique)
    # Independent re-check of the chosen design with a finer grid of starts.
    again = limit_set(
        part,
        ThrowParams(best.offset, best.speed, -9.66, 0.5),
        goal_edge=1,
        starts_per_edge=15,
        throws=300,
        sensing_height=0.001,
    )
    assert again.unique and 1 in again.cycle.edges and again.trigger is not None


def test_design_search_bad_input():
    part = triangle()
    with pytest.raises(InputError) as info:
        search(part, 1, np.array([-0.005]), np.array([0.0]), -9.66, 0.5)
    assert info.value.field == "release_speed"
    with pytest.raises(InputError) as info:
        search(part, 5, np.array([-0.005]), np.array([1.0]), -9.66, 0.5)
    assert info.value.field == "goal_edge"
