"""The paper model's assumptions checked per throw (issue 14 item 2): lift_off, slip, off_arm, toe_stub."""

import math

import numpy as np
from throwing_helpers import TRIANGLE_PARAMS, triangle

from feeder_planner.throwing.limit_set import edge_bounds
from feeder_planner.throwing.rolling import lift_off_in_swing, outside_cone
from feeder_planner.throwing.throw_map import ThrowParams, throw, throw_batch
from feeder_sim.throwing.arm import ThrowingArm


def test_lift_off_bound_matches_newton_on_a_dense_swing():
    # Rolling about a fixed pivot: N = a_y - g with a_y = alpha c_x - omega^2 c_y, alpha = g c_x / I,
    # omega^2 from the energy. The closed form's minimum over [cy_lo, cy_hi] must agree in sign with a
    # dense evaluation of Newton's law along the swing.
    rng = np.random.default_rng(4)
    g, rho = -9.81, 0.012
    agree = 0
    for _ in range(300):
        s = rng.uniform(0.005, 0.03)
        inertia = rho * rho + s * s
        phi = np.linspace(*np.sort(rng.uniform(0.1, math.pi - 0.1, 2)), 400)  # c = s (cos, sin) phi
        cx, cy = s * np.cos(phi), s * np.sin(phi)
        omega0 = rng.uniform(0, 40)
        energy = 0.5 * inertia * omega0**2 - g * cy[0]
        omega2 = 2 * (energy + g * cy) / inertia
        ok = omega2 >= 0
        normal = g * cx * cx / inertia - omega2 * cy - g
        dense = bool((normal[ok] < 0).any())
        closed = bool(lift_off_in_swing(rho, g, np.array([energy]), cy[ok].min(), cy[ok].max())[0])
        assert dense == closed or abs(normal[ok].min()) < 1e-6
        agree += dense
    assert 0 < agree < 300  # the sample holds swings of both kinds


def test_friction_cone_and_flags_of_a_throw():
    assert not outside_cone(np.array(0.4), np.array(1.0), 0.5)
    assert outside_cone(np.array(0.6), np.array(1.0), 0.5)
    assert outside_cone(np.array(0.0), np.array(-1.0), 0.5)  # a pull is no catch
    part, p = triangle(), TRIANGLE_PARAMS
    b = edge_bounds(part, p)
    edges = np.repeat(part.stable_edges, 30)
    # Interior radii: at the lowest R the left vertex barely lifts and the catch is degenerate.
    radii = np.concatenate([np.linspace(b.low[i], b.max[i], 32)[1:-1] for i in part.stable_edges])
    out = throw_batch(part, edges, radii, p)
    assert out.flag("slip").any() and out.flag("lift_off").any()  # mu = 0.5: the paper's part breaks both
    sticky = throw_batch(part, edges, radii, ThrowParams(p.offset, p.speed, p.gravity, 1e9))
    # A huge mu holds every catch; what is left is a strike whose normal impulse would pull (J_n <= 0).
    assert sticky.flag("slip").sum() <= 0.1 * out.flag("slip").sum()
    np.testing.assert_array_equal(sticky.radius, out.radius)  # mu only judges, the sticking model ignores it
    assert not out.flag("off_arm").any() and not out.flag("toe_stub").any()
    short = throw_batch(part, edges, radii, ThrowParams(p.offset, p.speed, p.gravity, p.mu, arm_length=0.1))
    assert np.array_equal(short.flag("off_arm"), short.flag("off_arm") | (out.radius > 0.1))
    one = throw(part, 1, 0.12, p).to_json()
    assert {"lift_off", "slip", "off_arm", "toe_stub"} <= set(one)


def test_the_arm_loses_a_part_whose_catch_is_off_the_arm():
    part, p = triangle(), TRIANGLE_PARAMS
    r = 0.14
    res = throw(part, 1, r, p)  # a jog outward, to R = 0.152 m
    # An arm that ends between the start's and the landing's right vertex: the throw is a part lost.
    end = 0.5 * (r + res.radius) + float(part.u_right[1])
    assert r + float(part.u_right[1]) < end < res.radius + float(part.u_right[res.edge])
    arm = ThrowingArm(part, p, 1, r, "paper", end)
    out = arm.throw()
    assert out.kind == "fault" and out.lost and "off_arm" in out.flags and not arm.on_arm
    ok = ThrowingArm(part, p, 1, 0.12, "paper", 1.0).throw()
    assert ok.kind != "fault" and "off_arm" not in ok.flags
    assert set(ok.flags) == set(throw(part, 1, 0.12, p).violations)
