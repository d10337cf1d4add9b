"""The contact fidelity: the paper's model where no assumption breaks, physical where one does (issue 14)."""

import json
import math

import numpy as np
import pytest
from throwing_helpers import BRACKET_PARAMS, EXAMPLES, TRIANGLE_PARAMS, bracket, regular, triangle

from feeder_planner.errors import InputError, SolverError
from feeder_planner.parts import make_part
from feeder_planner.throwing.geometry import arm_part
from feeder_planner.throwing.grasp import grasp_radius
from feeder_planner.throwing.throw_map import ThrowParams, lowest_radius, throw
from feeder_sim.throwing.arm import ThrowingArm
from feeder_sim.throwing.contact import contact_throw, contact_trace, sliding_impulse

HIGH_MU = 5.0


def _release_energy(part, edge, radius, p):
    """Mechanical energy per unit mass right after the impulsive release (eq. 5), above the arm."""
    a = p.offset + part.d[edge]
    return 0.5 * p.speed**2 * (radius**2 + a**2 + part.rho**2) - p.gravity * part.d[edge]


def _energies(part, edge, radius, p, trace):
    return np.array([_release_energy(part, edge, radius, p)] + [e.energy for e in trace.events])


def _starts(part, p, per_edge=12, span=0.25):
    for e in part.stable_edges:
        low = lowest_radius(part, e, p)
        for r in np.linspace(low + 1e-3, low + span, per_edge):
            yield e, float(r)


def test_agrees_exactly_with_the_paper_where_no_assumption_breaks():
    checked = 0
    for part, p in (
        (triangle(), ThrowParams(-0.005, math.radians(320), -9.66, HIGH_MU)),
        (bracket(), ThrowParams(-0.0025, math.radians(320), -2.20, HIGH_MU)),
        (regular(7), ThrowParams(-0.004, 4.0, -9.81, HIGH_MU)),
    ):
        for e, r in _starts(part, p):
            paper = throw(part, e, r, p)
            trace = contact_trace(part, e, r, p)
            if paper.lift_off or paper.slip or trace.hops or trace.slides:
                continue
            c = trace.result
            assert (c.edge, c.kind, c.impacts, c.turns) == (
                paper.edge,
                paper.kind,
                paper.impacts,
                paper.turns,
            )
            assert c.radius == paper.radius and c.rotation == paper.rotation  # the same arithmetic
            assert c.fidelity == "contact" and not (c.lift_off or c.slip)
            checked += 1
    assert checked >= 40, checked


def test_a_hop_leaves_the_pivot_where_the_normal_force_is_zero_and_loses_no_energy():
    part, p = triangle(), ThrowParams(-0.005, math.radians(320), -9.66, HIGH_MU)
    edge, radius = 0, 0.225  # the paper's rolling here would need a pulling normal force
    paper = throw(part, edge, radius, p)
    trace = contact_trace(part, edge, radius, p)
    assert paper.lift_off and trace.hops >= 1 and trace.result.lift_off
    assert (trace.result.impacts, trace.result.radius) != (paper.impacts, paper.radius)
    for event in (e for e in trace.events if e.kind == "lift_off"):
        x, y, theta, vx, vy, omega = event.state
        q = part.hull[event.vertex]
        c, s = math.cos(theta), math.sin(theta)
        rx, ry = c * q[0] - s * q[1], s * q[0] + c * q[1]
        assert y + ry == pytest.approx(p.offset, abs=1e-12)  # the pivot is on the arm
        assert math.hypot(vx - omega * ry, vy + omega * rx) < 1e-9  # and at rest
        # Normal force of rolling about it (rolling.lift_off_in_swing): zero at the event.
        inertia, cy = part.rho**2 + q @ q, -ry
        energy = 0.5 * inertia * omega**2 - p.gravity * cy
        normal = (-p.gravity * part.rho**2 - 2 * energy * cy - 3 * p.gravity * cy**2) / inertia
        assert normal == pytest.approx(0.0, abs=1e-9 * -p.gravity)
    energies = _energies(part, edge, radius, p, trace)
    assert np.all(np.diff(energies) <= 1e-12 * energies[0])


