"""The equilibria planner against the paper: Table 1, Theorem 7, Props. 5 and 6, the example of section 4."""

from __future__ import annotations

import math

import numpy as np
import pytest
from shapes import blob, bracket, plus, regular, square, washer

from feeder_planner.errors import InputError, SolverError
from feeder_planner.mems import asymptotic, lifted
from feeder_planner.mems.curve import curve, pivot_translation
from feeder_planner.mems.equilibria import find_equilibria
from feeder_planner.parts import make_part

TWO_PI = 2 * math.pi


def angle_gap(a: float, b: float) -> float:
    return abs(math.remainder(a - b, TWO_PI))


def derivative_fourier(part, k: int) -> np.ndarray:
    """|Fourier coefficients| of d^k x*/d delta^k (theta, 0) by the Table 1 recursion."""
    edges = lifted.part_edges(part)
    z0 = pivot_translation(edges)
    v = lifted.derivatives(edges, z0, k + 1)
    theta = TWO_PI * np.arange(64) / 64
    c = asymptotic.taylor_coefficients(v, part.area, theta, k)
    xk = math.factorial(k) * (np.cos(theta) * c[:, 0, k] - np.sin(theta) * c[:, 1, k])
    return np.abs(np.fft.rfft(xk)) / 64, v


def test_plus_shape_has_n3_with_only_frequency_4() -> None:
    part = plus()
    for k in (1, 2):
        coef, _ = derivative_fourier(part, k)
        assert coef.max() <= 1e-12  # x*, d x*/d delta, d^2 x*/d delta^2 vanish identically
    coef, v = derivative_fourier(part, 3)
    assert np.argmax(coef) == 4
    assert np.delete(coef, 4).max() <= 1e-12 * coef[4]
    # The paper's example, for any pi/2-symmetric part with V_11 = V_31 = 0:
    # d^3 x*/d delta^3 = |S|^3 (3 V_22 - V_40) / (4 lambda^4) sin 4 theta
    # (S = 16 gives the paper's 1024(3+sqrt 2)).
    lam = v[(2, 0)]
    predicted = part.area**3 * (3 * v[(2, 2)] - v[(4, 0)]) / (4 * lam**4)
    assert abs(2 * coef[4] - abs(predicted)) <= 1e-10 * abs(predicted)
    result = asymptotic.asymptotic_equilibria(part, 1e-3)
    assert result.asymptotic.n == 3


def test_plus_shape_four_stable_equilibria_at_multiples_of_half_pi() -> None:
    result = find_equilibria(plus(), 1e-3, "asymptotic")
    stable = sorted(e.theta for e in result.stable)
    assert len(stable) == 4 and len(result.equilibria) == 8
    for i, theta in enumerate(stable):
        assert angle_gap(theta, i * math.pi / 2) <= 1e-9


def test_square_stable_at_quarter_pi_offsets() -> None:
    result = find_equilibria(square(), 1e-3, "asymptotic")
    stable = sorted(e.theta for e in result.stable)
    assert len(stable) == 4
    for i, theta in enumerate(stable):
        assert angle_gap(theta, math.pi / 4 + i * math.pi / 2) <= 1e-9


def test_octagon_needs_n_7_with_frequency_8() -> None:
    part = regular(8)
    result = asymptotic.asymptotic_equilibria(part, 1e-3)
    assert result.asymptotic.n == 7
    assert {k for k, _ in result.asymptotic.dn_x_fourier} == {8}
    assert len(result.stable) == 8


def test_disc_like_part_is_refused_not_guessed() -> None:
    with pytest.raises(SolverError, match="vanishes identically"):
        asymptotic.asymptotic_equilibria(regular(13), 1e-3)


def test_non_symmetric_part_one_stable_tending_to_three_half_pi_minus_psi() -> None:
    part = bracket()
    edges = lifted.part_edges(part)
    z0 = pivot_translation(edges)
    psi = math.atan2(z0[1], z0[0])
    limit = (1.5 * math.pi - psi) % TWO_PI
    gaps = []
    for delta in (1e-2, 1e-3, 1e-4):
        result = find_equilibria(part, delta, "numeric")
        assert len(result.stable) == 1 and len(result.equilibria) == 2
        gaps.append(angle_gap(result.stable[0].theta, limit))
        # in the standard coordinates the stable configuration tends to (0, -rho, 3 pi/2 - psi)
        assert abs(result.stable[0].y + math.hypot(*z0)) <= 50 * delta
    assert gaps[0] > gaps[1] > gaps[2] and gaps[2] <= 1e-3
    assert result.pivot == pytest.approx((-z0[0], -z0[1]))


