"""The named steps of the equilibria methods, the one-definition checks and the result objects, one by one."""

from __future__ import annotations

import dataclasses
import json
import math
from types import SimpleNamespace
from typing import get_args

import numpy as np
import pytest
from shapes import bracket, plus, regular, washer

from feeder_planner.errors import InputError, SolverError
from feeder_planner.mems import (
    FIELD_TYPES,
    METHODS,
    CombinedField,
    ConstantField,
    Equilibrium,
    FieldType,
    Method,
    ProgramStep,
    QuadraticField,
    RadialField,
    SqueezeField,
    asymptotic,
    check_delta,
    check_field_type,
    check_method,
    field_from_mapping,
    find_equilibria,
    loop_edges,
    numeric,
    part_edges,
)
from feeder_planner.mems.curve import curve, pivot_translation
from feeder_planner.mems.fields import FIELD_CLASSES
from feeder_planner.mems.lifted import edge_endpoints
from feeder_planner.mems.tolerances import EXTRA
from feeder_planner.node_kit.msg_fields import field_spec_to_mapping, fill_field_spec, program_from_msg
from feeder_planner.units import STANDARD_GRAVITY
from feeder_sim.mems import FIDELITIES, Body, Fidelity, IdealForces, Scene, check_fidelity, random_poses
from feeder_sim.mems.bodies import drag_coefficients, wrench_on
from feeder_sim.mems.dynamic import DynamicWorld

TWO_PI = 2 * math.pi


# --- one definition per fact -------------------------------------------------------------------------


def test_part_edges_are_loop_edges_of_the_part_loops() -> None:
    part = washer()
    a, b = part_edges(part), loop_edges(part.loops(), part.radius)
    for name in ("start", "direction", "normal", "length"):
        assert np.array_equal(getattr(a, name), getattr(b, name))
    assert a.scale == b.scale == part.radius
    # placed loops default to their largest coordinate as the length scale
    placed = part.placed(0.3, -0.4, 0.7)
    assert loop_edges(placed).scale == np.abs(np.vstack(placed)).max()


def test_edge_endpoints_close_every_loop_separately() -> None:
    loops = washer().loops()
    start, end = edge_endpoints(loops)
    offset = 0
    for loop in loops:
        n = len(loop)
        assert np.array_equal(end[offset : offset + n - 1], start[offset + 1 : offset + n])
        assert np.array_equal(end[offset + n - 1], start[offset])  # closes on its own first vertex
        offset += n
    assert offset == len(start) == len(end)


@pytest.mark.parametrize("good", [0, 0.0, 0.5, 0.999999])
def test_check_delta_accepts_the_half_open_unit_interval(good) -> None:
    assert check_delta(good) == float(good) and isinstance(check_delta(good), float)


@pytest.mark.parametrize("bad", [-1e-12, 1.0, 1.5, math.nan, math.inf, True, "0.5", None])
def test_check_delta_refuses_naming_the_field(bad) -> None:
    with pytest.raises(InputError) as info:
        check_delta(bad, "request.delta")
    assert info.value.field == "request.delta"


def test_field_files_use_the_same_delta_range() -> None:
    with pytest.raises(InputError) as from_file:
        field_from_mapping({"type": "combined", "delta": 1.0}, "f")
    with pytest.raises(InputError) as direct:
        check_delta(1.0, "f.delta")
    assert from_file.value.field == "f.delta" and from_file.value.problem == direct.value.problem
    assert field_from_mapping({"type": "combined", "delta": 0}, "f") == CombinedField(0.0)


# --- closed sets --------------------------------------------------------------------------------------


def test_closed_sets_are_their_literal_types() -> None:
    assert METHODS == get_args(Method) == ("auto", "asymptotic", "numeric")
    assert FIELD_TYPES == get_args(FieldType) == ("radial", "constant", "combined", "squeeze", "quadratic")
    assert FIDELITIES == get_args(Fidelity) == ("ideal", "array", "dynamic")
    assert tuple(FIELD_CLASSES) == FIELD_TYPES
    assert all(cls.kind == kind for kind, cls in FIELD_CLASSES.items())


@pytest.mark.parametrize(
    "check,value,field",
    [
        (check_method, "guess", "method"),
        (check_field_type, "vortex", "x.type"),
        (check_fidelity, "psychic", "p"),
    ],
)
def test_closed_set_checks_name_the_field_and_list_the_choices(check, value, field) -> None:
    with pytest.raises(InputError) as info:
        check(value, field)
    assert (
        info.value.field == field and value in info.value.problem and "expected one of" in info.value.problem
    )


def test_closed_set_checks_return_the_known_value() -> None:
    assert [check_method(m) for m in METHODS] == list(METHODS)
    assert [check_fidelity(f) for f in FIDELITIES] == list(FIDELITIES)
    assert [check_field_type(t) for t in FIELD_TYPES] == list(FIELD_TYPES)


