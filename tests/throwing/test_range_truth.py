"""Radius ranges and trigger ranges of limit-set's defaults against long runs, on parts in millimetres.

Issue 35: an attractor's radius range is the closure of its tails' visits, so a start's approach must not
enter it. Three designs whose radii are quasi-periodic (the throws per round vary, their mean is no
integer), each part drawn in millimetres: the issue's quadrilateral (examples/throwing/quad35.yaml), the
wedge of test_attractor_transients and examples/throwing/transient5.yaml. Every start of limit-set's
default grid is also thrown LONG times one throw after the other, and its last half is its attractor
(truth_corpus.compare_ranges: within RANGE_GAPS mean gaps of the planner's recent quarters). The trigger
range is read as limit-set reads it: on the tails and the older states of their stays that may be visits.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from throwing_helpers import EXAMPLES
from truth_corpus import (
    RANGE_GAPS,
    CorpusDesign,
    Run,
    compare_ranges,
    long_runs,
    range_tolerance,
    tail_states,
)

from feeder_planner.parts import load_part, make_part
from feeder_planner.throwing.geometry import ArmPart, arm_part
from feeder_planner.throwing.limit_set import limit_set
from feeder_planner.throwing.sensor import read_trigger
from feeder_planner.throwing.throw_map import ThrowParams

MM = 0.001
# Long enough that every start's last half is past its transient (transient5's longest is ~700 throws)
# and holds hundreds of rounds: its gaps are far below the planner's.
LONG = 3000
WEDGE = [[1.29, 21.05], [-19.44, -10.49], [8.58, -17.46], [11.14, -16.61], [17.03, -14.01]]


def _design(name: str) -> tuple[ArmPart, ThrowParams, int]:
    if name == "quad35":
        part = arm_part(load_part(EXAMPLES / "quad35.yaml"))
        return part, ThrowParams(-7.2 * MM, math.radians(300), -9.66, 0.5), 0
    if name == "wedge":
        part = arm_part(make_part(WEDGE, unit_scale=MM))
        return part, ThrowParams(-1.128 * MM, math.radians(277.7), -9.66, 0.613), 0
    part = arm_part(load_part(EXAMPLES / "transient5.yaml"))
    return part, ThrowParams(-0.82 * MM, math.radians(106), -2.2, 0.41), 2


def _compare(name: str) -> tuple[Any, Any, list[Run], list[str], list[str]]:
    """Return limit-set's defaults on a design, its attractor, and what differs from the long runs."""
    part, params, goal = _design(name)
    ls = limit_set(part, params, goal_edge=goal, keep_trajectories=True)
    assert ls.converged and ls.attractors and ls.trajectories is not None
    (a,) = ls.attractors
    assert a.throws_per_round is not None
    low, mean, high = a.throws_per_round
    assert low < high and mean != round(mean), a.throws_per_round  # quasi-periodic radii
    t = ls.trajectories
    runs = long_runs([CorpusDesign(0, 0, part, params, True)], [(t.edge[:, 0], t.radius[:, 0])], LONG)[0]
    assert not any(r.escaped for r in runs)
    bad_ranges, bad_triggers, goals = compare_ranges(ls, runs, part)
    assert goals >= 1  # every edge the attractor visits is a goal edge compared
    # The tolerance is a small share of each range: the comparison has teeth.
    for e, (lo, hi) in a.edge_radius_ranges.items():
        assert range_tolerance(ls, a, e) < 0.02 * (hi - lo), (e, RANGE_GAPS)
    return ls, a, runs, bad_ranges, bad_triggers


@pytest.mark.parametrize("name", ["quad35", "transient5"])
def test_ranges_and_trigger_are_the_long_runs_tails(name: str) -> None:
    _, _, _, bad_ranges, bad_triggers = _compare(name)
    assert not bad_ranges and not bad_triggers, bad_ranges + bad_triggers


def test_the_wedges_range_falls_short_where_its_visits_thin_out_and_its_trigger_does_not() -> None:
    # A limitation of the ranges, measured: edge 1's highest visits are rare (the members' recent quarters
    # hold 1,639 states on edge 1, their top ones 0.01-0.04 mm apart, 195.84 mm; the long runs reach
    # 195.95 mm), and _trim_to_group takes a member's older visit up there, 3 mean gaps beyond its
    # reference, for the approach. So edge 1 reads about 0.08 mm short at its top, named.
    ls, a, runs, bad_ranges, bad_triggers = _compare("wedge")
    assert len(bad_ranges) == 1 and bad_ranges[0].startswith("attractor 0 edge 1:"), bad_ranges
    top = max(float(r.radius[LONG // 2 :][r.edge[LONG // 2 :] == 1].max()) for r in runs)
    lo, hi = a.edge_radius_ranges[1]
    assert 0 < top - hi < 0.15 * MM and abs(lo - 174.60 * MM) < 0.01 * MM, (lo, hi, top)
    # The trigger range must not reach beyond the attractor's (contract 3). Read on the tails alone its
    # low end would be 147.28 mm, 0.09 mm below the long runs' 147.36, beyond the tolerance: goal visits
    # to edge 0 that the tails' cut left out cover less (a sensor there would miss them). It is read on
    # the tails and the older states of their stays within TRIGGER_GAPS of the recent quarters, and agrees.
    assert not bad_triggers, bad_triggers
    assert ls.trigger is not None
    assert 147.30 * MM < ls.trigger[0] < 147.37 * MM and abs(ls.trigger[1] - 157.72 * MM) < 0.01 * MM
    t = ls.trajectories
    tails = [tail_states(t, b) for b in a.members]
    part, _, goal = _design("wedge")
    only_tails = read_trigger(part, goal, ls.sensing_height, [tails]).trigger
    assert only_tails is not None and only_tails[0] < 147.29 * MM, only_tails


def test_quad35_edge0_range_starts_where_the_long_runs_do() -> None:
    # The number: before issue 35 edge 0 read from 155.4 mm (a start's first landing); long runs
    # of 10,000 throws from 16 starts keep it in [159.25, 211.27] mm (the file's comment).
    part, params, goal = _design("quad35")
    (a,) = limit_set(part, params, goal_edge=goal).attractors
    lo, hi = a.edge_radius_ranges[0]
    assert np.allclose([lo / MM, hi / MM], [159.25, 211.27], atol=0.05)
