"""One HiGHS model kept alive across solves: warm restarts from saved bases, and an interior-point route to a basis.

This is the parametric programming of sec. III in practice. It uses the HiGHS binding that scipy ships
(``scipy.optimize._highspy``); if that private module is missing, every solve falls back to ``linprog``. For
objectives whose optimum is far from every saved basis, ``solve_by_interior_point`` solves by Clarabel's interior
point method and crosses over to an optimal HiGHS basis; HiGHS's simplex then certifies that basis.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

import numpy as np
from scipy import sparse
from scipy.optimize import linprog

try:  # scipy >= 1.15 ships the full HiGHS binding
    from scipy.optimize._highspy import _core as _highs
except ImportError:  # pragma: no cover - exercised only on older scipy
    _highs = None
try:
    import clarabel as _clarabel
except (
    ImportError
):  # pragma: no cover - requirements.lock installs it; without it far LPs stay on the simplex
    _clarabel = None

FEASIBILITY_TOLERANCE = 1e-9
PRIMAL_SIMPLEX = 4  # HiGHS simplex_strategy value
# Clarabel's gap and feasibility tolerances: the crossover only needs the right active set; HiGHS then certifies
# the crossover basis at its own 1e-9 tolerances (or the simplex continues from it).
INTERIOR_TOLERANCE = 1e-8
# HiGHS's crossover (IPX, through scipy's binding) crashed the process when it ran while another thread was in
# Clarabel, even on separate models: the whole interior point route runs under one process-wide lock.
_INTERIOR_POINT_LOCK = threading.Lock()


@dataclass(frozen=True)
class LPResult:
    """status: 'optimal', 'infeasible', 'limit' (pivot limit reached) or 'failed'; x and value when optimal."""

    status: str
    x: np.ndarray | None
    value: float
    message: str = ""


class WarmLP:
    """min c.x  s.t.  A x = b,  lower <= x <= upper  (inf for no bound)."""

    def __init__(self, A: sparse.spmatrix, b: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> None:
        self.A = sparse.csc_matrix(A)
        self.b = np.asarray(b, float)
        self.lower = np.asarray(lower, float).copy()
        self.upper = np.asarray(upper, float).copy()
        self.cost = np.zeros(self.A.shape[1])
        self.solves = 0
        self.crossovers = 0  # interior-point solves that reached a crossover basis (not a fallback)
        self._model = self._build() if _highs is not None else None
        self._has_run = False
        self._interior: _DualInteriorPoint | None = None  # built on first use, dropped when bounds change

    def _build(self):
        rows, cols = self.A.shape
        lp = _highs.HighsLp()
        lp.num_col_, lp.num_row_ = cols, rows
        lp.a_matrix_.num_col_, lp.a_matrix_.num_row_ = cols, rows
        lp.a_matrix_.format_ = _highs.MatrixFormat.kColwise
        lp.col_cost_ = self.cost.copy()
        lp.col_lower_ = np.where(np.isfinite(self.lower), self.lower, -_highs.kHighsInf)
        lp.col_upper_ = np.where(np.isfinite(self.upper), self.upper, _highs.kHighsInf)
        lp.row_lower_ = self.b.copy()
        lp.row_upper_ = self.b.copy()
        lp.a_matrix_.start_ = self.A.indptr.astype(np.int32)
        lp.a_matrix_.index_ = self.A.indices.astype(np.int32)
        lp.a_matrix_.value_ = self.A.data.astype(float)
        model = _highs._Highs()
        model.setOptionValue("output_flag", False)
        model.setOptionValue("primal_feasibility_tolerance", FEASIBILITY_TOLERANCE)
        model.setOptionValue("dual_feasibility_tolerance", FEASIBILITY_TOLERANCE)
        model.passModel(lp)
        return model

    def set_cost(self, indices: np.ndarray, values: np.ndarray) -> None:
        indices = np.asarray(indices, dtype=np.int32)
        values = np.asarray(values, dtype=float)
        self.cost[indices] = values
        if self._model is not None:
            self._model.changeColsCost(len(indices), indices, values)

    def set_bounds(self, indices: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> None:
        indices = np.asarray(indices, dtype=np.int32)
        self.lower[indices], self.upper[indices] = lower, upper
        self._interior = None
        if self._model is not None:
            self._model.changeColsBounds(
                len(indices), indices, np.asarray(lower, float), np.asarray(upper, float)
            )

    def basis(self):
        """The last solve's simplex basis (None if there is none), to restart a later solve from it."""
        if self._model is None:
            return None
        basis = self._model.getBasis()
        return basis if basis.valid else None

    def solve_from(self, basis, pivot_limit: int | None = None) -> LPResult:
        """Solve by the primal simplex started from ``basis`` (a basis saved by ``basis()`` on this model).

        A basis that was optimal for another objective stays primal feasible (only the costs changed), so the
        primal simplex continues from that vertex instead of restarting phase 1: with an objective close to the
        old one this takes a handful of pivots where a cold start takes thousands on these degenerate LPs.
        With ``pivot_limit`` the simplex stops after that many pivots with status 'limit'.
        """
        if self._model is None or basis is None:
            return self.solve(pivot_limit)
        self._model.setBasis(basis)
        return self._solve_with({"simplex_strategy": PRIMAL_SIMPLEX, "presolve": "off"}, pivot_limit)

    def solve(self, pivot_limit: int | None = None) -> LPResult:
        """Solve from the last basis (or cold); with ``pivot_limit``, status 'limit' after that many pivots."""
        return self._solve_with({}, pivot_limit)

    def _solve_with(self, options: dict, pivot_limit: int | None) -> LPResult:
        if self._model is None:
            return self._run()
        if pivot_limit is not None:
            options = {**options, "simplex_iteration_limit": int(pivot_limit)}
        model = self._model
        saved = {name: model.getOptionValue(name)[1] for name in options}
        for name, value in options.items():
            model.setOptionValue(name, value)
        try:
            return self._run()
        finally:
            if self._model is model:  # _run() rebuilds the model after a failure
                for name, value in saved.items():
                    model.setOptionValue(name, value)

    @property
    def pivots(self) -> int:
        """Simplex pivots of the last HiGHS run (0 without the HiGHS binding)."""
        return 0 if self._model is None else int(self._model.getInfo().simplex_iteration_count)

    @staticmethod
    def interior_point_available() -> bool:
        return _clarabel is not None and _highs is not None

    def solve_by_interior_point(self) -> LPResult:
        """Interior point (Clarabel), crossover to a vertex basis (HiGHS), then the simplex from that basis.

        On the degenerate support LPs a far optimum costs the simplex thousands of pivots (each O(rows)), while
        the interior point method needs 10-30 iterations whatever the distance. Its point lies inside the optimal
        face, so it is made complementary (each variable at a bound or with zero reduced cost) and HiGHS's
        crossover turns it into a basis. HiGHS certifies that basis optimal (primal and dual feasible at 1e-9, as
        after any simplex solve), or the simplex continues from it, so the result is exactly as trustworthy as a
        plain simplex solve. Any failure falls back to ``solve()``.
        """
        if not self.interior_point_available() or self._model is None:
            return self.solve()
        with _INTERIOR_POINT_LOCK:
            return self._interior_point_and_crossover()

    def _interior_point_and_crossover(self) -> LPResult:
        start = self._interior_point()
        if start is None:
            return self.solve()
        x, y = start
        if not self._has_run:
            # HiGHS's crossover dereferences solver state that only a first run creates (it crashes otherwise).
            self._solve_with({}, 0)
        solution = self._model.getSolution()  # a HighsSolution of the right shape, overwritten below
        reduced = self.cost - self.A.T @ y
        x, reduced = _complementary(x, reduced, self.lower, self.upper)
        solution.col_value = x.tolist()
        solution.col_dual = reduced.tolist()
        solution.row_value = (self.A @ x).tolist()
        solution.row_dual = y.tolist()
        solution.value_valid = True
        solution.dual_valid = True
        self._model.crossover(solution)
        basis = self._model.getBasis()
        if not basis.valid:
            return self.solve()
        self.crossovers += 1
        if self._model.getModelStatus() == _highs.HighsModelStatus.kOptimal:
            # HiGHS checked the crossover basis primal and dual feasible at its 1e-9 tolerances: a certified optimum.
            x = np.asarray(self._model.getSolution().col_value)
            return LPResult("optimal", x, float(self.cost @ x))
        return self.solve_from(basis)

    def _interior_point(self) -> tuple[np.ndarray, np.ndarray] | None:
        """Primal x and row duals y (HiGHS's sign: reduced costs c - A^T y) by Clarabel on the dual LP.

        The dual,  max b.y + l.v - u.w  s.t.  A^T y + v - w = c,  v, w >= 0  (v only for finite lower bounds, w
        only for finite upper ones), has one row per column of A and few variables: on the support LPs its KKT
        system is half the size of the primal's and solves about 1.5x faster. x comes back as its multipliers.
        The Clarabel solver (ordering and symbolic factorisation) is kept while only the costs c change.
        """
        if self._interior is None:
            self._interior = _DualInteriorPoint(self.A, self.b, self.lower, self.upper)
        return self._interior.solve(self.cost)

    def _run(self) -> LPResult:
        self.solves += 1
        if self._model is None:
            return self._solve_linprog()
        self._model.run()
        self._has_run = True
        status = self._model.getModelStatus()
        if status == _highs.HighsModelStatus.kOptimal:
            x = np.asarray(self._model.getSolution().col_value)
            return LPResult("optimal", x, float(self.cost @ x))
        if status == _highs.HighsModelStatus.kInfeasible:
            return LPResult("infeasible", None, float("nan"), "infeasible")
        if status == _highs.HighsModelStatus.kIterationLimit:
            return LPResult("limit", None, float("nan"), "simplex pivot limit reached")
        # Anything else (a stalled warm start, say): one cold solve before giving up.
        result = self._solve_linprog()
        self._model = self._build()
        self._has_run = False
        return result

    def _solve_linprog(self) -> LPResult:
        bounds = np.column_stack(
            [
                np.where(np.isfinite(self.lower), self.lower, -np.inf),
                np.where(np.isfinite(self.upper), self.upper, np.inf),
            ]
        )
        result = linprog(
            self.cost,
            A_eq=self.A,
            b_eq=self.b,
            bounds=bounds,
            method="highs",
            options={
                "primal_feasibility_tolerance": FEASIBILITY_TOLERANCE,
                "dual_feasibility_tolerance": FEASIBILITY_TOLERANCE,
            },
        )
        if result.status == 0:
            return LPResult("optimal", result.x, float(result.fun))
        if result.status == 2:
            return LPResult("infeasible", None, float("nan"), result.message)
        return LPResult("failed", None, float("nan"), result.message)


