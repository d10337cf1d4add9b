"""Transients kept out of attractors (issue 25): the rule's pieces, the long-transient example, regressions.

The regressions are designs found by a seeded search like ``truth_corpus``'s on which the former rule
(a start converged once its states recurred at the start grid's resolution, its last two windows the
tail) folded transient visits into the attractor, as in the issue's three designs.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from throwing_helpers import EXAMPLES
from truth_corpus import CorpusDesign, design_truth, long_runs

from feeder_planner.errors import SolverError
from feeder_planner.parts import load_part, make_part
from feeder_planner.throwing.attractors import (
    Rows,
    arrival,
    closure_gap,
    confirms,
    hole_start,
    iterate_to_attractor,
    settled,
    tail_start,
)
from feeder_planner.throwing.geometry import arm_part
from feeder_planner.throwing.limit_set import edge_bounds, limit_set, single_design_rows
from feeder_planner.throwing.sensor import reads
from feeder_planner.throwing.throw_map import ThrowBatch, ThrowParams
from feeder_planner.throwing.tolerances import HOLE_GAPS, TRIGGER_GAPS

MM = 0.001


def _tail(visits: list[tuple[int, int]]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return edge, radius, jog arrays of a stretch given as (edge, throws on it) visits, R = 0.1 + edge."""
    edge, jog = [], []
    for e, n in visits:
        edge += [e] * n
        jog += [False] + [True] * (n - 1)
    edge_a = np.array(edge)
    return edge_a, 0.1 + 0.01 * edge_a, np.array(jog)


WIDTH = np.full(6, 1e-3)


def test_a_tail_whose_older_half_still_visits_a_transient_edge_does_not_confirm():
    edge, radius, jog = _tail([(0, 3), (2, 1), (4, 2)] * 20)
    assert confirms(edge, radius, jog, WIDTH)
    older = [(1, 2), (0, 3), (2, 1), (4, 2)] * 10  # edge 1 only in the older half: a transient
    edge, radius, jog = _tail(older + [(0, 3), (2, 1), (4, 2)] * 10)
    assert not confirms(edge, radius, jog, WIDTH)


def test_a_tail_of_jogs_alone_is_a_transit_not_an_attractor():
    edge, radius, jog = _tail([(3, 80)])
    assert not confirms(edge, np.linspace(0.1, 0.2, 80), jog, WIDTH)


def test_a_run_must_keep_to_its_tail_twice_as_long_as_it_ever_did_before_leaving_it():
    # 60 throws of the cycle, an excursion to edge 5, then the cycle again: a stay of 60 ended by an
    # excursion says a tail of the cycle alone may be a stretch of an attractor that visits edge 5.
    before = [(0, 3), (2, 1), (4, 2)] * 10 + [(5, 1)]
    for again, ok in ((15, False), (25, True)):
        edge, radius, jog = _tail(before + [(0, 3), (2, 1), (4, 2)] * again)
        first = len(edge) - 6 * again // 2
        assert (settled(edge, radius, jog, first, WIDTH) >= 0) == ok
    edge, radius, jog = _tail(before + [(0, 3), (2, 1), (4, 2)] * 25)
    assert settled(edge, radius, jog, len(edge) - 60, WIDTH) == 61  # the stay begins after edge 5


def test_the_closure_gap_leaves_out_the_holes_between_a_samples_intervals():
    # One interval filled by a rotation: no hole, the mean gap is span / states.
    rotation = np.sort(0.1 + 0.01 * ((np.arange(200) * (math.sqrt(5) - 1) / 2) % 1.0))
    span = float(rotation[-1] - rotation[0])
    assert closure_gap(rotation) == pytest.approx(span / 200, rel=1e-12)
    # Two bands 1 mm wide, 10 mm apart (design 31.0's flips onto edge 0): the 9 mm hole is no gap.
    bands = np.sort(np.concatenate([rotation[::2] * 0.1, rotation[1::2] * 0.1 + 0.01]))
    filled = float(bands[99] - bands[0]) + float(bands[-1] - bands[100])
    assert closure_gap(bands) == pytest.approx(filled / 200, rel=1e-9)
    assert closure_gap(bands) < 0.2 * float(bands[-1] - bands[0]) / 200  # span / states counts the hole
    # A periodic orbit's points: no closure to speak of, once a hole spans more than HOLE_GAPS mean gaps.
    assert closure_gap(np.repeat([0.1, 0.2], 20)) == 0.0
    assert closure_gap(np.repeat([0.1, 0.2], 2)) == pytest.approx(0.025)  # 4 states: the gap is no hole
    assert closure_gap(np.array([0.1])) == 0.0 and closure_gap(np.array([])) == 0.0