@pytest.mark.parametrize("make", [bracket, plus, square, washer, lambda: blob(40)])
def test_asymptotic_and_numeric_agree_at_delta_1e3(make) -> None:
    """Stated tolerance: same count and stability; angles within 1e-6 rad; positions within 1e-6 radii."""
    part = make()
    a = find_equilibria(part, 1e-3, "asymptotic")
    b = find_equilibria(part, 1e-3, "numeric")
    assert len(a.equilibria) == len(b.equilibria)
    for ea in a.equilibria:
        match = min(b.equilibria, key=lambda eb: angle_gap(ea.theta, eb.theta))
        assert match.stable == ea.stable
        assert angle_gap(ea.theta, match.theta) <= 1e-6
        assert math.hypot(ea.x - match.x, ea.y - match.y) <= 1e-6 * part.radius


@pytest.mark.parametrize("delta", [0.05, 0.5])
def test_proposition_5_du_dtheta_equals_delta_area_x(delta: float) -> None:
    part = washer()
    edges = lifted.part_edges(part)
    theta = np.linspace(0.1, 6.0, 7)
    h = 1e-5

    def u_star(t: np.ndarray) -> np.ndarray:
        pts = curve(edges, part.area, delta, t)
        b = np.column_stack([np.sin(t), np.cos(t)])
        return lifted.potential(edges, pts.z) + delta * part.area * (b * pts.z).sum(1)  # eq. (12)

    derivative = (u_star(theta + h) - u_star(theta - h)) / (2 * h)
    x_star = curve(edges, part.area, delta, theta).x
    assert np.allclose(derivative, delta * part.area * x_star, rtol=1e-6, atol=1e-9)


def test_proposition_6_stable_iff_crossing_left_to_right_and_hessian() -> None:
    part = bracket()
    result = find_equilibria(part, 0.5, "numeric")
    edges = lifted.part_edges(part)
    for e in result.equilibria:
        assert abs(e.x) <= 1e-12
        pts = curve(edges, part.area, 0.5, np.array([e.theta]))
        assert (pts.dx[0] > 0) == e.stable
    # the equilibria found alternate stable / unstable around the circle (x* is periodic)
    kinds = [e.stable for e in sorted(result.equilibria, key=lambda e: e.theta)]
    assert all(kinds[i] != kinds[(i + 1) % len(kinds)] for i in range(len(kinds)))


def test_stable_equilibrium_is_a_local_minimum_of_u() -> None:
    """Independent check of the Hessian classification: perturb (x, y, theta) and evaluate U exactly."""
    part = washer()
    from feeder_planner.mems.fields import CombinedField

    field = CombinedField(0.3)
    result = find_equilibria(part, 0.3, "numeric")
    rng = np.random.default_rng(5)
    for e in result.equilibria:
        base = field.lifted(part.placed(e.x, e.y, e.theta))
        trials = [
            field.lifted(part.placed(e.x + d[0], e.y + d[1], e.theta + d[2]))
            for d in rng.normal(scale=[1e-3, 1e-3, 1e-3], size=(30, 3))
        ]
        if e.stable:
            assert min(trials) > base
        else:
            # a saddle: moving along the equilibrium curve (x, y re-minimised) lowers U on both sides
            edges = lifted.part_edges(part)
            for h in (-1e-3, 1e-3):
                p = curve(edges, part.area, 0.3, np.array([e.theta + h]))
                assert field.lifted(part.placed(p.x[0], p.y[0], e.theta + h)) < base


@pytest.mark.parametrize("delta", [1e-9, 1e-6, 0.5, 0.99])
@pytest.mark.parametrize("scale", [0.25e-6, 0.25])
def test_extremes_of_delta_and_size(delta: float, scale: float) -> None:
    part = bracket(scale=scale)  # 1 um and 1 m across
    result = find_equilibria(part, delta, "auto")
    assert len(result.stable) >= 1
    assert all(math.isfinite(v) for e in result.equilibria for v in (e.x, e.y, e.theta))
    if delta <= 1e-6:
        assert len(result.stable) == 1
    reference = find_equilibria(bracket(), delta, "auto")
    assert [e.stable for e in result.equilibria] == [e.stable for e in reference.equilibria]
    for a, b in zip(result.equilibria, reference.equilibria, strict=True):
        assert angle_gap(a.theta, b.theta) <= 1e-8
        assert abs(a.y / scale - b.y) <= 1e-8


