"""The throw map: jog/flip, turns, energy, domain checks and extremes (section III-C)."""

import math

import numpy as np
import pytest
from throwing_helpers import BRACKET_PARAMS, TRIANGLE_PARAMS, bracket, rectangle, regular, triangle

from feeder_planner.errors import InputError
from feeder_planner.throwing.grasp import grasp_radius
from feeder_planner.throwing.throw_map import ThrowParams, lowest_radius, throw, throw_batch


def _energy_at_rest(part, edge, params):
    return -params.gravity * (params.offset + part.d[edge])


def test_throw_never_gains_energy_and_lands_on_a_stable_edge():
    part, p = triangle(), TRIANGLE_PARAMS
    for i in part.stable_edges:
        r = np.linspace(lowest_radius(part, i, p) + 1e-4, 0.4, 200)
        out = throw_batch(part, np.full(r.size, i), r, p)
        assert part.stable[out.edge].all()
        release = 0.5 * p.speed**2 * (r**2 + (p.offset + part.d[i]) ** 2 + part.rho**2) + _energy_at_rest(
            part, i, p
        )
        rest = np.array([_energy_at_rest(part, e, p) for e in out.edge])
        assert np.all(rest <= release)


def test_jog_iff_same_edge_and_no_net_turn():
    part = regular(4)
    p = ThrowParams(offset=-0.002, speed=25.0, gravity=-9.81, mu=1.0)
    low = lowest_radius(part, 0, p)
    r = np.linspace(low + 1e-3, low + 0.6, 400)
    out = throw_batch(part, np.zeros(r.size, dtype=int), r, p)
    # A square that lands on its start edge after a whole turn is a flip, counted by whole turns.
    whole = (out.edge == 0) & (np.abs(out.rotation) > math.pi)
    assert whole.any()
    assert not out.is_jog(np.zeros(r.size, dtype=int))[whole].any()
    assert np.all(np.abs(out.turns[whole]) >= 1)
    remainder = out.rotation - 2 * math.pi * out.turns
    expected = np.mod(part.edge_angle[0] - part.edge_angle[out.edge], 2 * math.pi)
    gap = np.abs(np.mod(remainder - expected + math.pi, 2 * math.pi) - math.pi)
    assert np.all(gap < 1e-9)  # the net rotation is the one that puts the landing edge down


@pytest.mark.parametrize("speed", [1e-3, 0.1, 5.0, 50.0])
def test_release_speed_extremes(speed):
    part = triangle()
    p = ThrowParams(offset=-0.005, speed=speed, gravity=-9.66, mu=0.5)
    r = max(lowest_radius(part, 1, p), 0.0) + 0.05
    res = throw(part, 1, r, p)
    assert part.stable[res.edge] and math.isfinite(res.radius)
    if speed == 1e-3:
        assert res.kind == "jog" and abs(res.radius - r) < 1e-4


@pytest.mark.parametrize("fraction", [1e-9, 0.5, 1 - 1e-9])
def test_offset_near_zero_and_near_minus_d_min(fraction):
    part = triangle()
    p = ThrowParams(offset=-fraction * part.d_min, speed=math.radians(320), gravity=-9.66, mu=0.5)
    res = throw(part, 1, 0.12, p)
    assert part.stable[res.edge]


def test_radius_exactly_at_grasp_radius_and_below():
    part = bracket()
    p = BRACKET_PARAMS
    for i in part.stable_edges:
        r_grasp = grasp_radius(part, i, p.offset, p.mu)
        if r_grasp + part.u_left[i] > 0:
            throw(part, i, r_grasp, p)  # exactly at R_grasp: allowed
        with pytest.raises(InputError, match="radius"):
            throw(part, i, r_grasp - 1e-6, p)


def test_thin_part_and_many_vertices():
    thin = rectangle(0.1, 1e-4)
    p = ThrowParams(offset=-2e-5, speed=1.0, gravity=-9.81, mu=0.5)
    res = throw(thin, 0, 0.2, p)
    assert res.edge in (0, 2)
    many = regular(200, 0.01)
    assert many.n == 200
    p2 = ThrowParams(offset=-0.001, speed=3.0, gravity=-9.81, mu=0.5)
    res = throw(many, 0, lowest_radius(many, 0, p2) + 0.01, p2)
    assert many.stable[res.edge]
    tri = regular(3, 0.01)
    assert throw(tri, 0, lowest_radius(tri, 0, p2) + 0.05, p2).edge in (0, 1, 2)


def test_several_turns_in_flight():
    part = triangle()
    p = ThrowParams(offset=-0.005, speed=40.0, gravity=-9.66, mu=0.5)
    res = throw(part, 1, 0.3, p)
    assert res.flight_time * p.speed > 4 * math.pi  # two turns or more in the air
    assert abs(res.turns) >= 2 and res.kind == "flip"


def test_bad_parameters_name_the_field():
    for kwargs, field in (
        ({"gravity": 0.0}, "gravity"),
        ({"gravity": 1.0}, "gravity"),
        ({"speed": 0.0}, "release_speed"),
        ({"speed": -1.0}, "release_speed"),
        ({"mu": 0.0}, "mu"),
        ({"offset": float("nan")}, "offset"),
    ):
        base = {"offset": -0.005, "speed": 1.0, "gravity": -9.66, "mu": 0.5}
        base.update(kwargs)
        with pytest.raises(InputError) as info:
            ThrowParams(**base)
        assert info.value.field == field
