"""The simulated arm: analytic fidelity is the throw map, dynamic (pymunk) agrees with it, faults reported."""

import math

import numpy as np
import pytest
from throwing_helpers import BRACKET_PARAMS, TRIANGLE_PARAMS, bracket, regular, triangle

from feeder_planner.errors import InputError
from feeder_planner.throwing.flight import rest_pose
from feeder_planner.throwing.limit_set import iterate
from feeder_planner.throwing.throw_map import ThrowBatch, ThrowParams, lowest_radius, throw_batch
from feeder_sim.throwing.arm import ThrowingArm
from feeder_sim.throwing.dynamic import dynamic_throw, rest_outcome


def test_analytic_arm_follows_the_throw_map():
    part, p = triangle(), TRIANGLE_PARAMS
    arm = ThrowingArm(part, p, 1, 0.12)
    got = [(arm.throw(), arm.edge, arm.radius)[1:] for _ in range(40)]
    ref = iterate(part, p, np.array([1]), np.array([0.12]), 40)
    assert [e for e, _ in got] == list(ref.edge[0, 1:])
    assert np.allclose([r for _, r in got], ref.radius[0, 1:], rtol=0, atol=1e-15)


def test_part_leaving_the_arm_is_a_fault_and_stays_one():
    part, p = triangle(), TRIANGLE_PARAMS
    arm = ThrowingArm(part, p, 1, 0.17, arm_length=0.2)
    kinds = [arm.throw() for _ in range(5)]
    faults = [o for o in kinds if o.kind == "fault"]
    assert faults and "left the arm" in faults[0].fault
    assert kinds[-1].kind == "fault"  # no silent recovery


def test_start_outside_the_dynamic_grasp_is_refused():
    part, p = triangle(), TRIANGLE_PARAMS
    with pytest.raises(InputError, match="radius"):
        ThrowingArm(part, p, 1, 0.01)
    with pytest.raises(InputError, match="fidelity"):
        ThrowingArm(part, p, 1, 0.12, fidelity="magic")


@pytest.mark.parametrize(
    "make,params,span", [(triangle, TRIANGLE_PARAMS, 0.1), (bracket, BRACKET_PARAMS, 0.02)]
)
def test_dynamic_fidelity_agrees_with_analytic(make, params, span):
    part = make()
    agree, errors, total = 0, [], 0
    for e in part.stable_edges:
        lo = 1.2 * lowest_radius(part, e, params) + 0.002
        for r in np.linspace(lo, lo + span, 4):
            a = throw_batch(part, np.array([e]), np.array([r]), params)
            kind = "jog" if a.is_jog(np.array([e]))[0] else "flip"
            d = dynamic_throw(part, params, e, float(r), step=5e-4)
            total += 1
            assert d.kind != "fault", d.fault
            assert part.stable[d.edge_after]
            if d.edge_after == a.edge[0] and d.kind == kind:
                agree += 1
                errors.append(abs(d.radius_after - a.radius[0]) / part.radius)
    # Restitution 0.05 and finite friction against the sticking model: most outcomes agree, radii within 10 %.
    assert agree >= 0.8 * total
    assert float(np.median(errors)) < 0.1


def test_dynamic_arm_in_the_simulator():
    part, p = triangle(), TRIANGLE_PARAMS
    arm = ThrowingArm(part, p, 1, 0.12, fidelity="dynamic", dynamic_step=5e-4)
    out = arm.throw()
    assert out.kind in ("jog", "flip") and math.isfinite(out.radius_after) and out.path


def test_dynamic_carry_outside_the_grasp_is_a_fault_not_a_simulation():
    part, p = triangle(), TRIANGLE_PARAMS
    # A long, slow carry tilts the arm past the friction angle atan(0.5): the part would slide.
    out = dynamic_throw(part, p, 1, 0.12, step=5e-4, carry_angle=1.0)
    assert out.kind == "fault" and "dynamic grasp" in out.fault
    assert dynamic_throw(part, p, 1, 0.12, step=5e-4).kind in ("jog", "flip")


@pytest.mark.parametrize("k", [-2, -1, 1, 2])
@pytest.mark.parametrize("delta", [-1e-3, -1e-12, 0.0, 1e-12, 1e-3])
def test_both_fidelities_count_the_same_turns_at_a_whole_turn_boundary(k, delta):
    # A rest angle k whole turns (give or take rounding) from the start: the dynamic fidelity's outcome
    # must count the turns as the analytic throw map does, or the two disagree on the same landing.
    part, edge, radius = triangle(), 1, 0.12
    rotation = 2 * math.pi * k + delta * math.copysign(1.0, k)  # delta < 0: short of k turns
    theta0 = rest_pose(part, edge, radius, TRIANGLE_PARAMS.offset)[2]
    analytic = ThrowBatch(
        edge=np.array([edge]),
        radius=np.array([radius]),
        rotation=np.array([rotation]),
        flight_time=np.zeros(1),
        impacts=np.ones(1, dtype=int),
    )
    dynamic = rest_outcome(part, edge, radius, float(theta0 + rotation), radius)
    expected = k if delta > -1e-6 else k - int(math.copysign(1, k))
    assert dynamic.kind == "flip" and dynamic.edge_after == edge
    assert dynamic.turns == int(analytic.turns[0]) == expected


def test_dynamic_outcome_classifies_analytic_landings_as_the_throw_map_does():
    part = regular(4)
    p = ThrowParams(offset=-0.002, speed=25.0, gravity=-9.81, mu=1.0)
    r = np.linspace(lowest_radius(part, 0, p) + 1e-3, lowest_radius(part, 0, p) + 0.6, 200)
    out = throw_batch(part, np.zeros(r.size, dtype=int), r, p)
    theta0 = rest_pose(part, 0, 0.0, p.offset)[2]
    kinds = np.where(out.is_jog(np.zeros(r.size, dtype=int)), "jog", "flip")
    assert (np.abs(out.turns) >= 1).any()  # whole-turn flips back onto edge 0 are in the sweep
    for b in range(r.size):
        o = rest_outcome(part, 0, float(r[b]), float(theta0 + out.rotation[b]), float(out.radius[b]))
        assert (o.edge_after, o.kind, o.turns) == (int(out.edge[b]), kinds[b], int(out.turns[b]))
