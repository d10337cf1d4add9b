"""Method (b): Table 1 and Theorem 7, the equilibria for small delta from d^k x*/d delta^k (theta, 0).

The steps: decide whether the pivot is off the centroid (Table 1's first test, ``pivot_off_centroid``);
expand (X*, Y*)(theta, delta) in delta order by order (Prop. 8, eq. 25, ``expansion``) up to the first
d^n x*/d delta^n (theta, 0) not identically zero (Table 1's loop, ``first_nonzero_order``); find its
roots and slopes (Theorem 7, ``theorem7_roots``); follow each root to the given delta on the truncated
series (``follow_roots``); and place the part there (``configurations``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from feeder_planner.errors import SolverError
from feeder_planner.mems.curve import pivot_point, pivot_translation, plane_coordinates
from feeder_planner.mems.lifted import (
    Edges,
    derivatives,
    part_edges,
    value_gradient_hessian_noise,
)
from feeder_planner.mems.result import AsymptoticDetails, EquilibriaResult, Equilibrium
from feeder_planner.mems.tolerances import (
    ASYMPTOTIC_SAMPLES,
    BRANCH_WINDOW,
    EXTRA,
    FIRST_ORDER,
    FOURIER_REPORTED,
    MAX_ORDER,
    MULTIPLE_ROOT,
    PIVOT_TOL,
    ROOT_BISECTIONS,
    ROOT_GRID_PER_PERIOD,
    ROOT_NEWTON_ITER,
    ROOT_STEP_TOL,
    SERIES_NEWTON_ITER,
    ZERO_TOL,
)
from feeder_planner.parts import Part

__all__ = [
    "Expansion",
    "asymptotic_equilibria",
    "taylor_factorials",
    "taylor_coefficients",
    "pivot_off_centroid",
    "expansion",
    "first_nonzero_order",
    "expand_to_first_nonzero",
    "theorem7_roots",
    "follow_roots",
    "configurations",
]

TWO_PI = 2 * math.pi


@lru_cache(maxsize=16)
def _convolution(n: int) -> np.ndarray:
    """Return the (n, n, n) tensor of the truncated Cauchy product of two power series."""
    t = np.zeros((n, n, n))
    for i in range(n):
        for j in range(n - i):
            t[i, j, i + j] = 1.0
    return t


def _series_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Return the product of power series in delta (last axis = coefficient index), truncated."""
    return np.einsum("...i,...j,ijk->...k", a, b, _convolution(a.shape[-1]), optimize=False)


def taylor_factorials(order: int) -> np.ndarray:
    """Return 1 / (i! j!) for i + j <= order as a square array (zero elsewhere)."""
    f = np.zeros((order + 1, order + 1))
    for i in range(order + 1):
        for j in range(order + 1 - i):
            f[i, j] = 1.0 / (math.factorial(i) * math.factorial(j))
    return f


def taylor_coefficients(
    v: dict[tuple[int, int], float], area: float, theta: np.ndarray, order: int
) -> np.ndarray:
    """Return c_k(theta), k = 0..order, with (X*, Y*)(theta, delta) = Z0 + sum_k c_k delta^k (c_0 = 0).

    Solves grad V(Z0 + W) + delta |S| (sin, cos) = 0 order by order (eqs. 22-24, Prop. 8, eq. 25): at
    order k the unknown enters only through Hess V c_k, so c_k = -Hess^{-1} E_k with E_k from lower
    orders.
    """
    m = len(theta)
    hess = np.array([[v[(2, 0)], v[(1, 1)]], [v[(1, 1)], v[(0, 2)]]])
    fact = taylor_factorials(order)
    c = np.zeros((m, 2, order + 1))
    b = np.column_stack([np.sin(theta), np.cos(theta)])
    for k in range(1, order + 1):
        wx, wy = c[:, 0, :], c[:, 1, :]
        px = [np.eye(1, order + 1, 0).repeat(m, 0)]
        py = [np.eye(1, order + 1, 0).repeat(m, 0)]
        for _ in range(k):
            px.append(_series_mul(px[-1], wx))
            py.append(_series_mul(py[-1], wy))
        residual = np.zeros((m, 2))
        for i in range(k + 1):
            for j in range(k + 1 - i):
                if i + j == 0:
                    continue
                term = _series_mul(px[i], py[j])[:, k] * fact[i, j]
                residual[:, 0] += v[(i + 1, j)] * term
                residual[:, 1] += v[(i, j + 1)] * term
        if k == 1:
            residual += area * b
        c[:, :, k] = -np.linalg.solve(hess, residual.T).T
    return c