def test_an_approach_between_the_attractors_bands_is_cut_where_it_leaves_the_hole():
    # Issue 35, design 31.0's shape: the attractor visits edge 0 in two bands, [0.100, 0.101] and
    # [0.110, 0.111]; a start's stay first drifts through the hole between them, inside the edge's range
    # (so no range test sees it), then alternates between the bands.
    rng = np.random.default_rng(1)
    recent = np.where(np.arange(400) % 2 == 0, 0.100, 0.110) + 0.001 * rng.random(400)
    reference = {0: np.sort(recent)}
    far = HOLE_GAPS * closure_gap(reference[0])
    approach = np.linspace(0.106, 0.101 + 1.5 * far, 12)
    visits = np.where(np.arange(30) % 2 == 0, 0.100, 0.110) + 0.001 * rng.random(30)
    radius = np.concatenate([approach, visits, recent])
    edge = np.zeros(radius.size, dtype=int)
    first = approach.size + visits.size
    assert hole_start(edge, radius, 0, first, reference) == approach.size
    # Within HOLE_GAPS closure gaps of a band is a visit; a stay that never enters a hole is kept whole.
    near = radius.copy()
    near[approach.size - 1] = 0.101 + 0.5 * far
    assert hole_start(edge, near, 0, first, reference) == approach.size - 1
    assert hole_start(edge, radius, approach.size, first, reference) == approach.size
    # Beyond the sampled range is tail_start's to judge, not a hole.
    beyond = radius.copy()
    beyond[:12] = 0.12
    assert hole_start(edge, beyond, 0, first, reference) == 0


def test_the_triggers_states_begin_where_the_run_arrives_and_keep_its_later_excursions():
    # Issue 35, design 44.2's shape: edge 1's visits fill [0.100, 0.101]; a start approaches from 0.110
    # down, arrives, and later makes a rare excursion 0.0015 below (46 mean gaps in the design): the
    # approach is not read, the excursion is (a trigger read without it could reach beyond the truth).
    rng = np.random.default_rng(2)
    recent = 0.100 + 0.001 * rng.random(300)
    reference = {1: np.sort(recent)}
    approach = np.linspace(0.110, 0.1035, 8)
    inside = 0.100 + 0.001 * rng.random(40)
    stay = np.concatenate([approach, inside[:20], [0.0985], inside[20:], recent])
    edge = np.ones(stay.size, dtype=int)
    first = stay.size - recent.size
    assert arrival(edge, stay, 0, first, reference) == approach.size
    # tail_start at the same gaps takes the excursion for the approach: everything before it is cut.
    assert tail_start(edge, stay, 0, first, reference, TRIGGER_GAPS) == approach.size + 21
    # A run that never comes close within the stay keeps only what follows it.
    assert arrival(edge, np.full(stay.size, 0.2), 0, first, reference) == first


def test_a_start_that_never_confirms_is_unconverged_and_in_no_attractor():
    # Two starts replayed: one settles in the cycle [0, 4, 2], one jogs out along edge 1 forever.
    cycle = _tail([(0, 3), (2, 1), (4, 2)] * 100)[0]
    done = np.zeros(2, dtype=int)

    def throw(idx: np.ndarray, e: np.ndarray, r: np.ndarray) -> ThrowBatch:
        done[idx] += 1
        nxt = np.where(idx == 0, cycle[done[idx]], 1)
        radius = np.where(idx == 0, 0.1 + 0.01 * nxt, 0.1 + 1e-3 * done[idx])
        zero = np.zeros(len(idx))
        return ThrowBatch(nxt, radius, np.where(nxt == e, 0.0, 4.0), zero, zero)

    rows = Rows(np.array([0, 1]), np.array([0.1, 0.1]), np.zeros((2, 6)), np.full((2, 6), 1e-6))
    search = iterate_to_attractor(rows, throw, 400, window=40)
    assert search.converged.tolist() == [True, False]
    assert search.end[0] < 400 and search.end[1] == 400


def _example(name: str) -> tuple[object, str]:
    path = EXAMPLES / f"{name}.yaml"
    return arm_part(load_part(path)), path.read_text()


TRANSIENT5 = ThrowParams(offset=-0.82 * MM, speed=math.radians(106), gravity=-2.2, mu=0.41)


