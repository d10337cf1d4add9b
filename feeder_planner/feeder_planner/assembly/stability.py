"""The stability linear program (eq. 9) for one gravity direction, and its support form over the cube (sec. III)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import sparse
from scipy.optimize import linprog

from feeder_planner.assembly.lp import WarmLP
from feeder_planner.assembly.wrench import EquilibriumSystem, contact_forces
from feeder_planner.errors import InputError, SolverError

# HiGHS tolerances; a stable verdict is certified by re-checking the residual of the returned forces.
LP_OPTIONS = {"primal_feasibility_tolerance": 1e-9, "dual_feasibility_tolerance": 1e-9, "presolve": True}
RESIDUAL_TOLERANCE = 1e-7  # on the scaled equations: a fraction of each body's weight (and weight x size)
# A restarted support LP still unsolved after this many pivots has its optimum in another corner of P: it is
# solved by the interior point method and crossover instead (see SupportOracle). Small LPs never get there.
FAR_PIVOTS = 150


@dataclass(frozen=True)
class StabilityVerdict:
    """Whether g is potentially stable; forces (N, on body a, per contact) when it is, else the unbalanced bodies."""

    stable: bool
    forces: np.ndarray | None
    unbalanced: tuple[int, ...]
    residual: float


def unit_gravity(g: np.ndarray, field: str = "g") -> np.ndarray:
    """A finite, non-zero gravity direction, normalised."""
    g = np.asarray(g, dtype=float).reshape(-1)
    if g.shape != (3,):
        raise InputError(field, f"expected 3 components, got {g.size}")
    if not np.all(np.isfinite(g)):
        raise InputError(field, f"must be finite, got {g.tolist()}")
    norm = float(np.linalg.norm(g))
    if norm < 1e-12:
        raise InputError(field, "must be a non-zero direction")
    return g / norm


class StabilityChecker:
    """Eq. (9) for one gravity direction at a time, on one warm-started LP (g's columns fixed by bounds)."""

    def __init__(self, system: EquilibriumSystem) -> None:
        self.system = system
        columns = system.columns
        A = sparse.hstack([sparse.csc_matrix(system.B), system.A], format="csc")
        self.lp = WarmLP(A, np.zeros(system.A.shape[0]), np.concatenate([np.zeros(3), np.zeros(columns)]),
                         np.concatenate([np.zeros(3), np.full(columns, np.inf)]))
        # Minimise the total multiplier: a bounded objective that picks a small, well-scaled force distribution.
        self.lp.set_cost(np.arange(3, 3 + columns), np.ones(columns))

    def __call__(self, g: np.ndarray, explain: bool = True) -> StabilityVerdict:
        """Verdict for g; ``explain`` also finds the bodies that cannot be balanced when unstable (one more LP)."""
        system = self.system
        g = unit_gravity(g)
        rhs = -system.B @ g
        if system.A.shape[0] == 0:
            return StabilityVerdict(True, np.zeros((len(system.contacts), 3)), (), 0.0)
        if system.columns == 0:
            return StabilityVerdict(False, None, _bodies(system, np.abs(rhs) > RESIDUAL_TOLERANCE),
                                    float(np.abs(rhs).max()))
        self.lp.set_bounds(np.arange(3), g, g)
        result = self.lp.solve()
        if result.status == "optimal":
            lam = np.maximum(result.x[3:], 0.0)
            residual = float(np.abs(system.A @ lam - rhs).max())
            if residual > RESIDUAL_TOLERANCE:
                raise SolverError(f"stability LP returned forces with residual {residual:.3g} > {RESIDUAL_TOLERANCE}")
            return StabilityVerdict(True, contact_forces(system, lam), (), residual)
        if result.status == "infeasible":
            return _unbalanced(system, rhs) if explain else StabilityVerdict(False, None, (), float("nan"))
        raise SolverError(f"stability LP failed: {result.message}")


def check_stability(system: EquilibriumSystem, g: np.ndarray) -> StabilityVerdict:
    """Solve eq. (9) for unit g: feasible contact forces exist iff the assembly is potentially stable."""
    return StabilityChecker(system)(g)


def _unbalanced(system: EquilibriumSystem, rhs: np.ndarray) -> StabilityVerdict:
    """Least total imbalance (L1 over the scaled rows); bodies with imbalance left are the ones that move."""
    rows = system.A.shape[0]
    identity = sparse.identity(rows, format="csc")
    A = sparse.hstack([system.A, identity, -identity], format="csc")
    cost = np.concatenate([np.zeros(system.columns), np.ones(2 * rows)])
    result = linprog(cost, A_eq=A, b_eq=rhs, bounds=(0, None), method="highs", options=LP_OPTIONS)
    if result.status != 0:
        raise SolverError(f"imbalance LP failed: {result.message}")
    slack = result.x[system.columns:system.columns + rows] + result.x[system.columns + rows:]
    moving = _bodies(system, slack > RESIDUAL_TOLERANCE)
    return StabilityVerdict(False, None, moving, float(result.fun))


def _bodies(system: EquilibriumSystem, rows: np.ndarray) -> tuple[int, ...]:
    return tuple(sorted({int(b) for b in system.body_of_row[rows]}))


class SupportOracle:
    """max c.g over the cube section {g in V, |g|_inf <= 1} of the stable cone V (sec. III); counts its LPs."""

    def __init__(self, system: EquilibriumSystem, far_pivots: int | None = FAR_PIVOTS) -> None:
        """``far_pivots``: simplex pivots after which an LP moves to the interior point route (None: never)."""
        self.system = system
        columns = system.columns
        A = sparse.hstack([sparse.csc_matrix(system.B), system.A], format="csc")
        self.far_pivots = far_pivots
        self.lp = WarmLP(A, np.zeros(system.A.shape[0]), np.concatenate([-np.ones(3), np.zeros(columns)]),
                         np.concatenate([np.ones(3), np.full(columns, np.inf)]))
        self.calls = 0
        self.far_solves = 0
        # Optimal bases found so far, with their maximisers g: each is primal feasible for any new direction.
        self._points: list[np.ndarray] = []
        self._bases: list = []

    def __call__(self, direction: np.ndarray) -> tuple[float, np.ndarray]:
        self.calls += 1
        direction = np.asarray(direction, dtype=float)
        if self.system.A.shape[0] == 0:  # nothing free: every g is stable
            g = np.where(direction >= 0, 1.0, -1.0)
            return float(direction @ g), g
        self.lp.set_cost(np.arange(3), -direction)
        # Parametric start (sec. III): the primal simplex resumes from the known vertex of P that is best for the
        # new direction. Restarting from the last basis instead (whatever its vertex) costs thousands of
        # degenerate pivots on statically indeterminate assemblies. An optimum in another corner of P is still
        # thousands of pivots away (each O(rows)): past FAR_PIVOTS the interior point method, whose cost does not
        # grow with that distance, takes over and hands back an optimal basis for later restarts.
        limit = self.far_pivots if self.lp.interior_point_available() else None
        if self._points:
            best = int(np.argmax(np.asarray(self._points) @ direction))
            result = self.lp.solve_from(self._bases[best], limit)
        else:
            result = self.lp.solve(limit)
        if result.status == "limit":
            self.far_solves += 1
            result = self.lp.solve_by_interior_point()
        if result.status != "optimal":
            raise SolverError(f"support LP failed ({result.status}): {result.message}")
        g = np.clip(result.x[:3], -1.0, 1.0)
        lam = np.maximum(result.x[3:], 0.0)
        residual = float(np.abs(self.system.A @ lam + self.system.B @ g).max()) if self.system.columns else 0.0
        if residual > RESIDUAL_TOLERANCE:
            raise SolverError(f"support LP residual {residual:.3g} > {RESIDUAL_TOLERANCE}")
        basis = self.lp.basis()
        if basis is not None:
            self._points.append(g)
            self._bases.append(basis)
        return float(direction @ g), g