def test_scene_refuses_an_unknown_fidelity() -> None:
    with pytest.raises(InputError) as info:
        Scene([], (ProgramStep(CombinedField(0.2), math.inf),), "psychic")
    assert info.value.field == "fidelity"


FIELDS = [
    RadialField((0.1, 0.2), 1.3),
    ConstantField((0.3, -1.0)),
    CombinedField(0.3, (0.1, 0.2), 2.0),
    SqueezeField((0.2, 0.1), 0.4, 1.5),
    QuadraticField((0.1, 0.3), (1.0, 3.0), 0.3),
]


@pytest.mark.parametrize("field", FIELDS, ids=lambda f: f.kind)
def test_field_message_round_trip_for_every_type(field) -> None:
    blank = dict.fromkeys(
        ("delta", "center_x", "center_y", "strength", "angle", "k1", "k2", "force_x", "force_y", "duration"),
        0.0,
    )
    spec = fill_field_spec(SimpleNamespace(type="", **blank), ProgramStep(field, 2.0))
    assert spec.type == field.kind and spec.duration == 2.0
    assert program_from_msg(SimpleNamespace(steps=[spec])) == (ProgramStep(field, 2.0),)


def test_unknown_message_type_is_left_for_the_reader_to_name() -> None:
    assert field_spec_to_mapping(SimpleNamespace(type="vortex")) == {"type": "vortex"}


# --- numeric method steps ----------------------------------------------------------------------------


def samples_of(x_of_theta, n: int = 65) -> numeric.CurveSamples:
    theta = TWO_PI * (np.arange(n) + 0.3) / (n - 1)
    x = x_of_theta(theta)
    return numeric.CurveSamples(theta, x, np.gradient(x, theta), np.zeros((n, 2)))


def test_bracket_roots_finds_every_sign_change_once() -> None:
    brackets = numeric.bracket_roots(samples_of(lambda t: np.sin(2 * (t - 1.0))), floor=1e-12)
    assert len(brackets.lo) == 4
    roots = sorted((1.0 + k * math.pi / 2) % TWO_PI for k in range(4))
    found = sorted(
        next(r for r in roots if lo <= r <= hi or lo <= r + TWO_PI <= hi)
        for lo, hi in zip(brackets.lo, brackets.hi, strict=True)
    )
    assert found == roots
    assert np.all(brackets.x_lo != 0)


def test_a_sample_on_the_root_is_bracketed_by_its_neighbours() -> None:
    s = samples_of(lambda t: np.sin(t - TWO_PI * 10.3 / 64))  # roots exactly on samples 10 and 42
    brackets = numeric.bracket_roots(s, floor=1e-9)
    assert len(brackets.lo) == 2
    hit = [
        i for i, (lo, hi) in enumerate(zip(brackets.lo, brackets.hi, strict=True)) if lo < s.theta[10] < hi
    ]
    assert len(hit) == 1 and brackets.x_lo[hit[0]] == s.x[9]


def test_touching_zero_and_no_sign_change_are_refused() -> None:
    with pytest.raises(SolverError, match="touches zero"):
        numeric.bracket_roots(samples_of(lambda t: 1 - np.cos(t - TWO_PI * 5.3 / 64)), floor=1e-9)
    with pytest.raises(SolverError, match="never changes sign"):
        numeric.bracket_roots(samples_of(lambda t: 2 + np.sin(t)), floor=1e-9)


def test_drop_seam_duplicates() -> None:
    near_zero = Equilibrium(0.0, -1.0, 1e-11, True)
    near_two_pi = Equilibrium(0.0, -1.0, TWO_PI - 1e-11, True)
    other = Equilibrium(0.0, 1.0, 3.0, False)
    assert numeric.drop_seam_duplicates([near_zero, other, near_two_pi]) == [near_zero, other]
    twice = Equilibrium(0.0, 1.0, 3.0 + 1e-12, False)
    assert numeric.drop_seam_duplicates([near_zero, other, twice]) == [near_zero, other]
    assert numeric.drop_seam_duplicates([other]) == [other]


def test_numeric_steps_in_sequence() -> None:
    """Sample, subdivide, bracket, refine, classify: each step's output is what the next one needs."""
    part = bracket()
    edges = part_edges(part)
    points = numeric.sample_curve(edges, part.area, 0.5, pivot_translation(edges))
    floor = numeric.resolution_floor(points, 0.5)
    samples = numeric.subdivide(edges, part.area, 0.5, points, floor)
    assert np.all(np.diff(samples.theta) > 0)
    assert math.isclose(samples.theta[-1] - samples.theta[0], TWO_PI)
    assert len(samples.theta) >= len(points.theta)
    brackets = numeric.bracket_roots(samples, floor)
    roots = numeric.refine_roots(edges, part.area, 0.5, brackets)
    assert np.all(np.abs(roots.x) <= floor)
    equilibria, eig_min = numeric.classify(roots, floor, edges.scale)
    assert [e.stable for e in equilibria] == [m > 0 for m in eig_min]
    assert [e.theta for e in equilibria] == sorted(e.theta for e in equilibria)


