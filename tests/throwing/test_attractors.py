"""Attractors of the throw map (issue 14 item 1): periodic cycles, quasi-periodic rounds, convergence."""

import math

import numpy as np
import pytest
from throwing_helpers import EXAMPLES, TRIANGLE_PARAMS, triangle
from truth_corpus import tail_states

from feeder_planner.errors import SolverError
from feeder_planner.parts import load_part
from feeder_planner.throwing.attractors import _confirm, blocks, round_pattern, widening
from feeder_planner.throwing.geometry import arm_part
from feeder_planner.throwing.limit_set import limit_set, sensed_states
from feeder_planner.throwing.sensor import read_trigger
from feeder_planner.throwing.throw_map import ThrowParams

# convex12 (mm in the file): g = -9660 mm/s^2, h = -0.3 mm, W = 320 deg/s, mu = 0.5 (issue 14), in SI.
CONVEX12_PARAMS = ThrowParams(offset=-0.0003, speed=math.radians(320), gravity=-9.66, mu=0.5)


def convex12():
    return arm_part(load_part(EXAMPLES / "convex12.yaml"))


def test_round_pattern_of_the_issue_sequence_alternates_two_pairs():
    # The issue's description of convex12's attractor: 3/2 alternating 16 or 17 times, then 0/6 four or
    # five times; the round repeats with those counts varying. One throw per visit here.
    rounds = [(16, 4), (17, 5), (16, 5), (17, 4), (16, 4), (17, 5)]
    visits = []
    for pairs, other in rounds:
        visits += [3, 2] * pairs + [0, 6] * other
    lengths = [1] * len(visits)
    cut = blocks(visits)
    assert [visits[a:b][:2] for a, b in cut[:4]] == [[3, 2], [0, 6], [3, 2], [0, 6]]
    keys, counts, throws, orders = round_pattern(visits, lengths)
    assert keys == [(2, 3), (0, 6)] and orders == [[3, 2], [0, 6]]
    # Rounds 2..5 are whole (the first and last blocks are dropped as cut by the window).
    assert [[dict(c) for c in r] for r in counts] == [[{3: p, 2: p}, {0: o, 6: o}] for p, o in rounds[1:-1]]
    assert throws == [2 * (p + o) for p, o in rounds[1:-1]]


def test_triangle_has_one_periodic_attractor_the_cycle_1_0_2():
    ls = limit_set(triangle(), TRIANGLE_PARAMS, goal_edge=1, starts_per_edge=6, sensing_height=0.001)
    assert ls.converged and ls.unique and len(ls.attractors) == 1
    (a,) = ls.attractors
    assert a.periodic and a.cycle == [1, 0, 2] and a.edges == [0, 1, 2] and a.basin == 1.0
    assert ls.cycle is not None and ls.cycle.edges == [1, 0, 2]
    lo, mean, hi = a.throws_per_round
    assert 8 <= lo <= mean <= hi <= 20 and ls.cycle.throws_per_cycle == mean
    assert a.pattern == [(1, 1, 1), (0, 1, 1), (2, 1, 1)]
    assert ls.trigger is not None and ls.trigger_note is None
    # Each start stopped once it recurred: far fewer throws than the cap.
    assert ls.throws_used < ls.throws
    out = ls.to_json()["attractors"][0]
    assert set(out) >= {
        "edges",
        "edge_radius_ranges",
        "periodic",
        "cycle",
        "pattern",
        "throws_per_round",
        "basin",
        "longest_transient",
        "assumption_violations",
    }
    assert set(out["assumption_violations"]) == {"lift_off", "slip", "off_arm"}


def test_convex12_reaches_one_common_quasi_periodic_attractor():
    part = convex12()
    assert part.n == 12
    ls = limit_set(part, CONVEX12_PARAMS, goal_edge=3, starts_per_edge=4)
    assert ls.converged and ls.unique and len(ls.attractors) == 1
    (a,) = ls.attractors
    assert a.edges == [3, 5, 9] and a.basin == 1.0
    assert not a.periodic and a.cycle is None and ls.cycle is None  # never repeats exactly
    # Its round: edges 3 and 9 alternate a varying number of times, then one visit to edge 5.
    assert a.pattern is not None and [e for e, _, _ in a.pattern] == [3, 9, 5]
    (e3, lo3, hi3), (e9, lo9, hi9), (e5, lo5, hi5) = a.pattern
    assert lo3 < hi3 and lo9 < hi9 and (lo5, hi5) == (1, 1)
    lo, mean, hi = a.throws_per_round
    assert lo < mean < hi
    # Every start's state at the end of its transient is already inside the attractor's cells.
    assert 0 < a.longest_transient < ls.throws_used
    assert ls.trigger is None or ls.trigger_note is None


def test_too_few_throws_say_the_attractor_search_did_not_converge():
    with pytest.raises(SolverError) as info:
        limit_set(convex12(), CONVEX12_PARAMS, starts_per_edge=2, throws=12)
    assert "did not converge" in str(info.value) and "--throws" in str(info.value)


def test_a_range_the_recent_half_still_widens_is_growing_not_confirmed():
    # Issue 35: the mirror of the transient test. A tail whose recent half reaches well beyond its older
    # half's range (an orbit still spiralling out to its attractor) would read its range too narrow.
    rng = np.random.default_rng(0)
    n = 200
    edge = np.tile([0, 1], n // 2)
    width = np.full(2, 1e-4)
    steady = np.where(edge == 0, 0.10, 0.20) + 0.01 * rng.random(n)
    assert widening(edge, steady, width) == []
    growing = steady.copy()
    growing[n // 2 :][edge[n // 2 :] == 1] += np.linspace(0.0, 0.01, n // 4)  # edge 1 keeps reaching out
    assert widening(edge, growing, width) == [1]
    # One rare extreme in the recent half is sampling, not growth.
    rare = steady.copy()
    rare[-1] += 0.01
    assert widening(edge, rare, width) == []
    jog = np.zeros(n, dtype=bool)
    assert _confirm(edge, growing, jog, width) is None
    assert _confirm(edge, growing, jog, width, growth=False) is not None


def test_the_trigger_is_read_on_the_tails_and_more_and_never_wider():
    # Issue 35: the trigger range is read on each start's tail and on the older states of its stay that
    # may be visits (sensed <= tail); more states only shrink the goal visits' common cover and grow the
    # other edges' covers, so it lies inside the trigger read on the tails alone.
    part = triangle()
    ls = limit_set(part, TRIANGLE_PARAMS, goal_edge=1, starts_per_edge=6, keep_trajectories=True)
    t = ls.trajectories
    assert t is not None and t.sensed is not None and t.tail is not None
    assert (t.sensed <= t.tail).all() and (t.sensed >= 0).all()
    groups = [[sensed_states(t, b) for b in a.members] for a in ls.attractors]
    tails = [[tail_states(t, b) for b in a.members] for a in ls.attractors]
    height = ls.sensing_height
    assert read_trigger(part, 1, height, groups).trigger == ls.trigger
    lo, hi = ls.trigger
    tlo, thi = read_trigger(part, 1, height, tails).trigger
    assert tlo <= lo < hi <= thi
