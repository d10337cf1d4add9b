"""The support function of the stable cone's cube section (sec. III): max c.g over {g in V, |g|_inf <= 1}."""

from __future__ import annotations

import highspy
import numpy as np
from scipy import sparse

from feeder_planner.assembly.lp import LPResult, WarmLP
from feeder_planner.assembly.tolerances import (
    FACE_TILT,
    FAR_PIVOTS,
    INTERIOR_POINT_ROWS,
    RESIDUAL_TOLERANCE,
    TILT_AXIS,
)
from feeder_planner.assembly.wrench import EquilibriumSystem
from feeder_planner.errors import SolverError

__all__ = ["SupportOracle"]


class SupportOracle:
    """max c.g over the cube section of V for one equilibrium system; counts its LPs.

    Each call is one LP over eq. (12)'s feasible set with the cube's bounds on all of g, its objective the
    paper's eq. (13) extended to three components. Every optimal basis found is kept with its maximiser g: any
    of them is primal feasible for a new objective, so each LP restarts the primal simplex from the kept
    vertex best for its direction (the parametric programming of sec. III).
    """

    def __init__(self, system: EquilibriumSystem, far_pivots: int | None = FAR_PIVOTS) -> None:
        """Set up the LP; ``far_pivots``: pivots after which an LP goes by interior point (None: never)."""
        self.system = system
        self.far_pivots = far_pivots
        self.calls = 0
        self.far_solves = 0
        columns = system.columns
        A = sparse.hstack([sparse.csc_matrix(system.B), system.A], format="csc")
        self.lp = WarmLP(
            A,
            np.zeros(system.A.shape[0]),
            np.concatenate([-np.ones(3), np.zeros(columns)]),
            np.concatenate([np.ones(3), np.full(columns, np.inf)]),
        )
        self._large = system.A.shape[0] >= INTERIOR_POINT_ROWS
        self._points: list[np.ndarray] = []
        self._bases: list[highspy.HighsBasis] = []

    def __call__(self, direction: np.ndarray) -> tuple[float, np.ndarray]:
        """Return max direction.g over P and a maximiser g, certified by our residual check."""
        direction = np.asarray(direction, dtype=float)
        self.calls += 1
        if self.system.A.shape[0] == 0:  # nothing free: every g is stable
            g = np.where(direction >= 0, 1.0, -1.0)
            return float(direction @ g), g
        self.lp.set_cost(np.arange(3), -direction)
        result = self._optimise(direction, self._restart_basis(direction))
        if result.status != "optimal":
            raise SolverError(f"support LP failed ({result.status}): {result.message}")
        x = result.solution
        g = np.clip(x[:3], -1.0, 1.0)
        lam = np.maximum(x[3:], 0.0)
        residual = (
            float(np.abs(self.system.A @ lam + self.system.B @ g).max()) if self.system.columns else 0.0
        )
        if residual > RESIDUAL_TOLERANCE:
            raise SolverError(f"support LP residual {residual:.3g} > {RESIDUAL_TOLERANCE}")
        basis = self.lp.basis()
        if basis is not None:
            self._points.append(g)
            self._bases.append(basis)
        return float(direction @ g), g

    def _restart_basis(self, direction: np.ndarray) -> highspy.HighsBasis | None:
        """Return the kept basis whose vertex is best for ``direction`` (None before the first LP)."""
        if not self._points:
            return None
        return self._bases[int(np.argmax(np.asarray(self._points) @ direction))]

    def _optimise(self, direction: np.ndarray, start: highspy.HighsBasis | None) -> LPResult:
        """Solve by the restarted primal simplex; past ``far_pivots`` (large LPs) by interior point.

        Restarting from the last basis instead of the best vertex's costs thousands of degenerate pivots on
        statically indeterminate assemblies. An optimum in another corner of P is still thousands of pivots
        away (each O(rows)); the interior point method's cost does not grow with that distance, and its
        crossover hands back an optimal basis for later restarts.
        """
        lp = self.lp
        use_interior_point = self._large and self.far_pivots is not None and lp.interior_point_available()
        if use_interior_point and start is None:
            # Nothing to restart from: a cold simplex on a large degenerate LP takes thousands of pivots.
            return self._far_optimum(direction)
        limit = self.far_pivots if use_interior_point else None
        result = lp.solve_from(start, limit) if start is not None else lp.solve(limit)
        if result.status == "limit":
            result = self._far_optimum(direction)
        return result

    def _far_optimum(self, direction: np.ndarray) -> LPResult:
        """Solve by interior point + crossover on a tilted objective, then by simplex on the exact one.

        When ``direction`` is normal to an edge or facet of P (common: hull facets of symmetric assemblies)
        the interior point method returns the centre of that face, not a vertex of P, and the far LP is wasted
        on a point the hull does not need. Tilting by FACE_TILT (far above the interior point tolerance, 1e-8)
        breaks the tie towards one vertex of the face; that vertex is still optimal for the exact direction
        unless its normal cone is thinner than the tilt, and the simplex run on the exact objective from the
        crossover basis certifies it (usually without a pivot) or moves on to the exact optimum.
        """
        self.far_solves += 1
        lp = self.lp
        scale = float(np.linalg.norm(direction))
        lp.set_cost(np.arange(3), -(direction + FACE_TILT * scale * TILT_AXIS))
        lp.solve_by_interior_point()
        lp.set_cost(np.arange(3), -direction)
        basis = lp.basis()
        return lp.solve_from(basis) if basis is not None else lp.solve()