def _fourier(samples: np.ndarray) -> np.ndarray:
    """Return the rfft coefficients of one period of samples, normalised to amplitudes."""
    return np.fft.rfft(samples) / len(samples)


def _drop_noise(coef: np.ndarray) -> np.ndarray:
    """Return the coefficients with those below ZERO_TOL of the largest set to zero (rounding noise)."""
    return np.where(np.abs(coef) > ZERO_TOL * np.abs(coef).max(), coef, 0.0)


def _trig_eval(coef: np.ndarray, theta: np.ndarray, derivative: int = 0) -> np.ndarray:
    """Evaluate a real trig polynomial from its rfft coefficients (and its theta-derivatives)."""
    k = np.arange(len(coef))
    weights = np.where(k == 0, 1.0, 2.0)
    phase = np.exp(1j * np.outer(theta, k))
    return ((coef * weights * (1j * k) ** derivative)[None, :] * phase).sum(-1).real


def _trig_roots(coef: np.ndarray) -> np.ndarray:
    """Return the sign changes in [0, 2 pi) of a real trig polynomial, polished by Newton on the trig form.

    Coefficients below ZERO_TOL of the largest are rounding noise of an exactly symmetric part and
    are dropped first; ROOT_GRID_PER_PERIOD samples per period of the highest frequency cannot miss a
    simple root pair of a polynomial of this degree (roots closer than that are reported as multiple
    roots by ``theorem7_roots``).
    """
    coef = _drop_noise(coef)
    degree = int(np.max(np.flatnonzero(coef)))
    grid = np.linspace(0.0, TWO_PI, ROOT_GRID_PER_PERIOD * max(degree, 1) + 1)
    values = _trig_eval(coef, grid)
    exact = grid[:-1][values[:-1] == 0.0]
    change = np.flatnonzero((values[:-1] * values[1:] < 0))
    a, b, fa = grid[change], grid[change + 1], values[change]
    for _ in range(ROOT_BISECTIONS):  # bisection of every bracket at once, then safeguarded Newton
        mid = 0.5 * (a + b)
        fm = _trig_eval(coef, mid)
        left = fa * fm > 0
        a, b, fa = np.where(left, mid, a), np.where(left, b, mid), np.where(left, fm, fa)
    guess = 0.5 * (a + b)
    for _ in range(ROOT_NEWTON_ITER):
        step = _trig_eval(coef, guess) / _trig_eval(coef, guess, 1)
        guess = np.clip(guess - step, a, b)
        if np.all(np.abs(step) <= ROOT_STEP_TOL):
            break
    return np.mod(np.sort(np.concatenate([exact, guess])), TWO_PI)


@dataclass(frozen=True)
class Expansion:
    """The delta-expansion of the equilibrium curve to ``order`` (Prop. 8) sampled at ``theta``."""

    theta: np.ndarray  # (ASYMPTOTIC_SAMPLES,) one period
    c: np.ndarray  # (samples, 2, order + 1): (X*, Y*) = Z0 + sum_k c_k delta^k
    x_k: list[np.ndarray]  # d^k x*/d delta^k (theta, 0), k = 0..order (eq. 13 differentiated)


