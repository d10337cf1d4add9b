"""Named steps of the analytic model: release kinematics, impact pieces, rolling, domain, turns, JSON."""

import math

import numpy as np
import pytest
from throwing_helpers import BRACKET_PARAMS, TRIANGLE_PARAMS, bracket, regular, triangle

from feeder_planner.errors import InputError
from feeder_planner.throwing import (
    BelowGraspError,
    ThrowBatch,
    check_sensing_height,
    flight_state,
    grasp_radius,
    limit_set,
    rest_pose,
    search,
    sensing_height_or_default,
    throw,
    throw_kind,
    whole_turns,
)
from feeder_planner.throwing.flight import _flight_end, _height, _piece_minima, _pieces
from feeder_planner.throwing.limit_set import Cycle, _common_cycle, _grid_starts, default_burn_in, edge_bounds
from feeder_planner.throwing.rolling import _Geometry, _settled, _strike, _swing
from feeder_planner.throwing.rolling import _height as _cm_height
from feeder_planner.throwing.throw_map import ThrowParams, radius_in_domain
from feeder_planner.throwing.tolerances import GRASP_SLACK, SENSING_HEIGHT_FRACTION


def test_rest_pose_is_the_flight_at_release_and_the_flight_broadcasts_over_a_batch():
    part, p = triangle(), TRIANGLE_PARAMS
    edges, radii = np.array([0, 1, 2, 1]), np.array([0.1, 0.12, 0.15, 0.2])
    times = np.array([0.0, 0.01, 0.05, 0.1])
    batch = flight_state(part, edges, radii, p.offset, p.speed, p.gravity, times)
    for b in range(len(edges)):
        one = flight_state(
            part, int(edges[b]), float(radii[b]), p.offset, p.speed, p.gravity, times[b : b + 1]
        )
        assert np.array_equal(batch[b], one[0])
        x, y, theta = rest_pose(part, int(edges[b]), float(radii[b]), p.offset)
        at_release = flight_state(
            part, int(edges[b]), float(radii[b]), p.offset, p.speed, p.gravity, np.zeros(1)
        )[0]
        assert (at_release[0], at_release[1], at_release[2]) == (x, y, theta)
        # The centre of mass rests d^i above the arm surface y = h, edge i flat (eq. 5 at t = 0).
        assert y == pytest.approx(p.offset + part.d[edges[b]], abs=1e-15)
        assert math.isclose(math.cos(theta + part.edge_angle[edges[b]]), 1.0, abs_tol=1e-15)


def _impact_inputs(part, edge, radius, p):
    w, g = p.speed, p.gravity
    edge, radius = np.array([edge]), np.array([radius])
    d = part.d[edge][:, None]
    b = (radius * w)[:, None]
    s = np.hypot(part.hull[:, 0], part.hull[:, 1])[None, :]
    c = np.arctan2(part.hull[:, 1], part.hull[:, 0])[None, :] - part.edge_angle[edge][:, None]
    return d, b, s, c, w, g


@pytest.mark.parametrize(
    "make,edge,radius,speed,gravity",
    [
        (triangle, 1, 0.15, math.radians(320), -9.66),
        (bracket, 0, 0.03, 50.0, -2.2),
        (lambda: regular(7), 2, 0.3, 30.0, -9.81),
    ],
)
def test_flight_pieces_are_convex_or_concave_and_minima_found_on_convex_ones(
    make, edge, radius, speed, gravity
):
    part = make()
    p = ThrowParams(-0.3 * part.d_min, speed, gravity, 0.5)
    d, b, s, c, w, g = _impact_inputs(part, edge, radius, p)
    t_end = _flight_end(d, b, g)
    assert (
        abs(float(d[0, 0] + b[0, 0] * t_end[0, 0] + 0.5 * g * t_end[0, 0] ** 2)) < 1e-12
    )  # CM back at arm level
    pieces = _pieces(d, b, s, c, w, g, t_end)
    assert pieces.lo.size and np.all(pieces.hi > pieces.lo) and np.all(pieces.hi <= t_end[0, 0])
    minima = _piece_minima(pieces, g)
    for j in range(pieces.lo.size):
        t = np.linspace(pieces.lo[j], pieces.hi[j], 401)[1:-1]
        curvature = g - w * w * pieces.s[j] * np.sin(w * t + pieces.c[j])
        convex = bool(np.all(curvature > -1e-9))
        assert convex or np.all(curvature < 1e-9)  # one sign inside the piece
        if not convex:
            assert minima[j] == pieces.hi[j]
            continue
        f = _height(t, pieces.d[j], pieces.b[j], pieces.s[j], pieces.c[j], w, g)
        f_min = _height(minima[j], pieces.d[j], pieces.b[j], pieces.s[j], pieces.c[j], w, g)
        assert pieces.lo[j] <= minima[j] <= pieces.hi[j]
        assert f_min <= f.min() + 1e-12