def test_suspicious_interval_test() -> None:
    # equal signs, but the slopes say x* dips through zero in between
    assert numeric._suspicious(1e-3, 1e-3, -1.0, 1.0, 0.1, 1e-12)
    # equal signs, monotone and far from zero
    assert not numeric._suspicious(1.0, 2.0, 10.0, 10.0, 0.1, 1e-12)
    # a sign change is a bracket, not a suspicious interval
    assert not numeric._suspicious(-1.0, 1.0, 10.0, 10.0, 0.2, 1e-12)


def test_resolution_floor_refuses_an_unresolvable_curve() -> None:
    part = plus()
    edges = part_edges(part)
    points = numeric.sample_curve(edges, part.area, 1e-9, pivot_translation(edges))
    with pytest.raises(SolverError, match="too small to resolve"):
        numeric.resolution_floor(points, 1e-9)


# --- asymptotic method steps -------------------------------------------------------------------------


def test_pivot_off_centroid_is_table_1_first_test() -> None:
    for part, off in ((bracket(), True), (washer(), True), (plus(), False), (regular(8), False)):
        edges = part_edges(part)
        assert asymptotic.pivot_off_centroid(edges, pivot_translation(edges)) is off


@pytest.mark.parametrize("make,n", [(bracket, 0), (plus, 3), (lambda: regular(8), 7)])
def test_expansion_order_follows_table_1(make, n: int) -> None:
    part = make()
    edges = part_edges(part)
    got, order, exp = asymptotic.expand_to_first_nonzero(edges, pivot_translation(edges), part.area)
    assert (got, order) == (n, n + EXTRA)
    assert exp.c.shape[-1] >= order + 1 and len(exp.x_k) == exp.c.shape[-1]
    if n:
        assert asymptotic.first_nonzero_order(exp, n) == n
        assert asymptotic.first_nonzero_order(exp, n - 1) is None


def test_expansion_matches_the_solved_curve_to_its_order() -> None:
    """The truncated series of x* (Prop. 8) against Newton on the exact curve: error ~ delta^(order + 1)."""
    part = washer()
    edges = part_edges(part)
    n, order, exp = asymptotic.expand_to_first_nonzero(edges, pivot_translation(edges), part.area)
    errors = []
    for delta in (1e-3, 2e-3):
        series = sum(exp.x_k[k] * delta**k / math.factorial(k) for k in range(order + 1))
        errors.append(np.abs(series - curve(edges, part.area, delta, exp.theta).x).max())
    assert errors[0] <= 1e-9 * part.radius  # delta^3 part radii
    assert 7.0 < errors[1] / errors[0] < 9.0  # doubling delta multiplies the error by 2^3


def trig(coefficients: dict[int, complex], size: int = 8) -> np.ndarray:
    coef = np.zeros(size, complex)
    for k, value in coefficients.items():
        coef[k] = value
    return coef


# sin(4 (theta - 0.1)) in the module's rfft convention (value = sum_k w_k Re(c_k e^{ik theta}), w_k = 2)
SIN4 = trig({4: -0.5j * np.exp(-0.4j)})


def test_theorem7_roots_of_sin_4_theta() -> None:
    roots, slopes = asymptotic.theorem7_roots(SIN4, 3)
    assert np.allclose(roots, 0.1 + np.arange(8) * math.pi / 4, atol=1e-12)
    assert np.allclose(slopes, 4 * np.cos(4 * (roots - 0.1)))
    assert [s > 0 for s in slopes] == [k % 2 == 0 for k in range(8)]


def test_theorem7_refuses_a_multiple_root() -> None:
    coef = trig({0: 0.5, 1: -0.25})  # 1 - cos(theta): a double root at 0
    with pytest.raises(SolverError, match="multiple root"):
        asymptotic.theorem7_roots(coef, 2)