def test_the_long_transient_example_reaches_the_cycle_its_file_states():
    part, text = _example("transient5")
    stated = [int(e) for e in re.search(r"the cycle \[([0-9, ]+)\]", text).group(1).split(",")]
    ls = limit_set(part, TRANSIENT5, goal_edge=2)
    assert ls.converged and ls.unique
    (a,) = ls.attractors
    assert a.periodic and a.cycle == stated == [2, 0, 4] and a.edges == [0, 2, 4]
    assert 17 <= a.throws_per_round[0] and a.throws_per_round[2] <= 19
    # Some starts take hundreds of throws to lock in, and those throws are not in the attractor.
    assert a.longest_transient > 500 and a.median_transient < a.longest_transient
    lo, hi = ls.trigger
    assert abs(lo - 480.2 * MM) < 0.5 * MM and abs(hi - 496.2 * MM) < 0.5 * MM


def test_the_long_transient_example_agrees_with_its_long_run():
    # The first design: a five-edge part whose transient (here up to ~540 throws of the long
    # run) was folded into one quasi-periodic attractor on edges 0, 1, 2, 4 by the former rule.
    part, _ = _example("transient5")
    rows = single_design_rows(part, edge_bounds(part, TRANSIENT5), 2)
    runs = long_runs([CorpusDesign(0, 0, part, TRANSIENT5, True)], [(rows.edge, rows.radius)], 1500)[0]
    truths, why = design_truth(runs, part.radius)
    assert why == ""
    assert {(t.edges, t.cycle) for t in truths} == {((0, 2, 4), (0, 4, 2))}
    assert max(t.transient for t in truths) > 100  # and some start is long on the way


# The second design: a wedge whose trigger range for goal edge 0 came out null under the former
# rule (its tail held the radii of the approach). Issue 35: the range is [147.36, 157.72] mm on the last
# halves of 19 long runs of 4,000 throws from the grid's starts; limit-set read about 6 mm of it while the
# approach's first landings were in the tails (a blocking edge's range reached into it), [147.33, 157.72]
# since the trigger is read on the tails and the older states of their stays that may be visits.
WEDGE = [[1.29, 21.05], [-19.44, -10.49], [8.58, -17.46], [11.14, -16.61], [17.03, -14.01]]
WEDGE_PARAMS = ThrowParams(offset=-1.128 * MM, speed=math.radians(277.7), gravity=-9.66, mu=0.613)


def test_the_wedges_trigger_range_is_read_on_its_attractor_only():
    part = arm_part(make_part(WEDGE, unit_scale=MM))
    ls = limit_set(part, WEDGE_PARAMS, goal_edge=0, sensing_height=None)
    (a,) = ls.attractors
    assert ls.unique and a.cycle == [0, 4, 1] and a.edges == [0, 1, 4]
    assert ls.trigger is not None and ls.trigger_note is None
    lo, hi = ls.trigger
    assert 10 * MM < hi - lo < 10.8 * MM and abs(hi - 157.72 * MM) < 0.1 * MM
    # A sensor in the middle of the range, on the long run's last half: true at rest at least once per
    # cycle, and only on edge 0.
    rows = single_design_rows(part, edge_bounds(part, WEDGE_PARAMS), 1)
    runs = long_runs([CorpusDesign(0, 0, part, WEDGE_PARAMS, True)], [(rows.edge, rows.radius)], 800)[0]
    height = 0.01 * part.radius
    for run in runs:
        e, r = run.edge[400:], run.radius[400:]
        seen = np.array(
            [reads(part, int(x), float(y), 0.5 * (lo + hi), height) for x, y in zip(e, r, strict=True)]
        )
        assert not seen[e != 0].any()
        assert np.diff(np.flatnonzero(seen)).max() <= a.throws_per_round[2]


def test_no_trigger_names_the_attractor_and_edge_that_rule_it_out():
    part, _ = _example("transient5")
    ls = limit_set(part, TRANSIENT5, goal_edge=4, starts_per_edge=4)
    assert ls.trigger is None
    assert "edge 2 of attractor 0 (edges [0, 2, 4])" in ls.trigger_note


def test_no_start_confirming_is_the_raise_throws_error():
    part, _ = _example("transient5")
    with pytest.raises(SolverError) as info:
        limit_set(part, TRANSIENT5, starts_per_edge=2, throws=60)
    assert "did not converge" in str(info.value) and "raise --throws" in str(info.value)
