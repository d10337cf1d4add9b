"""The stability LP (eq. 9) for one gravity direction: the verdict, contact forces or the moving bodies."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import sparse
from scipy.optimize import linprog

from feeder_planner.assembly.lp import WarmLP
from feeder_planner.assembly.tolerances import FEASIBILITY_TOLERANCE, MIN_DIRECTION_NORM, RESIDUAL_TOLERANCE
from feeder_planner.assembly.wrench import EquilibriumSystem, contact_forces
from feeder_planner.errors import InputError, SolverError

__all__ = ["StabilityChecker", "StabilityVerdict", "unit_gravity"]

# HiGHS options of the least-imbalance LP; a stable verdict is certified by re-checking the residual of the
# returned forces, an unstable one names the rows left unbalanced beyond RESIDUAL_TOLERANCE.
LP_OPTIONS = {
    "primal_feasibility_tolerance": FEASIBILITY_TOLERANCE,
    "dual_feasibility_tolerance": FEASIBILITY_TOLERANCE,
    "presolve": True,
}


@dataclass(frozen=True)
class StabilityVerdict:
    """Whether g is potentially stable; forces (N, on body a, per contact) if so, else unbalanced bodies."""

    stable: bool
    forces: np.ndarray | None
    unbalanced: tuple[int, ...]
    residual: float


def unit_gravity(g: np.ndarray, field: str = "g") -> np.ndarray:
    """Return g as a unit vector; InputError naming ``field`` unless it has 3 finite, not all zero parts."""
    g = np.asarray(g, dtype=float).reshape(-1)
    if g.shape != (3,):
        raise InputError(field, f"expected 3 components, got {g.size}")
    if not np.all(np.isfinite(g)):
        raise InputError(field, f"must be finite, got {g.tolist()}")
    norm = float(np.linalg.norm(g))
    if norm < MIN_DIRECTION_NORM:
        raise InputError(field, "must be a non-zero direction")
    return g / norm


class StabilityChecker:
    """Eq. (9) for one gravity direction at a time, on one warm-started LP (g's columns fixed by bounds).

    Columns 0-2 of the LP are g itself, fixed to the direction asked by their bounds, so only the bounds
    change between calls and each solve restarts from the last basis.
    """

    def __init__(self, system: EquilibriumSystem) -> None:
        self.system = system
        columns = system.columns
        A = sparse.hstack([sparse.csc_matrix(system.B), system.A], format="csc")
        self.lp = WarmLP(
            A,
            np.zeros(system.A.shape[0]),
            np.concatenate([np.zeros(3), np.zeros(columns)]),
            np.concatenate([np.zeros(3), np.full(columns, np.inf)]),
        )
        # Minimise the total multiplier: a bounded objective picking a small, well-scaled force distribution.
        self.lp.set_cost(np.arange(3, 3 + columns), np.ones(columns))

    def __call__(self, g: np.ndarray, explain: bool = True) -> StabilityVerdict:
        """Decide g; ``explain`` also finds the bodies that cannot be balanced when unstable (one more LP)."""
        system = self.system
        g = unit_gravity(g)
        rhs = -system.B @ g
        if system.A.shape[0] == 0:
            return StabilityVerdict(True, np.zeros((len(system.contacts), 3)), (), 0.0)
        if system.columns == 0:
            return StabilityVerdict(
                False, None, _bodies(system, np.abs(rhs) > RESIDUAL_TOLERANCE), float(np.abs(rhs).max())
            )
        self.lp.set_bounds(np.arange(3), g, g)
        result = self.lp.solve()
        if result.status == "optimal":
            lam = np.maximum(result.solution[3:], 0.0)
            residual = float(np.abs(system.A @ lam - rhs).max())
            if residual > RESIDUAL_TOLERANCE:
                raise SolverError(
                    f"stability LP returned forces with residual {residual:.3g} > {RESIDUAL_TOLERANCE}"
                )
            return StabilityVerdict(True, contact_forces(system, lam), (), residual)
        if result.status == "infeasible":
            return _unbalanced(system, rhs) if explain else StabilityVerdict(False, None, (), float("nan"))
        raise SolverError(f"stability LP failed: {result.message}")


def _unbalanced(system: EquilibriumSystem, rhs: np.ndarray) -> StabilityVerdict:
    """Find the least total imbalance (L1, scaled rows); bodies with imbalance left are the ones that move."""
    rows = system.A.shape[0]
    identity = sparse.identity(rows, format="csc")
    A = sparse.hstack([system.A, identity, -identity], format="csc")
    cost = np.concatenate([np.zeros(system.columns), np.ones(2 * rows)])
    result = linprog(cost, A_eq=A, b_eq=rhs, bounds=(0, None), method="highs", options=LP_OPTIONS)
    if result.status != 0:
        raise SolverError(f"imbalance LP failed: {result.message}")
    slack = result.x[system.columns : system.columns + rows] + result.x[system.columns + rows :]
    moving = _bodies(system, slack > RESIDUAL_TOLERANCE)
    return StabilityVerdict(False, None, moving, float(result.fun))


def _bodies(system: EquilibriumSystem, rows: np.ndarray) -> tuple[int, ...]:
    """Return the sorted indices of the bodies owning the selected rows (a boolean mask of equations)."""
    return tuple(sorted({int(b) for b in system.body_of_row[rows]}))
