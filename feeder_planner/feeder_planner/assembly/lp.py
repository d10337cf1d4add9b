"""One HiGHS model kept across solves: warm restarts from saved bases, an interior-point route to a basis.

This is the parametric programming of sec. III in practice. It uses the public HiGHS binding ``highspy`` (a
hard dependency, pinned in requirements.lock); a model HiGHS cannot solve (a stalled warm start, say) gets one
cold ``linprog`` solve and a fresh model. For objectives whose optimum is far from every saved basis,
``solve_by_interior_point`` solves by Clarabel's interior point method and crosses over to an optimal HiGHS
basis; HiGHS's simplex then certifies that basis.

Two crash modes of HiGHS's crossover are guarded here (commit b5ff2b8, tests in test_interior_point_lp.py): it
crashed the process when it ran while another thread was inside Clarabel, even on separate models, so the
whole interior point route runs under one process-wide lock; and it dereferences solver state that only a
first run creates, so a model that never ran is run once (with a zero pivot limit) before its first crossover.

The public binding replaced scipy's private ``scipy.optimize._highspy._core`` (HiGHS 1.12 as vendored by scipy
1.17). Measured on the 960-point connected wall (brick_wall(12, 8)), 20 interleaved runs in one process: the
same pivots (3777 per region) and the same region, 0.790 s median against 0.776 s. The 1.8 % is HiGHS 1.16's
0.18 ms larger fixed cost per warm-started run (1.82 ms against 1.63 ms for a zero-pivot restart), not the
binding: with highspy's callbacks off it is the same. Kept for a public, pinned API over a scipy internal.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Literal, get_args

import highspy
import numpy as np
from scipy import sparse
from scipy.optimize import linprog

from feeder_planner.assembly.tolerances import FEASIBILITY_TOLERANCE, INTERIOR_TOLERANCE

try:
    import clarabel as _clarabel
except (
    ImportError
):  # pragma: no cover - requirements.lock installs it; without it far LPs stay on the simplex
    _clarabel = None

__all__ = ["LP_PHASES", "LP_STATUSES", "LPResult", "LPStatus", "WarmLP"]

LPStatus = Literal["optimal", "infeasible", "limit", "failed"]
"""'optimal', 'infeasible', 'limit' (the pivot limit was reached) or 'failed' (anything else)."""
LP_STATUSES: tuple[LPStatus, ...] = get_args(LPStatus)
# Where a model's solving time goes (WarmLP.seconds): Clarabel's interior point, HiGHS's crossover, and every
# HiGHS simplex run (warm restarts, certificates, cold solves and the linprog fallback).
LP_PHASES = ("interior_point", "crossover", "simplex")

# Clarabel's sparse LDL^T for the interior point route (see _DualInteriorPoint).
INTERIOR_LINEAR_SOLVER = "faer"
PRIMAL_SIMPLEX = int(highspy.simplex_constants.SimplexStrategy.kSimplexStrategyPrimal)
# HiGHS's crossover crashed the process when it ran while another thread was in Clarabel, even on separate
# models: the whole interior point route runs under one process-wide lock.
_INTERIOR_POINT_LOCK = threading.Lock()


class _QuietHighs(highspy.Highs):
    """``highspy.Highs`` whose console output is off before HiGHS can print anything.

    ``highspy.Highs.__init__`` registers its callback dispatcher (``enableCallbacks``), and HiGHS prints its
    banner on stdout at that moment while output is on (the default): one line of text before the JSON object
    of ``feeder ... --json``. Turning ``output_flag`` off first keeps stdout clean.
    """

    def enableCallbacks(self) -> None:  # noqa: N802 - highspy's name
        """Silence the model, then register highspy's callback dispatcher."""
        self.setOptionValue("output_flag", False)
        super().enableCallbacks()


