"""Method (b): the algorithm of Table 1 and Theorem 7, equilibria for small delta from d^k x*/d delta^k (theta, 0)."""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from feeder_planner.errors import SolverError
from feeder_planner.mems.curve import pivot_translation
from feeder_planner.mems.lifted import (
    Edges,
    derivatives,
    gradient_noise,
    part_edges,
    taylor_factorials,
    value_gradient_hessian,
)
from feeder_planner.mems.result import EquilibriaResult, Equilibrium
from feeder_planner.parts import Part

MAX_ORDER = 9  # n up to 9 (Table 1's loop), plus EXTRA orders for the refinement of theta(delta)
EXTRA = 2
PIVOT_TOL = (
    100.0  # |(X0, Y0)| below PIVOT_TOL times its rounding-error bound: pivot = centroid (Table 1's test)
)
ZERO_TOL = 1e-9  # d^k x*/d delta^k is 'identically zero' below this fraction of max_{j<=k} |d^j (X*, Y*)|
SAMPLES = 32  # theta samples: the trig polynomials have degree <= k + 1 <= 12 < 16, so the FFT is exact


@lru_cache(maxsize=16)
def _convolution(n: int) -> np.ndarray:
    t = np.zeros((n, n, n))
    for i in range(n):
        for j in range(n - i):
            t[i, j, i + j] = 1.0
    return t


def _series_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Product of power series in delta (last axis = coefficient index), truncated."""
    return np.einsum("...i,...j,ijk->...k", a, b, _convolution(a.shape[-1]), optimize=False)


def taylor_coefficients(
    v: dict[tuple[int, int], float], area: float, theta: np.ndarray, order: int
) -> np.ndarray:
    """c_k(theta), k = 0..order, with (X*, Y*)(theta, delta) = Z0 + sum_k c_k delta^k (c_0 = 0).

    Solves grad V(Z0 + W) + delta |S| (sin, cos) = 0 order by order (Prop. 8, eq. 25): at order k the
    unknown enters only through Hess V c_k, so c_k = -Hess^{-1} E_k with E_k from lower orders.
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
    return np.fft.rfft(samples) / len(samples)


def _trig_eval(coef: np.ndarray, theta: np.ndarray, derivative: int = 0) -> np.ndarray:
    """Evaluate a real trig polynomial from its rfft coefficients (and its theta-derivatives)."""
    k = np.arange(len(coef))
    weights = np.where(k == 0, 1.0, 2.0)
    phase = np.exp(1j * np.outer(theta, k))
    return ((coef * weights * (1j * k) ** derivative)[None, :] * phase).sum(-1).real


def _trig_roots(coef: np.ndarray) -> np.ndarray:
    """Sign changes in [0, 2 pi) of a real trig polynomial, polished by Newton on the trig form.

    Coefficients below ZERO_TOL of the largest are rounding noise of an exactly symmetric part and
    are dropped first; 16 samples per period of the highest frequency cannot miss a simple root pair
    of a polynomial of this degree (roots closer than that are reported as multiple roots below).
    """
    coef = np.where(np.abs(coef) > ZERO_TOL * np.abs(coef).max(), coef, 0.0)
    degree = int(np.max(np.flatnonzero(coef)))
    grid = np.linspace(0.0, 2 * math.pi, 16 * max(degree, 1) + 1)
    values = _trig_eval(coef, grid)
    exact = grid[:-1][values[:-1] == 0.0]
    change = np.flatnonzero((values[:-1] * values[1:] < 0))
    a, b, fa = grid[change], grid[change + 1], values[change]
    for _ in range(12):  # bisection of every bracket at once, then safeguarded Newton
        mid = 0.5 * (a + b)
        fm = _trig_eval(coef, mid)
        left = fa * fm > 0
        a, b, fa = np.where(left, mid, a), np.where(left, b, mid), np.where(left, fm, fa)
    guess = 0.5 * (a + b)
    for _ in range(8):
        step = _trig_eval(coef, guess) / _trig_eval(coef, guess, 1)
        guess = np.clip(guess - step, a, b)
        if np.all(np.abs(step) <= 1e-15):
            break
    a = b = guess
    roots = np.sort(np.concatenate([exact, 0.5 * (a + b)]))
    return np.mod(np.array(roots), 2 * math.pi)