def test_symmetric_part_at_tiny_delta_certified_elsewhere() -> None:
    result = find_equilibria(plus(), 1e-9, "auto")
    assert result.method == "asymptotic" and result.auto.certified_at_delta > 1e-9
    assert len(result.stable) == 4


def test_many_vertices() -> None:
    for n in (3, 500):
        part = blob(n) if n > 3 else make_part([[0, 0], [3, 0], [0.5, 1]])
        result = find_equilibria(part, 0.1, "auto")
        assert len(result.stable) >= 1


def test_nearly_symmetric_part_is_not_misclassified() -> None:
    """Pivot within 1e-12 of the centroid: auto must agree with the numeric method at delta = 1e-3."""
    v = [
        [1, -1],
        [3 + 3e-12, -1],
        [3, 1],
        [1, 1],
        [1, 3],
        [-1, 3],
        [-1, 1],
        [-3, 1],
        [-3, -1],
        [-1, -1],
        [-1, -3],
        [1, -3],
    ]
    part = make_part(v)
    edges = lifted.part_edges(part)
    assert np.hypot(*pivot_translation(edges)) <= 1e-12
    auto = find_equilibria(part, 1e-3, "auto")
    numeric = find_equilibria(part, 1e-3, "numeric")
    # agreement within the numeric method's own stated resolution (its x* floor over the slope)
    window = 1e-6 + 2 * numeric.numeric.theta_uncertainty
    assert len(auto.equilibria) == len(numeric.equilibria) == 8
    for a in auto.equilibria:
        assert min(angle_gap(a.theta, b.theta) for b in numeric.equilibria if b.stable == a.stable) <= window
    assert len(auto.stable) == 4
    try:
        tiny = find_equilibria(part, 1e-9, "auto")
    except SolverError as error:  # a clear refusal is allowed at the resolution limit
        assert "certif" in str(error) or "resolve" in str(error)
    else:
        assert all(math.isfinite(e.theta) for e in tiny.equilibria)


def test_pivot_within_1e9_of_the_boundary() -> None:
    """A square with a wedge notch whose tip is put 1e-9 from the pivot (fixed point on the tip)."""
    tip = 0.0
    for _ in range(6):
        part = make_part([[-1, -1], [1, -1], [1, -0.01], [tip, 0], [1, 0.01], [1, 1], [-1, 1]])
        pivot = np.array(part.offset) + np.array(find_equilibria(part, 0.5, "numeric").pivot)
        tip = float(pivot[0]) + 1e-9
    part = make_part([[-1, -1], [1, -1], [1, -0.01], [tip, 0], [1, 0.01], [1, 1], [-1, 1]])
    pivot = np.array(part.offset) + np.array(find_equilibria(part, 0.5, "numeric").pivot)
    assert 0 < tip - pivot[0] <= 2e-9
    for delta in (1e-3, 0.3):
        result = find_equilibria(part, delta, "auto")
        assert len(result.stable) >= 1
        assert all(math.isfinite(e.y) for e in result.equilibria)


@pytest.mark.parametrize(
    "delta,problem",
    [(1.0, "0 <= delta < 1"), (-0.1, "0 <= delta < 1"), (float("nan"), "finite"), (0.0, "orientation")],
)
def test_bad_delta_named(delta: float, problem: str) -> None:
    with pytest.raises(InputError, match=problem) as info:
        find_equilibria(bracket(), delta)
    assert info.value.field == "delta"


def test_unknown_method_named() -> None:
    with pytest.raises(InputError) as info:
        find_equilibria(bracket(), 0.1, "guess")
    assert info.value.field == "method"


def test_certification_flags() -> None:
    assert find_equilibria(bracket(), 0.2, "numeric").certified is True
    assert find_equilibria(bracket(), 0.2, "asymptotic").certified is False
    assert find_equilibria(plus(), 1e-3, "auto").certified is True
