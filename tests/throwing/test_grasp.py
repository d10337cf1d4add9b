"""Dynamic grasp: eqs. (1)-(4) against the wrench-cone test (Proposition III.3)."""

import math

import numpy as np
import pytest
from throwing_helpers import bracket, triangle

from feeder_planner.errors import InputError
from feeder_planner.throwing.grasp import carry_in_grasp, grasp_radius, impulse_in_grasp


@pytest.mark.parametrize("make", [triangle, bracket])
@pytest.mark.parametrize("offset", [-0.004, -0.001, 0.0, 0.003])
@pytest.mark.parametrize("mu", [0.2, 0.5, 1.5])
def test_grasp_radius_agrees_with_cone_test_over_sweep(make, offset, mu):
    part = make()
    for i in part.stable_edges:
        r_grasp = grasp_radius(part, i, offset, mu)
        assert math.isfinite(r_grasp)  # Proposition III.3: finite
        span = 3 * part.radius + abs(r_grasp)
        for radius in np.linspace(r_grasp - span, r_grasp + span, 301):
            if abs(radius - r_grasp) < 1e-9 * span:
                continue
            assert impulse_in_grasp(part, i, radius, offset, mu) == (radius >= r_grasp), (i, radius, r_grasp)


def test_impulsive_limit_of_the_carry_is_the_impulse_cone():
    part = triangle()
    offset, mu, g = -0.005, 0.5, -9.66
    for i in part.stable_edges:
        r_grasp = grasp_radius(part, i, offset, mu)
        for radius in (r_grasp * 0.9 - 0.01, r_grasp * 1.1 + 0.01):
            # A huge angular acceleration at the start of the carry: gravity and theta_dot^2 terms vanish.
            carried = carry_in_grasp(part, i, radius, offset, g, mu, 0.0, 0.0, 1e9)
            assert carried == impulse_in_grasp(part, i, radius, offset, mu)


def test_resting_part_is_grasped_and_free_fall_of_palm_is_not():
    part = triangle()
    for i in part.stable_edges:
        assert carry_in_grasp(part, i, 0.1, -0.005, -9.66, 0.5, 0.0, 0.0, 0.0)
        # The arm accelerating its surface downward faster than gravity at the part (Example III.2) loses it.
        assert not carry_in_grasp(part, i, 0.1, -0.005, -9.66, 0.5, 0.0, 0.0, -2 * 9.66 / 0.1)


def test_unstable_edge_has_no_grasp_radius():
    part = bracket()
    bad = [i for i in range(part.n) if not part.stable[i]][0]
    with pytest.raises(InputError, match="edge"):
        grasp_radius(part, bad, -0.0025, 0.5)
