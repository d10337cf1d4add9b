"""Propositions IV.1 and IV.4, Theorem IV.6 (Figs. 7, 8) and the sensor trigger range."""

import numpy as np
import pytest
from throwing_helpers import BRACKET_PARAMS, TRIANGLE_PARAMS, bracket, triangle

from feeder_planner.throwing.limit_set import edge_bounds, iterate, limit_set
from feeder_planner.throwing.sensor import reads
from feeder_planner.throwing.throw_map import ThrowParams, lowest_radius, throw_batch


def test_proposition_iv1_no_stable_jog_fixed_point_when_all_edges_stable():
    part = triangle()
    assert part.stable.all()
    found = 0
    for offset in (0.002, 0.005, 0.01, 0.02):
        for speed in (2.0, 4.0, 6.0):
            p = ThrowParams(offset=offset, speed=speed, gravity=-9.66, mu=0.5)
            for i in part.stable_edges:
                r = np.linspace(lowest_radius(part, i, p) + 1e-4, 0.5, 3000)
                out = throw_batch(part, np.full(r.size, i), r, p)
                jog = out.is_jog(np.full(r.size, i))
                gap = out.radius - r
                for a in np.flatnonzero(jog[:-1] & jog[1:] & (np.sign(gap[:-1]) != np.sign(gap[1:]))):
                    found += 1
                    # Fixed point of a jog: R1 - R crosses zero upward, so deviations grow (unstable).
                    assert gap[a] < 0 < gap[a + 1], (offset, speed, i, r[a])
    assert found > 0  # the sweep does contain jog fixed points


@pytest.mark.parametrize("make,params", [(triangle, TRIANGLE_PARAMS), (bracket, BRACKET_PARAMS)])
def test_proposition_iv4_small_throws_jog_out_large_throws_move_in(make, params):
    part = make()
    assert -part.d_min < params.offset < 0
    b = edge_bounds(part, params)
    assert b.invariant
    for i in part.stable_edges:
        assert b.grasp[i] <= b.low[i] <= b.flip[i] <= b.max[i]
        if make is triangle:
            assert b.flip[i] > b.low[i]  # every triangle edge has a jog range
        if b.flip[i] > b.low[i]:
            r = np.linspace(b.low[i], b.flip[i], 200, endpoint=False)[1:]
            out = throw_batch(part, np.full(r.size, i), r, params)
            assert out.is_jog(np.full(r.size, i)).all() and np.all(out.radius > r)  # property 1
        # Sufficiently large R: the leftward flight drift 2 W^2 R (d + h) / |g| exceeds any rolling distance.
        big = np.geomspace(20 * b.max[i], 200 * b.max[i], 100)
        out = throw_batch(part, np.full(big.size, i), big, params)
        assert np.all(out.radius < big)  # negative feedback on R


@pytest.mark.parametrize("make,params", [(triangle, TRIANGLE_PARAMS), (bracket, BRACKET_PARAMS)])
def test_theorem_iv6_every_start_reaches_the_same_cycle(make, params):
    part = make()
    ls = limit_set(part, params, starts_per_edge=25)  # throws: the default cap, starts stop on recurrence
    assert ls.unique and ls.cycle is not None
    assert all(c == ls.cycle.edges for c in ls.cycles_by_start)
    assert len(ls.cycle.edges) >= 2 and all(part.stable[e] for e in ls.cycle.edges)
    assert ls.cycle.throws_range[0] >= len(ls.cycle.edges)
    if make is triangle:
        # The paper's triangle cycles in about 13 throws (Fig. 5); ours, a triangle of similar size, alike.
        assert 8 <= ls.cycle.throws_per_cycle <= 20


def test_sensor_in_trigger_range_reads_only_on_goal_edge_and_every_cycle():
    part, p = triangle(), TRIANGLE_PARAMS
    height = 0.002
    ls = limit_set(part, p, goal_edge=1, sensing_height=height)
    assert ls.trigger is not None
    lo, hi = ls.trigger
    rng = np.random.default_rng(7)
    starts = rng.uniform(0.1, 0.2, 20)
    traj = iterate(part, p, np.full(20, 1), starts, 400)
    for sensor in (lo + 0.1 * (hi - lo), 0.5 * (lo + hi), hi - 0.1 * (hi - lo)):
        for row in range(20):
            e, r = traj.edge[row, 150:], traj.radius[row, 150:]
            seen = np.array(
                [reads(part, int(ei), float(ri), sensor, height) for ei, ri in zip(e, r, strict=True)]
            )
            assert not seen[e != 1].any()
            # At least once in every cycle: gaps between readings shorter than the longest cycle.
            hits = np.flatnonzero(seen)
            assert (
                hits.size
                and np.diff(np.concatenate([[0], hits, [len(e) - 1]])).max() <= ls.cycle.throws_range[1] + 1
            )
