"""Flight (eqs. 5, 6), the certified earliest impact, and the sticking impact (eqs. 7-9)."""

import math

import numpy as np
import pytest
from throwing_helpers import TRIANGLE_PARAMS, bracket, rectangle, regular, triangle

from feeder_planner.throwing.flight import earliest_impact, flight_state, vertex_positions
from feeder_planner.throwing.impact import kinetic_energy, sticking_impact


def test_flight_conserves_energy_and_matches_its_derivatives():
    part, p = triangle(), TRIANGLE_PARAMS
    t = np.linspace(0, 0.5, 2001)
    s = flight_state(part, 1, 0.15, p.offset, p.speed, p.gravity, t)
    energy = 0.5 * (s[:, 3] ** 2 + s[:, 4] ** 2 + part.rho**2 * s[:, 5] ** 2) - p.gravity * s[:, 1]
    assert np.ptp(energy) <= 1e-12 * abs(energy).max()
    dt = t[1] - t[0]
    for pos, vel in ((0, 3), (1, 4), (2, 5)):
        assert np.allclose(np.gradient(s[:, pos], dt)[1:-1], s[1:-1, vel], atol=1e-9)


def _brute_first_contact(part, edge, radius, offset, speed, gravity, t_hit, samples=40001):
    """Independent check: sample every vertex height densely up to t_hit."""
    t = np.linspace(0, t_hit, samples)[1:-1]
    lowest = np.array(
        [vertex_positions(part, edge, radius, offset, speed, gravity, tt)[:, 1].min() for tt in t]
    )
    return lowest.min() - offset


@pytest.mark.parametrize(
    "make,edge,radius,speed,gravity",
    [
        (triangle, 1, 0.15, math.radians(320), -9.66),
        (triangle, 0, 0.25, 12.0, -9.66),  # several turns in flight
        (bracket, 0, 0.03, 50.0, -2.2),  # fast spin: f has many inflections
        (lambda: regular(7), 2, 0.3, 30.0, -9.81),
    ],
)
def test_earliest_impact_misses_no_root(make, edge, radius, speed, gravity):
    part = make()
    offset = -0.3 * part.d_min
    t_hit, k = earliest_impact(part, np.array([edge]), np.array([radius]), offset, speed, gravity)
    t_hit, k = float(t_hit[0]), int(k[0])
    verts = vertex_positions(part, edge, radius, offset, speed, gravity, t_hit)
    assert abs(verts[k, 1] - offset) < 1e-9 * part.radius  # vertex k is on the arm at t*
    assert verts[:, 1].min() >= offset - 1e-9 * part.radius
    # No vertex went below the arm earlier (dense sampling, independent of the piecewise method).
    assert _brute_first_contact(part, edge, radius, offset, speed, gravity, t_hit * (1 - 1e-6)) > -1e-12


def test_sticking_impact_stops_vertex_and_never_adds_energy():
    rng = np.random.default_rng(4)
    n = 5000
    rx, ry = rng.normal(size=n), rng.normal(size=n)
    vx, vy, w = rng.normal(size=n) * 3, rng.normal(size=n) * 3, rng.normal(size=n) * 5
    rho = 0.7
    xp, yp, wp = sticking_impact(rx, ry, vx, vy, w, rho)
    assert np.allclose(xp - ry * wp, 0) and np.allclose(yp + rx * wp, 0)  # eqs. (7), (8)
    assert np.allclose(rx * (yp - vy) - ry * (xp - vx), rho**2 * (wp - w))  # eq. (9)
    assert np.all(kinetic_energy(xp, yp, wp, rho) <= kinetic_energy(vx, vy, w, rho) * (1 + 1e-12))


def test_sweet_spot_catch_exists_where_momentum_about_vertex_is_zero():
    rho, rx, ry = 0.5, -0.3, -0.2
    vx, vy = 1.0, 2.0
    w = -(ry * vx - rx * vy) / rho**2
    assert (
        abs(
            sticking_impact(
                np.array([rx]), np.array([ry]), np.array([vx]), np.array([vy]), np.array([w]), rho
            )[2][0]
        )
        < 1e-15
    )


def test_thin_part_flight_impact():
    part = rectangle(1.0, 0.001)
    t_hit, k = earliest_impact(part, np.array([0]), np.array([0.6]), -0.0002, 0.5, -9.81)
    assert np.isfinite(t_hit[0]) and k[0] >= 0
