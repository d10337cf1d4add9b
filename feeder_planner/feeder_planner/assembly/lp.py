"""One HiGHS model kept alive across solves: a changed bound re-solves from the last basis, a new objective can
restart from any saved optimal basis.

This is the parametric programming of sec. III in practice. It uses the HiGHS binding that scipy ships
(``scipy.optimize._highspy``); if that private module is missing, every solve falls back to ``linprog``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import sparse
from scipy.optimize import linprog

try:  # scipy >= 1.15 ships the full HiGHS binding
    from scipy.optimize._highspy import _core as _highs
except ImportError:  # pragma: no cover - exercised only on older scipy
    _highs = None

FEASIBILITY_TOLERANCE = 1e-9
PRIMAL_SIMPLEX = 4  # HiGHS simplex_strategy value


@dataclass(frozen=True)
class LPResult:
    """status: 'optimal', 'infeasible' or 'failed'; x and the objective value when optimal."""

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
        self._model = self._build() if _highs is not None else None

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
        if self._model is not None:
            self._model.changeColsBounds(len(indices), indices, np.asarray(lower, float), np.asarray(upper, float))

    def basis(self):
        """The last solve's simplex basis (None if there is none), to restart a later solve from it."""
        if self._model is None:
            return None
        basis = self._model.getBasis()
        return basis if basis.valid else None

    def solve_from(self, basis) -> LPResult:
        """Solve by the primal simplex started from ``basis`` (a basis saved by ``basis()`` on this model).

        A basis that was optimal for another objective stays primal feasible (only the costs changed), so the
        primal simplex continues from that vertex instead of restarting phase 1: with an objective close to the
        old one this takes a handful of pivots where a cold start takes thousands on these degenerate LPs.
        """
        if self._model is None or basis is None:
            return self.solve()
        model = self._model
        saved = {name: model.getOptionValue(name)[1] for name in ("simplex_strategy", "presolve")}
        model.setBasis(basis)
        model.setOptionValue("simplex_strategy", PRIMAL_SIMPLEX)
        model.setOptionValue("presolve", "off")
        try:
            return self.solve()
        finally:
            for name, value in saved.items():
                if self._model is model:  # solve() rebuilds the model after a failure
                    model.setOptionValue(name, value)

    def solve(self) -> LPResult:
        self.solves += 1
        if self._model is None:
            return self._solve_linprog()
        self._model.run()
        status = self._model.getModelStatus()
        if status == _highs.HighsModelStatus.kOptimal:
            x = np.asarray(self._model.getSolution().col_value)
            return LPResult("optimal", x, float(self.cost @ x))
        if status == _highs.HighsModelStatus.kInfeasible:
            return LPResult("infeasible", None, float("nan"), "infeasible")
        # Anything else (a stalled warm start, say): one cold solve before giving up.
        result = self._solve_linprog()
        self._model = self._build()
        return result

    def _solve_linprog(self) -> LPResult:
        bounds = np.column_stack([np.where(np.isfinite(self.lower), self.lower, -np.inf),
                                  np.where(np.isfinite(self.upper), self.upper, np.inf)])
        result = linprog(self.cost, A_eq=self.A, b_eq=self.b, bounds=bounds, method="highs",
                         options={"primal_feasibility_tolerance": FEASIBILITY_TOLERANCE,
                                  "dual_feasibility_tolerance": FEASIBILITY_TOLERANCE})
        if result.status == 0:
            return LPResult("optimal", result.x, float(result.fun))
        if result.status == 2:
            return LPResult("infeasible", None, float("nan"), result.message)
        return LPResult("failed", None, float("nan"), result.message)