def _rolling_states(part, count, seed):
    rng = np.random.default_rng(seed)
    geo = _Geometry(part)
    k = rng.integers(0, part.n, count)
    theta = -part.edge_angle[k] + rng.uniform(0.05, 0.95, count) * part.exterior[k]  # inside k's interval
    omega = rng.normal(0.0, 20.0, count)
    lo = theta - (theta + part.edge_angle[k])
    hi = lo + part.exterior[k]
    return geo, k, theta, omega, lo, hi


def test_swing_conserves_energy_about_its_pivot():
    part, g = triangle(), -9.66
    geo, k, theta, omega, lo, hi = _rolling_states(part, 2000, 3)
    direction = np.where(omega >= 0, 1.0, -1.0)
    direction, target, h_target, om_end = _swing(geo, g, k, theta, omega, direction, lo, hi)
    assert np.all((target == lo) | (target == hi))
    inertia = geo.inertia[k]
    before = 0.5 * inertia * omega**2 - g * _cm_height(geo, k, theta)
    after = 0.5 * inertia * om_end**2 - g * h_target
    moving = om_end != 0
    assert moving.mean() > 0.5
    assert np.allclose(after[moving], before[moving], rtol=1e-12, atol=1e-12)
    assert np.all(after <= before + 1e-12)  # a swing that cannot reach an end only loses its speed
    assert np.all(np.sign(om_end[moving]) == direction[moving])


def test_strike_conserves_angular_momentum_about_the_struck_vertex():
    part = bracket()
    geo, k, theta, omega, lo, hi = _rolling_states(part, 2000, 5)
    direction = np.where(omega >= 0, 1.0, -1.0)
    target = np.where(direction > 0, hi, lo)
    h_target = _cm_height(geo, k, target)
    j, e, cm_x, om_new, j_x = _strike(geo, k, direction, target, h_target, omega, np.zeros(len(k)))
    assert np.all(j == np.where(direction > 0, (k - 1) % part.n, (k + 1) % part.n))
    c, s = np.cos(target), np.sin(target)
    r_k = np.stack([c * geo.qx[k] - s * geo.qy[k], s * geo.qx[k] + c * geo.qy[k]])  # CM -> pivot k
    r_j = np.stack([c * geo.qx[j] - s * geo.qy[j], s * geo.qx[j] + c * geo.qy[j]])  # CM -> struck vertex j
    assert np.allclose(j_x - cm_x, r_j[0]) and np.allclose(cm_x, -r_k[0])
    v = omega * np.stack([r_k[1], -r_k[0]])  # rolling about k: v_cm = omega x (cm - k)
    momentum_before = geo.rho**2 * omega + (-r_j[0]) * v[1] - (-r_j[1]) * v[0]
    momentum_after = (geo.rho**2 + geo.s2[j]) * om_new
    stuck = om_new == 0  # the other vertex of the flat edge would go into the arm: both stick
    assert (~stuck).any()
    assert np.allclose(momentum_after[~stuck], momentum_before[~stuck], rtol=1e-12, atol=1e-12)  # eq. (9)


def test_settled_only_at_rest_on_a_stable_edge():
    part, g = bracket(), -2.2
    geo = _Geometry(part)
    for e in range(part.n):
        # Flat on edge e at rest: pivot e swung clockwise to the low end of its interval, vertex e + 1 struck.
        k, j = np.array([e]), np.array([(e + 1) % part.n])
        target = np.array([-part.edge_angle[e]])
        h_target = _cm_height(geo, k, target)
        lo, hi = target, target + part.exterior[k]
        direction = np.array([-1.0])
        at_rest = _settled(geo, g, k, j, np.array([e]), direction, target, h_target, lo, hi, np.zeros(1))
        spinning = _settled(geo, g, k, j, np.array([e]), direction, target, h_target, lo, hi, np.full(1, 1e3))
        assert bool(at_rest[0]) == bool(part.stable[e])
        assert not spinning[0]


def test_domain_check_accepts_r_grasp_exactly_and_names_the_unit():
    part, p = bracket(), BRACKET_PARAMS
    r = grasp_radius(part, 1, p.offset, p.mu)
    assert radius_in_domain(r, r) and radius_in_domain(r * (1 - 0.5 * GRASP_SLACK), r)
    assert not radius_in_domain(r * (1 - 2 * GRASP_SLACK), r)
    assert list(radius_in_domain(np.array([r, 0.9 * r]), np.array([r, r]))) == [True, False]
    throw(part, 1, r, p)
    with pytest.raises(BelowGraspError) as info:
        throw(part, 1, r * (1 - 1e-9), p)
    assert info.value.field == "radius" and info.value.r_grasp == r and info.value.edge == 1
    in_cm = info.value.in_unit(0.01, "cm")
    assert in_cm.field == "radius" and f"R_grasp = {r / 0.01:.6g} cm" in in_cm.problem