def test_a_slide_opposes_the_slip_on_the_cone_edge_and_loses_energy():
    part, p = triangle(), TRIANGLE_PARAMS  # mu = 0.5: the catch at R = 8.58 cm needs more
    edge, radius = 1, 0.0858
    paper = throw(part, edge, radius, p)
    trace = contact_trace(part, edge, radius, p)
    assert paper.slip and trace.slides >= 1 and trace.result.slip
    assert trace.result.radius != paper.radius
    slides = [e for e in trace.events if e.kind == "slide"]
    for event in slides:
        j_t, j_n = event.impulse
        _, _, theta, vx, _, omega = event.state
        q = part.hull[event.vertex]
        ry = math.sin(theta) * q[0] + math.cos(theta) * q[1]
        after = vx - omega * ry  # the vertex's tangential velocity once the impulse has acted
        assert j_n > 0 and abs(j_t) <= p.mu * j_n * (1 + 1e-12)  # never outside the cone
        if after * event.slip > 0:  # slipped one way throughout: friction opposes it, on the cone's edge
            assert j_t * event.slip < 0 and abs(j_t) == pytest.approx(p.mu * j_n, rel=1e-12)
    assert any(abs(e.slip) > 0 for e in slides)
    energies = _energies(part, edge, radius, p, trace)
    assert np.all(np.diff(energies) <= 1e-12 * energies[0])
    assert part.stable[trace.result.edge]


def test_sliding_impulse_stops_the_normal_velocity_and_refuses_painleve():
    rho, mu = 0.01, 0.3
    rx, ry, vx, vy, omega = 0.012, -0.008, 0.4, -0.9, 3.0
    j_t, j_n, d_omega, stuck = sliding_impulse(rx, ry, vx, vy, omega, rho, mu)
    # Independently: the vertex velocity after, from the impulse applied at the vertex.
    assert vy + j_n + (omega + d_omega) * rx == pytest.approx(0.0, abs=1e-15)  # plastic: normal v = 0
    slip_after = vx + j_t - (omega + d_omega) * ry
    assert d_omega == pytest.approx((rx * j_n - ry * j_t) / rho**2, rel=1e-14)
    assert vx - omega * ry > 0 and slip_after > 0 and not stuck  # slipped toward +x throughout
    assert j_t == pytest.approx(-mu * j_n) and j_n > 0
    # A slip that stops within the impact sticks if |K_tn / K_tt| <= mu: the vertex ends at rest.
    j_t, j_n, d_omega, stuck = sliding_impulse(0.012, -0.008, 0.01, -0.9, 0.0, rho, 1.0)
    assert stuck and 0.01 + j_t - d_omega * -0.008 == pytest.approx(0.0, abs=1e-15)
    assert abs(j_t) <= 1.0 * j_n
    before = 0.5 * (vx**2 + vy**2 + rho**2 * omega**2)
    after = 0.5 * ((vx + j_t) ** 2 + (vy + j_n) ** 2 + rho**2 * (omega + d_omega) ** 2)
    assert after < before
    with pytest.raises(SolverError, match="Painleve"):
        sliding_impulse(0.01, -0.02, 1.0, -1.0, 0.0, 0.001, 5.0)


def test_extremes_of_friction():
    part = triangle()
    # mu -> 0: every catch and strike slides (R_grasp grows as 1 / mu, eqs. 2, 4); energy still falls.
    low_mu = ThrowParams(-0.005, math.radians(320), -9.66, 0.02)
    for e in part.stable_edges:
        r = lowest_radius(part, e, low_mu) * 1.01
        trace = contact_trace(part, e, r, low_mu)
        impacts = [ev for ev in trace.events if ev.kind in ("catch", "strike", "slide")]
        assert impacts and all(ev.kind == "slide" for ev in impacts)
        energies = _energies(part, e, r, low_mu, trace)
        assert np.all(np.diff(energies) <= 1e-12 * energies[0]) and part.stable[trace.result.edge]
    # mu large: friction never binds, so the outcome no longer depends on mu.
    for e, r in _starts(part, TRIANGLE_PARAMS, per_edge=5):
        big = contact_throw(part, e, r, ThrowParams(-0.005, math.radians(320), -9.66, 1e4))
        huge = contact_throw(part, e, r, ThrowParams(-0.005, math.radians(320), -9.66, 1e6))
        assert (big.edge, big.kind, big.impacts) == (huge.edge, huge.kind, huge.impacts)
        # A slide that friction cannot prevent (the sticking impulse would pull) converges as 1 / mu.
        assert big.radius == pytest.approx(huge.radius, abs=1e-5 * part.radius)


def test_grazing_catches_end_at_rest_without_gaining_energy():
    part, p = triangle(), TRIANGLE_PARAMS
    for e in part.stable_edges:
        for eps in (1e-12, 1e-6):
            r = lowest_radius(part, e, p) * (1 + eps)
            trace = contact_trace(part, e, r, p)
            assert trace.result.flight_time < 1e-6
            energies = _energies(part, e, r, p, trace)
            assert np.all(np.diff(energies) <= 1e-12 * energies[0])
            assert part.stable[trace.result.edge]