@dataclass(frozen=True)
class LPResult:
    """The outcome of one solve: ``x`` and ``value`` when 'optimal', else None and NaN with a message."""

    status: LPStatus
    x: np.ndarray | None
    value: float
    message: str = ""

    @property
    def solution(self) -> np.ndarray:
        """The optimal x; raises ValueError when the status is not 'optimal'."""
        if self.x is None:
            raise ValueError(f"no solution: the LP is {self.status} ({self.message})")
        return self.x


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
        self.seconds = dict.fromkeys(LP_PHASES, 0.0)  # wall-clock seconds per phase, summed over all solves
        self._model = self._build()
        self._has_run = False
        self._interior: _DualInteriorPoint | None = None  # built on first use, dropped when bounds change

    def _build(self) -> highspy.Highs:
        """Build a fresh HiGHS model of the LP with the current costs and bounds, at our tolerances."""
        rows, cols = self.A.shape
        lp = highspy.HighsLp()
        lp.num_col_, lp.num_row_ = cols, rows
        lp.a_matrix_.num_col_, lp.a_matrix_.num_row_ = cols, rows
        lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
        lp.col_cost_ = self.cost.copy()
        lp.col_lower_ = np.where(np.isfinite(self.lower), self.lower, -highspy.kHighsInf)
        lp.col_upper_ = np.where(np.isfinite(self.upper), self.upper, highspy.kHighsInf)
        lp.row_lower_ = self.b.copy()
        lp.row_upper_ = self.b.copy()
        lp.a_matrix_.start_ = self.A.indptr.astype(np.int32)
        lp.a_matrix_.index_ = self.A.indices.astype(np.int32)
        lp.a_matrix_.value_ = self.A.data.astype(float)
        model = _QuietHighs()
        model.setOptionValue("primal_feasibility_tolerance", FEASIBILITY_TOLERANCE)
        model.setOptionValue("dual_feasibility_tolerance", FEASIBILITY_TOLERANCE)
        model.passModel(lp)
        return model

    def set_cost(self, indices: np.ndarray, values: np.ndarray) -> None:
        """Change the objective coefficients of the columns ``indices`` (the model keeps its basis)."""
        indices = np.asarray(indices, dtype=np.int32)
        values = np.asarray(values, dtype=float)
        self.cost[indices] = values
        self._model.changeColsCost(len(indices), indices, values)

    def set_bounds(self, indices: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> None:
        """Change the bounds of the columns ``indices``."""
        indices = np.asarray(indices, dtype=np.int32)
        self.lower[indices], self.upper[indices] = lower, upper
        self._interior = None
        self._model.changeColsBounds(
            len(indices), indices, np.asarray(lower, float), np.asarray(upper, float)
        )

    def basis(self) -> highspy.HighsBasis | None:
        """Return the last solve's simplex basis (None if there is none), to restart a later solve from it."""
        basis = self._model.getBasis()
        return basis if basis.valid else None

    def solve_from(self, basis: highspy.HighsBasis | None, pivot_limit: int | None = None) -> LPResult:
        """Solve by the primal simplex started from ``basis`` (a basis saved by ``basis()`` on this model).

        A basis that was optimal for another objective stays primal feasible (only the costs changed), so the
        primal simplex continues from that vertex instead of restarting phase 1: with an objective close to
        the old one this takes a handful of pivots where a cold start takes thousands on these degenerate LPs.
        With ``pivot_limit`` the simplex stops after that many pivots with status 'limit'.
        """
        if basis is None:
            return self.solve(pivot_limit)
        self._model.setBasis(basis)
        return self._solve_with({"simplex_strategy": PRIMAL_SIMPLEX, "presolve": "off"}, pivot_limit)

    def solve(self, pivot_limit: int | None = None) -> LPResult:
        """Solve from the last basis (or cold); with ``pivot_limit``, status 'limit' after so many pivots."""
        return self._solve_with({}, pivot_limit)

    def _solve_with(self, options: dict[str, int | float | str], pivot_limit: int | None) -> LPResult:
        """Run with ``options`` set for this solve only (the model's own values are restored afterwards)."""
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
        """Simplex pivots of the last HiGHS run."""
        return int(self._model.getInfo().simplex_iteration_count)

    @staticmethod
    def interior_point_available() -> bool:
        """Whether the interior point route can run (Clarabel is importable)."""
        return _clarabel is not None

    def solve_by_interior_point(self) -> LPResult:
        """Interior point (Clarabel), crossover to a vertex basis (HiGHS), then the simplex from that basis.

        On the degenerate support LPs a far optimum costs the simplex thousands of pivots (each O(rows)),
        while the interior point method needs 10-30 iterations whatever the distance. Its point lies inside
        the optimal face, so it is made complementary (each variable at a bound or with zero reduced cost) and
        HiGHS's crossover turns it into a basis. HiGHS certifies that basis optimal (primal and dual feasible
        at 1e-9, as after any simplex solve), or the simplex continues from it, so the result is exactly as
        trustworthy as a plain simplex solve. Any failure falls back to ``solve()``.
        """
        if not self.interior_point_available():
            return self.solve()
        with _INTERIOR_POINT_LOCK:
            return self._interior_point_and_crossover()

    def _interior_point_and_crossover(self) -> LPResult:
        """Run the interior point route's steps under the lock: point, crossover, certificate (or simplex)."""
        start = self._interior_point()
        if start is None:
            return self.solve()
        if not self._ensure_has_run():
            return self.solve()
        crossover_start = self._crossover_start(*start)
        with self._timed("crossover"):
            self._model.crossover(crossover_start)
        basis = self._model.getBasis()
        if not basis.valid:
            return self.solve()
        self.crossovers += 1
        if self._model.getModelStatus() == highspy.HighsModelStatus.kOptimal:
            # HiGHS checked the crossover basis primal and dual feasible at 1e-9: a certified optimum.
            x = np.asarray(self._model.getSolution().col_value)
            return LPResult("optimal", x, float(self.cost @ x))
        return self.solve_from(basis)

    def _ensure_has_run(self) -> bool:
        """Run a never-run model once, with no pivot allowed; False if the model still has not run.

        HiGHS's crossover dereferences solver state that only a first run creates (it crashes otherwise). A
        run that fails rebuilds the model (see ``_run``), which then has not run either: no crossover on it.
        """
        if not self._has_run:
            self._solve_with({}, 0)
        return self._has_run

    def _crossover_start(self, x: np.ndarray, y: np.ndarray) -> highspy.HighsSolution:
        """Return the crossover's input: the complementary primal-dual pair of ``x`` and row duals ``y``."""
        solution = self._model.getSolution()  # a HighsSolution of the right shape, overwritten below
        x, reduced = _complementary(x, self.cost - self.A.T @ y, self.lower, self.upper)
        solution.col_value = x.tolist()
        solution.col_dual = reduced.tolist()
        solution.row_value = (self.A @ x).tolist()
        solution.row_dual = y.tolist()
        solution.value_valid = True
        solution.dual_valid = True
        return solution

    def _interior_point(self) -> tuple[np.ndarray, np.ndarray] | None:
        """Primal x and row duals y (HiGHS's sign: reduced costs c - A^T y) by Clarabel on the dual LP.

        The dual,  max b.y + l.v - u.w  s.t.  A^T y + v - w = c,  v, w >= 0  (v only for finite lower bounds,
        w only for finite upper ones), has one row per column of A and few variables: on the support LPs its
        KKT system is half the size of the primal's and solves about 1.5x faster. x comes back as its
        multipliers. The Clarabel solver (ordering and symbolic factorisation) is kept while only the costs c
        change.
        """
        with self._timed("interior_point"):
            if self._interior is None:
                self._interior = _DualInteriorPoint(self.A, self.b, self.lower, self.upper)
            return self._interior.solve(self.cost)

    @contextmanager
    def _timed(self, phase: str) -> Iterator[None]:
        """Add the wall-clock time of the block to ``seconds[phase]``."""
        started = time.perf_counter()
        try:
            yield
        finally:
            self.seconds[phase] += time.perf_counter() - started

    def _run(self) -> LPResult:
        """One HiGHS run with the current options, its status mapped to an LPResult."""
        self.solves += 1
        with self._timed("simplex"):
            self._model.run()
        self._has_run = True
        status = self._model.getModelStatus()
        if status == highspy.HighsModelStatus.kOptimal:
            x = np.asarray(self._model.getSolution().col_value)
            return LPResult("optimal", x, float(self.cost @ x))
        if status == highspy.HighsModelStatus.kInfeasible:
            return LPResult("infeasible", None, float("nan"), "infeasible")
        if status == highspy.HighsModelStatus.kIterationLimit:
            return LPResult("limit", None, float("nan"), "simplex pivot limit reached")
        # Anything else (a stalled warm start, say): one cold solve before giving up, and a fresh model.
        with self._timed("simplex"):
            result = self._solve_linprog()
        self._model = self._build()
        self._has_run = False
        return result

    def _solve_linprog(self) -> LPResult:
        """Solve the same LP cold by scipy's ``linprog`` (no shared state with the model)."""
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
    """Return the crossover's start: each variable at a bound (reduced cost of the right sign) or cost-free.

    Which one is chosen by the smaller of distance-to-bound and reduced cost (the interior point's own
    indicator of the active set); variables left between their bounds get reduced cost 0.
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


@dataclass(frozen=True)
class _ColumnKinds:
    """The columns of an LP by the kind of their bounds (boolean masks, each column in exactly one)."""

    free: np.ndarray
    boxed: np.ndarray
    lower_only: np.ndarray
    upper_only: np.ndarray
    fixed: np.ndarray

    @staticmethod
    def of(lower: np.ndarray, upper: np.ndarray) -> _ColumnKinds:
        """Classify columns by which of their bounds are finite (equal finite bounds: fixed)."""
        has_lower, has_upper = np.isfinite(lower), np.isfinite(upper)
        fixed = has_lower & has_upper & (lower == upper)
        return _ColumnKinds(
            free=~has_lower & ~has_upper,
            boxed=has_lower & has_upper & ~fixed,
            lower_only=has_lower & ~has_upper,
            upper_only=has_upper & ~has_lower,
            fixed=fixed,
        )

    @property
    def counts(self) -> np.ndarray:
        """Start offsets of the free, boxed, lower-only and upper-only blocks in the dual's cone rows."""
        return np.cumsum(
            [0, self.free.sum(), self.boxed.sum(), self.lower_only.sum(), self.upper_only.sum()]
        ).astype(int)


def _dual_matrix(A: sparse.csc_matrix, kinds: _ColumnKinds) -> sparse.csc_matrix:
    """Return Clarabel's G of the dual in variables (y, v, w), v and w the boxed columns' bound multipliers.

    Zero-cone rows: free and boxed columns (A_j.y + v_j - w_j = c_j); non-negative rows: one-sided columns,
    then v >= 0 and w >= 0. Fixed columns give no row: their x is known.
    """
    rows = A.shape[0]
    AT = sparse.csr_matrix(A.T)
    k = int(kinds.boxed.sum())
    eye = sparse.identity(k, format="csr")

    def pick(mask: np.ndarray) -> sparse.csr_matrix:
        return AT[np.nonzero(mask)[0]]

    def zeros(mask: np.ndarray) -> sparse.csr_matrix:
        return sparse.csr_matrix((int(mask.sum()), k))

    return sparse.vstack(
        [
            sparse.hstack([pick(kinds.free), zeros(kinds.free), zeros(kinds.free)]),
            sparse.hstack([pick(kinds.boxed), eye, -eye]),
            sparse.hstack([pick(kinds.lower_only), zeros(kinds.lower_only), zeros(kinds.lower_only)]),
            sparse.hstack([-pick(kinds.upper_only), zeros(kinds.upper_only), zeros(kinds.upper_only)]),
            sparse.hstack([sparse.csr_matrix((k, rows)), -eye, sparse.csr_matrix((k, k))]),
            sparse.hstack([sparse.csr_matrix((k, rows)), sparse.csr_matrix((k, k)), -eye]),
        ],
        format="csc",
    )


def _dual_objective(
    A: sparse.csc_matrix, b: np.ndarray, lower: np.ndarray, upper: np.ndarray, kinds: _ColumnKinds
) -> np.ndarray:
    """Return Clarabel's q (it minimises): minus the dual objective b.y + l.v - u.w, one-sided bounds in y."""
    bound_of = np.where(kinds.lower_only | kinds.fixed, lower, np.where(kinds.upper_only, upper, 0.0))
    bound_of = np.where(np.isfinite(bound_of), bound_of, 0.0)
    return np.concatenate([-b + A @ bound_of, -lower[kinds.boxed], upper[kinds.boxed]])


def _primal_from_dual(z: np.ndarray, kinds: _ColumnKinds, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """Return primal x from the dual's cone multipliers z: each column's row multiplier, plus a bound."""
    x = np.where(kinds.fixed, lower, 0.0)
    counts = kinds.counts
    x[kinds.free] = z[counts[0] : counts[1]]
    x[kinds.boxed] = z[counts[1] : counts[2]]
    x[kinds.lower_only] = lower[kinds.lower_only] + z[counts[2] : counts[3]]
    x[kinds.upper_only] = upper[kinds.upper_only] - z[counts[3] : counts[4]]
    return x


class _DualInteriorPoint:
    """Clarabel on the dual of  min c.x  s.t.  A x = b,  l <= x <= u;  c enters only the right-hand side."""

    def __init__(self, A: sparse.csc_matrix, b: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> None:
        self.kinds = _ColumnKinds.of(lower, upper)
        self.lower, self.upper, self.rows = lower, upper, A.shape[0]
        self.G = _dual_matrix(A, self.kinds)
        self.q = _dual_objective(A, b, lower, upper, self.kinds)
        k = int(self.kinds.boxed.sum())
        equalities = int(self.kinds.free.sum()) + k
        inequalities = int(self.kinds.lower_only.sum() + self.kinds.upper_only.sum()) + 2 * k
        self.cones = [
            cone(size)
            for cone, size in ((_clarabel.ZeroConeT, equalities), (_clarabel.NonnegativeConeT, inequalities))
            if size
        ]
        self.settings = _clarabel.DefaultSettings()
        self.settings.verbose = False
        self.settings.presolve_enable = False  # keeps the rows fixed, so later costs update the data in place
        # Static KKT regularisation only slows these LPs down; the dynamic one still guards singular pivots.
        self.settings.static_regularization_enable = False
        self.settings.tol_gap_abs = self.settings.tol_gap_rel = self.settings.tol_feas = INTERIOR_TOLERANCE
        # The KKT factorisation fills in like a 2-D grid on connected walls: faer's supernodal LDL^T takes
        # 5.2 s of CPU where QDLDL takes 17 s (10,580-point wall, 35 iterations; the same 0.35 s at 3,504
        # points). One thread: on a shared 2-core machine more threads only wait for each other (15 s).
        self.settings.direct_solve_method = INTERIOR_LINEAR_SOLVER
        self.settings.max_threads = 1
        self._solver: _clarabel.DefaultSolver | None = None  # made at the first solve

    def _rhs(self, cost: np.ndarray) -> np.ndarray:
        """Return Clarabel's h for costs c: the dual constraints' right-hand side (c, then 0 for v, w)."""
        kinds = self.kinds
        return np.concatenate(
            [
                cost[kinds.free],
                cost[kinds.boxed],
                cost[kinds.lower_only],
                -cost[kinds.upper_only],
                np.zeros(2 * int(kinds.boxed.sum())),
            ]
        )

    def solve(self, cost: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """Return primal x and row duals y for costs ``cost``; None when Clarabel does not solve the dual."""
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
        x = _primal_from_dual(np.asarray(solution.z, float), self.kinds, self.lower, self.upper)
        return x, y