def _complementary(
    x: np.ndarray, reduced: np.ndarray, lower: np.ndarray, upper: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The crossover's start: each variable either at a bound (reduced cost of the right sign) or with zero
    reduced cost, chosen by which of distance-to-bound and reduced cost is smaller (the interior point's own
    indicator of the active set).
    """
    x = np.clip(x, lower, upper)
    reduced = reduced.copy()
    at_lower = np.isfinite(lower) & (x - lower <= np.maximum(reduced, 0.0))
    at_upper = ~at_lower & np.isfinite(upper) & (upper - x <= np.maximum(-reduced, 0.0))
    x[at_lower] = lower[at_lower]
    x[at_upper] = upper[at_upper]
    reduced[at_lower] = np.maximum(reduced[at_lower], 0.0)
    reduced[at_upper] = np.minimum(reduced[at_upper], 0.0)
    reduced[~(at_lower | at_upper)] = 0.0
    return x, reduced


class _DualInteriorPoint:
    """Clarabel on the dual of  min c.x  s.t.  A x = b,  l <= x <= u;  c enters only the right-hand side."""

    def __init__(self, A: sparse.csc_matrix, b: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> None:
        rows, cols = A.shape
        has_lower, has_upper = np.isfinite(lower), np.isfinite(upper)
        self.fixed = has_lower & has_upper & (lower == upper)
        self.boxed = has_lower & has_upper & ~self.fixed
        self.lower_only = has_lower & ~has_upper
        self.upper_only = has_upper & ~has_lower
        self.free = ~has_lower & ~has_upper
        self.lower, self.upper, self.rows = lower, upper, rows
        AT = sparse.csr_matrix(A.T)
        k = int(self.boxed.sum())
        eye = sparse.identity(k, format="csr")
        pick = lambda mask: AT[np.nonzero(mask)[0]]  # noqa: E731
        zeros = lambda mask: sparse.csr_matrix((int(mask.sum()), k))  # noqa: E731
        # Variables (y, v, w) with v, w the boxed columns' bound multipliers. Zero-cone rows: free and boxed
        # columns (A_j.y + v_j - w_j = c_j); non-negative rows: one-sided columns, then v >= 0 and w >= 0.
        G = sparse.vstack(
            [
                sparse.hstack([pick(self.free), zeros(self.free), zeros(self.free)]),
                sparse.hstack([pick(self.boxed), eye, -eye]),
                sparse.hstack([pick(self.lower_only), zeros(self.lower_only), zeros(self.lower_only)]),
                sparse.hstack([-pick(self.upper_only), zeros(self.upper_only), zeros(self.upper_only)]),
                sparse.hstack([sparse.csr_matrix((k, rows)), -eye, sparse.csr_matrix((k, k))]),
                sparse.hstack([sparse.csr_matrix((k, rows)), sparse.csr_matrix((k, k)), -eye]),
            ],
            format="csc",
        )
        # The dual objective's y-part collects the bounds of one-sided and fixed columns.
        bound_of = np.where(self.lower_only | self.fixed, lower, np.where(self.upper_only, upper, 0.0))
        bound_of = np.where(np.isfinite(bound_of), bound_of, 0.0)
        q = np.concatenate([-b + A @ bound_of, -lower[self.boxed], upper[self.boxed]])
        equalities = int(self.free.sum()) + k
        inequalities = int(self.lower_only.sum() + self.upper_only.sum()) + 2 * k
        cones = [
            cone(size)
            for cone, size in ((_clarabel.ZeroConeT, equalities), (_clarabel.NonnegativeConeT, inequalities))
            if size
        ]
        self.settings = _clarabel.DefaultSettings()
        self.settings.verbose = False
        self.settings.presolve_enable = False  # keeps the rows fixed, so later costs update the data in place
        # The static KKT regularisation only slows these LPs down; the dynamic one still guards singular pivots.
        self.settings.static_regularization_enable = False
        self.settings.tol_gap_abs = self.settings.tol_gap_rel = self.settings.tol_feas = INTERIOR_TOLERANCE
        self.G, self.q, self.cones = G, q, cones
        self._solver = None

    def _rhs(self, cost: np.ndarray) -> np.ndarray:
        k = int(self.boxed.sum())
        return np.concatenate(
            [
                cost[self.free],
                cost[self.boxed],
                cost[self.lower_only],
                -cost[self.upper_only],
                np.zeros(2 * k),
            ]
        )

    def solve(self, cost: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        h = self._rhs(cost)
        if self._solver is None:
            size = self.G.shape[1]
            self._solver = _clarabel.DefaultSolver(
                sparse.csc_matrix((size, size)), self.q, self.G, h, self.cones, self.settings
            )
        else:
            self._solver.update(b=h)
        solution = self._solver.solve()
        if str(solution.status) not in ("Solved", "AlmostSolved"):
            return None
        y = np.asarray(solution.x, float)[: self.rows]
        z = np.asarray(solution.z, float)
        x = np.where(self.fixed, self.lower, 0.0)
        counts = np.cumsum(
            [0, self.free.sum(), self.boxed.sum(), self.lower_only.sum(), self.upper_only.sum()]
        )
        x[self.free] = z[counts[0] : counts[1]]
        x[self.boxed] = z[counts[1] : counts[2]]
        x[self.lower_only] = self.lower[self.lower_only] + z[counts[2] : counts[3]]
        x[self.upper_only] = self.upper[self.upper_only] - z[counts[3] : counts[4]]
        return x, y