def test_domain_is_the_paper_models():
    part, p = bracket(), BRACKET_PARAMS
    r_grasp = grasp_radius(part, 0, p.offset, p.mu)
    with pytest.raises(InputError) as error:
        contact_throw(part, 0, 0.5 * r_grasp, p)
    assert error.value.field == "radius"
    with pytest.raises(InputError) as error:
        contact_throw(part, 99, 0.1, p)
    assert error.value.field == "edge"


CLI_PAPER = ["--offset", "-0.5", "--release-speed", "320deg", "--gravity", "-966", "--mu", "0.5"]


def test_feeder_throw_fidelity_flag(capsys):
    from feeder_cell.cli.main import main

    tri = str(EXAMPLES / "triangle.yaml")
    start = ["throw", tri, "--edge", "1", "--radius", "14", *CLI_PAPER, "--json"]
    got = {}
    for fidelity in ("paper", "analytic", "contact", "dynamic"):
        assert main([*start, "--fidelity", fidelity]) == 0
        got[fidelity] = json.loads(capsys.readouterr().out)
    assert main(start) == 0  # the default is the paper model, as before the flag
    assert json.loads(capsys.readouterr().out) == got["paper"] == got["analytic"]
    expected = contact_throw(triangle(), 1, 0.14, TRIANGLE_PARAMS)
    assert got["contact"]["fidelity"] == "contact" and got["contact"]["radius"] == expected.radius
    assert got["contact"]["lift_off"] == expected.lift_off and got["contact"]["impacts"] == expected.impacts
    dyn = got["dynamic"]
    assert dyn["fidelity"] == "dynamic" and dyn["flight_time"] is None and dyn["impacts"] is None
    assert dyn["kind"] in ("jog", "flip") and 0.05 < dyn["radius"] < 0.5
    with pytest.raises(SystemExit) as bad:
        main([*start, "--fidelity", "magic"])
    assert bad.value.code == 2
    err = capsys.readouterr().err
    assert "--fidelity" in err and len(err.strip().splitlines()) == 1


def test_arm_throws_at_the_contact_fidelity():
    part, p = triangle(), TRIANGLE_PARAMS
    arm = ThrowingArm(part, p, 1, 0.14, fidelity="contact")
    out = arm.throw()
    expected = contact_throw(part, 1, 0.14, p)
    assert arm.fidelity == "contact" and out.kind == expected.kind
    assert (arm.edge, arm.radius) == (expected.edge, expected.radius)
    assert ThrowingArm(part, p, 1, 0.14, fidelity="analytic").fidelity == "paper"
    with pytest.raises(InputError) as error:
        ThrowingArm(part, p, 1, 0.14, fidelity="exact")
    assert error.value.field == "fidelity" and "contact" in error.value.problem


def test_random_parts_never_gain_energy_nor_sink_into_the_arm():
    rng = np.random.default_rng(1)
    thrown = 0
    while thrown < 150:
        n = int(rng.integers(3, 9))
        angles = np.sort(rng.uniform(0, 2 * math.pi, n))
        radii = 0.02 * (1 + 0.5 * rng.uniform(-1, 1, n))
        try:
            part = arm_part(make_part(np.c_[radii * np.cos(angles), radii * np.sin(angles)].tolist()))
        except InputError:
            continue  # a degenerate polygon
        mu = float(rng.choice([0.05, 0.2, 0.5, 1.0, 3.0]))
        p = ThrowParams(-float(rng.uniform(0.05, 0.9)) * part.d_min, float(rng.uniform(2, 12)), -9.81, mu)
        for e in part.stable_edges:
            for r in lowest_radius(part, e, p) + part.radius * rng.uniform(1e-6, 6, 3):
                trace = contact_trace(part, e, float(r), p)
                thrown += 1
                energies = _energies(part, e, float(r), p, trace)
                assert np.all(np.diff(energies) <= 1e-12 * energies[0])
                for event in trace.events:
                    _, y, theta, *_ = event.state
                    heights = y + np.sin(theta) * part.hull[:, 0] + np.cos(theta) * part.hull[:, 1]
                    # The sliding ODE keeps the contact to its tolerances (1e-10 relative per step).
                    assert heights.min() - p.offset >= -1e-8 * part.radius, event
                assert part.stable[trace.result.edge]