def asymptotic_equilibria(part: Part, delta: float, edges: Edges | None = None) -> EquilibriaResult:
    """All equilibria for small delta by Table 1 and Theorem 7, refined with EXTRA orders of the expansion."""
    edges = edges or part_edges(part)
    z0 = pivot_translation(edges)
    rho = float(np.hypot(*z0))
    theta_grid = 2 * math.pi * np.arange(SAMPLES) / SAMPLES
    c_t, s_t = np.cos(theta_grid), np.sin(theta_grid)
    # Table 1 tests grad V(0, 0) != 0; in floating point: is the pivot resolvably off the centroid?
    hess0 = value_gradient_hessian(edges, z0)[2]
    noise = float(gradient_noise(edges, z0)) / float(np.linalg.eigvalsh(hess0)[0])
    if rho > PIVOT_TOL * noise:
        n = 0
    else:
        n = None
    first_guess = 3 + EXTRA  # enough for n <= 3 (every 4-fold symmetric part); raised when needed
    order = EXTRA if n == 0 else first_guess
    while True:
        v = derivatives(edges, z0, order + 1)
        c = taylor_coefficients(v, part.area, theta_grid, order)
        x_k = [c_t * z0[0] - s_t * z0[1]] + [
            math.factorial(k) * (c_t * c[:, 0, k] - s_t * c[:, 1, k]) for k in range(1, order + 1)
        ]
        if n == 0:
            break
        # Table 1, second branch: the first d^k x*/d delta^k (theta, 0) not identically zero.
        size = 0.0
        for k in range(1, order - EXTRA + 1):
            size = max(size, math.factorial(k) * np.abs(c[:, :, k]).max())
            if np.abs(x_k[k]).max() > ZERO_TOL * size:
                n = k
                break
        if n is not None:
            order = n + EXTRA
            break
        if order >= MAX_ORDER + EXTRA:
            raise SolverError(
                f"d^k x*/d delta^k (theta, 0) vanishes identically for k <= {MAX_ORDER}: "
                "the part is (nearly) rotation-invariant, orientation undetermined"
            )
        order = MAX_ORDER + EXTRA
    coefs = [_fourier(x) for x in x_k]
    coefs[n] = np.where(np.abs(coefs[n]) > ZERO_TOL * np.abs(coefs[n]).max(), coefs[n], 0.0)
    roots = _trig_roots(coefs[n])
    slopes = _trig_eval(coefs[n], roots, 1)
    amplitude = np.abs(coefs[n]).max()
    if len(roots) == 0 or np.any(np.abs(slopes) <= 1e-7 * amplitude):
        raise SolverError(
            f"d^{n} x*/d delta^{n} (theta, 0) has a multiple root: Theorem 7 (iii) does not apply"
        )
    # theta(delta): root of sum_k x_k delta^(k-n)/k! near each Theorem-7 root (Newton on the truncated series).
    thetas = roots.copy()
    series = sum(coefs[k] * delta ** (k - n) / math.factorial(k) for k in range(n, order + 1))
    for _ in range(30):
        step = _trig_eval(series, thetas) / _trig_eval(series, thetas, 1)
        thetas = thetas - step
        if np.all(np.abs(step) <= 1e-15):
            break
    if np.any(np.abs(np.angle(np.exp(1j * (thetas - roots)))) > 0.5 * math.pi / max(len(roots), 1)):
        raise SolverError(f"delta = {delta} is outside the range of the small-delta expansion")
    equilibria = []
    # (X*, Y*)(theta, delta) at the roots: the c_k are trig polynomials of degree <= k, so the
    # samples' Fourier series interpolates them exactly.
    powers = np.arange(c.shape[-1])
    z_series = c[:, :, : order + 1] @ (
        delta ** powers[: order + 1] * (powers[: order + 1] > 0)
    )  # (SAMPLES, 2)
    z_at = np.column_stack(
        [_trig_eval(_fourier(z_series[:, 0]), thetas), _trig_eval(_fourier(z_series[:, 1]), thetas)]
    )
    for theta, slope, dz in zip(thetas, slopes, z_at):
        z = z0 + dz
        ct, st = math.cos(theta), math.sin(theta)
        equilibria.append(
            Equilibrium(
                float(ct * z[0] - st * z[1]),
                float(st * z[0] + ct * z[1]),
                float(theta % (2 * math.pi)),
                bool(slope > 0),
            )
        )
    equilibria.sort(key=lambda e: e.theta)
    # Theorem 7 holds for delta below an unknown delta_0: alone, this result is not certified at delta.
    details = {
        "n": n,
        "certified": False,
        "pivot_distance": rho,
        "theorem7_roots": [float(r) for r in roots],
        "theorem7_slopes": [float(s) for s in slopes],
        "dn_x_fourier": {
            str(k): float(2 * abs(a) if k else abs(a))
            for k, a in enumerate(coefs[n])
            if abs(a) > 1e-9 * amplitude
        },
    }
    if n == 0:
        psi = math.atan2(z0[1], z0[0])
        details["stable_limit_theta"] = (1.5 * math.pi - psi) % (2 * math.pi)
    return EquilibriaResult(
        (float(-z0[0]), float(-z0[1])), part.area, delta, "asymptotic", tuple(equilibria), details
    )
