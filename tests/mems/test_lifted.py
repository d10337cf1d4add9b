"""Exact lifted radial potential V (eq. 4), its derivatives (eqs. 5-9, any order) and Proposition 3."""

from __future__ import annotations

import math

import numpy as np
import pytest
from shapes import blob, bracket, plus, washer

from feeder_planner.errors import InputError
from feeder_planner.mems import lifted
from feeder_planner.mems.curve import pivot_translation
from feeder_planner.parts import make_part


def rectangle_integral(x0: float, x1: float, y0: float, y1: float) -> float:
    """int int sqrt(x^2 + y^2) over a rectangle in the first quadrant, from the textbook antiderivative."""

    def f(x: float, y: float) -> float:
        r = math.hypot(x, y)
        first = x**3 * math.log(y + r) if x else 0.0  # x^3 log(...) -> 0 as x -> 0
        second = y**3 * math.log(x + r) if y else 0.0
        return (2 * x * y * r + first + second) / 6

    return f(x1, y1) - f(x0, y1) - f(x1, y0) + f(x0, y0)


def test_potential_matches_independent_closed_form_to_1e12() -> None:
    part = make_part([[0.5, 0.25], [2, 0.25], [2, 1.5], [0.5, 1.5]])
    edges = lifted.part_edges(part)
    # V at the translation that puts the part back where the file drew it
    value = lifted.potential(edges, part.offset)
    assert abs(value / rectangle_integral(0.5, 2, 0.25, 1.5) - 1) <= 1e-12
    # origin inside a rectangle: split into four first-quadrant rectangles
    part = make_part([[-1, -0.5], [2, -0.5], [2, 3], [-1, 3]])
    expected = (
        rectangle_integral(0, 2, 0, 3)
        + rectangle_integral(0, 1, 0, 3)
        + rectangle_integral(0, 2, 0, 0.5)
        + rectangle_integral(0, 1, 0, 0.5)
    )
    assert abs(lifted.potential(lifted.part_edges(part), part.offset) / expected - 1) <= 1e-12


def test_scaling_law_v_scales_as_length_cubed() -> None:
    for s in (1e-6, 1.0):
        small = bracket(scale=s)
        big = bracket(scale=2 * s)
        v1 = lifted.potential(lifted.part_edges(small), np.array([0.3, -0.1]) * s)
        v2 = lifted.potential(lifted.part_edges(big), np.array([0.6, -0.2]) * s)
        assert abs(v2 / v1 - 8) <= 1e-12


@pytest.mark.parametrize("make", [bracket, washer, plus])
def test_gradient_and_hessian_are_derivatives_of_v(make) -> None:
    edges = lifted.part_edges(make())
    rng = np.random.default_rng(1)
    for z in rng.uniform(-3, 3, size=(5, 2)):
        _, g, h = lifted.value_gradient_hessian(edges, z)
        step = 1e-6
        for k in range(2):
            dz = np.zeros(2)
            dz[k] = step
            fd = (lifted.potential(edges, z + dz) - lifted.potential(edges, z - dz)) / (2 * step)
            assert abs(fd - g[k]) <= 1e-7 * (1 + abs(g[k]))
            fdg = (lifted.gradient(edges, z + dz) - lifted.gradient(edges, z - dz)) / (2 * step)
            assert np.allclose(fdg, h[k], rtol=1e-6, atol=1e-7)


def test_higher_derivatives_are_consistent_to_order_8() -> None:
    edges = lifted.part_edges(bracket())
    z = np.array([0.3, -0.2])  # origin inside the part, off the boundary
    d = lifted.derivatives(edges, z, 8)
    step = 1e-4
    for axis in range(2):
        dz = np.zeros(2)
        dz[axis] = step
        up, down = lifted.derivatives(edges, z + dz, 7), lifted.derivatives(edges, z - dz, 7)
        for (i, j), _ in up.items():
            if i + j < 2:
                continue
            key = (i + 1, j) if axis == 0 else (i, j + 1)
            fd = (up[(i, j)] - down[(i, j)]) / (2 * step)
            # central differences: error ~ step^2 * (next derivative), generous for order 8
            assert abs(fd - d[key]) <= 1e-5 * (1 + abs(d[key])) * 10 ** max(0, i + j - 3), (key, fd, d[key])


def test_quadrature_reproduces_closed_form_hessian() -> None:
    """Order-3 derivative from the quadrature path equals the finite difference of the closed-form Hessian
    at points very close to the boundary (grading of the pieces)."""
    part = bracket()
    edges = lifted.part_edges(part)
    # distance 1e-9 from an edge: origin just inside the part near the edge x = 0 (file frame)
    z = part.offset - np.array([1e-9, 1.5])
    d = lifted.derivatives(edges, z, 3)
    assert all(math.isfinite(v) for v in d.values())
    step = 1e-11
    h_plus = lifted.value_gradient_hessian(edges, z + [0, step])[2]
    h_minus = lifted.value_gradient_hessian(edges, z - [0, step])[2]
    fd = (h_plus - h_minus) / (2 * step)
    assert abs(fd[1, 1] - d[(0, 3)]) <= 1e-4 * abs(d[(0, 3)]) + 1e-3


def test_field_centre_on_boundary_is_refused() -> None:
    part = make_part([[0, 0], [2, 0], [2, 2], [0, 2]])
    edges = lifted.part_edges(part)
    with pytest.raises(InputError, match="boundary"):
        lifted.derivatives(edges, part.offset - np.array([1.0, 0.0]), 3)


@pytest.mark.parametrize("make", [bracket, washer, plus, lambda: blob(64)])
def test_proposition_3_hessian_positive_definite_everywhere(make) -> None:
    edges = lifted.part_edges(make())
    rng = np.random.default_rng(7)
    z = rng.uniform(-8, 8, size=(400, 2))
    _, _, h = lifted.value_gradient_hessian(edges, z)
    assert np.all(h[:, 0, 0] + h[:, 1, 1] > 0)
    assert np.all(np.linalg.det(h) > 0)


def test_proposition_3_unique_minimum_from_any_start() -> None:
    edges = lifted.part_edges(washer())
    z0 = pivot_translation(edges)
    assert np.linalg.norm(lifted.gradient(edges, z0)) <= 1e-12 * 14
    rng = np.random.default_rng(3)
    values = lifted.potential(edges, z0 + rng.normal(scale=0.5, size=(200, 2)))
    assert np.all(values > lifted.potential(edges, z0))