def pivot_off_centroid(edges: Edges, z0: np.ndarray) -> bool:
    """Return Table 1's first test, grad V(0, 0) != 0, in floating point.

    The pivot counts as off the centroid when |(X0, Y0)| exceeds PIVOT_TOL times its rounding bound
    (the gradient's rounding floor mapped through Hess^-1).
    """
    _, _, hess0, gnoise = value_gradient_hessian_noise(edges, z0)
    noise = float(gnoise) / float(np.linalg.eigvalsh(hess0)[0])
    return float(np.hypot(*z0)) > PIVOT_TOL * noise


def expansion(edges: Edges, z0: np.ndarray, area: float, theta: np.ndarray, order: int) -> Expansion:
    """Return the Taylor coefficients of (X*, Y*) to ``order`` and the d^k x*/d delta^k (theta, 0)."""
    v = derivatives(edges, z0, order + 1)
    c = taylor_coefficients(v, area, theta, order)
    c_t, s_t = np.cos(theta), np.sin(theta)
    x_k = [plane_coordinates(c_t, s_t, z0[0], z0[1])[0]] + [
        math.factorial(k) * plane_coordinates(c_t, s_t, c[:, 0, k], c[:, 1, k])[0]
        for k in range(1, order + 1)
    ]
    return Expansion(theta, c, x_k)


def first_nonzero_order(exp: Expansion, up_to: int) -> int | None:
    """Return the first k in 1..up_to with d^k x*/d delta^k (theta, 0) not identically zero, if any.

    'Identically zero' is relative: below ZERO_TOL of max_{j<=k} |d^j (X*, Y*)/d delta^j|.
    """
    size = 0.0
    for k in range(1, up_to + 1):
        size = max(size, math.factorial(k) * np.abs(exp.c[:, :, k]).max())
        if np.abs(exp.x_k[k]).max() > ZERO_TOL * size:
            return k
    return None


def expand_to_first_nonzero(edges: Edges, z0: np.ndarray, area: float) -> tuple[int, int, Expansion]:
    """Return (n, order, expansion): Table 1's n, the order used (n + EXTRA) and an expansion to it.

    Pivot off the centroid: n = 0. Otherwise the expansion is first computed to FIRST_ORDER (enough
    for every 4-fold symmetric part), then once to MAX_ORDER; a part with no non-zero order up to
    MAX_ORDER is (nearly) rotation-invariant: SolverError. The expansion may extend beyond ``order``.
    """
    theta = TWO_PI * np.arange(ASYMPTOTIC_SAMPLES) / ASYMPTOTIC_SAMPLES
    if pivot_off_centroid(edges, z0):
        return 0, EXTRA, expansion(edges, z0, area, theta, EXTRA)
    order = FIRST_ORDER + EXTRA
    while True:
        exp = expansion(edges, z0, area, theta, order)
        n = first_nonzero_order(exp, order - EXTRA)
        if n is not None:
            return n, n + EXTRA, exp
        if order >= MAX_ORDER + EXTRA:
            raise SolverError(
                f"d^k x*/d delta^k (theta, 0) vanishes identically for k <= {MAX_ORDER}: "
                "the part is (nearly) rotation-invariant, orientation undetermined"
            )
        order = MAX_ORDER + EXTRA


