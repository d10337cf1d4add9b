"""WarmLP's interior-point route (Clarabel on the dual, then HiGHS crossover) solves bounded LPs exactly."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import sparse
from scipy.optimize import linprog

from feeder_planner.assembly.lp import WarmLP


def _random_lp(seed: int) -> tuple[sparse.csc_matrix, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A feasible, bounded LP whose columns have every kind of bound: free, lower, upper, boxed and fixed."""
    rng = np.random.default_rng(seed)
    rows, cols = 12, 40
    A = (
        sparse.random(rows, cols, density=0.35, random_state=seed, format="csc")
        + sparse.eye(rows, cols) * 2.0
    )
    kinds = rng.integers(0, 5, cols)
    kinds[:rows] = 2  # boxed columns on the identity part keep the LP bounded
    lower = np.where(np.isin(kinds, (1, 2, 4)), rng.uniform(-2, 0, cols), -np.inf)
    upper = np.where(np.isin(kinds, (2, 3)), rng.uniform(0.5, 3, cols), np.inf)
    upper = np.where(kinds == 4, lower, upper)  # fixed
    feasible = np.clip(
        rng.normal(size=cols), np.where(np.isfinite(lower), lower, -5), np.where(np.isfinite(upper), upper, 5)
    )
    b = A @ feasible
    # Costs that keep free and one-sided columns bounded: they point into the side that has a bound.
    cost = rng.normal(size=cols)
    cost = np.where(kinds == 1, np.abs(cost), np.where(kinds == 3, -np.abs(cost), cost))
    cost[kinds == 0] = 0.0
    return A, b, lower, upper, cost


@pytest.mark.parametrize("seed", range(8))
def test_interior_point_route_matches_linprog(seed: int) -> None:
    A, b, lower, upper, cost = _random_lp(seed)
    reference = linprog(cost, A_eq=A, b_eq=b, bounds=list(zip(lower, upper, strict=True)), method="highs")
    assert reference.status == 0, reference.message
    lp = WarmLP(A, b, lower, upper)
    lp.set_cost(np.arange(A.shape[1]), cost)
    result = lp.solve_by_interior_point()
    assert result.status == "optimal"
    assert lp.crossovers == 1  # answered through the interior point, not the simplex fallback
    assert lp.seconds["interior_point"] > 0 and lp.seconds["crossover"] > 0  # the profile saw both phases
    assert result.value == pytest.approx(reference.fun, abs=1e-7)
    assert np.abs(A @ result.x - b).max() < 1e-7
    assert np.all(result.x >= lower - 1e-9) and np.all(result.x <= upper + 1e-9)
    # The crossover left an optimal basis behind: restarting from it takes no pivot.
    again = lp.solve_from(lp.basis())
    assert again.status == "optimal" and lp.pivots == 0


def test_interior_point_route_reports_infeasible_lp() -> None:
    A = sparse.csc_matrix(np.array([[1.0, 1.0]]))
    lp = WarmLP(A, np.array([-1.0]), np.zeros(2), np.full(2, np.inf))  # x >= 0 cannot sum to -1
    lp.set_cost(np.arange(2), np.ones(2))
    assert lp.solve_by_interior_point().status == "infeasible"


def test_interior_point_route_is_safe_from_two_threads(from_doc) -> None:
    """Unserialised, HiGHS's crossover crashed the process while another thread was inside Clarabel."""
    from concurrent.futures import ThreadPoolExecutor

    from feeder_planner.assembly.generate import brick_wall

    system = from_doc(brick_wall(12, 8)).system
    A = sparse.hstack([sparse.csc_matrix(system.B), system.A], format="csc")
    lower = np.concatenate([-np.ones(3), np.zeros(system.columns)])
    upper = np.concatenate([np.ones(3), np.full(system.columns, np.inf)])

    def solve_far_directions(_: int) -> list[float]:
        lp = WarmLP(A, np.zeros(A.shape[0]), lower, upper)
        values = []
        for direction in ([1.0, 0.0, 0.0], [-1.0, 0.1, 0.0]):
            lp.set_cost(np.arange(3), -np.asarray(direction))
            result = lp.solve_by_interior_point()
            assert result.status == "optimal"
            values.append(result.value)
        return values

    with ThreadPoolExecutor(2) as pool:
        first, second = pool.map(solve_far_directions, [0, 1])
    assert first == pytest.approx(second, abs=1e-9)