def test_follow_roots_stays_put_without_higher_orders_and_refuses_far_jumps() -> None:
    roots, _ = asymptotic.theorem7_roots(SIN4, 0)
    zero = np.zeros_like(SIN4)
    assert np.allclose(asymptotic.follow_roots([SIN4, zero, zero], 0, 2, 0.1, roots), roots, atol=1e-14)
    # sin(4 (theta - 0.1)) + 0.9: every root moves by asin(0.9)/4 = 0.28 rad, more than half of half
    # the root spacing (pi/16 = 0.196)
    shift = trig({0: 1.0})
    with pytest.raises(SolverError, match="outside the range"):
        asymptotic.follow_roots([SIN4, shift], 0, 1, 0.9, roots)
    # a small shift is followed: the roots of sin(4 (theta - 0.1)) + 0.1
    moved = asymptotic.follow_roots([SIN4, shift], 0, 1, 0.1, roots)
    assert np.allclose(np.sin(4 * (moved - 0.1)), -0.1, atol=1e-12)


# --- results -----------------------------------------------------------------------------------------


def test_results_are_frozen() -> None:
    result = find_equilibria(bracket(), 0.3, "numeric")
    with pytest.raises(dataclasses.FrozenInstanceError):
        result.delta = 0.1
    with pytest.raises(dataclasses.FrozenInstanceError):
        result.equilibria[0].stable = False


def test_to_json_is_the_contract_object_with_its_key_order() -> None:
    numeric_json = find_equilibria(bracket(), 0.3, "numeric").to_json()
    assert list(numeric_json) == ["pivot", "area", "delta", "method", "equilibria", "details"]
    assert list(numeric_json["equilibria"][0]) == ["x", "y", "theta", "stable"]
    assert list(numeric_json["details"]) == [
        "certified",
        "samples",
        "x_resolution",
        "hessian_min_eigenvalues",
        "theta_uncertainty",
    ]
    asym = find_equilibria(bracket(), 1e-3, "asymptotic").to_json()["details"]
    assert list(asym) == [
        "n",
        "certified",
        "pivot_distance",
        "theorem7_roots",
        "theorem7_slopes",
        "dn_x_fourier",
        "stable_limit_theta",
    ]
    assert asym["certified"] is False
    auto = find_equilibria(plus(), 1e-9, "auto").to_json()["details"]
    assert list(auto)[-3:] == ["certified_at_delta", "numeric_refused", "requested"]
    assert auto["certified"] is True and auto["requested"] == "auto"
    disagreed = find_equilibria(bracket(), 0.1, "auto").to_json()["details"]
    assert list(disagreed)[-2:] == ["asymptotic_disagreed", "requested"]
    for obj in (numeric_json, asym, auto, disagreed):
        json.dumps(obj, allow_nan=False)


def test_to_json_normalises_signed_zeros_and_angles() -> None:
    e = Equilibrium(-0.0, -0.0, -1e-3, True).to_json()
    assert math.copysign(1, e["x"]) == 1 and math.copysign(1, e["y"]) == 1
    assert 0 <= e["theta"] < TWO_PI


# --- simulator -----------------------------------------------------------------------------------------


def test_random_poses_are_seeded_and_inside_the_disc() -> None:
    a, b = random_poses(50, 1e-3, seed=7), random_poses(50, 1e-3, seed=7)
    assert np.array_equal(a, b) and a.shape == (50, 3)
    assert np.all(np.hypot(a[:, 0], a[:, 1]) <= 1e-3) and np.all((0 <= a[:, 2]) & (a[:, 2] < TWO_PI))
    assert not np.array_equal(a, random_poses(50, 1e-3, seed=8))


def test_dynamic_world_needs_no_scene() -> None:
    """The world integrates bodies with a force model alone, exactly as the scene that owns one does."""
    part = bracket(scale=1e-3)
    program = (ProgramStep(CombinedField(0.3), math.inf),)
    start = np.array([2e-4, -1e-4, 0.5])
    scene = Scene([Body(part, start.copy())], program, "dynamic", damping=1e3, friction=0.1)
    alone = [Body(part, start.copy())]
    world = DynamicWorld(alone, IdealForces(), damping=1e3, friction=0.1, gravity=STANDARD_GRAVITY)
    for _ in range(20):
        scene.step(1e-4)
        world.step(1e-4, program[0].field)
    assert np.array_equal(scene.bodies[0].pose, alone[0].pose)
    assert np.array_equal(scene.bodies[0].wrench, alone[0].wrench)


def test_quasi_static_rate_is_wrench_over_drag() -> None:
    part = washer()
    body = Body(part, np.array([0.3, -0.4, 0.7]))
    field = CombinedField(0.3)
    w = wrench_on(body, IdealForces(), field)
    assert np.array_equal(w, field.wrench_at(body.frame, body.pose))  # tests/mems/test_fields.py: = wrench
    drag = drag_coefficients(part, 2.0)
    assert np.allclose(drag, 2.0 * np.array([part.area, part.area, part.polar_moment]))
    scene = Scene([body], (ProgramStep(field, math.inf),), "ideal", damping=2.0)
    rate, _ = scene._rate(body, body.pose, field)
    assert np.allclose(rate * drag, w, rtol=1e-14, atol=0)