def theorem7_roots(coef_n: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Return the roots of d^n x*/d delta^n (theta, 0) and its slopes there (Theorem 7 (ii)-(iii)).

    A multiple root (slope below MULTIPLE_ROOT of the largest amplitude), or none at all, leaves
    Theorem 7 inapplicable: SolverError.
    """
    roots = _trig_roots(coef_n)
    slopes = _trig_eval(coef_n, roots, 1)
    if len(roots) == 0 or np.any(np.abs(slopes) <= MULTIPLE_ROOT * np.abs(coef_n).max()):
        raise SolverError(
            f"d^{n} x*/d delta^{n} (theta, 0) has a multiple root: Theorem 7 (iii) does not apply"
        )
    return roots, slopes


def follow_roots(coefs: list[np.ndarray], n: int, order: int, delta: float, roots: np.ndarray) -> np.ndarray:
    """Return theta(delta): the root of sum_{k=n}^{order} x_k delta^(k-n)/k! near each Theorem-7 root.

    Newton on the truncated series; a root that moves more than BRANCH_WINDOW of half the root
    spacing has left its branch, so delta is outside the expansion's range: SolverError.
    """
    thetas = roots.copy()
    series = coefs[n] / math.factorial(n)
    for k in range(n + 1, order + 1):
        series = series + coefs[k] * delta ** (k - n) / math.factorial(k)
    for _ in range(SERIES_NEWTON_ITER):
        step = _trig_eval(series, thetas) / _trig_eval(series, thetas, 1)
        thetas = thetas - step
        if np.all(np.abs(step) <= ROOT_STEP_TOL):
            break
    if np.any(np.abs(np.angle(np.exp(1j * (thetas - roots)))) > BRANCH_WINDOW * math.pi / max(len(roots), 1)):
        raise SolverError(f"delta = {delta} is outside the range of the small-delta expansion")
    return thetas


def configurations(
    exp: Expansion, order: int, delta: float, z0: np.ndarray, thetas: np.ndarray, slopes: np.ndarray
) -> list[Equilibrium]:
    """Return the equilibria at angles ``thetas``, sorted by theta, stable where the slope is > 0.

    (X*, Y*)(theta, delta) from the series to ``order``: the c_k are trig polynomials of degree <= k,
    so the samples' Fourier series interpolates them exactly; (x, y) by eqs. (13-14).
    """
    powers = np.arange(exp.c.shape[-1])
    z_series = exp.c[:, :, : order + 1] @ (
        delta ** powers[: order + 1] * (powers[: order + 1] > 0)
    )  # (ASYMPTOTIC_SAMPLES, 2)
    z_at = np.column_stack(
        [_trig_eval(_fourier(z_series[:, 0]), thetas), _trig_eval(_fourier(z_series[:, 1]), thetas)]
    )
    equilibria = []
    for theta, slope, dz in zip(thetas, slopes, z_at, strict=True):
        z = z0 + dz
        x, y = plane_coordinates(math.cos(theta), math.sin(theta), z[0], z[1])
        equilibria.append(Equilibrium(float(x), float(y), float(theta % TWO_PI), bool(slope > 0)))
    equilibria.sort(key=lambda e: e.theta)
    return equilibria


def asymptotic_equilibria(part: Part, delta: float, edges: Edges | None = None) -> EquilibriaResult:
    """Return all equilibria for small delta by Table 1 and Theorem 7, refined with EXTRA orders.

    Theorem 7 holds for delta below an unknown delta_0: alone, this result is not certified at delta.
    """
    edges = edges or part_edges(part)
    z0 = pivot_translation(edges)
    n, order, exp = expand_to_first_nonzero(edges, z0, part.area)
    coefs = [_fourier(x) for x in exp.x_k]
    coefs[n] = _drop_noise(coefs[n])
    roots, slopes = theorem7_roots(coefs[n], n)
    thetas = follow_roots(coefs, n, order, delta, roots)
    amplitude = np.abs(coefs[n]).max()
    details = AsymptoticDetails(
        n=n,
        pivot_distance=float(np.hypot(*z0)),
        theorem7_roots=tuple(float(r) for r in roots),
        theorem7_slopes=tuple(float(s) for s in slopes),
        dn_x_fourier=tuple(
            (k, float(2 * abs(a) if k else abs(a)))
            for k, a in enumerate(coefs[n])
            if abs(a) > FOURIER_REPORTED * amplitude
        ),
        # n = 0: Theorem 7's stable limit 3 pi/2 - psi with (X0, Y0) = rho (cos psi, sin psi)
        stable_limit_theta=(1.5 * math.pi - math.atan2(z0[1], z0[0])) % TWO_PI if n == 0 else None,
    )
    return EquilibriaResult(
        pivot_point(z0),
        part.area,
        delta,
        "asymptotic",
        tuple(configurations(exp, order, delta, z0, thetas, slopes)),
        certified=False,
        asymptotic=details,
    )