@pytest.mark.parametrize("k", [-3, -1, 1, 2])
def test_whole_turns_count_a_rotation_a_hair_short_of_k_turns_as_k(k):
    full = 2 * math.pi * k
    assert whole_turns(full) == k
    assert whole_turns(full - math.copysign(1e-12, k)) == k  # rounding short of a whole turn
    assert whole_turns(full + math.copysign(1e-12, k)) == k
    assert whole_turns(full - math.copysign(1e-3, k)) == k - math.copysign(1, k)  # really short of it
    assert whole_turns(0.5 * math.pi * math.copysign(1, k)) == 0


def test_throw_kind_is_jog_only_on_the_same_edge_without_a_turn():
    assert throw_kind(1, 1, 0.3) == "jog" and throw_kind(1, 1, -3.0) == "jog"
    assert throw_kind(1, 1, 2 * math.pi) == "flip"  # a whole turn back onto the start edge
    assert throw_kind(1, 0, 0.1) == "flip"
    batch = ThrowBatch(
        edge=np.array([1, 1, 0]),
        radius=np.zeros(3),
        rotation=np.array([0.2, 6.3, 0.2]),
        flight_time=np.zeros(3),
        impacts=np.zeros(3, dtype=int),
    )
    assert list(batch.is_jog(np.array([1, 1, 1]))) == [True, False, False]
    assert list(batch.turns) == [0, 1, 0]


def test_sensing_height_default_and_check_name_the_field():
    part = triangle()
    assert sensing_height_or_default(part, None) == SENSING_HEIGHT_FRACTION * part.radius
    assert sensing_height_or_default(part, 0.0) == 0.0
    for bad in (-1e-3, math.nan, math.inf):
        with pytest.raises(InputError) as info:
            check_sensing_height(bad)
        assert info.value.field == "sensing_height"
    with pytest.raises(InputError) as info:
        search(part, 1, np.array([-0.005]), np.array([5.0]), -9.66, 0.5, sensing_height=-0.001)
    assert info.value.field == "sensing_height"  # refused up front, not hidden in every row's note


def test_grid_starts_are_cell_centres_and_burn_in_is_capped():
    part, p = triangle(), TRIANGLE_PARAMS
    bounds = edge_bounds(part, p, points=60)
    edges, radii = _grid_starts(part, bounds, 4)
    assert edges == [e for e in part.stable_edges for _ in range(4)]
    for e, r in zip(edges, radii, strict=True):
        assert bounds.low[e] < r < bounds.max[e]
    assert default_burn_in(30) == 10 and default_burn_in(300) == 100 and default_burn_in(3000) == 100


def test_common_cycle_needs_every_start_on_the_same_cycle():
    a, b = Cycle([1, 0, 2], 13.0, (12, 14)), Cycle([1, 0, 2], 14.0, (13, 15))
    common = _common_cycle([a, b])
    assert common == Cycle([1, 0, 2], 13.5, (12, 15))
    assert _common_cycle([a, Cycle([0, 2], 9.0, (9, 9))]) is None
    assert _common_cycle([a, None]) is None


def test_results_give_the_contract_json_objects():
    part, p = triangle(), TRIANGLE_PARAMS
    result = throw(part, 1, 0.12, p).to_json()
    assert (
        {"edge", "radius", "kind"} <= set(result)
        and result["start_edge"] == 1
        and result["start_radius"] == 0.12
    )
    ls = limit_set(part, p, goal_edge=1, starts_per_edge=4, throws=120, sensing_height=0.001).to_json()
    assert list(ls) == [
        "stable_edges",
        "grasp_radius",
        "flip_radius",
        "max_radius",
        "invariant",
        "cycle",
        "unique",
        "edge_radius_ranges",
        "trigger",
        "starts",
        "throws",
        "attractors",
        "converged",
        "unconverged_starts",
        "trigger_note",
        "throws_used",
    ]
    assert set(ls["grasp_radius"]) == {str(i) for i in ls["stable_edges"]}
    assert ls["trigger"] is None or (
        ls["trigger"]["goal_edge"] == 1 and ls["trigger"]["sensing_height"] == 0.001
    )
    assert ls["cycle"] is None or set(ls["cycle"]) == {"edges", "throws_per_cycle", "throws_range"}
